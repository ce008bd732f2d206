"""Every figure the CLI writes: no text past the canvas, a legend entry for every line,
signed positions in sync's figure.

Each CLI run is recorded at `Figure.savefig` (the figure as saved) and judged by what a
draw of it shows (`verify.plot.drawn_texts`: tick labels of ticks outside the view are
not drawn and not judged).
"""

from __future__ import annotations

import dataclasses
from pathlib import Path
from types import SimpleNamespace
from typing import Any

import numpy as np
import pytest

from profiles.motor import bundled_motor_paths, load_motor
from profiles.ppmc312.planner import plan_free_curve
from tests.support.cli import exits
from tests.support.figures import close, problems, record_saved, scale_labels
from tests.support.paths import ROOT
from verify.compare import compare_table
from verify.plot import comparison_figure, fit_texts, texts_outside

EXAMPLES = ROOT / "examples"


@pytest.fixture
def saved(monkeypatch: pytest.MonkeyPatch) -> list[Any]:
    """The figures saved while the test runs."""
    return record_saved(monkeypatch)


@pytest.mark.slow  # ~3 s; CI runs it
def test_motor_show_plot(tmp_path: Path, saved: list[Any],
                         capsys: pytest.CaptureFixture[str]) -> None:
    for motor in ("nema17-1600", str(EXAMPLES / "motor-nema17-tolerances.json")):
        exits(["motor", "show", motor, "--plot", str(tmp_path / "m.png")])
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
        exits(argv, (0, 1))
    assert len(saved) == len(runs)
    for argv, fig in zip(runs, saved, strict=True):
        assert problems(fig) == [], argv


MOTOR = load_motor(bundled_motor_paths()[0])


PLAN = plan_free_curve(MOTOR, pulses=4000)


@pytest.fixture(scope="module")
def cmp() -> Any:
    return compare_table(PLAN.table, MOTOR, 4000, include=("ruckig",))


def test_negative_stall_margins_are_drawn_below_zero(cmp: Any) -> None:
    acc = np.asarray(cmp.margins["accel"], float).copy()
    acc[:3] = [-0.4, -0.1, 0.5]
    shown = SimpleNamespace(**{k: getattr(cmp, k) for k in (
        "table", "execution", "references", "table_s", "ratio", "safe", "failed_judges",
        "pulses", "motor")}, margins={**cmp.margins, "accel": acc, "min": -0.4},
        stall_margin=-0.4)
    fig = comparison_figure(shown)
    ax = fig.axes[-1]
    heights = sorted(p.get_height() for p in ax.patches)
    assert heights[:2] == pytest.approx([-0.4, -0.1])
    assert ax.get_ylim()[0] < -0.4
    assert "2 below 0" in ax.get_title()
    close(fig)


def test_reference_lines_differ_in_style() -> None:
    from verify.plot import REFERENCE_STYLE

    looks = {(s["color"], s["ls"], s["lw"], s.get("marker")) for s in REFERENCE_STYLE.values()}
    assert len(looks) == len(REFERENCE_STYLE)
    assert REFERENCE_STYLE["exact"]["zorder"] < REFERENCE_STYLE["toppra"]["zorder"] \
        < REFERENCE_STYLE["casadi"]["zorder"]


def motor_named(name: str) -> Any:
    return next(load_motor(p) for p in bundled_motor_paths() if p.stem.endswith(name))


def test_motor_show_marks_the_reachable_top_speed_and_the_drive() -> None:
    from verify.plot import motor_figure
    from verify.references import accel_zero_pps

    heavy = motor_named("nema23-heavy")
    zero = accel_zero_pps(heavy)
    assert zero < heavy.top_pps  # a_acc < 0 before the curve's end (12 000 pps)
    fig = motor_figure(heavy)
    for ax in fig.axes:
        marks = [ln for ln in ax.get_lines() if ln.get_label().startswith("reachable top")]
        assert [float(m.get_xdata()[0]) for m in marks] == [pytest.approx(zero)]
    assert "drive: not stated" in fig.get_suptitle()
    close(fig)
    said = {"pullout_torque": [{"value": 0.44, "from": "model: T_h 0.59 N·m; drive 24 V, "
                                                       "1.5 A RMS, 1/8 step"}]}
    fig = motor_figure(dataclasses.replace(MOTOR, name="", sources=said), "17hs19")
    assert fig.get_suptitle() == ("17hs19: torque and capability\ndrive 24 V, 1.5 A RMS, 1/8 "
                                  "step; rotary: 1600 pulses/rev (no travel_mm_per_rev)")
    close(fig)


def test_motor_show_hides_no_line_under_another() -> None:
    from verify.plot import motor_figure

    fig = motor_figure(dataclasses.replace(MOTOR, safety_factor=1.0, friction_torque_nm=0.0))
    ax_t = fig.axes[0]
    curves = [ln for ln in ax_t.get_lines() if len(ln.get_xdata()) > 2]
    assert len(curves) == 1 and "safety factor 1" in curves[0].get_label()
    zero = next(ln for ln in ax_t.get_lines() if ln.get_label().startswith("cruising needs"))
    assert ax_t.get_ylim()[0] < float(zero.get_ydata()[0]) == 0.0  # above the frame
    close(fig)


def test_real_units_beside_pulses_mm_with_a_travel_else_rev(cmp: Any) -> None:
    from verify.plot import motor_figure

    fig = comparison_figure(cmp)  # the bundled NEMA17: rotary, rpm and rev
    assert scale_labels(fig.axes[0]) == ["speed [rpm]"]
    assert sorted(scale_labels(fig.axes[1])) == ["position [rev]", "speed [rpm]"]
    close(fig)
    screw = dataclasses.replace(MOTOR, travel_mm_per_rev=8.0)
    fig = comparison_figure(dataclasses.replace(cmp, motor=screw))
    assert sorted(scale_labels(fig.axes[1])) == ["position [mm]", "speed [mm/s]"]
    top = next(c for c in fig.axes[1].child_axes if c.get_xlabel() == "position [mm]")
    top.apply_aspect()  # a second scale takes its view from its axes when laid out
    lo, hi = top.get_xlim()  # the same view: 4000 pulses = 20 mm at 1600 pulses/rev
    pulses_lo, pulses_hi = fig.axes[1].get_xlim()
    assert (lo, hi) == pytest.approx((pulses_lo * 8 / 1600, pulses_hi * 8 / 1600))
    close(fig)
    fig = motor_figure(screw)
    assert scale_labels(fig.axes[0]) == ["speed [mm/s]"]
    assert sorted(scale_labels(fig.axes[1])) == ["acceleration [mm/s²]", "speed [mm/s]"]
    assert "8 mm/rev" in fig.get_suptitle()
    close(fig)
