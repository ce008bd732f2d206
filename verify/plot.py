"""Figures: a staircase against its references, and a motor's capability.

matplotlib is imported here only, and this module only when a figure is
asked for, so the CLI starts fast. The Agg backend is used unless a notebook
already chose one.
"""

from __future__ import annotations

from pathlib import Path
from typing import Any

import numpy as np

REFERENCE_STYLE = {"toppra": ("tab:blue", "-"), "ruckig": ("tab:green", "--"),
          "casadi": ("tab:purple", "-."), "exact": ("0.4", ":")}


def pyplot() -> Any:
    import matplotlib

    if "matplotlib.pyplot" not in __import__("sys").modules:
        matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    return plt


def comparison_figure(comparison: Any) -> Any:
    """Speed against time and against position (staircase as steps, references as
    lines), and the stall margin of each stage."""
    plt = pyplot()
    fig, axes = plt.subplots(3, 1, figsize=(8.0, 9.0), constrained_layout=True,
                             gridspec_kw={"height_ratios": [3, 3, 2]})
    ax_t, ax_x, ax_m = axes
    t, x, v = comparison.execution.edges()
    label = (f"table ({len(comparison.table.rates)} stages, "
             f"{comparison.table_s * 1e3:.2f} ms)")
    ax_t.step(t * 1e3, v, where="post", color="tab:red", lw=1.6, label=label)
    ax_x.step(x, v, where="post", color="tab:red", lw=1.6, label=label)
    for name, ref in comparison.references.items():
        color, ls = REFERENCE_STYLE.get(name, ("k", "-"))
        lab = f"{name} ({ref.duration_s * 1e3:.2f} ms)"
        ax_t.plot(ref.t_s * 1e3, ref.v_pps, color=color, ls=ls, lw=1.2, label=lab)
        ax_x.plot(ref.x_pulses, ref.v_pps, color=color, ls=ls, lw=1.2, label=lab)
    verdict = ("SAFE" if comparison.safe else
               "UNSAFE (" + ", ".join(comparison.failed_judges) + ")")
    ax_t.set(xlabel="time [ms]", ylabel="speed [pps]",
             title=f"{comparison.motor.name or 'motor'}: {comparison.pulses} pulses\n"
                   f"table / optimum = {comparison.ratio:.3f} — {verdict}")
    if not comparison.safe:
        ax_t.title.set_color("tab:red")
    ax_x.set(xlabel="position [pulses]", ylabel="speed [pps]")
    # Headroom above the cruise holds the one legend (both panels share its styles),
    # so it never hides a curve whatever the move's shape.
    v_top = max([float(np.max(v))] + [float(np.max(r.v_pps)) for r in
                                       comparison.references.values() if len(r.v_pps)])
    for ax in (ax_t, ax_x):
        ax.grid(alpha=0.3)
        ax.set_ylim(0, 1.32 * v_top)
    ax_t.legend(loc="upper center", ncols=3, fontsize=8, framealpha=0.9)

    margins = comparison.margins
    acc = np.asarray(margins["accel"], float)
    dec = margins.get("decel")
    dec = None if dec is None else np.asarray(dec, float)
    shown = [m[np.isfinite(m)] for m in (acc, dec) if m is not None]
    finite = np.concatenate(shown) if shown else np.array([])
    # Margins span 1 … tens: a log axis keeps the stages near the limit readable. The
    # bars start below the smallest positive margin, and a margin at or below 0 (the
    # motor cannot make that step at all) is drawn at the floor, so none vanishes.
    positive = finite[finite > 0]
    floor = float(positive.min()) if positive.size else 0.8
    bottom = min(0.8, 0.5 * floor)
    acc = np.where(np.isfinite(acc), np.maximum(acc, bottom * 1.25), acc)
    if dec is not None:
        dec = np.where(np.isfinite(dec), np.maximum(dec, bottom * 1.25), dec)
    top = max(2.0, 1.5 * float(finite.max())) if finite.size else 2.0
    stages = np.arange(len(acc))
    ax_m.bar(stages - 0.2, np.where(np.isfinite(acc), acc, np.nan) - bottom, width=0.4,
             bottom=bottom, color="tab:red", label="accel")
    if dec is not None:
        ax_m.bar(np.arange(len(dec)) + 0.2, np.where(np.isfinite(dec), dec, np.nan) - bottom,
                 width=0.4, bottom=bottom, color="tab:orange", label="decel")
    ax_m.axhline(1.0, color="k", lw=1, ls="--", label="stall limit (1)")
    ax_m.set_yscale("log")
    ax_m.set_ylim(bottom, top)
    from matplotlib.ticker import FuncFormatter, LogLocator, NullLocator

    # Plain numbers (1, 2, 5, 10 …) read better than 10^0 on a margin axis.
    ax_m.yaxis.set_major_locator(LogLocator(subs=(1.0, 2.0, 5.0)))
    ax_m.yaxis.set_minor_locator(NullLocator())
    ax_m.yaxis.set_major_formatter(FuncFormatter(lambda y, _pos: f"{y:g}"))
    ax_m.set(xlabel="stage (0 = fastest)", ylabel="stall margin\n(capability / need)",
             title=f"stall margin per stage (log scale; ≥ 1 is stall-safe): smallest "
                   f"{comparison.stall_margin:.3f}")
    ax_m.grid(alpha=0.3, axis="y", which="both")
    ax_m.legend(fontsize=8, loc="upper left", ncols=3)
    return fig


def motor_figure(motor: Any) -> Any:
    """Pull-out torque (×safety factor) and the acceleration capability."""
    plt = pyplot()
    fig, (ax_t, ax_a) = plt.subplots(1, 2, figsize=(10.0, 4.0), constrained_layout=True)
    v = np.linspace(0, motor.top_curve_pps, 500)
    ax_t.plot(v, motor.torque_nm(v), label="pull-out torque")
    ax_t.plot(v, motor.safety_factor * motor.torque_nm(v), ls="--",
              label=f"× safety factor {motor.safety_factor:g}")
    ax_t.axhline(motor.friction_torque_nm, color="0.5", ls=":", label="friction")
    if motor.load_torque_nm:
        ax_t.axhline(abs(motor.load_torque_nm), color="tab:brown", ls="-.",
                     label="load torque (either way)")
    ax_t.set(xlabel="speed [pps]", ylabel="torque [N·m]", title=motor.name or "motor")
    ax_t.set_ylim(bottom=0)
    ax_a.plot(v, motor.a_acc_pps2(v), label="a_acc (speeding up)")
    ax_a.plot(v, motor.a_dec_pps2(v), label="a_dec (slowing down)")
    ax_a.axhline(0, color="k", lw=0.8, label="0: no capability")
    ax_a.set(xlabel="speed [pps]", ylabel="acceleration [pps²]", title="capability")
    for ax in (ax_t, ax_a):
        ax.grid(alpha=0.3)
        ax.legend(fontsize=8)
    return fig


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
    for ax in fig.axes:
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
