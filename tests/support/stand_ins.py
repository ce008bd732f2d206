"""A stand-in for a motor with hand-checkable accelerations, as the PPMC-312 stall
criterion reads it, the exact float limit of the criterion's relative tolerance, and a
plain NEMA17 the load-angle tests drive."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from profiles.motor import Motor
from profiles.ppmc312.criterion import REL_TOL


@dataclass(frozen=True)
class StandIn:
    """The motor attributes the criterion reads, with hand-checkable values."""

    start_pps: float = 1000.0
    top_pps: float = 4000.0
    jump_pps: float = 1500.0
    acc_k: float = 50.0  # a_acc over [lo, hi] = acc_k · lo  (pps²)
    dec_k: float = 40.0  # a_dec over [lo, hi] = dec_k · hi
    max_jerk_pps3: float | None = None

    def min_a_acc_pps2(self, lo: np.ndarray, hi: np.ndarray) -> np.ndarray:
        return self.acc_k * np.asarray(lo, dtype=float)

    def min_a_dec_pps2(self, lo: np.ndarray, hi: np.ndarray) -> np.ndarray:
        return self.dec_k * np.asarray(hi, dtype=float)


def exact_limit(v: float) -> float:
    """The limit L with L · (1 + REL_TOL) == v exactly (a float search around v / tol)."""
    tol = 1 + REL_TOL
    lim = v / tol
    for _ in range(50):
        if lim * tol == v:
            return lim
        lim = float(np.nextafter(lim, v if lim * tol < v else 0.0))
    raise AssertionError(f"no exact limit for {v}")


def plain_motor(**kw: object) -> Motor:
    """0.4 N·m flat to 2000 pps, then falling: a NEMA17 at 1/8 step."""
    args: dict[str, object] = dict(
        steps_per_rev=1600, curve_speed_pps=np.array([0.0, 2000.0, 8000.0, 48000.0]),
        curve_torque_nm=np.array([0.4, 0.4, 0.32, 0.04]), inertia_kgm2=6.8e-6,
        safety_factor=0.6, start_pps=800.0)
    args.update(kw)
    return Motor(**args)  # type: ignore[arg-type]
