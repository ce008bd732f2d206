"""Resonance bands: the planner jumps narrow bands, never cruises in one, crosses wide
ones with minimal stages; `check` reports resonance-dwell."""

from __future__ import annotations

import json
from dataclasses import replace

import numpy as np
import pytest

from profiles.motor import Motor, load_motor
from profiles.motor.resonance import in_bands
from profiles.ppmc312.criterion import all_length_problems
from profiles.ppmc312.planner import plan_free_curve
from profiles.ppmc312.resonance import forbidden_dwells
from profiles.ppmc312.table import FreeCurveTable
from tests.support.nominal_table import NEMA17, PULSES, nominal_plan, speeds


@pytest.fixture(scope="module")
def nominal() -> tuple[Motor, FreeCurveTable]:
    return nominal_plan()


def with_bands(m: Motor, bands: list[tuple[float, float]]) -> Motor:
    return replace(m, resonance_bands_pps=tuple(bands))


def test_narrow_band_is_jumped(nominal: tuple[Motor, FreeCurveTable]) -> None:
    m, table = nominal
    v = speeds(table)
    mid = float(v[5])  # a low stage: the jump-limited region
    band = (mid - 150.0, mid + 150.0)
    assert band[1] - band[0] < m.jump_pps
    banded = with_bands(m, [band])
    assert forbidden_dwells(table, banded)  # the nominal table dwells in it
    new = plan_free_curve(banded, pulses=PULSES).table
    w = speeds(new)
    assert not in_bands(w, (band,)).any()
    below, above = w[w < band[0]].max(), w[w > band[1]].min()
    assert above - below <= m.jump_pps * (1 + 1e-12)  # one step over it
    assert not all_length_problems(new, banded)
    assert forbidden_dwells(new, banded) == []


def test_top_never_in_a_band(nominal: tuple[Motor, FreeCurveTable]) -> None:
    m, table = nominal
    top = float(speeds(table)[-1])
    band = (top - 3000.0, top + 3000.0)  # wider than the jump limit: only the cruise is barred
    banded = with_bands(m, [band])
    dwell = forbidden_dwells(table, banded)
    assert [d.kind for d in dwell] == ["cruise"]
    new = plan_free_curve(banded, pulses=PULSES).table
    assert not in_bands(speeds(new)[-1:], (band,)).any()
    assert forbidden_dwells(new, banded) == []


def test_wide_band_is_crossed_with_minimal_stages(nominal: tuple[Motor, FreeCurveTable]) -> None:
    """Every stage inside a band wider than the jump limit runs the fewest pulses the
    criterion allows (one pulse fewer on either side breaks it, or it is at the chip
    minimum), and there are as few of them as the jump limit allows."""
    m, _ = nominal
    band = (9000.0, 14000.0)
    banded = with_bands(m, [band])
    new = plan_free_curve(banded, pulses=PULSES, separate_decel=True).table
    assert new.decel_pulses is not None
    v = new.clock.hz / np.asarray(new.rates, dtype=float)  # fastest first
    inside = np.flatnonzero(in_bands(v, (band,)))
    assert len(inside) >= 2 and 0 not in inside
    assert not all_length_problems(new, banded)
    chip_min = np.maximum(2, np.ceil(256 / np.asarray(new.rates)))
    tried = 0
    for k in inside.tolist():
        for side in ("accel_pulses", "decel_pulses"):
            counts = list(getattr(new, side))
            if counts[k] <= chip_min[k]:
                continue
            counts[k] -= 1
            fewer = replace(new, **{side: tuple(counts)})
            assert all_length_problems(fewer, banded), (k, side)
            tried += 1
    # here the jump limit binds (counts at the chip minimum): as few stages as steps of at
    # most jump_pps from below the band to above it need
    assert tried + np.sum(chip_min[inside] == np.asarray(new.accel_pulses)[inside]) >= len(inside)
    assert len(inside) == int(np.ceil((band[1] - band[0]) / m.jump_pps)) - 1


@pytest.mark.parametrize("bands, words", [
    ([[3000, 2000]], "0 < lo < hi"), ([[0, 10]], "0 < lo < hi"), ([3000], "pairs")])
def test_bad_bands(bands: list, words: str) -> None:
    obj = json.loads(NEMA17.read_text())
    obj["resonance_bands_pps"] = bands
    with pytest.raises(Exception, match="resonance_bands_pps") as e:
        Motor.from_json(obj)
    assert words in str(e.value)


def test_bands_are_closed_and_their_edge_rates_lie_just_outside() -> None:
    """A band [lo, hi] holds both ends; the rates a jump over it needs are the first whose
    speed is below lo and the first above hi; a band exactly as wide as the jump limit is
    not narrow (one jump cannot clear it)."""
    from profiles.motor.resonance import band_edges_rates, narrow_bands

    bands = ((4000.0, 4500.0),)
    assert in_bands([3999.9, 4000.0, 4250.0, 4500.0, 4500.1], bands).tolist() == [
        False, True, True, True, False]
    m = with_bands(load_motor(NEMA17), [(4000.0, 4500.0)])
    below, above = band_edges_rates(m, 8e6)
    assert 8e6 / below < 4000.0 <= 8e6 / (below - 1)
    assert 8e6 / above > 4500.0 >= 8e6 / (above + 1)
    assert narrow_bands(with_bands(m, [(4000.0, 4000.0 + m.jump_pps)])) == ()
    assert narrow_bands(with_bands(m, [(4000.0, 3999.0 + m.jump_pps)])) != ()
