"""Figures: a staircase against its references, and a motor's capability.

matplotlib is imported here only, and this module only when a figure is
asked for, so the CLI starts fast. The Agg backend is used unless a notebook
already chose one.
"""

from __future__ import annotations

from pathlib import Path
from typing import Any

import numpy as np

# Each reference distinguishable where they overlap (the exact optimum, toppra and casadi
# often coincide): exact as a wide pale band underneath, toppra a thin solid line on it,
# casadi dashed with open circles on top, ruckig dash-dotted.
REFERENCE_STYLE: dict[str, dict[str, Any]] = {
    "exact": {"color": "0.55", "ls": "-", "lw": 5.0, "alpha": 0.45, "zorder": 1},
    "toppra": {"color": "tab:blue", "ls": "-", "lw": 1.2, "zorder": 3},
    "casadi": {"color": "tab:purple", "ls": "--", "lw": 1.2, "zorder": 4, "marker": "o",
               "ms": 4, "mfc": "none", "markevery": 0.07},
    "ruckig": {"color": "tab:green", "ls": "-.", "lw": 1.2, "zorder": 3},
}
FROM_START_STYLE = {"color": "tab:brown", "ls": ":", "lw": 1.8, "zorder": 4}
TABLE_STYLE = {"color": "tab:red", "lw": 1.6, "zorder": 5}
LONG_MOVE_RAMP_SHARE = 0.12   # a ramp shorter than this share of the move gets a zoom
ZOOM_PAST_RAMP = 1.4          # the zoom shows the slowest ramp's end × this


def pyplot() -> Any:
    import matplotlib

    if "matplotlib.pyplot" not in __import__("sys").modules:
        matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    return plt


def comparison_figure(comparison: Any, angles: Any = None,
                      motor_label: str | None = None) -> Any:
    """Speed against time (a zoom of the ramp below it when the ramp is a sliver of the
    move) and against position (staircase as steps, references as lines), the move's
    load angle against time with the aim and the 90° peak (`angles`: (label,
    `profiles.ppmc312.load_angle_trace.LoadAngleTrace`) pairs; none: no panel) and the
    stall margin of each stage. `motor_label` names a motor whose file has no name."""
    plt = pyplot()
    zoom_end = ramp_zoom_end_s(comparison)
    rows = [("t", 3.0)] + ([("zoom", 2.0)] if zoom_end else []) + [("x", 3.0)] + \
        ([("angle", 2.4)] if angles else []) + [("margin", 2.2)]
    fig, axes = plt.subplots(len(rows), 1, figsize=(8.0, 0.95 * sum(h for _, h in rows) + 1.0),
                             constrained_layout=True,
                             gridspec_kw={"height_ratios": [h for _, h in rows]})
    ax = dict(zip((k for k, _ in rows), axes, strict=True))
    speed_panels(ax["t"], ax["x"], comparison)
    units = motor_units(comparison.motor)
    if units is not None:  # mm and mm/s (or rev and rpm) beside pulses and pps
        for key in ("t", "x") + (("zoom",) if zoom_end else ()):
            real_axis(ax[key], units, "speed", "right")
        real_axis(ax["x"], units, "distance", "top")
    verdict = ("SAFE" if comparison.safe else
               "UNSAFE (" + ", ".join(comparison.failed_judges) + ")")
    name = comparison.motor.name or motor_label or "motor"
    fig.suptitle(f"{name}: {comparison.pulses} pulses\n"
                 f"table / optimum = {comparison.ratio:.3f} — {verdict}",
                 color="k" if comparison.safe else "tab:red")
    if zoom_end:
        ramp_zoom(ax["zoom"], ax["t"], zoom_end)
    if angles:
        aim = getattr(getattr(comparison, "move_verdict", None), "aim_deg", None)
        load_angle_panel(ax["angle"], angles, aim, ax["t"].get_xlim())
    margin_panel(ax["margin"], comparison)
    return fig


