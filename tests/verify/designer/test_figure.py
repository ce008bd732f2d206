"""The designer's figure (verify/designer/figure.py): its panels, a change drawn over the
kept frames (the picture a fresh figure draws), the time axes' numbers, the mark, the PNG."""

from __future__ import annotations

import dataclasses
import io

import numpy as np
import pytest
from PIL import Image

from tests.support.designer_settings import NEMA17, RINGS
from verify.designer import DesignFigure, Settings, design, first_design
from verify.designer.figure import TIME_TICKS, nice_step

MARK_RGB = (0xB3, 0x6B, 0x00)  # the first table's mark


def pixels(png: bytes) -> np.ndarray:
    return np.asarray(Image.open(io.BytesIO(png)).convert("RGB"))


def marked(png: bytes) -> int:
    """How many pixels have the mark's colour."""
    return int(np.all(pixels(png) == MARK_RGB, axis=-1).sum())


def test_the_figure_names_its_three_axes_and_marks_the_peak() -> None:
    """Speed against time, the stall margin per stage, the load angle against time with
    the ±90° peak drawn; each axis says its quantity and unit."""
    fig = DesignFigure()
    labels = [(ax.get_xlabel(), ax.get_ylabel()) for ax in (fig.ax_v, fig.ax_m, fig.ax_l)]
    assert labels == [("time [ms]", "speed [pps]"), ("stage (0 = fastest)", "stall margin"),
                      ("time [ms]", "load angle [° el.]")]
    peaks = sorted(line.get_ydata()[0] for line in fig.ax_l.get_lines()
                   if line is not fig.lag_line)
    assert peaks == [-90, 90]


def test_the_png_is_the_canvas() -> None:
    """`fast_png` writes the canvas's pixels as they are (a standard PNG any reader opens)."""
    fig = DesignFigure()
    png = fig.update(design(NEMA17, RINGS))
    assert png[:8] == b"\x89PNG\r\n\x1a\n"
    canvas = np.asarray(fig.canvas.buffer_rgba())[:, :, :3]
    assert np.array_equal(pixels(png), canvas)


def test_a_change_is_drawn_over_the_kept_frames_as_a_fresh_figure_draws_it() -> None:
    fig = DesignFigure()
    final_png = fig.update(design(NEMA17, RINGS))
    assert fig.last_drawing == "full" and not fig.mark.get_visible()
    assert marked(final_png) == 0
    nearby = Settings(pulses=5_500, safety_factor=RINGS.safety_factor)
    first = first_design(NEMA17, nearby)
    png = fig.update(first)
    assert fig.last_drawing == "over" and fig.mark.get_visible()
    assert fig.table_line.get_linestyle() == "--" and marked(png) > 200
    assert png == DesignFigure().update(first)  # nothing of the last table stays behind
    near = design(NEMA17, nearby)
    over = fig.update(near)
    assert fig.last_drawing == "over" and not fig.mark.get_visible() and marked(over) == 0
    assert over == DesignFigure().update(near)
    # a much longer move: the time axes' numbers change, their frames do not
    numbers = [t.get_text() for t in fig.time_labels[fig.ax_v]]
    longer = first_design(NEMA17, Settings(pulses=60_000))
    far = fig.update(longer)
    assert fig.last_drawing == "over" and fig.ax_v.get_xlim()[1] > 2 * float(numbers[-1])
    assert [t.get_text() for t in fig.time_labels[fig.ax_v]] != numbers
    assert far == DesignFigure().update(longer)
    # a margin outside the panel's range draws that panel again: the picture a full
    # drawing at those limits is
    low = dataclasses.replace(near, margins={**near.margins, "min": 0.3,
                                             "accel": [0.3, *near.margins["accel"][1:]]})
    redrawn = fig.update(low)
    assert fig.last_drawing == "panels" and fig.ax_m.get_ylim()[0] < 0.3
    fig.shown, fig.background = (), None
    assert fig.update(low) == redrawn and fig.last_drawing == "full"
    # the references shown change the legend: in full
    fig.update(near, {"toppra": near.exact})
    assert fig.last_drawing == "full"


def test_the_time_axes_hold_every_line_and_fill_half_of_them() -> None:
    """Five steps of 1, 2, 2.5 or 5 × 10^k: the end of every line inside (the load angle's
    with the rotor settling after the move), at least half the axis used, the numbers
    under the ticks those steps."""
    assert [nice_step(x) for x in (0.3, 1.0, 1.01, 2.4, 4.9, 5.1, 730.0)] == \
        [0.5, 1.0, 2.0, 2.5, 5.0, 10.0, 1000.0]
    fig = DesignFigure()
    for pulses in (50, 5_000, 60_000):
        result = design(NEMA17, Settings(pulses=pulses))
        fig.update(result)
        speeds = max(float(result.execution.duration_s), float(result.exact.duration_s))
        for ax, end_s in ((fig.ax_v, speeds), (fig.ax_l, float(result.physics.lag_t_s[-1]))):
            end = end_s * 1e3
            top = ax.get_xlim()[1]
            assert end <= top <= 2.05 * end
            step = top / TIME_TICKS
            assert [t.get_text() for t in fig.time_labels[ax]] == \
                [f"{k * step:g}" for k in range(TIME_TICKS + 1)]


def test_readouts_and_the_speed_axis_speak_the_axis_units() -> None:
    """mm and mm/s where the motor file states its travel per revolution, rev and rpm
    otherwise (profiles.motor.travel's conversions), beside pulses and pps."""
    screw = dataclasses.replace(NEMA17, travel_mm_per_rev=8.0)  # 1600 pulses/rev
    fig = DesignFigure()
    for motor, length, speed in ((screw, "(25 mm)", "speed [mm/s]"),
                                 (NEMA17, "(3.125 rev)", "speed [rpm]")):
        result = first_design(motor, Settings(pulses=5_000))
        summary = result.summary()
        assert f"5000 pulses {length}" in summary
        top = float(result.execution.edges()[2].max())
        assert f"({result.units.speed_text(top)})" in summary
        fig.update(result)
        assert fig.last_drawing == "full"  # another motor's units: a new second scale
        (second,) = fig.ax_v.child_axes
        assert second.get_ylabel() == speed
    assert result.units.speed(top) == pytest.approx(top * 60 / 1600)
