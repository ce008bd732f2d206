"""`stepramp motor new` (a motor file from a datasheet or a vendor curve, with loads) and
`stepramp motor check` (a motor file against its schema, each problem as a JSON pointer)."""

from __future__ import annotations

import argparse
import json
from typing import Any

from ._common import (
    EXIT_FINDINGS,
    EXIT_OK,
    EXIT_UNUSABLE,
    fields_as_options,
    number,
    positive_int,
)


def add_subparser(sub: Any) -> None:
    from profiles.motor.loads import LOAD_HELP
    from profiles.motor.units import SPEED_UNITS, TORQUE_UNITS

    motor = sub.add_parser("motor", help="motor files: from a datasheet or curve, and checks")
    msub = motor.add_subparsers(dest="motor_command", required=True, metavar="SUBCOMMAND")

    n = msub.add_parser("new", help="a motor file from a datasheet (electrical model) or a "
                                    "vendor curve, plus loads")
    g = n.add_argument_group("motor")
    g.add_argument("--phases", type=positive_int, default=2, choices=(2, 5),
                   help="motor phases, 2 or 5 (default 2; a motor file may state others)")
    g.add_argument("--step-angle", type=number, default=1.8, metavar="DEG",
                   help="full-step angle [°] (default 1.8)")
    g.add_argument("--microstep", type=positive_int, default=1,
                   help="driver microsteps per full step (default 1): "
                        "steps_per_rev = 360/step angle × microstep")
    g.add_argument("--rotor-inertia-gcm2", type=number, required=True, metavar="G·CM²",
                   help="rotor inertia [g·cm²] as datasheets print it (1 g·cm² = 1e-7 kg·m²)")
    g.add_argument("--detent-torque-nm", type=number, default=0.0, metavar="N·M",
                   help="detent torque [N·m], counted as friction (default 0)")
    d = n.add_argument_group("datasheet (the electrical model of profiles/datasheet.py)")
    d.add_argument("--holding-torque-nm", type=number, metavar="N·M",
                   help="holding torque [N·m], two phases on at the rated current")
    d.add_argument("--rated-current-a", type=number, metavar="A",
                   help="rated current per phase [A] (RMS)")
    d.add_argument("--resistance-ohm", type=number, metavar="Ω", help="phase resistance [Ω]")
    d.add_argument("--inductance-mh", type=number, metavar="MH", help="phase inductance [mH]")
    d.add_argument("--supply-v", type=number, metavar="V", help="drive supply voltage [V]")
    d.add_argument("--current-a", type=number, metavar="A",
                   help="drive current setting per phase [A] RMS (default: the rated current)")
    c = n.add_argument_group("vendor curve (instead of the model)")
    c.add_argument("--curve", metavar="FILE.csv",
                   help="pull-out curve: two columns speed, torque (a header line is skipped)")
    c.add_argument("--speed-unit", metavar="|".join(SPEED_UNITS),
                   help="the curve's speed unit: pps (the driver's pulses at --microstep), Hz "
                        "(FULL steps/s), rps or rpm")
    c.add_argument("--torque-unit", metavar="|".join(TORQUE_UNITS),
                   help="the curve's torque unit (also spelled N.m, Nm, mNm, oz-in, kgf-cm, "
                        "kg-cm)")
    o = n.add_argument_group("load and use")
    o.add_argument("--load", action="append", default=[], metavar="SPEC", help=LOAD_HELP)
    o.add_argument("--safety-factor", type=number, default=0.6,
                   help="share of the pull-out torque a plan may use [1], 0 < sf ≤ 1 (default 0.6)")
    o.add_argument("--start-pps", type=number, metavar="PPS",
                   help="self-start speed [pps] (default: estimated, see the guide)")
    o.add_argument("--name", default="", help="the motor file's name")
    n.add_argument("-o", "--output", metavar="M.json", help="write here (default stdout)")
    n.set_defaults(func=_do_new)

    k = msub.add_parser("check", help="check motor files against the schema and the loader")
    k.add_argument("files", nargs="+", metavar="FILE", help="motor files (stepramp.motor/1)")
    k.set_defaults(func=_do_check)


_DATASHEET_OPTS = ("holding_torque_nm", "rated_current_a", "resistance_ohm", "inductance_mh",
                   "supply_v")
# The library's fields by the options that set them (a refusal names what the user typed),
# and the factor from a field's unit to its option's.
OPTIONS = {"microstep": "--microstep", "phases": "--phases", "step_angle_deg": "--step-angle",
           "rotor_inertia_kgm2": "--rotor-inertia-gcm2", "detent_torque_nm": "--detent-torque-nm",
           "holding_torque_nm": "--holding-torque-nm", "rated_current_a": "--rated-current-a",
           "resistance_ohm": "--resistance-ohm", "inductance_h": "--inductance-mh",
           "supply_v": "--supply-v", "current_a": "--current-a",
           "safety_factor": "--safety-factor", "start_pps": "--start-pps"}
SCALES = {"rotor_inertia_kgm2": 1e7, "inductance_h": 1e3}


