"""casadi/Ipopt: minimum-time move with the torque curve and (optionally) a jerk limit.

Direct multiple shooting on a uniform time grid of K intervals with free final time:
states (p, v, a), jerk piecewise constant and integrated exactly per interval; the
capability −a_dec(v) ≤ a ≤ a_acc(v) is imposed at the nodes. Normalised units (x/N,
t/t_ref). The NLP is built once per (K, jerk-limited?, curve size) with the motor and
move as parameters, so repeated solves reuse the same Ipopt instance.
"""

from __future__ import annotations

import time
from dataclasses import dataclass
from typing import Any

import numpy as np

from profiles.errors import ReferenceSolveError, require_int, require_number
from profiles.motor import Motor

from ._common import MoveLimits, Reference, move_limits
from .exact import exact_optimum
from .ruckig_ref import ruckig_reference

#: Trust bracket: casadi checks the capability at nodes only, so it may undercut the
#: exact (jerk-free) optimum slightly; more than this means a wrong answer.
CASADI_LOWER_SLACK = 0.005

#: Width of the smoothed curve corners, relative to v_lim: the capability differs from
#: the piecewise-linear curve by at most |slope change|·width/2 within that width.
SMOOTHING = 1e-3


@dataclass
class _Problem:
    opti: Any
    states: Any      # 3 × (K+1): p, v, a
    jerk: Any        # K
    total: Any       # final time
    params: dict[str, Any]


_CACHE: dict[tuple[int, bool, int], _Problem] = {}


def _ramp_form(motor: Motor, f: Any, v_lim: float) -> tuple[float, float, np.ndarray]:
    """f(v) = base + slope0·v + Σ kink_j·max(0, v − c_j) on [0, v_lim] (c_j: inner curve
    points). Returns (base, slope0, kinks); kinks beyond v_lim are zeroed."""
    bps = motor.curve_speed_pps
    vals = np.asarray(f(bps), dtype=float)
    slopes = np.diff(vals) / np.diff(bps)
    kinks = np.diff(slopes)
    kinks[bps[1:-1] >= v_lim] = 0.0
    return float(vals[0]), float(slopes[0]), kinks


def _build(intervals: int, jerk_limited: bool, inner_points: int) -> _Problem:
    import casadi as ca

    opti = ca.Opti()
    x = opti.variable(3, intervals + 1)
    j = opti.variable(1, intervals)
    total = opti.variable()
    par = {name: opti.parameter() for name in ("v0", "v_lim", "j_max", "acc_base",
                                                 "acc_slope", "dec_base", "dec_slope", "eps")}
    par["knots"] = opti.parameter(inner_points)
    par["acc_kinks"] = opti.parameter(inner_points)
    par["dec_kinks"] = opti.parameter(inner_points)
    par["weights"] = opti.parameter(1, intervals)  # interval lengths as fractions of total
    h = total * par["weights"]
    p, v, a = x[0, :], x[1, :], x[2, :]
    # Exact integration of a piecewise-constant jerk over each interval.
    opti.subject_to(p[1:] == p[:-1] + v[:-1] * h + a[:-1] * h**2 / 2 + j * h**3 / 6)
    opti.subject_to(v[1:] == v[:-1] + a[:-1] * h + j * h**2 / 2)
    opti.subject_to(a[1:] == a[:-1] + j * h)
    opti.subject_to(p[0] == 0)
    opti.subject_to(p[-1] == 1)
    opti.subject_to(v[0] == par["v0"])
    opti.subject_to(v[-1] == par["v0"])
    opti.subject_to(opti.bounded(0, v, par["v_lim"]))
    if jerk_limited:
        opti.subject_to(a[0] == 0)
        opti.subject_to(a[-1] == 0)
        opti.subject_to(opti.bounded(-par["j_max"], j, par["j_max"]))

    def capability(base: Any, slope: Any, kinks: Any) -> Any:
        out = base + slope * v
        for i in range(inner_points):
            # smooth max(0, d) = (d + sqrt(d² + ε²))/2: a hard kink makes Ipopt cycle
            # when a node sits on a curve point (seen on motor-nema23-heavy). It exceeds
            # max(0, d) by ≤ ε/2; the base is lowered by that for convex corners so the
            # smoothed capability stays below the curve (see _set_motor).
            d = v - par["knots"][i]
            out = out + kinks[i] * (d + ca.sqrt(d * d + par["eps"] ** 2)) / 2
        return out

    opti.subject_to(a <= capability(par["acc_base"], par["acc_slope"], par["acc_kinks"]))
    opti.subject_to(-a <= capability(par["dec_base"], par["dec_slope"], par["dec_kinks"]))
    opti.subject_to(total >= 1e-9)
    opti.minimize(total)
    opti.solver("ipopt", {"print_time": False, "ipopt.print_level": 0, "ipopt.sb": "yes",
                          "ipopt.max_iter": 1000, "ipopt.tol": 1e-10,
                          # Ipopt relaxes bounds by 1e-8 (absolute) by default: in normalised
                          # units that lets a long move exceed v_lim by ~2e-6
                          "ipopt.bound_relax_factor": 0.0})
    return _Problem(opti=opti, states=x, jerk=j, total=total, params=par)


def _problem(intervals: int, jerk_limited: bool, inner_points: int) -> _Problem:
    key = (intervals, jerk_limited, inner_points)
    if key not in _CACHE:
        _CACHE[key] = _build(*key)
    return _CACHE[key]


