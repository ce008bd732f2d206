"""A motor's tolerance box: its corners, Monte Carlo samples and worst-case capability.

A motor file's `tolerances` give each of `inertia_kgm2`, `friction_torque_nm`,
`load_torque_nm`, `torque_scale` (multiplies the pull-out curve; nominal 1) and
`damping_ratio` an absolute [low, high] range; the box is their product. A
parameter without a range (or with low == high) is no dimension of the box.

The criterion over the box (docs/manual-notes.md, "Tolerance box: the binding
corner"): with s the torque scale,

    a_acc(v) = (sf·s·T(v) − T_f − |T_L|) · steps_per_rev / (2π·J)
    a_dec(v) = (sf·s·T(v) + T_f − |T_L|) · steps_per_rev / (2π·J)

are monotone in each parameter, so a_acc is smallest at (s min, T_f max, |T_L|
max, J max) and a_dec at (s min, T_f MIN, |T_L| max, J max) — at every speed
at once (J max binds where the numerator is positive; where it is not the
motor cannot make that step at any corner and the verdict is the same). The
criterion judges every step against those minima and nothing else that varies
in the box, so it passes over the whole box exactly when it passes on one
plain motor with that capability: `worst_case_motor` (friction (T_f min + T_f
max)/2 and load |T_L| max + (T_f max − T_f min)/2 give both minima exactly).
"""

from __future__ import annotations

import itertools
from dataclasses import dataclass, replace

import numpy as np

from ..errors import FormatError
from .model import TOLERANCE_KEYS, Motor


@dataclass(frozen=True)
class Variant:
    """One motor of the box: a corner or a sample, with its parameter values."""

    label: str                       # "nominal", "corner 5" or "sample 17"
    params: dict[str, float]
    motor: Motor

    def describe(self) -> str:
        values = ", ".join(f"{k} {v:.4g}" for k, v in self.params.items())
        return f"{self.label} ({values})" if values else self.label


def box(motor: Motor) -> dict[str, tuple[float, float]]:
    """The box's dimensions: every parameter whose range has low < high."""
    out = {}
    for key in TOLERANCE_KEYS:
        lo, hi = motor.tolerance(key)
        if hi > lo:
            out[key] = (lo, hi)
    return out


def variant(motor: Motor, params: dict[str, float]) -> Motor:
    """`motor` with the given parameter values (torque_scale scales the pull-out curve and
    the holding torque); the variant carries no tolerances of its own."""
    changes: dict[str, object] = {"tolerances": ()}
    for key, value in params.items():
        if key == "torque_scale":
            changes["curve_torque_nm"] = np.asarray(motor.curve_torque_nm) * value
            if motor.holding_torque_nm is not None:
                changes["holding_torque_nm"] = motor.holding_torque_nm * value
        else:
            changes[key] = value
    try:
        return replace(motor, **changes)  # type: ignore[arg-type]
    except FormatError as e:
        raise FormatError(f"tolerance box {_show(params)}: {e}") from None


def corners(motor: Motor) -> list[Variant]:
    """The 2^k corners of the box (k its dimensions; the nominal motor when k = 0)."""
    dims = box(motor)
    if not dims:
        return [Variant("nominal", {}, motor)]
    out = []
    for i, choice in enumerate(itertools.product((0, 1), repeat=len(dims))):
        params = {k: dims[k][c] for k, c in zip(dims, choice, strict=True)}
        out.append(Variant(f"corner {i}", params, variant(motor, params)))
    return out


def sample_params(motor: Motor, n: int, seed: int = 0) -> dict[str, np.ndarray]:
    """`n` points uniform in the box (seeded: the same seed gives the same points),
    as one array per dimension; parameters without a range stay nominal."""
    rng = np.random.default_rng(seed)
    dims = box(motor)
    out = {}
    for key in TOLERANCE_KEYS:
        lo, hi = dims.get(key, (motor.nominal(key), motor.nominal(key)))
        out[key] = rng.uniform(lo, hi, n) if key in dims else np.full(n, lo)
    return out


def samples(motor: Motor, n: int, seed: int = 0) -> list[Variant]:
    """`sample_params` as motors (for the scalar model and for tests)."""
    p = sample_params(motor, n, seed)
    dims = box(motor)
    return [Variant(f"sample {i}", {k: float(p[k][i]) for k in dims},
                    variant(motor, {k: float(p[k][i]) for k in dims})) for i in range(n)]


def worst_case_motor(motor: Motor) -> Motor:
    """One plain motor whose a_acc is the box's smallest a_acc and whose a_dec is the box's
    smallest a_dec at every speed (module docstring): what the criterion and the planner
    judge a tolerance box by."""
    dims = box(motor)
    if not dims:
        return motor
    j_hi = motor.tolerance("inertia_kgm2")[1]
    f_lo, f_hi = motor.tolerance("friction_torque_nm")
    l_lo, l_hi = motor.tolerance("load_torque_nm")
    load = max(abs(l_lo), abs(l_hi))
    s_lo = motor.tolerance("torque_scale")[0]
    try:
        return variant(motor, {"inertia_kgm2": j_hi, "friction_torque_nm": (f_lo + f_hi) / 2,
                               "load_torque_nm": load + (f_hi - f_lo) / 2,
                               "torque_scale": s_lo})
    except FormatError as e:
        raise FormatError(f"{e} (at the tolerance box's worst case: the motor cannot start "
                          "there)") from None


def clopper_pearson_upper(failures: int, n: int, confidence: float = 0.95) -> float:
    """The exact (Clopper–Pearson) one-sided upper confidence bound on a probability seen
    `failures` times in `n` trials: the p where P(X ≤ failures | n, p) = 1 − confidence.
    With 0 failures it is 1 − (1 − confidence)^(1/n), ≈ 3/n at 95 % ("rule of three")."""
    if not 0 <= failures <= n or n < 1:
        raise ValueError(f"failures {failures} of {n} trials")
    alpha = 1.0 - confidence
    if failures == n:
        return 1.0
    if failures == 0:
        return 1.0 - alpha ** (1.0 / n)

    # The bound is the `confidence` quantile of Beta(failures + 1, n − failures); scipy
    # (a dependency of toppra) inverts the incomplete beta function exactly. Imported here:
    # the usual verdict has no failure and takes the closed form above.
    from scipy.special import betaincinv

    return float(betaincinv(failures + 1, n - failures, confidence))


def _show(params: dict[str, float]) -> str:
    return "(" + ", ".join(f"{k} {v:g}" for k, v in params.items()) + ")"
