"""The designer's figure: one figure kept across changes, a change drawn in milliseconds.

Three panels: speed against time (the table's staircase, the exact optimum, any slow
references), the stall margin per stage, the load angle against time. What a change
costs is drawing, and text is what matplotlib draws slowest (about 0.1 ms a glyph): so
the panels' frames (axes, grid, ticks, labels, legend, titles) are drawn once into a
kept background, and a change draws over it only its data: the lines, the numbers under
the two time axes and, for a first table, its mark (rendered once, its pixels copied
in). The time axes keep their ticks where they are: their limit is five times a
1-2-2.5-5 step, so a longer move changes the numbers under the ticks, never the frame.
The other scales are fixed for a motor: speed up to its top speed, the chip's 127
stages, margins 0.5–100, load angle ±100°; a design outside them (a margin below 0.5,
an angle past ±100°: an unsafe table) draws the panels whose limits moved again
("panels"), another motor's units or other references everything ("full"). The numbers
a title would carry (move time, ratio, smallest margin, worst angle) are in the summary
every view shows beside the figure.

The PNG is written with no row filter at zlib level 1 (`verify.plot.fast_png`): Pillow
always filters every row, which takes most of its time on a plot's flat colours.
"""

from __future__ import annotations

import math
from typing import Any

from .model import TIGHTENING, Design

TIME_TICKS = 5                   # divisions of a time axis: its limit is 5 × a nice step
NICE_STEPS = (1.0, 2.0, 2.5, 5.0)
MARGIN_RANGE = (0.5, 100.0)      # the margin panel's scale unless a margin falls outside
ANGLE_SPAN_DEG = 100.0           # the load-angle panel shows ±100° (the ±90° peak drawn)
STAGE_AXIS = 127                 # the chip's most stages: the margin panel's x scale


