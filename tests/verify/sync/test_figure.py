"""verify.sync.figure: sync's figure draws signed positions, nothing past the canvas."""

from __future__ import annotations

import json
from pathlib import Path
from typing import Any

import numpy as np
import pytest

from tests.support.cli import exits
from tests.support.figures import close, record_saved
from tests.support.paths import ROOT

EXAMPLES = ROOT / "examples"


@pytest.fixture
def saved(monkeypatch: pytest.MonkeyPatch) -> list[Any]:
    """The figures saved while the test runs."""
    return record_saved(monkeypatch)


@pytest.mark.slow
def test_sync_figure_positions_are_signed(tmp_path: Path, saved: list[Any],
                                          capsys: pytest.CaptureFixture[str]) -> None:
    # axes-xy.json: x +12 000, y −5 000 pulses
    axes = json.loads((EXAMPLES / "axes-xy.json").read_text())
    assert [a["pulses"] for a in axes["axes"]] == [12000, -5000]
    exits(["sync", str(EXAMPLES / "axes-xy.json"), "--mode", "line", "-o",
             str(tmp_path / "out"), "--plot", str(tmp_path / "line.png")], (0, 1))
    [fig] = saved
    path_ax, _, speed_ax = fig.axes
    executed, line = path_ax.get_lines()
    assert executed.get_ydata()[-1] == -5000 and executed.get_xdata()[-1] == 12000
    assert list(line.get_xdata()) == [0, 12000] and list(line.get_ydata()) == [0, -5000]
    y_speed = next(ln for ln in speed_ax.get_lines() if ln.get_label().startswith("y ("))
    assert max(y_speed.get_ydata()) < 0  # y runs CCW the whole move (from its start speed)


def test_sync_deviation_is_an_envelope_with_its_worst_marked() -> None:
    import matplotlib.pyplot as plt
    from matplotlib.collections import PolyCollection

    from verify.sync.figure import DEVIATION_BINS, binned_envelope, deviation_panel

    rng = np.random.default_rng(0)
    t = np.cumsum(rng.uniform(1e-6, 2e-5, 100_000))
    d = rng.uniform(0.0, 0.8, t.size) * (np.arange(t.size) % 2)  # 0 at every other instant
    d[54_321] = 1.5
    fig, ax = plt.subplots()
    deviation_panel(ax, t, d)
    [fill] = [c for c in ax.collections if isinstance(c, PolyCollection)]
    assert len(fill.get_paths()[0].vertices) < 6 * DEVIATION_BINS  # not one per instant
    lines = ax.get_lines()
    assert all(len(ln.get_xdata()) <= DEVIATION_BINS + 1 for ln in lines)
    [worst] = [ln for ln in lines if ln.get_label().startswith("worst")]
    assert worst.get_ydata()[0] == 1.5 and worst.get_xdata()[0] == pytest.approx(t[54_321] * 1e3)
    edges, lo, hi = binned_envelope(t, d, DEVIATION_BINS)
    assert hi.max() == 1.5 and lo.min() == 0.0 and np.all(lo <= hi)
    inside = (t >= edges[7]) & (t < edges[8])  # a bin's own instants lie within its band
    assert lo[7] <= d[inside].min() and d[inside].max() <= hi[7]
    close(fig)
