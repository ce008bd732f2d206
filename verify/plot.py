"""Figures: a staircase against its references, and a motor's capability.

matplotlib is imported here only, and this module only when a figure is
asked for, so the CLI starts fast. The Agg backend is used unless a notebook
already chose one.
"""

from __future__ import annotations

from pathlib import Path
from typing import Any

import numpy as np

_STYLE = {"toppra": ("tab:blue", "-"), "ruckig": ("tab:green", "--"),
          "casadi": ("tab:purple", "-."), "exact": ("0.4", ":")}


def _plt() -> Any:
    import matplotlib

    if "matplotlib.pyplot" not in __import__("sys").modules:
        matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    return plt


def comparison_figure(comparison: Any) -> Any:
    """Speed against time and against position (staircase as steps, references as
    lines), and the stall margin of each stage."""
    from verify.compare import staircase_xy

    plt = _plt()
    fig, axes = plt.subplots(3, 1, figsize=(8.0, 9.0), constrained_layout=True,
                             gridspec_kw={"height_ratios": [3, 3, 2]})
    ax_t, ax_x, ax_m = axes
    t, x, v = staircase_xy(comparison.execution)
    label = (f"table ({len(comparison.table.rates)} stages, "
             f"{comparison.table_s * 1e3:.2f} ms)")
    ax_t.step(t * 1e3, v, where="post", color="tab:red", lw=1.6, label=label)
    ax_x.step(x, v, where="post", color="tab:red", lw=1.6, label=label)
    for name, ref in comparison.references.items():
        color, ls = _STYLE.get(name, ("k", "-"))
        lab = f"{name} ({ref.duration_s * 1e3:.2f} ms)"
        ax_t.plot(ref.t_s * 1e3, ref.v_pps, color=color, ls=ls, lw=1.2, label=lab)
        ax_x.plot(ref.x_pulses, ref.v_pps, color=color, ls=ls, lw=1.2, label=lab)
    ax_t.set(xlabel="time [ms]", ylabel="speed [pps]",
             title=f"{comparison.motor.name or 'motor'}: {comparison.pulses} pulses, "
                   f"table / optimum = {comparison.ratio:.3f}")
    ax_x.set(xlabel="position [pulses]", ylabel="speed [pps]")
    for ax in (ax_t, ax_x):
        ax.grid(alpha=0.3)
        ax.legend(loc="best", fontsize=8, framealpha=0.85)
        ax.set_ylim(bottom=0)

    margins = comparison.margins
    acc = np.asarray(margins["accel"], float)
    stages = np.arange(len(acc))
    ax_m.bar(stages - 0.2, np.where(np.isfinite(acc), acc, np.nan), width=0.4,
             color="tab:red", label="accel")
    dec = margins.get("decel")
    if dec is not None:
        dec = np.asarray(dec, float)
        ax_m.bar(np.arange(len(dec)) + 0.2, np.where(np.isfinite(dec), dec, np.nan), width=0.4,
                 color="tab:orange", label="decel")
    ax_m.axhline(1.0, color="k", lw=1, ls="--", label="stall limit")
    ax_m.set(xlabel="stage (0 = fastest)", ylabel="stall margin\n(capability / need)",
             title=f"smallest margin {comparison.stall_margin:.3f}")
    ax_m.grid(alpha=0.3, axis="y")
    ax_m.legend(fontsize=8)
    return fig


def motor_figure(motor: Any) -> Any:
    """Pull-out torque (×safety factor) and the acceleration capability."""
    plt = _plt()
    fig, (ax_t, ax_a) = plt.subplots(1, 2, figsize=(10.0, 4.0), constrained_layout=True)
    v = np.linspace(0, motor.top_curve_pps, 500)
    ax_t.plot(v, motor.torque_nm(v), label="pull-out torque")
    ax_t.plot(v, motor.safety_factor * motor.torque_nm(v), ls="--",
              label=f"× safety factor {motor.safety_factor:g}")
    ax_t.axhline(motor.friction_torque_nm, color="0.5", ls=":", label="friction")
    ax_t.set(xlabel="speed [pps]", ylabel="torque [N·m]", title=motor.name or "motor")
    ax_a.plot(v, motor.a_acc_pps2(v), label="a_acc (speeding up)")
    ax_a.plot(v, motor.a_dec_pps2(v), label="a_dec (slowing down)")
    ax_a.axhline(0, color="k", lw=0.8)
    ax_a.set(xlabel="speed [pps]", ylabel="acceleration [pps/s]", title="capability")
    for ax in (ax_t, ax_a):
        ax.grid(alpha=0.3)
        ax.legend(fontsize=8)
    return fig


def save_figure(fig: Any, path: str | Path) -> None:
    """Save as PNG or SVG (by extension), atomically."""
    import io

    from profiles.errors import FormatError
    from verify.output import write_output

    suffix = Path(path).suffix.lower().lstrip(".")
    if suffix not in ("png", "svg"):
        raise FormatError(f"{path}: the figure format is taken from the extension: .png or .svg")
    buf = io.BytesIO()
    fig.savefig(buf, format=suffix, dpi=150)
    _plt().close(fig)
    write_output(str(path), buf.getvalue())