def speed_panels(ax_t: Any, ax_x: Any, comparison: Any) -> None:
    """The table's staircase and the references against time and position, one legend:
    a failed reference named with its reason, the references' start speed when the table
    starts elsewhere, and the exact optimum from the table's own start."""
    t, x, v = comparison.execution.edges()
    label = (f"table ({len(comparison.table.rates)} stages, "
             f"{comparison.table_s * 1e3:.2f} ms, from {v[0]:.6g} pps)")
    ax_t.step(t * 1e3, v, where="post", label=label, **TABLE_STYLE)
    ax_x.step(x, v, where="post", label=label, **TABLE_STYLE)
    refs = dict(comparison.references)
    start = getattr(comparison, "from_table_start", None)
    for name, ref in refs.items():
        style = REFERENCE_STYLE.get(name, {"color": "k"})
        lab = f"{name} ({ref.duration_s * 1e3:.2f} ms)"
        ax_t.plot(ref.t_s * 1e3, ref.v_pps, label=lab, **style)
        ax_x.plot(ref.x_pulses, ref.v_pps, label=lab, **style)
    if start is not None:
        lab = f"exact from the table's start ({start.duration_s * 1e3:.2f} ms)"
        ax_t.plot(start.t_s * 1e3, start.v_pps, label=lab, **FROM_START_STYLE)
        ax_x.plot(start.x_pulses, start.v_pps, label=lab, **FROM_START_STYLE)
    failed = dict(getattr(comparison, "failed_references", {}) or {})
    for name, why in failed.items():  # an entry, no curve: the legend says it failed
        ax_t.plot([], [], label=f"{name}: FAILED ({why})", color="tab:red", ls="none",
                  marker="x")
    ax_t.set(xlabel="time [ms]", ylabel="speed [pps]")
    ax_x.set(xlabel="position [pulses]", ylabel="speed [pps]")
    # One legend for both panels (they share the styles), above them, outside any axes:
    # it hides no curve whatever the move's shape.
    v_top = max([float(np.max(v))] + [float(np.nanmax(r.v_pps)) for r in refs.values()
                                       if len(r.v_pps)])
    for ax in (ax_t, ax_x):
        ax.grid(alpha=0.3)
        ax.set_ylim(0, 1.08 * v_top)
    v0 = refs["exact"].v_pps[0] if "exact" in refs and len(refs["exact"].v_pps) else None
    title = None if v0 is None or start is None else \
        (f"references from the motor's start speed {v0:.6g} pps, the table from "
         f"{v[0]:.6g} pps")
    handles, labels = ax_t.get_legend_handles_labels()
    legend = ax_t.legend(handles, labels, loc="lower center", bbox_to_anchor=(0.5, 1.01),
                         ncols=2, fontsize=7, title=title, title_fontsize=7)
    for text in legend.get_texts():
        if ": FAILED (" in text.get_text():
            text.set_color("tab:red")


def ramp_zoom_end_s(comparison: Any) -> float | None:
    """The end [s] of a zoom on the ramp when the table's speeding-up is under
    LONG_MOVE_RAMP_SHARE of its move (the slower of the table's and the exact optimum's
    ramps, × ZOOM_PAST_RAMP), else None."""
    t, _, v = comparison.execution.edges()
    if len(v) < 2 or comparison.table_s <= 0:
        return None
    ramp = float(t[int(np.argmax(v >= 0.99 * np.max(v)))])
    if ramp >= LONG_MOVE_RAMP_SHARE * comparison.table_s:
        return None
    exact = comparison.references.get("exact")  # the optimum's ramp; ruckig's is long
    ends = [ramp] + ([float(exact.t_s[int(np.argmax(exact.v_pps >= 0.99 * np.nanmax(
        exact.v_pps)))])] if exact is not None and len(exact.v_pps) else [])
    return ZOOM_PAST_RAMP * max(ends) if max(ends) > 0 else None


def ramp_zoom(ax: Any, ax_t: Any, end_s: float) -> None:
    """The speed–time panel's curves again, over its first `end_s` seconds (the span is
    shaded on the full panel)."""
    for line in ax_t.get_lines():
        ax.plot(line.get_xdata(), line.get_ydata(), color=line.get_color(),
                ls=line.get_linestyle(), lw=line.get_linewidth(), alpha=line.get_alpha(),
                marker=line.get_marker(), ms=line.get_markersize(), mfc="none",
                markevery=line.get_markevery(), drawstyle=line.get_drawstyle(),
                zorder=line.get_zorder(), label=line.get_label())
    ax.set_xlim(0, end_s * 1e3)
    ax.set_ylim(*ax_t.get_ylim())
    ax.set(xlabel="time [ms]", ylabel="speed [pps]",
           title=f"the ramp, zoomed: the first {end_s * 1e3:.3g} ms (shaded above)")
    ax.title.set_fontsize(9)
    ax.grid(alpha=0.3)
    ax_t.axvspan(0, end_s * 1e3, color="0.85", alpha=0.5, zorder=0)


