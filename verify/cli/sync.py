"""`stepramp sync`: several axes, one move — synchronised tables (or A-Link settings)."""

from __future__ import annotations

import argparse
import contextlib
import json
from dataclasses import replace
from pathlib import Path
from typing import Any

from ._common import EXIT_FINDINGS, EXIT_OK, command_line


def add_subparser(sub: Any) -> None:
    from verify.devices import synchronised

    devices = "|".join(d.name for d in synchronised())
    s = sub.add_parser("sync", help="tables for several axes that finish together or keep "
                                    "a straight line")
    s.add_argument("axes", metavar="AXES.json",
                   help=f"a stepramp.axes/1 file (mode time|line, device {devices}, axes with "
                        "motor files and signed pulses)")
    s.add_argument("-o", "--output", metavar="DIR", required=True,
                   help="folder for the per-axis tables, upload files, move commands, the "
                        "C header axes.h and report.json (created if missing)")
    s.add_argument("--mode", choices=("time", "line"),
                   help="override the file's mode: time (finish together) or line (straight "
                        "joint path)")
    s.add_argument("--plot", metavar="OUT.png",
                   help="write the figure (joint path, deviation [pulses], speeds [pps] "
                        "against time [ms]); PNG or SVG by extension")
    s.add_argument("--no-ruckig", action="store_true",
                   help="skip ruckig's time/phase-synchronised durations [s]")
    s.add_argument("--format", choices=("text", "json"), default="text",
                   help="summary on stdout (default text; times in ms, JSON in s)")
    s.set_defaults(func=_do_sync, output_folder=True)


def _do_sync(args: argparse.Namespace) -> int:
    from profiles.errors import FormatError
    from verify import sync
    from verify.devices import get, load_axes
    from verify.output import Data, refuse_unsafe_outputs, write_output, write_outputs
    from verify.sync.files import check_axis_names, plan_files

    if args.plot and not args.plot.lower().endswith((".png", ".svg")):
        raise FormatError(f"--plot {args.plot}: the figure format is taken from the "
                          "extension: .png or .svg")
    out_dir = Path(args.output)
    if out_dir.exists() and not out_dir.is_dir():
        raise FormatError(f"-o {out_dir}: exists and is not a folder")
    axes = load_axes(args.axes)
    if args.mode is not None:
        axes = replace(axes, mode=args.mode)
    check_axis_names([a.name for a in axes.axes], axes.device)
    # what the folder will get must not be what is read (an axes file named axes.json in
    # -o's folder, a motor file there): refused before planning
    names = sync.output_names([a.name for a in axes.axes], axes.device)
    refuse_unsafe_outputs([("-o", str(out_dir / n)) for n in names], [
        args.axes, *(str(a.motor_path) for a in axes.axes if a.motor_path)], folder_ok=True)
    plan = sync.plan_axes(axes)
    ruckig = None
    if not args.no_ruckig:
        ruckig = sync.ruckig_sync([a.motor for a in plan.axes], [a.pulses for a in plan.axes])
    commands = get(axes.device).sync_module().move_commands(plan)
    report = sync.sync_report(plan, device=axes.device, ruckig=ruckig, commands=commands)
    files = plan_files(plan, axes.device, report, command=command_line(args))
    outputs: list[tuple[str | None, Data]] = [(str(out_dir / n), d) for n, d in files.items()]
    if args.plot:
        from verify.plot import figure_bytes

        outputs.append((args.plot, figure_bytes(sync.sync_figure(plan, ruckig), args.plot)))
    # everything is built before the first file is written, then written all or none
    _write_all(out_dir, outputs, write_outputs)
    write_output(None, json.dumps(report, indent=1) + "\n" if args.format == "json"
                 else _text(report))
    return EXIT_FINDINGS if sync.report_problems(report) else EXIT_OK


def _write_all(out_dir: Path, outputs: Any, write_outputs: Any) -> None:
    """Every output, all or none; a folder made for this run goes too when nothing lands."""
    created = not out_dir.exists()
    out_dir.mkdir(parents=True, exist_ok=True)
    try:
        write_outputs(outputs)
    except BaseException:
        if created:  # made for this run and still empty: gone too
            with contextlib.suppress(OSError):
                out_dir.rmdir()
        raise


def _text(r: dict[str, Any]) -> str:
    spread_us = r["finish_spread_s"] * 1e6
    allowed_us = r["finish_spread_tolerance_s"] * 1e6
    lines = [f"{r['device']} {r['mode']} mode: {r['duration_s'] * 1e3:.6g} ms "
             f"(fastest slowest axis alone {r['unsynchronised_s'] * 1e3:.6g} ms), finish spread "
             f"{spread_us:.3f} µs (allowed {allowed_us:.0f} µs), line deviation "
             f"{r['max_line_deviation_pulses']:.4g} pulses"]
    for a in r["axes"]:
        lines.append(f"  {a['name']}: {a['pulses']} pulses, {a['duration_s'] * 1e3:.6g} ms "
                     f"(alone {a['fastest_s'] * 1e3:.6g} ms): {a['how']}")
        if "safety" in a:
            v = a["safety"]
            lines.append(f"    {'safe' if v['safe'] else 'UNSAFE: ' + ', '.join(v['failed'])}"
                         f" over every move length; worst load angle "
                         f"{v['worst_load_angle_deg']:.1f}° electrical ({v['worst_pulses']} "
                         f"pulses)")
    if "ruckig" in r:
        k = r["ruckig"]
        lines.append(f"ruckig (constant limits): time-synchronised "
                     f"{k['time_synchronised_s'] * 1e3:.6g} ms, phase-synchronised "
                     f"{k['phase_synchronised_s'] * 1e3:.6g} ms (optimistic bounds "
                     f"{k['time_synchronised_optimistic_s'] * 1e3:.6g} / "
                     f"{k['phase_synchronised_optimistic_s'] * 1e3:.6g} ms)")
    return "\n".join(lines) + "\n"
