"""All references on one move, each re-checked in physical units, and the best of them."""

from __future__ import annotations

from collections.abc import Callable, Iterable
from typing import Any

from profiles.errors import FormatError, ReferenceSolveError, echo
from profiles.motor import Motor
from profiles.progress import Progress, track

from ._common import Reference, capability_violation, move_limits
from .exact import exact_optimum

#: Prefix put into `Reference.info` when the sampled output breaks the capability.
VIOLATION_MARK = "capability violated:"

#: Acceleration slack of the re-check, relative to a_acc(0): solver tolerances and
#: node-only constraints leave ~1e-7; a real violation is orders of magnitude larger.
CHECK_REL_TOL = 1e-4

SOLVERS = ("toppra", "ruckig", "casadi")


def _solver(name: str) -> Callable[[Motor, float], Reference]:
    if name == "toppra":
        from .toppra_ref import toppra_reference
        return toppra_reference
    if name == "ruckig":
        from .ruckig_ref import ruckig_reference
        return ruckig_reference
    from .casadi_ref import casadi_reference
    return casadi_reference


def references(motor: Motor, pulses: Any, *, include: Iterable[str] = SOLVERS,
               progress: Progress | None = None) -> dict[str, Reference]:
    """The exact optimum plus each included solver on the same move, keyed by name
    ("exact", "toppra", "ruckig" (the feasible bound), "casadi").

    Every result is re-checked on its samples (speed ≤ v_lim·(1+1e-6), −a_dec(v) − tol ≤
    a ≤ a_acc(v) + tol, ends at v0, covers 0…N); problems go into its `info` after
    VIOLATION_MARK. A solver that fails is left out and named in the exact one's info
    (`solve_references` gives the failures by name).
    The solvers take seconds: `progress` hears (solvers run, solvers included).
    """
    return solve_references(motor, pulses, include=include, progress=progress)[0]


def solve_references(motor: Motor, pulses: Any, *, include: Iterable[str] = SOLVERS,
                     progress: Progress | None = None
                     ) -> tuple[dict[str, Reference], dict[str, str]]:
    """`references`, and the solvers that failed: name → the reason (the solver's message
    without its leading "name: "), in the order asked for."""
    wanted = list(include)
    for name in wanted:
        if name not in SOLVERS:
            raise FormatError(f"include: unknown reference {echo(name)} (known: "
                              f"{', '.join(SOLVERS)})")
    lim = move_limits(motor, pulses)
    out = {"exact": exact_optimum(motor, lim.pulses)}
    failures: dict[str, str] = {}
    for name in track(wanted, progress):
        try:
            out[name] = _solver(name)(motor, lim.pulses)
        except ReferenceSolveError as exc:
            text = str(exc)
            failures[name] = text.removeprefix(f"{name}: ") or "no reason given"
    for ref in out.values():
        problem = capability_violation(motor, lim, ref, rel_tol=CHECK_REL_TOL)
        ref.info += f"; {VIOLATION_MARK} {problem}" if problem else "; check ok"
    if failures:
        out["exact"].info += "; failed: " + " | ".join(
            f"{name}: {why}" for name, why in failures.items())
    return out, failures


def is_feasible(ref: Reference) -> bool:
    """True unless the re-check in `references` found a violation."""
    return VIOLATION_MARK not in ref.info


def best_reference(refs: dict[str, Reference]) -> Reference:
    """The fastest reference whose samples passed the capability re-check."""
    feasible = [r for r in refs.values() if is_feasible(r)]
    if not feasible:
        raise ReferenceSolveError("best_reference: no reference passed the capability check")
    return min(feasible, key=lambda r: r.duration_s)
