"""verify.references._suite: every reference solved, the fastest feasible one chosen."""

from __future__ import annotations

import pytest

from profiles.errors import FormatError
from tests.support.reference_moves import BUNDLED, assert_move
from verify.references import (
    ReferenceSolveError,
    best_reference,
    is_feasible,
    move_limits,
    references,
    ruckig_reference,
)
from verify.references._common import capability_violation
from verify.references._suite import CHECK_REL_TOL


@pytest.mark.slow
def test_references_all_feasible_and_best_is_fastest() -> None:
    motor = BUNDLED["motor-nema23-heavy"]
    refs = references(motor, 5000)
    assert set(refs) == {"exact", "toppra", "ruckig", "casadi"}
    for ref in refs.values():
        assert is_feasible(ref), ref.info
        assert_move(motor, 5000, ref, rel_tol=CHECK_REL_TOL)
    best = best_reference(refs)
    assert best.duration_s == min(r.duration_s for r in refs.values())
    assert best.duration_s == pytest.approx(refs["exact"].duration_s, rel=2e-3)


def test_references_flags_violations_and_best_skips_them() -> None:
    motor = BUNDLED["motor-nema17-1600"]
    refs = references(motor, 3000, include=("ruckig",))
    assert set(refs) == {"exact", "ruckig"}
    assert all(is_feasible(r) for r in refs.values())
    # a reference that accelerates harder than the motor can is marked and skipped
    fast = ruckig_reference(motor, 3000, bound="optimistic")
    fast.info += "; " + "capability violated: " + capability_violation(
        motor, move_limits(motor, 3000), fast, rel_tol=CHECK_REL_TOL)
    assert not is_feasible(fast)
    assert best_reference({**refs, "fast": fast}) is refs["exact"]
    with pytest.raises(ReferenceSolveError):
        best_reference({"fast": fast})
    with pytest.raises(FormatError, match=r"^include: "):
        references(motor, 3000, include=("gurobi",))
