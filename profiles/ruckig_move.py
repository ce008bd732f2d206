"""ruckig, once: a 1-DOF move between equal speeds with constant limits.

Every single-axis use of ruckig goes through `solve_move` (the MC-200 stream's
profile and the continuous reference of verify.references). ruckig fails on a few
percent of moves in raw pulse units (REFERENCES.md), so the move is solved in
normalised units (x/N, t/t_ref) and converted back here, at the edge. Its refusals
become one-line `StepRampError`s (its own text is a dump of the input).
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Any

import numpy as np

from .errors import StepRampError


@dataclass(frozen=True)
class RuckigMove:
    """A solved move of `pulses` from speed v0 back to v0 (physical units)."""

    pulses: float
    t_ref_s: float
    duration_s: float
    trajectory: Any = None    # ruckig's Trajectory, in normalised units

    @property
    def phase_ends_s(self) -> np.ndarray:
        """The ends of ruckig's seven profile phases [s]."""
        return np.cumsum(np.asarray(self.trajectory.profiles[0][0].t, float)) * self.t_ref_s

    def sample(self, t_s: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """(x_pulses, v_pps, a_pps2) at the instants `t_s` (ruckig's own evaluation)."""
        tn = np.clip(np.asarray(t_s, dtype=float) / self.t_ref_s, 0.0,
                     self.duration_s / self.t_ref_s)
        pva = np.array([[s[0] for s in self.trajectory.at_time(float(t))] for t in tn])
        scale = self.pulses
        return (pva[:, 0] * scale, pva[:, 1] * scale / self.t_ref_s,
                pva[:, 2] * scale / self.t_ref_s**2)

    def position_at(self, t_s: Any) -> np.ndarray:
        """x_pulses at `t_s`, vectorised from the profile's phase polynomials (finite jerk
        only: millions of instants, as the MC-200 stream needs)."""
        prof = self.trajectory.profiles[0][0]
        if prof.brake.duration > 0:  # never for a start within the limits
            raise StepRampError("ruckig: unexpected brake phase in the profile")
        durations = np.asarray(prof.t, dtype=float)
        starts = np.concatenate(([0.0], np.cumsum(durations)))[:-1]
        j = np.asarray(prof.j, dtype=float)
        if not np.all(np.isfinite(j)):
            raise StepRampError("ruckig: position_at needs a finite jerk limit")
        a0, v0, p0 = (np.asarray(x, dtype=float)[:7] for x in (prof.a, prof.v, prof.p))
        tn = np.clip(np.asarray(t_s, dtype=float) / self.t_ref_s, 0.0,
                     self.duration_s / self.t_ref_s)
        k = np.clip(np.searchsorted(starts, tn, side="right") - 1, 0, 6)
        dt = tn - starts[k]
        pn = p0[k] + dt * (v0[k] + dt * (a0[k] / 2 + dt * j[k] / 6))
        return np.clip(pn, 0.0, 1.0) * self.pulses


def solve_move(pulses: float, *, v_max_pps: float, a_up_pps2: float, a_down_pps2: float,
               j_max_pps3: float | None, v0_pps: float = 0.0,
               t_ref_s: float | None = None) -> RuckigMove:
    """The time-optimal ruckig move of `pulses` pulses from `v0_pps` back to `v0_pps`
    under constant limits (acceleration +`a_up_pps2`, braking −`a_down_pps2`; no jerk
    limit when `j_max_pps3` is None: ruckig's second-order mode, an exact trapezoid).
    Normalised by `t_ref_s` (default sqrt(pulses / a_up))."""
    from ruckig import InputParameter, Result, Ruckig, RuckigError, Trajectory

    length = float(pulses)
    t_ref = math.sqrt(length / a_up_pps2) if t_ref_s is None else t_ref_s
    v_ref, a_ref = length / t_ref, length / t_ref**2
    inp = InputParameter(1)
    inp.current_position, inp.target_position = [0.0], [1.0]
    inp.current_velocity = inp.target_velocity = [v0_pps / v_ref]
    inp.current_acceleration = inp.target_acceleration = [0.0]
    inp.max_velocity = [v_max_pps / v_ref]
    inp.max_acceleration = [a_up_pps2 / a_ref]
    inp.min_acceleration = [-a_down_pps2 / a_ref]
    inp.max_jerk = [math.inf if j_max_pps3 is None else j_max_pps3 * t_ref**3 / length]
    traj = Trajectory(1)
    what = (f"{pulses:g} pulses, v {v_max_pps:g} pps, a +{a_up_pps2:g}/−{a_down_pps2:g} pps²"
            + ("" if j_max_pps3 is None else f", j {j_max_pps3:g} pps³"))
    try:
        result = Ruckig(1).calculate(inp, traj)
    except RuckigError:  # the limits are outside ruckig's numeric range
        raise StepRampError(f"ruckig: no move for {what} (the limits are outside ruckig's "
                            "numeric range)") from None
    if result != Result.Working:
        raise StepRampError(f"ruckig: no move for {what} ({result})")
    return RuckigMove(length, t_ref, float(traj.duration) * t_ref, traj)