def load_angle_panel(ax: Any, angles: Any, aim_deg: float | None,
                     xlim: tuple[float, float]) -> None:
    """The signed load angle (> 0: the rotor behind the field) against time, the aim and
    the 90° peak on both sides, the worst marked."""
    from profiles.motor.angles import PEAK_DEG

    colors = ("tab:red", "tab:purple", "tab:olive")
    lo, hi = -PEAK_DEG * 1.1, PEAK_DEG * 1.1
    for (label, tr), color in zip(angles, colors, strict=False):
        ax.plot(tr.lag_t_s * 1e3, tr.angle_deg, color=color, lw=1.2, label=label)
        which = "" if len(angles) == 1 else f" ({label.split(',')[0]})"
        ax.plot([tr.worst_time_s * 1e3], [tr.worst_angle_deg], "o", color=color, ms=5,
                label=f"worst {abs(tr.worst_angle_deg):.1f}° at {tr.worst_time_s * 1e3:.3g} ms"
                      + which)
        if tr.slipped and tr.slip_time_s is not None:
            ax.axvline(tr.slip_time_s * 1e3, color=color, ls=":", lw=1.2,
                       label=f"slips a pole at {tr.slip_time_s * 1e3:.3g} ms{which}")
        lo = min(lo, 1.08 * float(np.min(tr.angle_deg)))
        hi = max(hi, 1.08 * float(np.max(tr.angle_deg)))
    if aim_deg is not None and aim_deg < PEAK_DEG:
        for sign in (1, -1):
            ax.axhline(sign * aim_deg, color="tab:orange", ls="--", lw=1.0,
                       label=f"±{aim_deg:g}° aim")
    for sign in (1, -1):
        ax.axhline(sign * PEAK_DEG, color="k", ls="-", lw=1.0,
                   label=f"±{PEAK_DEG:g}° peak (stall past it)")
    handles, labels = ax.get_legend_handles_labels()
    once = dict(zip(labels, handles, strict=True))  # ± lines: one entry each
    ax.set_ylim(lo - (0.25 if len(once) <= 4 else 0.4) * (hi - lo), hi)  # room: the legend
    ends = [float(tr.worst_time_s) * 1e3 for _, tr in angles]
    ax.set_xlim(xlim[0], max(xlim[1], 1.05 * max(ends)))
    ax.set(xlabel="time [ms]", ylabel="load angle\n[° electrical]",
           title="the move's load angle (> 0: rotor behind the field)")
    ax.title.set_fontsize(9)
    ax.grid(alpha=0.3)
    ax.legend(once.values(), once.keys(), fontsize=7, loc="lower center",
              ncols=min(4, len(once)), framealpha=0.9)


def margin_panel(ax_m: Any, comparison: Any) -> None:
    """Capability / need per stage, accel and decel: a log axis above 1 (margins span 1 …
    hundreds), linear below it (symlog), so a margin under 1 and a negative one (the
    motor cannot make that step at all: its capability is below 0) show as they are."""
    margins = comparison.margins
    acc = np.asarray(margins["accel"], float)
    dec = margins.get("decel")
    dec = None if dec is None else np.asarray(dec, float)
    shown = [m[np.isfinite(m)] for m in (acc, dec) if m is not None]
    finite = np.concatenate(shown) if shown else np.array([])
    top = max(2.0, 4.0 * float(finite.max())) if finite.size else 2.0  # room: legend
    low = min(0.0, 1.3 * float(finite.min())) if finite.size else 0.0
    stages = np.arange(len(acc))
    ax_m.bar(stages - 0.2, np.where(np.isfinite(acc), acc, np.nan), width=0.4,
             color="tab:red", label="accel")
    if dec is not None:
        ax_m.bar(np.arange(len(dec)) + 0.2, np.where(np.isfinite(dec), dec, np.nan),
                 width=0.4, color="tab:orange", label="decel")
    ax_m.axhline(1.0, color="k", lw=1, ls="--", label="stall limit (1)")
    ax_m.axhline(0.0, color="0.3", lw=0.6, label="0 (below: no capability)")
    ax_m.set_yscale("symlog", linthresh=1.0, linscale=0.8)
    ax_m.set_ylim(low, top)
    from matplotlib.ticker import FuncFormatter, NullLocator, SymmetricalLogLocator

    # Plain numbers (−1, 0, 1, 2, 5, 10 …) read better than 10^0 on a margin axis.
    ax_m.yaxis.set_major_locator(SymmetricalLogLocator(base=10, linthresh=1.0,
                                                       subs=(1.0, 2.0, 5.0)))
    ax_m.yaxis.set_minor_locator(NullLocator())
    ax_m.yaxis.set_major_formatter(FuncFormatter(lambda y, _pos: f"{y:g}"))
    negative = int(np.sum(finite < 0))
    ax_m.set(xlabel="stage (0 = fastest)", ylabel="stall margin\n(capability / need)",
             title=f"stall margin per stage: smallest {comparison.stall_margin:.3f}"
                   + (f", {negative} below 0 (no capability)" if negative else "")
                   + "\n(≥ 1 is stall-safe; log scale above 1, linear below)")
    ax_m.title.set_fontsize(9)
    ax_m.grid(alpha=0.3, axis="y", which="both")
    ax_m.legend(fontsize=7, loc="upper right", ncols=4)