def _do_new(args: argparse.Namespace) -> int:
    from profiles.motor import Motor
    from verify.output import write_output

    with fields_as_options(OPTIONS, SCALES):
        obj = _motor_object(args)
        Motor.from_json(obj)   # refuse here what the planner would refuse later
    text_out = dump_motor(obj)
    write_output(args.output, text_out)
    if args.output not in (None, "-"):
        curve = obj["pullout_torque"]
        assert isinstance(curve, list)
        print(f"{args.output}: {obj['steps_per_rev']} steps/rev, {len(curve)} curve points up to "
              f"{curve[-1][0]:g} pps, inertia {obj['inertia_kgm2']:.4g} kg·m², friction "
              f"{obj['friction_torque_nm']:.4g} N·m, load torque "
              f"{obj.get('load_torque_nm', 0.0):.4g} N·m, start {obj['start_pps']:g} pps")
    return EXIT_OK


def _motor_object(args: argparse.Namespace) -> dict[str, Any]:
    """The motor file's object from the datasheet or the vendor curve, and the loads."""
    from profiles.errors import FormatError, require_int
    from profiles.motor.datasheet import (
        MICROSTEP_MAX,
        Datasheet,
        Drive,
        Mechanics,
        curve_from_csv,
        full_steps_per_rev,
        motor_from_datasheet,
        motor_object,
    )
    from profiles.motor.loads import loads_from_specs
    from profiles.reading import read_bytes

    # first: the curve's speeds are converted with it (a 0 would be blamed on the curve)
    require_int("microstep", args.microstep, 1, MICROSTEP_MAX)
    loads = loads_from_specs(args.load)
    given = [o for o in _DATASHEET_OPTS if getattr(args, o) is not None]
    if args.curve is None:
        missing = [o for o in _DATASHEET_OPTS if getattr(args, o) is None]
        if missing:
            raise FormatError("a datasheet motor needs " + ", ".join(
                "--" + o.replace("_", "-") for o in missing) + " (or a vendor --curve)")
        ds = Datasheet(step_angle_deg=args.step_angle, holding_torque_nm=args.holding_torque_nm,
                       rated_current_a=args.rated_current_a, resistance_ohm=args.resistance_ohm,
                       inductance_h=args.inductance_mh * 1e-3,
                       rotor_inertia_kgm2=args.rotor_inertia_gcm2 * 1e-7, phases=args.phases,
                       detent_torque_nm=args.detent_torque_nm)
        current = args.rated_current_a if args.current_a is None else args.current_a
        drive = Drive(args.supply_v, current, args.microstep)
        obj = motor_from_datasheet(ds, drive, loads, safety_factor=args.safety_factor,
                                   start_pps=args.start_pps, name=args.name)
    else:
        if given:
            raise FormatError("--curve replaces the datasheet model: drop " + ", ".join(
                "--" + o.replace("_", "-") for o in given))
        if args.speed_unit is None or args.torque_unit is None:
            raise FormatError("--curve needs --speed-unit and --torque-unit (declared, never "
                              "guessed)")
        mech = Mechanics(args.step_angle, args.rotor_inertia_gcm2 * 1e-7, args.phases,
                         args.detent_torque_nm)
        speeds, torques = curve_from_csv(
            read_bytes(args.curve).decode("utf-8", errors="replace"),
            speed_unit=args.speed_unit, torque_unit=args.torque_unit,
            steps_per_rev=full_steps_per_rev(args.step_angle) * args.microstep,
            microstep=args.microstep, name=args.curve)
        obj = motor_object(speeds, torques, mech, args.microstep, loads,
                           safety_factor=args.safety_factor, start_pps=args.start_pps,
                           name=args.name, curve_from=(f"vendor curve {args.curve} "
                                                       f"({args.speed_unit}, {args.torque_unit})"))
    return obj


def dump_motor(obj: dict[str, Any]) -> str:
    """One key per line, values inline: diffable and short."""
    lines = [f" {json.dumps(k)}: {json.dumps(v, ensure_ascii=False)}" for k, v in obj.items()]
    return "{\n" + ",\n".join(lines) + "\n}\n"


def _do_check(args: argparse.Namespace) -> int:
    """The problems of each file on stdout: a verdict (exit 1) like `stepramp check`'s; a
    file that cannot be read is also named on stderr, one line each (exit 2)."""
    import sys

    from profiles.errors import StepRampError, bounded
    from profiles.motor.schema import problems
    from profiles.reading import display_path, read_json

    unusable, bad = [], False
    for path in args.files:
        name = display_path(path)
        try:
            found = problems(read_json(path))
        except StepRampError as e:
            line = str(e) if str(e).startswith(name) else f"{name}: {e}"
            print(bounded(line))
            unusable.append(line)
            continue
        if not found:
            print(f"{name}: ok")
        for where, message in found:  # a schema message can quote a whole field
            print(bounded(f"{name}: {where or '/'}: {message}"))
        bad = bad or bool(found)
    for line in unusable:
        print(f"stepramp motor: {bounded(line)}", file=sys.stderr)
    return EXIT_UNUSABLE if unusable else EXIT_FINDINGS if bad else EXIT_OK