class DesignFigure:
    """One figure kept across changes (module docstring): `update(result)` gives the PNG;
    `last_drawing` says what the last change drew: "over" (the data over the kept
    background), "panels" (the panels whose limits moved, then the data) or "full"."""

    MAX_POINTS = 1500  # the lag trace is drawn as a min/max envelope of this many bins

    def __init__(self, *, dpi: int = 72) -> None:
        from matplotlib.backends.backend_agg import FigureCanvasAgg
        from matplotlib.figure import Figure

        self.dpi = dpi
        self.fig = Figure(figsize=(9.0, 7.5), dpi=dpi)
        self.canvas = FigureCanvasAgg(self.fig)
        # room on the right for the speed's second scale in real units
        self.fig.subplots_adjust(left=0.09, right=0.91, top=0.96, bottom=0.07, hspace=0.55)
        self.ax_v, self.ax_m, self.ax_l = self.fig.subplots(3, 1, height_ratios=[3, 2, 2])
        self._frames()
        self.table_line, = self.ax_v.step([], [], where="post", color="tab:red", lw=1.5)
        self.ref_lines: dict[str, Any] = {}
        self.margin_lines = {
            side: self.ax_m.plot([], [], marker=marker, ls="none", ms=3, color=color,
                                 label=side)[0]
            for side, marker, color in (("accel", "o", "tab:red"),
                                        ("decel", "s", "tab:orange"))}
        self.ax_m.legend(fontsize=7, ncols=3, loc="upper left")
        self.lag_line, = self.ax_l.plot([], [], color="tab:blue", lw=1.0)
        self.time_labels = {ax: _tick_numbers(self.fig, ax) for ax in (self.ax_v, self.ax_l)}
        # each time label's pixels once drawn, by (label, text): the numbers under the
        # fixed ticks come back change after change, and rendering text is half a
        # drawing; kept while the background under them is
        self.label_pixels: dict[tuple[int, str], Any] = {}
        # a first table's mark, over the speed panel
        self.mark = self.ax_v.text(0.99, 0.04, f"{TIGHTENING} first table, not judged: "
                                   "not safe to use", transform=self.ax_v.transAxes,
                                   ha="right", va="bottom", fontsize=10, fontweight="bold",
                                   color="white", bbox={"facecolor": "#b36b00",
                                                        "edgecolor": "none", "pad": 3})
        for artist in (*self._live(), *(t for ts in self.time_labels.values() for t in ts)):
            artist.set_animated(True)  # left out of the background, drawn over it
        self.mark.set_animated(True)
        self.background: Any = None   # the canvas without the live artists, once drawn
        self.mark_pixels: Any = None  # the mark, rendered once
        self.drawn_refs: tuple[str, ...] = ()  # the references the legend names
        self.shown: tuple[Any, ...] = ()        # what the last PNG shows
        self.units: Any = None                  # the real units the second scale shows
        self.png = b""
        self.last_drawing = ""

    def _frames(self) -> None:
        """Titles, labels, fixed scales and the reference lines of the three panels."""
        from matplotlib.ticker import FuncFormatter, LogLocator, MultipleLocator, NullLocator

        self.ax_v.set(xlabel="time [ms]", ylabel="speed [pps]")
        self.ax_v.set_title("speed: the table's staircase and the optimum", fontsize=10)
        self.ax_m.set(xlabel="stage (0 = fastest)", ylabel="stall margin",
                      xlim=(-1, STAGE_AXIS + 1))
        self.ax_m.set_title("stall margin per stage (≥ 1: stall-safe)", fontsize=10)
        self.ax_m.set_yscale("log")
        self.ax_m.set_ylim(*MARGIN_RANGE)
        # Plain numbers (1, 2, 5 …) read better than 10^0 on a margin axis.
        self.ax_m.yaxis.set_major_locator(LogLocator(subs=(1.0, 2.0, 5.0)))
        self.ax_m.yaxis.set_minor_locator(NullLocator())
        self.ax_m.yaxis.set_major_formatter(FuncFormatter(lambda y, _pos: f"{y:g}"))
        self.ax_m.axhline(1.0, color="k", lw=1, ls="--", label="stall limit")
        self.ax_l.set(xlabel="time [ms]", ylabel="load angle [° el.]",
                      ylim=(-ANGLE_SPAN_DEG, ANGLE_SPAN_DEG))
        self.ax_l.set_title("load angle of this move (peak ±90°)", fontsize=10)
        for sign in (1, -1):
            self.ax_l.axhline(90 * sign, color="k", lw=1, ls="--")
        for ax in (self.ax_v, self.ax_m, self.ax_l):
            ax.grid(alpha=0.3)
        for ax in (self.ax_v, self.ax_l):
            ax.tick_params(axis="x", labelcolor="none")  # numbers drawn over (`_live`)
            # ticks at fifths of the axis from the start: an axis yet without a line
            # looks as it will with one
            ax.set_xlim(0.0, TIME_TICKS)
            ax.xaxis.set_major_locator(MultipleLocator(1.0))

    def update(self, result: Design, slow: dict[str, Any] | None = None) -> bytes:
        """Show `result` (and `slow` references); the PNG (the last one again when only the
        verdict differs from what it shows, as when the other commands' verdicts come)."""
        shown = (result.plan, result.physics, result.exact, result.final,
                 *sorted((slow or {}).items()))
        if len(shown) == len(self.shown) and all(a is b for a, b in zip(shown, self.shown,
                                                                         strict=True)):
            return self.png
        self.shown = shown
        self._set_units(result.units)
        self._set_lines(result, slow)
        self._set_time()
        limits = self._limits(result)
        changed = [ax for ax, lim in limits.items() if lim != ax.get_ylim()]
        for ax, lim in limits.items():
            ax.set_ylim(*lim)
        if self.background is None or tuple(self.ref_lines) != self.drawn_refs:
            self._draw_frames()
            self.last_drawing = "full"
        elif changed:
            self._redraw(changed)  # only the panels whose limits moved
            self.background = self.canvas.copy_from_bbox(self.fig.bbox)
            self.last_drawing = "panels"
        else:
            self.canvas.restore_region(self.background)
            self.last_drawing = "over"
        if self.last_drawing != "over":
            self.label_pixels.clear()
        for artist in self._live():
            self.fig.draw_artist(artist)
        self._draw_labels()
        if not result.final:
            self.canvas.restore_region(self.mark_pixels)
        from verify.plot import fast_png

        self.png = fast_png(self.canvas)
        return self.png

    def _draw_frames(self) -> None:
        """Everything but the live artists, kept as the background; the mark rendered once."""
        legend = self.ax_v.legend(loc="upper center", ncols=4, fontsize=7)
        legend.legend_handles[0].set_linestyle("-")  # the table's, dashed or not
        self.drawn_refs = tuple(self.ref_lines)
        self.canvas.draw()
        self.background = self.canvas.copy_from_bbox(self.fig.bbox)
        visible = self.mark.get_visible()
        self.mark.set_visible(True)
        self.fig.draw_artist(self.mark)
        box = self.mark.get_bbox_patch().get_window_extent(self.canvas.get_renderer())
        self.mark_pixels = self.canvas.copy_from_bbox(box)
        self.mark.set_visible(visible)
        self.canvas.restore_region(self.background)

    def _redraw(self, panels: list[Any]) -> None:
        """The kept background with `panels` (axes, ticks, labels, grid) drawn again."""
        from matplotlib.patches import Rectangle
        from matplotlib.transforms import IdentityTransform

        self.canvas.restore_region(self.background)
        renderer = self.canvas.get_renderer()
        for ax in panels:
            box = ax.get_tightbbox(renderer)
            blank = Rectangle((box.x0 - 2, box.y0 - 2), box.width + 4, box.height + 4,
                              transform=IdentityTransform(), facecolor=self.fig.get_facecolor(),
                              edgecolor="none")
            blank.set_figure(self.fig)
            blank.draw(renderer)
            self.fig.draw_artist(ax)

    def _set_units(self, units: Any) -> None:
        """The speed panel's second scale in mm/s (rpm on a rotary axis), set again (and
        the figure drawn in full) when another motor's units come."""
        from verify.plot import real_axis

        if units == self.units:
            return
        for child in list(self.ax_v.child_axes):
            child.remove()
        real_axis(self.ax_v, units, "speed", "right")
        self.units, self.background = units, None

    def _live(self) -> list[Any]:
        """The lines every change draws again (animated: the background leaves them out)."""
        return [self.table_line, *self.ref_lines.values(), *self.margin_lines.values(),
                self.lag_line]

    def _draw_labels(self) -> None:
        """The time labels (animated too), each from its pixels when drawn before over
        this background (below the axes: no line crosses them)."""
        labels = (t for texts in self.time_labels.values() for t in texts)
        for k, text in enumerate(labels):
            if not text.get_text():
                continue
            key = (k, text.get_text())
            if key in self.label_pixels:
                self.canvas.restore_region(self.label_pixels[key])
                continue
            self.fig.draw_artist(text)
            box = text.get_window_extent(self.canvas.get_renderer()).padded(2)
            self.label_pixels[key] = self.canvas.copy_from_bbox(box)

    def _set_lines(self, result: Design, slow: dict[str, Any] | None) -> None:
        import numpy as np

        from verify.plot import envelope

        t, _, v = result.execution.edges()
        self.table_line.set_data(t * 1e3, v)
        self.table_line.set_linestyle("-" if result.final else "--")
        self.table_line.set_label("table")
        refs = {"exact": result.exact, **(slow or {})}
        for name in list(self.ref_lines):
            if name not in refs:
                self.ref_lines.pop(name).remove()
        for name, ref in refs.items():
            if name not in self.ref_lines:
                self.ref_lines[name], = self.ax_v.plot([], [], animated=True,
                                                       **_reference_style(name))
            line = self.ref_lines[name]
            line.set_data(ref.t_s * 1e3, ref.v_pps)
            line.set_label(name if name == "exact" else
                           f"{name} ({ref.duration_s * 1e3:.2f} ms)")  # drawn in full
        self.mark.set_visible(not result.final)
        for side, line in self.margin_lines.items():
            m = np.asarray(result.margins[side], float)
            line.set_data(np.arange(len(m)), np.where(np.isfinite(m), m, np.nan))
        ph = result.physics
        self.lag_line.set_data(*(envelope(ph.lag_t_s * 1e3, ph.angle_deg, self.MAX_POINTS)
                                 if ph is not None else ([], [])))

    def _set_time(self) -> None:
        """Each time axis to five steps of the first 1-2-2.5-5 step that holds its lines
        (`_set_lines` set them: the speeds; the load angle, which goes on while the rotor
        settles), their numbers written under the kept ticks."""
        from matplotlib.ticker import MultipleLocator

        for ax, texts in self.time_labels.items():
            ends = [float(line.get_xdata()[-1]) for line in ax.get_lines()
                    if line.get_animated() and len(line.get_xdata())]
            if not ends:  # a first table has no trace yet: an empty panel, no numbers
                for text in texts:
                    text.set_text("")
                continue
            step = nice_step(1.02 * max(ends) / TIME_TICKS)
            ax.set_xlim(0.0, TIME_TICKS * step)
            ax.xaxis.set_major_locator(MultipleLocator(step))  # a full drawing's ticks
            for k, text in enumerate(texts):
                text.set_text(f"{k * step:g}")

    def _limits(self, result: Design) -> dict[Any, tuple[float, float]]:
        """The y limits of each panel for `result`: the motor's speeds, the margins'
        fixed range (wider only for a margin outside it), ±100° (wider past it)."""
        import numpy as np

        top = max(float(result.motor.top_pps), *(float(np.max(line.get_ydata()))
                                                 for line in (self.table_line,
                                                              *self.ref_lines.values())))
        margins = np.concatenate([np.asarray(result.margins[side], float)
                                  for side in self.margin_lines])
        margins = margins[np.isfinite(margins) & (margins > 0)]
        lo, hi = MARGIN_RANGE
        if margins.size:
            lo = min(lo, 10.0 ** math.floor(math.log10(float(margins.min()))))
            hi = max(hi, _rounded_up(1.5 * float(margins.max())))
        lag = self.lag_line.get_ydata()
        angle = float(np.max(np.abs(lag))) if len(lag) else 0.0
        span = max(ANGLE_SPAN_DEG, _rounded_up(1.1 * angle))
        return {self.ax_v: (0.0, _rounded_up(1.1 * top)), self.ax_m: (lo, hi),
                self.ax_l: (-span, span)}