def motor_figure(motor: Any, motor_label: str | None = None) -> Any:
    """Pull-out torque (×safety factor), what cruising needs and the cruise reserve's floor;
    the acceleration capability; on both the reachable top speed (where a_acc falls to 0,
    when before the curve's end) and the top the default cruise reserve keeps; the drive
    the curve was made for in the title. `motor_label` names a motor whose file has none."""
    from profiles.motor.reserve import CruiseReserve
    from verify.references import accel_zero_pps

    plt = pyplot()
    fig, (ax_t, ax_a) = plt.subplots(1, 2, figsize=(11.0, 5.8), constrained_layout=True)
    v = np.linspace(0, motor.top_curve_pps, 800)
    torque = motor.torque_nm(v)
    ax_t.plot(v, torque, color="tab:blue", lw=2.2, zorder=2, label="pull-out torque")
    if motor.safety_factor < 1:  # at 1 it would lie on the pull-out curve: said there
        ax_t.plot(v, motor.safety_factor * torque, color="tab:orange", ls="--", lw=1.4,
                  zorder=3, label=f"× safety factor {motor.safety_factor:g}")
    else:
        ax_t.lines[0].set_label(f"pull-out torque (× safety factor {motor.safety_factor:g})")
    need = motor.friction_torque_nm + abs(motor.load_torque_nm)
    ax_t.axhline(need, color="0.35", ls=":", lw=1.6, zorder=4,
                 label=f"cruising needs {need:.3g} N·m (friction"
                       + (" + load torque)" if motor.load_torque_nm else ")"))
    reserve = CruiseReserve()
    floor = reserve.floor_nm(motor)
    ax_t.axhline(floor, color="tab:green", ls="-.", lw=1.2, zorder=4,
                 label=f"cruise reserve floor {floor:.3g} N·m ({reserve.spec})")
    top_t = float(np.max(torque))
    ax_t.set_ylim(-0.03 * top_t, 1.12 * max(top_t, floor))  # a line at 0 stays visible
    ax_t.set(xlabel="speed [pps]", ylabel="torque [N·m]")
    ax_a.plot(v, motor.a_acc_pps2(v), color="tab:blue", lw=1.8, label="a_acc (speeding up)")
    ax_a.plot(v, motor.a_dec_pps2(v), color="tab:orange", lw=1.8, ls="--",
              label="a_dec (slowing down)")
    ax_a.axhline(0, color="k", lw=0.8, label="0: no capability")
    ax_a.set(xlabel="speed [pps]", ylabel="acceleration [pps²]")
    speed_marks((ax_t, ax_a), motor, accel_zero_pps(motor), reserve.top_pps(motor))
    units = motor_units(motor)  # mm/s (or rpm) above the pps, mm/s² (or rev/s²) beside pps²
    for ax in (ax_t, ax_a):
        real_axis(ax, units, "speed", "top")
    real_axis(ax_a, units, "accel", "right")
    from matplotlib.ticker import EngFormatter

    ax_a.yaxis.set_major_formatter(EngFormatter())  # 5 M, not a 1e6 under the top scale
    entries: dict[str, Any] = {}
    for ax in (ax_t, ax_a):
        ax.grid(alpha=0.3)
        handles, labels = ax.get_legend_handles_labels()
        entries.update(zip(labels, handles, strict=True))
    # one legend below the panels (the marks are the same on both): inside, it hid curves
    fig.legend(entries.values(), entries.keys(), loc="outside lower center", ncols=2,
               fontsize=7.5)
    fig.suptitle(f"{motor.name or motor_label or 'motor'}: torque and capability\n"
                 f"{drive_text(motor)}; {units.describe()}", fontsize=10)
    return fig


