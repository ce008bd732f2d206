"""verify.references.casadi_ref: the CasADi reference against the exact optimum."""

from __future__ import annotations

import numpy as np
import pytest

from profiles.errors import FieldRangeError
from tests.support.reference_moves import BUNDLED, assert_move, flat_motor, solved_against_exact
from verify.references import casadi_reference, exact_optimum, ruckig_reference


@pytest.mark.slow
@pytest.mark.parametrize("name", sorted(BUNDLED))
@pytest.mark.parametrize("n", [2000, 100_000])
def test_casadi_without_jerk_within_0p2_percent_of_exact(name: str, n: int) -> None:
    ref, exact = solved_against_exact(casadi_reference, name, n)
    assert ref.duration_s == pytest.approx(exact, rel=2e-3)


@pytest.mark.slow
def test_casadi_jerk_limited_sits_between_exact_and_ruckig() -> None:
    motor = BUNDLED["motor-pk566-5phase-half"]
    jerk = 1e9
    ref = casadi_reference(motor, 2000, jerk=jerk)
    exact = exact_optimum(motor, 2000).duration_s
    ruck = ruckig_reference(motor, 2000, j_max_pps3=jerk).duration_s
    assert exact < ref.duration_s <= ruck
    assert_move(motor, 2000, ref)
    assert ref.a_pps2[0] == pytest.approx(0, abs=1e-6 * jerk) and \
        ref.a_pps2[-1] == pytest.approx(0, abs=1e-6 * jerk)
    assert np.all(np.abs(np.diff(ref.a_pps2)) <= jerk * np.diff(ref.t_s) * (1 + 1e-6) + 1e-3)


def test_casadi_bad_arguments() -> None:
    with pytest.raises(FieldRangeError, match=r"^intervals: "):
        casadi_reference(flat_motor(), 10, intervals=2)
    with pytest.raises(FieldRangeError, match=r"^jerk: "):
        casadi_reference(flat_motor(), 10, jerk=0.0)
