"""verify.sync.figure: sync's figure draws signed positions, nothing past the canvas."""

from __future__ import annotations

import json
from collections.abc import Iterator
from pathlib import Path
from typing import Any

import pytest
from matplotlib.figure import Figure

from tests.support.paths import ROOT
from verify import cli

EXAMPLES = ROOT / "examples"


@pytest.fixture
def saved(monkeypatch: pytest.MonkeyPatch) -> Iterator[list[Any]]:
    """The figures saved while the test runs."""
    figures: list[Any] = []
    original = Figure.savefig

    def record(self: Any, *args: Any, **kwargs: Any) -> None:
        figures.append(self)
        original(self, *args, **kwargs)

    monkeypatch.setattr(Figure, "savefig", record)
    yield figures


def run_cli(argv: list[str], tmp_path: Path, exit_codes: tuple[int, ...] = (0,)) -> None:
    code = cli.main(argv)
    assert code in exit_codes, argv


@pytest.mark.slow
def test_sync_figure_positions_are_signed(tmp_path: Path, saved: list[Any],
                                          capsys: pytest.CaptureFixture[str]) -> None:
    # axes-xy.json: x +12 000, y −5 000 pulses
    axes = json.loads((EXAMPLES / "axes-xy.json").read_text())
    assert [a["pulses"] for a in axes["axes"]] == [12000, -5000]
    run_cli(["sync", str(EXAMPLES / "axes-xy.json"), "--mode", "line", "-o",
             str(tmp_path / "out"), "--plot", str(tmp_path / "line.png")], tmp_path, (0, 1))
    [fig] = saved
    path_ax, _, speed_ax = fig.axes
    executed, line = path_ax.get_lines()
    assert executed.get_ydata()[-1] == -5000 and executed.get_xdata()[-1] == 12000
    assert list(line.get_xdata()) == [0, 12000] and list(line.get_ydata()) == [0, -5000]
    y_speed = next(ln for ln in speed_ax.get_lines() if ln.get_label().startswith("y ("))
    assert max(y_speed.get_ydata()) < 0  # y runs CCW the whole move (from its start speed)