def speed_marks(axes: Any, motor: Any, zero_pps: float, reserve_pps: float) -> None:
    """On each panel: where a_acc falls to 0 (the reachable top; beyond it shaded) when that
    is before the curve's end, else the top speed, and the cruise reserve's top."""
    end = motor.top_curve_pps
    u = motor_units(motor)
    for i, ax in enumerate(axes):
        if zero_pps < end:
            label = (f"reachable top {pps(zero_pps, u)}: a_acc = 0 (the curve and `motor "
                     f"list` go to {pps(motor.top_pps)})")
            ax.axvline(zero_pps, color="tab:red", lw=1.4, label=label)
            ax.axvspan(zero_pps, end, color="tab:red", alpha=0.08, zorder=0)
        else:
            label = f"top {pps(motor.top_pps)} (" + (
                "max_pps)" if motor.max_pps is not None and motor.max_pps < end else
                "the curve's end)")
            ax.axvline(motor.top_pps, color="tab:red", lw=1.4, label=label)
        if 0 < reserve_pps < min(zero_pps, motor.top_pps):
            ax.axvline(reserve_pps, color="tab:green", ls="-.", lw=1.2,
                       label=f"top with the cruise reserve {pps(reserve_pps, u)}")
        if i == 0:
            ax.axvline(motor.start_pps, color="0.5", ls="--", lw=1.0,
                       label=f"start {pps(motor.start_pps, u)}")


def pps(speed_pps: float, units: Any = None) -> str:
    """A speed as a figure says it: whole pulses per second, thousands spaced, and in real
    units when given (`profiles.motor.travel.AxisUnits`)."""
    text = f"{speed_pps:,.0f} pps".replace(",", "\u2009")
    return text if units is None else f"{text} ({units.speed_text(speed_pps)})"


def drive_text(motor: Any) -> str:
    """The drive the pull-out curve holds for, as the motor file's sources say it (`motor
    new` writes the supply, current and microstep), and the steps per revolution."""
    said = [s.get("from", "") for s in ((motor.sources or {}).get("pullout_torque") or [])]
    text = next((s for s in said if "drive " in s), None)
    drive = ("drive " + text.split("drive ", 1)[1]) if text else \
        "drive: not stated in the motor file (its curve holds for the drive it was measured on)"
    return drive


def motor_units(motor: Any) -> Any:
    """The motor's real units (`profiles.motor.travel.AxisUnits`: mm where its file states
    the travel per revolution, else rev and rpm), or None for a stand-in without a
    resolution (a bench figure's)."""
    from profiles.motor.travel import axis_units

    if not isinstance(getattr(motor, "steps_per_rev", None), int):
        return None
    return axis_units(motor)


def real_axis(ax: Any, units: Any, what: str, side: str) -> None:
    """A second scale on `ax` in real units beside its pulses: `what` is "speed" (pps),
    "distance" (pulses) or "accel" (pps²); `side` "right" (a y scale) or "top" (x)."""
    to, back, unit = {"speed": (units.speed, units.speed_pps, units.speed_unit),
                      "distance": (units.distance, units.pulses, units.distance_unit),
                      "accel": (units.accel, units.accel_pps2, units.accel_unit)}[what]
    name = {"speed": "speed", "distance": "position", "accel": "acceleration"}[what]
    if side == "right":
        ax.secondary_yaxis("right", functions=(to, back)).set_ylabel(f"{name} [{unit}]")
    else:
        ax.secondary_xaxis("top", functions=(to, back)).set_xlabel(f"{name} [{unit}]",
                                                                   fontsize=8)


def save_figure(fig: Any, path: str | Path) -> None:
    """Save as PNG or SVG (by extension), atomically, every text inside the canvas
    (`fit_texts`)."""
    from verify.output import write_output

    write_output(str(path), figure_bytes(fig, path))


