"""`stepramp sweep`: plan and verify a catalogue of motors × move lengths."""

from __future__ import annotations

import argparse
import sys
from pathlib import Path
from typing import Any

from profiles.motor.angles import AIM_DEG

from ._common import (
    EXIT_FINDINGS,
    EXIT_OK,
    add_cruise_reserve_option,
    add_sample_options,
    cruise_reserve,
    fields_as_options,
    number,
    positive_int,
    progress_bar,
    pulse_list,
)

TIMEOUT_S = 10.0   # verify.sweep.DEFAULT_TIMEOUT_S, kept here so --help needs no import
OPTIONS = {"workers": "--workers", "timeout [s]": "--timeout",
           "load angle target [°]": "--load-angle"}


def add_subparser(sub: Any) -> None:
    s = sub.add_parser("sweep", help="plan and verify robust tables for motors × move lengths "
                                     "into a CSV or Parquet file")
    s.add_argument("--motors", nargs="+", required=True, metavar="MOTOR",
                   help="motor files or names from `stepramp motor list` (with their loads, "
                        "tolerances and resonance bands)")
    s.add_argument("--pulses", type=pulse_list, required=True, metavar="N[,M…]",
                   help="move lengths to plan for [pulses]")
    add_sample_options(s, "")
    s.add_argument("--load-angle", type=number, default=AIM_DEG, metavar="DEG",
                   help="tighten each table until its worst load angle is at most this [°] "
                        f"(electrical; default {AIM_DEG:g})")
    add_cruise_reserve_option(s, "plan each table")
    s.add_argument("--workers", type=positive_int, default=1, metavar="N",
                   help="local worker processes (default 1: in this process)")
    s.add_argument("--scheduler", metavar="ADDRESS",
                   help="run on the existing Dask cluster at this scheduler address, e.g. "
                        "tcp://10.0.0.5:8786 (needs the extra stepramp[cluster]); a worker "
                        "lost mid-sweep has its jobs run again on the others")
    s.add_argument("--timeout", type=number, metavar="SECONDS",
                   help="with --scheduler: how long to wait for the scheduler to answer [s]: "
                        "to connect, and whenever no job has finished for this long (it must "
                        f"then answer and have workers); default {TIMEOUT_S:g}")
    s.add_argument("--plot", metavar="OUT.png",
                   help="also write a summary figure (move time and worst load angle per "
                        "move length and motor)")
    s.add_argument("--plot-x", choices=("pulses", "rev", "mm"), default="pulses",
                   help="the figure's move lengths in pulses (default), in motor revolutions, "
                        "or in mm (every motor file then states its travel_mm_per_rev)")
    s.add_argument("-o", "--output", required=True, metavar="RESULTS",
                   help="results: CSV, or Parquet when the name ends in .parquet")
    s.set_defaults(func=_do_sweep)


def _do_sweep(args: argparse.Namespace) -> int:
    from profiles.errors import FormatError
    from profiles.motor import load_motor
    from verify.output import write_output
    from verify.sweep import (
        check_options,
        encode_rows,
        jobs_of,
        run_sweep,
        scheduler_address,
        sweep_figure,
    )

    # the options first, before any file is read or Dask imported
    if args.scheduler is not None:
        scheduler_address(args.scheduler, "--scheduler")
        if args.workers != 1:
            raise FormatError("--workers runs local processes; with --scheduler the "
                              "cluster's workers run the jobs: give one or the other")
    elif args.timeout is not None:
        raise FormatError("--timeout bounds the waits on a Dask scheduler: give it with "
                          "--scheduler")
    timeout_s = TIMEOUT_S if args.timeout is None else args.timeout
    with fields_as_options(OPTIONS):
        check_options(workers=args.workers, timeout_s=timeout_s, load_angle_deg=args.load_angle)
    cruise_reserve(args)
    motors = []
    units: dict[str, Any] = {}
    stems = [Path(p).stem for p in args.motors]
    for path, stem in zip(args.motors, stems, strict=True):
        motor = load_motor(path)  # a bad file stops the sweep before any work
        # rows name a motor by its file's stem, by its path where two stems are the same
        motors.append((stem if stems.count(stem) == 1 else path, motor.to_json()))
        units[motors[-1][0]] = plot_units(args.plot_x, path, motor)
    jobs = jobs_of(motors, args.pulses, samples=args.samples, seed=args.seed,
                   load_angle_deg=args.load_angle, cruise_reserve=args.cruise_reserve)
    with progress_bar("sweep", unit="job") as progress:
        rows = run_sweep(jobs, workers=args.workers, scheduler=args.scheduler,
                         timeout_s=timeout_s, progress=progress)
    data = encode_rows(rows, args.output)
    if args.plot:
        from verify.plot import save_figure

        save_figure(sweep_figure(rows, args.load_angle,
                                 units=None if args.plot_x == "pulses" else units), args.plot)
    write_output(args.output, data)
    unsafe = [r for r in rows if not r["safe"]]
    print(f"stepramp sweep: {len(motors)} motor(s) × {len(args.pulses)} move length(s): "
          f"{len(rows) - len(unsafe)} safe, {len(unsafe)} not safe → {args.output}",
          file=sys.stderr)
    return EXIT_FINDINGS if unsafe else EXIT_OK


def plot_units(plot_x: str, path: str, motor: Any) -> Any:
    """The units `--plot-x` draws `motor`'s lengths in (profiles.motor.travel.AxisUnits):
    rev for every motor, mm for a motor whose file states its travel (else one line naming
    the file and the option)."""
    from profiles.errors import FormatError
    from profiles.motor.travel import AxisUnits, axis_units

    if plot_x == "mm" and motor.travel_mm_per_rev is None:
        raise FormatError(f"--plot-x mm: {path} states no travel_mm_per_rev (a rotary axis): "
                          "give --plot-x rev, or the travel in the motor file")
    return axis_units(motor) if plot_x == "mm" else AxisUnits(int(motor.steps_per_rev))
