"""verify.cli._common: what every command shares (quantity options, pulse lists, progress bars
on a terminal only)."""

from __future__ import annotations

import argparse
import io
import re
import sys

import pytest

from tests.support.cli import arguments
from verify.cli import _common

# motor new's datasheet options add N·m, A, Ω, mH, V, g·cm², ° and [1] (a ratio); mc200
# stream's torque constant N·m/A
UNIT = re.compile(r"\[(pps|pps²|pps³|s|ms|µs|Hz|pulses|N·m|N·m/A|N·cm|A|Ω|mH|V|g·cm²|°|1|mm|rev)\]")


def test_every_quantity_option_names_its_unit() -> None:
    # Number-typed options and those named for a unit are quantities: their help
    # says the unit in brackets, spelled one way.
    quantity = [(name, a) for name, a in arguments()
                if a.type is _common.number
                or any(re.search(r"(pps|-us|-hz|pulses)$", o) for o in a.option_strings)]
    assert len(quantity) >= 10
    lacking = [f"{name} {a.option_strings}" for name, a in quantity
               if not UNIT.search(a.help or "")]
    assert not lacking, f"quantity options whose help has no [unit]: {lacking}"


class _Tty(io.StringIO):
    def isatty(self) -> bool:
        return True


def test_progress_bar_only_on_a_terminal(monkeypatch: pytest.MonkeyPatch) -> None:
    monkeypatch.setattr(_common, "PROGRESS_DELAY_S", 0.0)
    pipe = io.StringIO()
    monkeypatch.setattr(sys, "stderr", pipe)
    with _common.progress_bar("work") as progress:
        assert progress is None
    assert pipe.getvalue() == ""
    tty = _Tty()
    monkeypatch.setattr(sys, "stderr", tty)
    with _common.progress_bar("work", unit="packet") as progress:
        assert progress is not None
        progress(0, 40)
        progress(40, 40)
    assert "work" in tty.getvalue() and "40/40" in tty.getvalue()


def test_a_pulse_list_is_every_length_given_in_order() -> None:
    """--pulses N[,M…]: each length kept, spaces allowed, 1..2³²−1 (a move counter)."""
    assert _common.pulse_list("1000, 3000,10000") == [1000, 3000, 10000]
    assert _common.pulse_list("4294967295") == [4294967295]
    for bad in ("0", "4294967296", "1000,", "1000,x"):
        with pytest.raises(argparse.ArgumentTypeError):
            _common.pulse_list(bad)
