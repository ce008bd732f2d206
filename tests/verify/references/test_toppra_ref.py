"""verify.references.toppra_ref: the TOPP-RA reference against the exact optimum."""

from __future__ import annotations

import pytest

from profiles.errors import FieldRangeError
from tests.support.reference_moves import BUNDLED, assert_move, flat_motor, solved_against_exact
from verify.references import exact_optimum, toppra_reference


@pytest.mark.slow
@pytest.mark.parametrize("name", sorted(BUNDLED))
@pytest.mark.parametrize("n", [2000, 100_000])
def test_toppra_within_0p2_percent_of_exact(name: str, n: int) -> None:
    ref, exact = solved_against_exact(toppra_reference, name, n)
    # interpolation discretisation holds the constraint at both interval ends, so the
    # result is feasible and therefore never faster than the exact optimum
    assert exact * (1 - 1e-9) <= ref.duration_s <= exact * 1.002


@pytest.mark.slow  # a toppra solve; CI runs it
def test_toppra_short_move() -> None:
    motor = BUNDLED["motor-nema17-1600"]
    ref = toppra_reference(motor, 10, gridpoints=200)
    assert ref.duration_s == pytest.approx(exact_optimum(motor, 10).duration_s, rel=5e-3)
    assert_move(motor, 10, ref)


def test_toppra_bad_gridpoints() -> None:
    with pytest.raises(FieldRangeError, match=r"^gridpoints: "):
        toppra_reference(flat_motor(), 10, gridpoints=3)
