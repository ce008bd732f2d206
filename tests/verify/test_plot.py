"""Every figure the CLI writes: no text past the canvas, a legend entry for every line,
signed positions in sync's figure.

Each CLI run is recorded at `Figure.savefig` (the figure as saved) and judged by what a
draw of it shows (`verify.plot.drawn_texts`: tick labels of ticks outside the view are
not drawn and not judged).
"""

from __future__ import annotations

from collections.abc import Iterator
from pathlib import Path
from typing import Any

import pytest
from matplotlib.figure import Figure

from tests.support.figures import problems
from tests.support.paths import ROOT
from verify import cli
from verify.plot import fit_texts, texts_outside

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


@pytest.mark.slow  # ~3 s; CI runs it
def test_motor_show_plot(tmp_path: Path, saved: list[Any],
                         capsys: pytest.CaptureFixture[str]) -> None:
    for motor in ("nema17-1600", str(EXAMPLES / "motor-nema17-tolerances.json")):
        run_cli(["motor", "show", motor, "--plot", str(tmp_path / "m.png")], tmp_path)
    assert len(saved) == 2 and (tmp_path / "m.png").stat().st_size > 1000
    for fig in saved:
        assert problems(fig) == []


@pytest.mark.slow  # 2–3 s: the quick suite's budget; CI runs it
def test_a_long_title_is_wrapped_and_a_long_word_shrunk() -> None:
    import matplotlib.pyplot as plt

    fig, ax = plt.subplots(figsize=(4.0, 3.0), constrained_layout=True)
    ax.plot([0, 1], [0, 1], label="x")
    ax.legend()
    ax.set_title("a title far too long for a figure four inches wide, " * 3)
    ax.set_xlabel("x" * 120)
    assert texts_outside(fig), "the example must overflow to test anything"
    fit_texts(fig)
    assert texts_outside(fig) == []
    assert "\n" in ax.get_title() and ax.xaxis.label.get_fontsize() < 10
    plt.close(fig)


def test_a_figure_without_layout_engine_gets_constrained_layout() -> None:
    import matplotlib.pyplot as plt

    fig, ax = plt.subplots()
    ax.set_ylabel("a label")
    fig.tight_layout()
    fit_texts(fig)
    assert fig.get_layout_engine().__class__.__name__ == "ConstrainedLayoutEngine"
    plt.close(fig)


@pytest.mark.slow
def test_every_cli_figure(tmp_path: Path, saved: list[Any],
                          capsys: pytest.CaptureFixture[str]) -> None:
    runs = [
        ["compare", str(EXAMPLES / "free-curve-nema17.json"), "--motor", "nema17-1600",
         "--pulses", "5000", "--references", "ruckig", "--plot", str(tmp_path / "c.png")],
        # the heavy motor: an UNSAFE verdict makes the longest title
        ["compare", str(EXAMPLES / "free-curve-nema17.json"), "--motor", "nema23-heavy",
         "--pulses", "5000", "--references", "ruckig", "--plot", str(tmp_path / "c2.svg")],
        ["sweep", "--motors", "nema17-1600", "pk566-5phase-half", "--pulses", "3200",
         "--samples", "0", "--plot", str(tmp_path / "sw.png"), "-o", str(tmp_path / "sw.csv")],
    ]
    for axes in ("axes-xy.json", "axes-alink.json"):
        for mode in ("time", "line"):
            runs.append(["sync", str(EXAMPLES / axes), "--mode", mode, "-o",
                         str(tmp_path / f"{axes}-{mode}"), "--plot",
                         str(tmp_path / f"{axes}-{mode}.png")])
    for argv in runs:
        run_cli(argv, tmp_path, (0, 1))
    assert len(saved) == len(runs)
    for argv, fig in zip(runs, saved, strict=True):
        assert problems(fig) == [], argv
