"""ruckig's synchronised multi-axis moves, a reference for `stepramp sync`.

Ruckig(n_dofs) with Synchronization.Time and .Phase in normalised units (each axis's
position / its pulses, time / the longest axis's t_ref): see REFERENCES.md. Constant
limits bracket the torque curve as for one axis (verify/references/ruckig_ref.py): the
least capability over each axis's speeds is a feasible bound, the largest an infeasible
(optimistic) one.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass
from typing import Any

import numpy as np

from profiles.errors import ReferenceSolveError, StepRampError
from profiles.motor import Motor
from profiles.ruckig_move import solve_move

from ._common import MoveLimits, move_limits
from .ruckig_ref import max_over, v_max_candidates

Trajectories = dict[str, tuple[np.ndarray, np.ndarray, np.ndarray]]  # t, x[axes], v[axes]


@dataclass(frozen=True)
class RuckigSync:
    """ruckig's synchronised durations for the same per-axis limits, bracketing the
    torque curve (see the module docstring)."""

    time_feasible_s: float
    phase_feasible_s: float
    time_optimistic_s: float
    phase_optimistic_s: float
    v_max_pps: tuple[float, ...]
    trajectories: Trajectories

    def to_json(self) -> dict[str, Any]:
        return {"time_synchronised_s": self.time_feasible_s,
                "phase_synchronised_s": self.phase_feasible_s,
                "time_synchronised_optimistic_s": self.time_optimistic_s,
                "phase_synchronised_optimistic_s": self.phase_optimistic_s,
                "v_max_pps": list(self.v_max_pps)}


@dataclass(frozen=True)
class Limits:
    """Per-axis constant limits [pps, pps², pps³] and boundary speeds of one solve."""

    v0: list[float]
    vmax: list[float]
    acc: list[float]
    dec: list[float]
    jerk: list[float | None]


def ruckig_sync(motors: Sequence[Motor], pulses: Sequence[int], *, samples: int = 801
                ) -> RuckigSync:
    """Time- and phase-synchronised durations, feasible and optimistic, and the feasible
    trajectories sampled at `samples` instants.

    Per axis: v0 = min(start, jump) (phase: the boundary speeds are made proportional,
    each at most its own, and every limit in the line's normalised coordinate is the least
    of the axes', or ruckig falls back to time synchronisation); the feasible bound takes
    each axis's speed cap that makes its own move fastest (as `ruckig_reference` does) and
    min a_acc / min a_dec over [v0, cap]; the optimistic one v_lim and the largest a_acc /
    a_dec over [0, v_lim]; jerk: max_jerk_pps3 or none.
    """
    dist = [float(abs(p)) for p in pulses]
    lims = [move_limits(m, d) for m, d in zip(motors, dist, strict=True)]
    t_ref = max(lim.t_ref_s for lim in lims)
    v0 = [lim.v0_pps for lim in lims]
    caps = speed_caps(motors, dist, lims)
    jerk = [m.max_jerk_pps3 for m in motors]
    feasible = Limits(v0, caps, [float(m.min_a_acc_pps2(v0[i], caps[i])) for i, m in
                                 enumerate(motors)],
                      [float(m.min_a_dec_pps2(v0[i], caps[i])) for i, m in enumerate(motors)],
                      jerk)
    optimistic = Limits(v0, [lim.v_lim_pps for lim in lims],
                        [max_over(m, m.a_acc_pps2, 0.0, lims[i].v_lim_pps)
                         for i, m in enumerate(motors)],
                        [max_over(m, m.a_dec_pps2, 0.0, lims[i].v_lim_pps)
                         for i, m in enumerate(motors)], jerk)
    share = min(v0[i] / dist[i] for i in range(len(dist)))
    out: dict[str, float] = {}
    trajs: Trajectories = {}
    for name, start in (("time", v0), ("phase", [share * d for d in dist])):
        traj = solve_synchronised(dist, t_ref, _with_v0(feasible, start), name)
        out[f"{name}_feasible"] = float(traj.duration) * t_ref
        trajs[name] = sample(traj, dist, t_ref, samples)
        out[f"{name}_optimistic"] = float(solve_synchronised(
            dist, t_ref, _with_v0(optimistic, start), name).duration) * t_ref
    return RuckigSync(out["time_feasible"], out["phase_feasible"], out["time_optimistic"],
                      out["phase_optimistic"], tuple(caps), trajs)


def _with_v0(lim: Limits, v0: list[float]) -> Limits:
    return Limits(v0, lim.vmax, lim.acc, lim.dec, lim.jerk)


def speed_caps(motors: Sequence[Motor], dist: Sequence[float], lims: Sequence[MoveLimits]
               ) -> list[float]:
    """Each axis's speed cap that makes its own constant-limit move fastest (the feasible
    acceleration is the capability's minimum over [v0, cap])."""
    caps = []
    for m, d, lim in zip(motors, dist, lims, strict=True):
        v0 = lim.v0_pps

        def own(v: float, m: Motor = m, d: float = d, v0: float = v0) -> float:
            a = float(m.min_a_acc_pps2(v0, v))
            if a <= 0:
                return math.inf
            try:
                return solve_move(d, v_max_pps=v, a_up_pps2=a,
                                  a_down_pps2=float(m.min_a_dec_pps2(v0, v)),
                                  j_max_pps3=m.max_jerk_pps3, v0_pps=v0).duration_s
            except (StepRampError, RuntimeError):
                return math.inf
        caps.append(min(v_max_candidates(m, v0, lim.v_lim_pps), key=own))
    return caps


def solve_synchronised(dist: Sequence[float], t_ref: float, lim: Limits, sync: str) -> Any:
    """ruckig's trajectory of every axis from 0 to its pulses, normalised (see the module),
    synchronised by time or phase."""
    from ruckig import InputParameter, Result, Ruckig, Synchronization, Trajectory

    n = len(dist)
    inp = InputParameter(n)
    inp.current_position, inp.target_position = [0.0] * n, [1.0] * n
    # phase: ruckig checks collinearity to machine epsilon, so proportional boundary
    # speeds must be the very same normalised float on every axis
    vn = [lim.v0[i] * t_ref / dist[i] for i in range(n)]
    vm = [lim.vmax[i] * t_ref / dist[i] for i in range(n)]
    am = [lim.acc[i] * t_ref**2 / dist[i] for i in range(n)]
    dm = [lim.dec[i] * t_ref**2 / dist[i] for i in range(n)]
    jm = [math.inf if j is None else j * t_ref**3 / dist[i] for i, j in enumerate(lim.jerk)]
    if sync == "phase":
        # On the line every axis runs the same normalised profile, so each limit is the
        # least of the axes'. (Given per-axis limits, ruckig only scales the limiting
        # axis's profile and falls back to time synchronisation when that breaks another
        # axis's limit: no straight line at all.)
        vn, vm, am, dm, jm = ([min(x)] * n for x in (vn, vm, am, dm, jm))
    inp.current_velocity, inp.target_velocity = vn, list(vn)
    inp.current_acceleration, inp.target_acceleration = [0.0] * n, [0.0] * n
    inp.max_velocity, inp.max_acceleration = vm, am
    inp.min_acceleration = [-x for x in dm]
    inp.max_jerk = jm
    inp.synchronization = Synchronization.Phase if sync == "phase" else Synchronization.Time
    traj = Trajectory(n)
    try:
        result = Ruckig(n).calculate(inp, traj)
    except RuntimeError as exc:
        raise ReferenceSolveError(f"ruckig: {str(exc).splitlines()[0]}") from exc
    if result != Result.Working:
        raise ReferenceSolveError(f"ruckig: calculation failed ({result})")
    return traj


def sample(traj: Any, dist: Sequence[float], t_ref: float, samples: int
           ) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """(t [s], x[axes] [pulses], v[axes] [pps]) of a normalised trajectory at `samples`
    instants."""
    n = len(dist)
    t_n = np.linspace(0.0, float(traj.duration), samples)
    pv = [traj.at_time(float(t)) for t in t_n]
    x = np.array([[p[0][i] * dist[i] for i in range(n)] for p in pv])
    v = np.array([[p[1][i] * dist[i] / t_ref for i in range(n)] for p in pv])
    return t_n * t_ref, x, v