def figure_bytes(fig: Any, path: str | Path) -> bytes:
    """The figure as the bytes of a PNG or SVG file (by `path`'s extension), every text
    inside the canvas (`fit_texts`), closed: for a command that writes it with its other
    outputs, all or none."""
    import io

    from profiles.errors import FormatError

    suffix = Path(path).suffix.lower().lstrip(".")
    if suffix not in ("png", "svg"):
        raise FormatError(f"{path}: the figure format is taken from the extension: .png or .svg")
    fig.set_dpi(SAVE_DPI)  # lay out at the resolution it is saved in
    fit_texts(fig)
    buf = io.BytesIO()
    fig.savefig(buf, format=suffix, dpi=SAVE_DPI)
    pyplot().close(fig)
    return buf.getvalue()


SAVE_DPI = 150
_FIT_PASSES = 6


def fast_png(canvas: Any) -> bytes:
    """An Agg canvas (opaque) as an RGB PNG, its rows unfiltered at zlib level 1: Pillow
    filters every row, most of its time on a plot's flat colours, for a file hardly
    smaller; an interactive view writes one a change (verify/designer/figure.py)."""
    import struct
    import zlib

    pixels = np.asarray(canvas.buffer_rgba())[:, :, :3]
    height, width = pixels.shape[:2]
    rows = np.zeros((height, 1 + 3 * width), np.uint8)  # each row's filter byte: 0, none
    rows[:, 1:].reshape(height, width, 3)[...] = pixels  # one copy, through a view

    def chunk(kind: bytes, data: bytes) -> bytes:
        return (struct.pack(">I", len(data)) + kind + data
                + struct.pack(">I", zlib.crc32(kind + data)))

    header = struct.pack(">IIBBBBB", width, height, 8, 2, 0, 0, 0)  # 8-bit RGB
    return (b"\x89PNG\r\n\x1a\n" + chunk(b"IHDR", header)
            + chunk(b"IDAT", zlib.compress(rows.data, 1)) + chunk(b"IEND", b""))


def fit_texts(fig: Any) -> None:
    """Constrained layout, then any text still past the canvas's edge (a title longer than
    its axes is wide: constrained layout makes room around axes, it never shortens a
    title) is wrapped at spaces, or made smaller when it has none, until all fit."""
    import textwrap

    from matplotlib.layout_engine import ConstrainedLayoutEngine

    if not isinstance(fig.get_layout_engine(), ConstrainedLayoutEngine):  # tight_layout too:
        fig.set_layout_engine("constrained")                             # it lays out once
    for _ in range(_FIT_PASSES):
        outside = texts_outside(fig)
        if not outside:
            return
        for t in outside:
            lines = t.get_text().splitlines()
            longest = max(lines, key=len)
            if " " in longest:
                width = max(8, int(len(longest) * 0.8))
                t.set_text("\n".join(textwrap.fill(line, width) for line in lines))
            else:
                t.set_fontsize(t.get_fontsize() * 0.85)


def texts_outside(fig: Any) -> list[Any]:
    """The texts a draw of `fig` puts (partly) outside its canvas (1 px tolerance)."""
    if not hasattr(fig.canvas, "get_renderer"):  # a figure pyplot has closed: draw it in Agg
        from matplotlib.backends.backend_agg import FigureCanvasAgg

        FigureCanvasAgg(fig)
    fig.canvas.draw()
    renderer = fig.canvas.get_renderer()
    w, h = fig.bbox.width, fig.bbox.height
    out = []
    for t in drawn_texts(fig):
        box = t.get_window_extent(renderer)
        if box.x0 < -1 or box.y0 < -1 or box.x1 > w + 1 or box.y1 > h + 1:
            out.append(t)
    return out


def drawn_texts(fig: Any) -> list[Any]:
    """Every text a draw of `fig` shows: visible, not empty, and for tick labels only those
    of ticks inside the axis's view (matplotlib keeps labels for ticks it does not draw)."""
    from matplotlib.text import Text

    hidden: set[int] = set()
    every = [ax for top in fig.axes for ax in (top, *top.child_axes)]  # second scales too
    for ax in every:
        for axis in (ax.xaxis, ax.yaxis):
            lo, hi = sorted(axis.get_view_interval())
            tol = 1e-9 * max(abs(lo), abs(hi), 1.0)
            for tick in axis.get_major_ticks() + axis.get_minor_ticks():
                if not lo - tol <= tick.get_loc() <= hi + tol:
                    hidden.update({id(tick.label1), id(tick.label2)})
    return [t for t in fig.findobj(Text) if t.get_visible() and t.get_text().strip()
            and id(t) not in hidden]