def nice_step(x: float) -> float:
    """The first of 1, 2, 2.5, 5 × 10^k at or above `x` (> 0): a time axis of five such
    steps is filled at least halfway."""
    return _first_at_or_above(x, NICE_STEPS)


def _tick_numbers(fig: Any, ax: Any) -> list[Any]:
    """The texts under `ax`'s TIME_TICKS + 1 fixed x ticks, where matplotlib puts tick
    labels (the tick's length and pad below the axes, its label size)."""
    from matplotlib import rcParams
    from matplotlib.font_manager import FontProperties
    from matplotlib.transforms import offset_copy

    below = offset_copy(ax.transAxes, fig=fig, y=-(rcParams["xtick.major.size"]
                                                   + rcParams["xtick.major.pad"]),
                        units="points")
    size = FontProperties(size=rcParams["xtick.labelsize"]).get_size_in_points()
    return [ax.text(k / TIME_TICKS, 0.0, "", transform=below, ha="center", va="top",
                    fontsize=size) for k in range(TIME_TICKS + 1)]


def _reference_style(name: str) -> dict[str, Any]:
    """A reference line's look from verify.plot's styles (a (color, ls) pair or keywords)."""
    from verify.plot import REFERENCE_STYLE

    style: Any = REFERENCE_STYLE.get(name, ("k", "-"))
    if isinstance(style, dict):
        return {"lw": 1.1, **style}
    color, ls = style
    return {"color": color, "ls": ls, "lw": 1.1}


def _rounded_up(x: float) -> float:
    """The first of 1, 1.2, 1.5, 2, 2.5, 3, 4, 5, 6, 8 × 10^k at or above `x` (> 0)."""
    return _first_at_or_above(x, (1.0, 1.2, 1.5, 2.0, 2.5, 3.0, 4.0, 5.0, 6.0, 8.0))


def _first_at_or_above(x: float, mantissas: tuple[float, ...]) -> float:
    """The first of `mantissas` (ascending, from 1) × 10^k at or above `x`; 1 for x ≤ 0."""
    if not x > 0:
        return 1.0
    scale = 10.0 ** math.floor(math.log10(x))
    return next(m * scale for m in (*mantissas, 10.0) if m * scale >= x * (1 - 1e-12))


def render_figure(result: Design, slow: dict[str, Any] | None = None) -> bytes:
    """PNG of one design (a fresh `DesignFigure`)."""
    return DesignFigure().update(result, slow)
