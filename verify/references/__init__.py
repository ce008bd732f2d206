"""Continuous time-optimal references for a rest-to-rest move: exact oracle, toppra,
ruckig and casadi (toppra, casadi and ruckig are imported lazily, inside the solvers)."""

from profiles.errors import ReferenceSolveError

from ._common import MoveLimits, Reference, accel_zero_pps, move_limits
from ._suite import SOLVERS, best_reference, is_feasible, references, solve_references
from .casadi_ref import casadi_reference
from .exact import exact_optimum
from .ruckig_ref import ruckig_reference
from .toppra_ref import toppra_reference

__all__ = ["SOLVERS", "MoveLimits", "Reference", "ReferenceSolveError", "accel_zero_pps",
           "best_reference", "casadi_reference", "exact_optimum", "is_feasible", "move_limits",
           "references", "ruckig_reference", "solve_references", "toppra_reference"]