def _set_motor(prob: _Problem, motor: Motor, lim: MoveLimits, j_max_pps3: float | None) -> None:
    opti, par = prob.opti, prob.params
    opti.set_value(par["v0"], lim.v0_pps / lim.v_ref_pps)
    opti.set_value(par["v_lim"], lim.v_lim_pps / lim.v_ref_pps)
    opti.set_value(par["j_max"], 0.0 if j_max_pps3 is None else j_max_pps3 / lim.j_ref_pps3)
    opti.set_value(par["knots"], motor.curve_speed_pps[1:-1] / lim.v_ref_pps)
    opti.set_value(par["eps"], SMOOTHING * lim.v_lim_pps / lim.v_ref_pps)
    for side, f in (("acc", motor.a_acc_pps2), ("dec", motor.a_dec_pps2)):
        base, slope, kinks = _ramp_form(motor, f, lim.v_lim_pps)
        eps_pps = SMOOTHING * lim.v_lim_pps
        base -= float(np.sum(np.maximum(kinks, 0.0))) * eps_pps / 2
        opti.set_value(par[f"{side}_base"], base / lim.a_ref_pps2)
        opti.set_value(par[f"{side}_slope"], slope * lim.v_ref_pps / lim.a_ref_pps2)
        opti.set_value(par[f"{side}_kinks"], kinks * lim.v_ref_pps / lim.a_ref_pps2)


def _node_weights(guess: Reference, intervals: int) -> np.ndarray:
    """Interval lengths (fractions of the move) spreading nodes evenly over time plus
    speed change of the warm start: a uniform time grid leaves a long move's short
    ramps, where the capability binds, with only a handful of nodes."""
    t = guess.t_s / guess.duration_s
    span = float(np.ptp(guess.v_pps)) or 1.0
    measure = t + np.concatenate([[0.0], np.cumsum(np.abs(np.diff(guess.v_pps)))]) / span
    nodes = np.interp(np.linspace(0.0, measure[-1], intervals + 1), measure, t)
    nodes[0], nodes[-1] = 0.0, 1.0
    # keep every interval at least a tenth of the uniform one (Ipopt scaling)
    w = np.maximum(np.diff(nodes), 0.1 / intervals)
    return w / w.sum()


def casadi_reference(motor: Motor, pulses: Any, *, intervals: int = 300,
                     jerk: float | None = None) -> Reference:
    """Minimum-time move of `pulses` pulses (v0 → v0) by Ipopt, torque curve at the nodes.

    Jerk limit: `jerk` [pps³], else the motor's max_jerk_pps3, else none. Warm-started
    from the exact jerk-free optimum. Accepted only on Ipopt success with a duration in
    [exact × (1 − 0.5 %), ruckig feasible with the same jerk]; else ReferenceSolveError.
    """
    require_int("intervals", intervals, 10, 20_000)
    if jerk is not None:
        require_number("jerk", jerk, 1e-9, 1e18)
    j_max = float(jerk) if jerk is not None else motor.max_jerk_pps3
    lim = move_limits(motor, pulses)
    exact = exact_optimum(motor, lim.pulses, points=max(2 * intervals, 400))
    upper = ruckig_reference(motor, lim.pulses, j_max_pps3=j_max)

    start = time.perf_counter()
    prob = _problem(intervals, j_max is not None, len(motor.curve_speed_pps) - 2)
    _set_motor(prob, motor, lim, j_max)
    # Warm start: the exact optimum on a uniform time grid (or ruckig's when the jerk
    # limit makes it slower; the solver then starts from a feasible trajectory).
    guess = exact if j_max is None else upper
    weights = _node_weights(guess, intervals)
    t_guess = np.concatenate([[0.0], np.cumsum(weights)]) * guess.duration_s
    a_guess = np.interp(t_guess, guess.t_s, guess.a_pps2) / lim.a_ref_pps2
    if j_max is not None:
        a_guess[0] = a_guess[-1] = 0.0
    opti = prob.opti
    opti.set_value(prob.params["weights"], weights)
    h_guess = weights * guess.duration_s / lim.t_ref_s
    opti.set_initial(prob.states, np.vstack([
        guess.position_at(t_guess) / lim.pulses, guess.speed_at(t_guess) / lim.v_ref_pps,
        a_guess]))
    opti.set_initial(prob.jerk, np.diff(a_guess) / h_guess)
    opti.set_initial(prob.total, guess.duration_s / lim.t_ref_s)
    try:
        sol = opti.solve()
    except RuntimeError as exc:
        status = opti.stats().get("return_status", "error")
        raise ReferenceSolveError(f"casadi: Ipopt did not succeed ({status})") from exc
    solve_s = time.perf_counter() - start
    stats = opti.stats()
    if not stats.get("success", False):
        raise ReferenceSolveError(f"casadi: Ipopt did not succeed ({stats.get('return_status')})")
    duration = float(sol.value(prob.total)) * lim.t_ref_s
    lo = exact.duration_s * (1 - CASADI_LOWER_SLACK)
    if not lo <= duration <= upper.duration_s * (1 + 1e-9):
        raise ReferenceSolveError(f"casadi: duration {duration:.9g} s outside the trust bracket "
                                  f"{lo:.9g}..{upper.duration_s:.9g} s")
    states = np.asarray(sol.value(prob.states), dtype=float)
    t_s = np.concatenate([[0.0], np.cumsum(weights)]) * duration
    x = states[0] * lim.pulses
    x[0], x[-1] = 0.0, lim.pulses
    v = states[1] * lim.v_ref_pps
    v[0] = v[-1] = lim.v0_pps
    a = states[2] * lim.a_ref_pps2
    jerk_txt = "none" if j_max is None else f"{j_max:.6g} pps³"
    info = (f"casadi: {intervals} intervals, jerk {jerk_txt}, {stats.get('iter_count')} Ipopt "
            f"iterations")
    return Reference(name="casadi", duration_s=duration, t_s=t_s, x_pulses=x, v_pps=v,
                     a_pps2=a, solve_s=solve_s, info=info)
