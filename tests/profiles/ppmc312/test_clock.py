"""profiles.ppmc312.clock: the chip's clocks by name (any case) and by CLK code."""

from __future__ import annotations

import pytest

from profiles.ppmc312.clock import Clock


@pytest.mark.parametrize("typed", ["8mhz", "8MHZ", "62.5khz", "15.625 kHz"])
def test_clock_names_any_case(typed: str) -> None:
    assert Clock.named(typed) == Clock.internal(
        next(n for n in ("8MHz", "62.5kHz", "15.625kHz") if n.lower() == typed.replace(
            " ", "").lower()))


@pytest.mark.parametrize(("code", "hz"), [(0, 8e6), (1, 1e6), (2, 500e3), (3, 250e3),
                                          (4, 62.5e3), (5, 15.625e3)])
def test_each_clk_code_is_the_manuals_clock(code: int, hz: float) -> None:
    """SPEC §1: CLK 000 8 MHz … 101 15.625 kHz (000 is a clock, not "none")."""
    assert Clock.from_code(code) == Clock(code, hz)


def test_an_external_clock_is_named_by_its_edge() -> None:
    from profiles.ppmc312.clock import EXTCK_RISING, Clock

    assert Clock(EXTCK_RISING, 2e6).name == "EXTCK 2e+06 Hz rising"
    assert Clock(EXTCK_RISING + 1, 2e6).name == "EXTCK 2e+06 Hz falling"