def following_figure(following: Any) -> Any:
    """An MC-200 stream against its reply log (`profiles.mc200.follow.Following`): the
    commanded and encoder positions, the following error with its worst, the move's end
    and in-position marked, and the motor current the replies give, against time."""
    plt = pyplot()
    f = following
    fig, (ax_x, ax_e, ax_i) = plt.subplots(3, 1, figsize=(8.0, 8.0), sharex=True,
                                           constrained_layout=True,
                                           gridspec_kw={"height_ratios": [3, 3, 2]})
    # ms for a move, s for a log of minutes: the unit the engineer reads the span in
    long_log = len(f.t_s) > 0 and f.t_s[-1] > 10.0
    t = f.t_s * (1.0 if long_log else 1e3)
    shown_x = [ax_x.plot(*envelope(t, f.command), color="tab:blue", lw=1.4,
                         label="command")[0],
               ax_x.plot(*envelope(t, np.where(f.servo_on, f.encoder, np.nan)),
                         color="tab:orange", lw=1.2, ls="--", label="encoder (servo on)")[0]]
    ax_x.set(ylabel="position [pulses]")
    ax_x.ticklabel_format(axis="y", style="plain", useOffset=False)  # pulses, not ×1e6
    ax_e.plot(*envelope(t, f.error), color="tab:red", lw=1.2, label="command − encoder")
    ax_e.axhline(0, color="k", lw=0.8, label="no error")
    w, end, inpos = f.worst, f.move_end, f.in_position_at
    if w is not None:
        ax_e.plot([t[w]], [f.error[w]], "o", color="tab:red", ms=6,
                  label=f"worst {f.error[w]:+g} pulses at {f.t_s[w] * 1e3:g} ms")
    for ax in (ax_x, ax_e, ax_i):  # the same marks on every panel, named once (ax_e)
        if end is not None:
            ax.axvline(t[end], color="0.4", ls=":", lw=1.0, label="the command's end")
        if inpos is not None:
            ax.axvline(t[inpos], color="tab:green", ls="-.", lw=1.0, label="in position")
        ax.grid(alpha=0.3)
    ax_e.set(ylabel="following error [pulses]")
    shown_i = ax_i.plot(*envelope(t, f.current_a), color="tab:purple", lw=1.0,
                        label="motor current (replies)")
    ax_i.set(xlabel="time [s]" if long_log else "time [ms]", ylabel="motor current [A]")
    settle = ("in position: not by the log's end" if inpos is None or end is None else
              f"in position {(inpos - end) * f.period_us * 1e-3:g} ms after the command's end")
    worst = "no reply follows a position" if w is None else \
        f"worst {f.error[w]:+g} pulses at {f.t_s[w] * 1e3:g} ms"
    ax_x.set_title(f"MC-200 following error: {worst}; {settle}")
    ax_x.legend(handles=shown_x, fontsize=8, loc="upper left")
    ax_e.legend(fontsize=8, loc="best")
    ax_i.legend(handles=shown_i, fontsize=8, loc="upper right")
    return fig


ENVELOPE_BUCKETS = 4000  # a figure is ~1200 px wide: more points draw nothing more


def envelope(t: np.ndarray, y: np.ndarray, buckets: int = ENVELOPE_BUCKETS
             ) -> tuple[np.ndarray, np.ndarray]:
    """A long series as what a figure can show of it: per bucket of consecutive samples
    its first time twice and its smallest and largest value, so every peak (a worst
    following error) is still drawn; a series of ≤ 2·buckets samples unchanged. A log of
    millions of replies draws in a second, not in minutes."""
    n = len(y)
    if n <= 2 * buckets:
        return t, y
    size = -(-n // buckets)
    buckets = -(-n // size)  # only the last bucket is short: every one starts inside
    pad = size * buckets - n
    grid = np.concatenate([y.astype(float), np.full(pad, np.nan)]).reshape(buckets, size)
    seen = ~np.isnan(grid)
    lo = np.where(seen, grid, np.inf).min(axis=1)
    hi = np.where(seen, grid, -np.inf).max(axis=1)
    empty = ~seen.any(axis=1)
    lo[empty] = hi[empty] = np.nan
    starts = t[np.arange(buckets) * size]
    return np.repeat(starts, 2), np.column_stack([lo, hi]).reshape(-1)
