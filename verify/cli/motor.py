"""`stepramp motor new` (a motor file from a datasheet or a vendor curve, with loads),
`stepramp motor check` (a motor file against its schema, each problem as a JSON pointer),
`stepramp motor list` (the catalogue: bundled and user motors by name) and `stepramp
motor show` (one motor's curve and capability, as text or a figure)."""

from __future__ import annotations

import argparse
import json
from typing import Any

from ._common import (
    EXIT_FINDINGS,
    EXIT_OK,
    EXIT_UNUSABLE,
    MOTOR_HELP,
    MOTOR_METAVAR,
    fields_as_options,
    number,
    positive_int,
)


def add_subparser(sub: Any) -> None:
    motor = sub.add_parser("motor", help="motors: list and show them by name, make motor files "
                                         "from a datasheet or curve, check them")
    msub = motor.add_subparsers(dest="motor_command", required=True, metavar="SUBCOMMAND")
    _add_new(msub)

    k = msub.add_parser("check", help="check motor files against the schema and the loader")
    k.add_argument("files", nargs="+", metavar="MOTOR",
                   help="motor files (stepramp.motor/1) or names from `stepramp motor list`")
    k.set_defaults(func=_do_check)

    ls = msub.add_parser("list", help="the motors known by name: bundled, in $STEPRAMP_MOTORS "
                                      "and in the user config folder")
    ls.add_argument("--format", choices=("text", "json"), default="text",
                    help="output format (default text)")
    ls.set_defaults(func=_do_list)

    sh = msub.add_parser("show", help="one motor: its data, pull-out curve and acceleration "
                                      "capability")
    sh.add_argument("motor", metavar=MOTOR_METAVAR, help=MOTOR_HELP)
    sh.add_argument("--plot", metavar="OUT.png",
                    help="also write its figure (torque [N·m] and capability [pps²] against "
                         "speed [pps]); PNG or SVG by extension")
    sh.set_defaults(func=_do_show)


def _add_new(msub: Any) -> None:
    from profiles.motor.loads import LOAD_HELP
    from profiles.motor.units import SPEED_UNITS, TORQUE_UNITS

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
    detent = g.add_mutually_exclusive_group()
    detent.add_argument("--detent-torque-nm", type=number, metavar="N·M",
                        help="detent torque [N·m], counted as friction (default 0)")
    detent.add_argument("--detent-torque-ncm", type=number, metavar="N·CM",
                        help="detent torque [N·cm], as most datasheets print it")
    d = n.add_argument_group("datasheet (the electrical model of profiles/datasheet.py)")
    holding = d.add_mutually_exclusive_group()
    holding.add_argument("--holding-torque-nm", type=number, metavar="N·M",
                         help="holding torque [N·m], two phases on at the rated current "
                              "(with --curve too: the curve is checked against it)")
    holding.add_argument("--holding-torque-ncm", type=number, metavar="N·CM",
                         help="holding torque [N·cm], as most datasheets print it")
    d.add_argument("--rated-current-a", type=number, metavar="A",
                   help="rated current per phase [A] (RMS)")
    d.add_argument("--resistance-ohm", type=number, metavar="Ω", help="phase resistance [Ω]")
    d.add_argument("--inductance-mh", type=number, metavar="MH", help="phase inductance [mH]")
    d.add_argument("--supply-v", type=number, metavar="V", help="drive supply voltage [V]")
    d.add_argument("--current-a", type=number, metavar="A",
                   help="drive current setting per phase [A] RMS (default: the rated current; "
                        "above it only with --allow-overcurrent)")
    d.add_argument("--allow-overcurrent", action="store_true",
                   help="accept a --current-a above --rated-current-a (the motor runs hotter "
                        "than its rating; only where its datasheet allows it)")
    c = n.add_argument_group("vendor curve (instead of the model)")
    c.add_argument("--curve", metavar="FILE.csv",
                   help="pull-out curve: two columns speed, torque (a header line is skipped)")
    c.add_argument("--speed-unit", metavar="|".join(SPEED_UNITS),
                   help="the curve's speed unit: pps (the driver's pulses at --microstep), Hz "
                        "(FULL steps/s), rps or rpm")
    c.add_argument("--torque-unit", metavar="|".join(TORQUE_UNITS),
                   help="the curve's torque unit (also spelled N.m, Nm, N.cm, Ncm, mNm, oz-in, "
                        "kgf-cm, kg-cm)")
    o = n.add_argument_group("load and use")
    o.add_argument("--load", action="append", default=[], metavar="SPEC", help=LOAD_HELP)
    o.add_argument("--safety-factor", type=number, default=0.6,
                   help="share of the pull-out torque a plan may use [1], 0 < sf ≤ 1 (default 0.6)")
    o.add_argument("--start-pps", type=number, metavar="PPS",
                   help="self-start speed [pps] (default: estimated, see the guide)")
    o.add_argument("--name", default="", help="the motor file's name")
    o.add_argument("--travel-mm-per-rev", type=number, metavar="MM",
                   help="the axis travel per motor revolution [mm] (default: from a screw's "
                        "lead or a belt pulley's π·d in --load, through its gears; none for "
                        "a rotary load): plan, show and the figures then give mm beside "
                        "pulses, and plan takes --distance-mm")
    n.add_argument("-o", "--output", metavar="M.json", help="write here (default stdout)")
    n.set_defaults(func=_do_new)

# The datasheet's options by their library field (a refusal names what the user typed).
_DATASHEET_OPTS = {"holding_torque_nm": "--holding-torque-nm", "rated_current_a":
                   "--rated-current-a", "resistance_ohm": "--resistance-ohm",
                   "inductance_mh": "--inductance-mh", "supply_v": "--supply-v"}
# The library's fields by the options that set them (a refusal names what the user typed),
# and the factor from a field's unit to its option's.
# Each with its unit, in the help's brackets: a refusal names the value's unit too.
OPTIONS = {"microstep": "--microstep", "phases": "--phases",
           "step_angle_deg": "--step-angle [°]",
           "rotor_inertia_kgm2": "--rotor-inertia-gcm2 [g·cm²]",
           "detent_torque_nm": "--detent-torque-nm [N·m]",
           "holding_torque_nm": "--holding-torque-nm [N·m]",
           "rated_current_a": "--rated-current-a [A]", "resistance_ohm": "--resistance-ohm [Ω]",
           "inductance_h": "--inductance-mh [mH]", "supply_v": "--supply-v [V]",
           "current_a": "--current-a [A]", "safety_factor": "--safety-factor [1]",
           "start_pps": "--start-pps [pps]",
           "travel_mm_per_rev": "--travel-mm-per-rev [mm]"}
SCALES = {"rotor_inertia_kgm2": 1e7, "inductance_h": 1e3}
NCM_PER_NM = 100.0


def _do_new(args: argparse.Namespace) -> int:
    from profiles.motor import Motor
    from verify.output import write_output

    options, scales = dict(OPTIONS), dict(SCALES)
    for what in ("holding", "detent"):  # a torque typed in N·cm is refused in N·cm
        if getattr(args, f"{what}_torque_ncm") is not None:
            options[f"{what}_torque_nm"] = f"--{what}-torque-ncm [N·cm]"
            scales[f"{what}_torque_nm"] = NCM_PER_NM
    with fields_as_options(options, scales):
        obj = _motor_object(args)
        _add_travel(args, obj)
        Motor.from_json(obj)   # refuse here what the planner would refuse later
    text_out = dump_motor(obj)
    write_output(args.output, text_out)
    if args.output not in (None, "-"):
        curve = obj["pullout_torque"]
        assert isinstance(curve, list)
        print(f"{args.output}: {obj['steps_per_rev']} steps/rev, {len(curve)} curve points up to "
              f"{curve[-1][0]:g} pps, inertia {obj['inertia_kgm2']:.4g} kg·m², friction "
              f"{_friction_text(obj)} N·m, load torque "
              f"{obj.get('load_torque_nm', 0.0):.4g} N·m, start {obj['start_pps']:g} pps"
              + (f", travel {obj['travel_mm_per_rev']:.6g} mm/rev" if "travel_mm_per_rev" in obj
                 else ""))
    say_assumed(obj)
    return EXIT_OK


def _add_travel(args: argparse.Namespace, obj: dict[str, Any]) -> None:
    """The axis travel per motor revolution, given or from the loads' mechanism, into the
    motor file with where it came from (none for a rotary load)."""
    from profiles.errors import FormatError
    from profiles.motor.loads import mechanisms_from_specs
    from profiles.motor.plausible import Label, value_problem

    if args.travel_mm_per_rev is not None:
        value, source = args.travel_mm_per_rev, "--travel-mm-per-rev (given)"
        label = Label("--travel-mm-per-rev", "mm")
    else:
        found = mechanisms_from_specs(args.load)
        if not found:
            return
        travels = sorted({f"{m.travel_mm_per_rev:.9g}" for m in found})
        if len(travels) > 1:
            raise FormatError(f"--load: the mechanisms travel {', '.join(travels)} mm per "
                              "motor revolution: give the one the axis is measured by with "
                              "--travel-mm-per-rev [mm]")
        value, source = found[0].travel_mm_per_rev, found[0].source
        label = Label(f"--load (travel per motor revolution: {source})", "mm")
    problem = value_problem("travel_mm_per_rev", value, label)
    if problem:
        raise FormatError(problem)
    obj["travel_mm_per_rev"] = value
    obj.setdefault("sources", {})["travel_mm_per_rev"] = [{"value": value, "from": source}]


def _friction_text(obj: dict[str, Any]) -> str:
    """The friction as written: its range when it rests on an assumption."""
    lo_hi = obj.get("tolerances", {}).get("friction_torque_nm")
    return (f"{obj['friction_torque_nm']:.4g}" if lo_hi is None
            else f"{lo_hi[0]:.4g}..{lo_hi[1]:.4g}")


def say_assumed(obj: dict[str, Any]) -> None:
    """Each value the file assumes (its sources say "assumed"), on stderr, and the
    friction range it plans over: a user sees what to measure and give."""
    import sys

    from profiles.motor.loads import ASSUMED

    for field, entries in obj.get("sources", {}).items():
        for entry in entries:
            if f"({ASSUMED}:" in entry["from"]:
                print(f"stepramp motor: {field} {entry['value']:.4g}: {entry['from']}",
                      file=sys.stderr)
    lo_hi = obj.get("tolerances", {}).get("friction_torque_nm")
    if lo_hi is not None:
        print(f"stepramp motor: friction {lo_hi[0]:.4g}..{lo_hi[1]:.4g} N·m planned over that "
              "range (tolerances): the most where it slows the ramps up, the least where it "
              "would help them stop; give the values to narrow it", file=sys.stderr)


def _torque(args: argparse.Namespace, what: str) -> tuple[float | None, Any]:
    """A torque given in N·m or N·cm (`what`: holding, detent) in N·m, and how it was typed."""
    from profiles.motor.plausible import Label

    ncm = getattr(args, f"{what}_torque_ncm")
    if ncm is not None:
        return ncm / NCM_PER_NM, Label(f"--{what}-torque-ncm", "N·cm", NCM_PER_NM)
    return getattr(args, f"{what}_torque_nm"), Label(f"--{what}-torque-nm", "N·m")


def _refuse_implausible(args: argparse.Namespace, holding: float | None, label: Any) -> None:
    """Refuse, naming the option and its unit, a value no stepper's datasheet has (a unit
    slip) and a drive current above the rating (profiles/motor/plausible.py)."""
    from profiles.errors import FormatError
    from profiles.motor.plausible import Label, datasheet_problems

    mh, gcm2 = args.inductance_mh, args.rotor_inertia_gcm2
    values = {"holding_torque_nm": holding, "rated_current_a": args.rated_current_a,
              "current_a": args.current_a, "resistance_ohm": args.resistance_ohm,
              "inductance_h": None if mh is None else mh * 1e-3,
              "rotor_inertia_kgm2": gcm2 * 1e-7, "supply_v": args.supply_v}
    labels = {"holding_torque_nm": label, "rated_current_a": Label("--rated-current-a", "A"),
              "current_a": Label("--current-a", "A"),
              "resistance_ohm": Label("--resistance-ohm", "Ω"),
              "inductance_h": Label("--inductance-mh", "mH", 1e3),
              "rotor_inertia_kgm2": Label("--rotor-inertia-gcm2", "g·cm²", 1e7),
              "supply_v": Label("--supply-v", "V")}
    found = datasheet_problems(values, labels, allow_overcurrent=None if args.allow_overcurrent
                               else "--allow-overcurrent")
    if found:
        raise FormatError(found[0])


def _motor_object(args: argparse.Namespace) -> dict[str, Any]:
    """The motor file's object from the datasheet or the vendor curve, and the loads."""
    from profiles.errors import FormatError, require_int
    from profiles.motor.datasheet import MICROSTEP_MAX, assumed_detent
    from profiles.motor.loads import loads_from_specs

    # first: the curve's speeds are converted with it (a 0 would be blamed on the curve)
    require_int("microstep", args.microstep, 1, MICROSTEP_MAX)
    steps = 360.0 / args.step_angle if 0 < args.step_angle <= 90 else 0.5
    if abs(steps - round(steps)) > 1e-6:  # named as typed, not as the library's field
        raise FormatError(f"--step-angle [°]: {args.step_angle:g} does not divide 360° "
                          "(1.8, 0.9, 0.72, 0.36, …; at most 90)")
    holding, label = _torque(args, "holding")
    given_detent = _torque(args, "detent")[0]
    detent = given_detent or 0.0
    given = [o for f, o in _DATASHEET_OPTS.items() if f != "holding_torque_nm"
             and getattr(args, f) is not None]
    if args.curve is None:
        missing = [o for f, o in _DATASHEET_OPTS.items() if (holding if f == "holding_torque_nm"
                                                            else getattr(args, f)) is None]
        if missing:
            raise FormatError(f"a datasheet motor needs {', '.join(missing)} (or a vendor "
                              "--curve)")
    elif given or args.current_a is not None:
        raise FormatError("--curve replaces the datasheet model: drop " + ", ".join(
            given + ["--current-a"] * (args.current_a is not None)))
    _refuse_implausible(args, holding, label)
    loads = loads_from_specs(args.load)
    if given_detent is None and holding is not None:
        # no datasheet value: a share of the holding torque, said and written as assumed
        loads.insert(0, assumed_detent(holding))
    if args.curve is None:
        return _datasheet_motor(args, holding, detent, loads)
    return _curve_motor(args, (holding, label), detent, loads,
                        assume_detent=given_detent is None and holding is None)


def _datasheet_motor(args: argparse.Namespace, holding: Any, detent: float,
                     loads: Any) -> dict[str, Any]:
    from profiles.motor.datasheet import Datasheet, Drive, motor_from_datasheet

    ds = Datasheet(step_angle_deg=args.step_angle, holding_torque_nm=holding,
                   rated_current_a=args.rated_current_a, resistance_ohm=args.resistance_ohm,
                   inductance_h=args.inductance_mh * 1e-3,
                   rotor_inertia_kgm2=args.rotor_inertia_gcm2 * 1e-7, phases=args.phases,
                   detent_torque_nm=detent)
    current = args.rated_current_a if args.current_a is None else args.current_a
    drive = Drive(args.supply_v, current, args.microstep)
    return motor_from_datasheet(ds, drive, loads, safety_factor=args.safety_factor,
                                start_pps=args.start_pps, name=args.name)


def _curve_motor(args: argparse.Namespace, holding: tuple[float | None, Any], detent: float,
                 loads: Any, *, assume_detent: bool) -> dict[str, Any]:
    """A motor from a vendor curve; a holding torque given beside it is written to the file
    and the curve is checked against it (a torque unit slip shows as a curve far above);
    without a detent torque or a holding torque, the detent is assumed from the curve's
    torque at standstill."""
    from profiles.errors import FormatError
    from profiles.motor.datasheet import (
        Mechanics,
        assumed_detent,
        curve_from_csv,
        full_steps_per_rev,
        motor_object,
    )
    from profiles.motor.plausible import Label, curve_problem, ratio_problem
    from profiles.reading import read_bytes, utf8_text

    if args.speed_unit is None or args.torque_unit is None:
        raise FormatError("--curve needs --speed-unit and --torque-unit (declared, never "
                          "guessed)")
    mech = Mechanics(args.step_angle, args.rotor_inertia_gcm2 * 1e-7, args.phases, detent)
    speeds, torques = curve_from_csv(
        utf8_text(read_bytes(args.curve), args.curve),
        speed_unit=args.speed_unit, torque_unit=args.torque_unit,
        steps_per_rev=full_steps_per_rev(args.step_angle) * args.microstep,
        microstep=args.microstep, name=args.curve)
    curve = Label(f"--curve {args.curve} (--torque-unit {args.torque_unit})", "N·m")
    value, label = holding
    inertia = Label("--rotor-inertia-gcm2", "g·cm²", 1e7)
    found = (curve_problem(float(max(torques)), value, curve, label) if value is not None
             else None) or ratio_problem(float(torques[0]), mech.rotor_inertia_kgm2, curve,
                                         inertia)
    if found:
        raise FormatError(found)
    if assume_detent:
        loads = [assumed_detent(float(torques[0]), "curve's torque at standstill"), *loads]
    return motor_object(speeds, torques, mech, args.microstep, loads,
                        safety_factor=args.safety_factor, start_pps=args.start_pps,
                        name=args.name, holding_torque_nm=value,
                        curve_from=(f"vendor curve {args.curve} "
                                    f"({args.speed_unit}, {args.torque_unit})"))


def dump_motor(obj: dict[str, Any]) -> str:
    """One key per line, values inline: diffable and short."""
    lines = [f" {json.dumps(k)}: {json.dumps(v, ensure_ascii=False)}" for k, v in obj.items()]
    return "{\n" + ",\n".join(lines) + "\n}\n"


def _do_check(args: argparse.Namespace) -> int:
    """The problems of each file on stdout: a verdict (exit 1) like `stepramp check`'s; a
    file that cannot be read is also named on stderr, one line each (exit 2)."""
    import sys

    from profiles.errors import StepRampError, bounded
    from profiles.motor.catalogue import resolve
    from profiles.motor.schema import problems
    from profiles.reading import display_path, read_json

    unusable, bad = [], False
    for path in args.files:
        name = display_path(path)
        try:
            found = problems(read_json(resolve(path)))
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


def _do_list(args: argparse.Namespace) -> int:
    import sys

    from profiles.motor.catalogue import entries, motor_dirs
    from profiles.reading import display_path, json_text
    from verify.output import write_output

    for source, folder in motor_dirs():
        if source != "user config" and not folder.is_dir():  # a typo in the variable
            print(f"stepramp motor: warning: {source} folder {display_path(folder)} is not a "
                  "folder", file=sys.stderr)
    rows = [_entry_row(e) for e in entries()]
    if args.format == "json":
        write_output(None, json_text({"motors": rows}))
    else:
        write_output(None, _list_text(rows))
    return EXIT_OK


def _entry_row(entry: Any) -> dict[str, Any]:
    """One catalogue entry as `motor list` shows it; an unreadable file says why."""
    from profiles.errors import StepRampError
    from profiles.motor import load_motor
    from profiles.reading import display_path

    row: dict[str, Any] = {"name": entry.name, "source": entry.source,
                           "shadowed_by": entry.shadowed_by, "path": display_path(entry.path)}
    try:
        m = load_motor(entry.path)
    except StepRampError as e:  # the row names the file already
        return row | {"error": str(e).removeprefix(f"{row['path']}: ")}
    holding = m.holding_torque_nm
    return row | {"steps_per_rev": m.steps_per_rev,
                  "holding_torque_nm": float(m.torque_nm(0.0)) if holding is None else holding,
                  "holding_from": "pullout_torque at 0 pps" if holding is None
                  else "holding_torque_nm",
                  "top_pps": m.top_pps, "top_rpm": m.top_pps * 60.0 / m.steps_per_rev,
                  "description": m.name}


def _list_text(rows: list[dict[str, Any]]) -> str:
    head = ("name", "steps/rev", "holding [N·m]", "top [pps]", "[rpm]", "source", "description")
    table = [head]
    for r in rows:
        source = r["source"] + (f" (shadowed by {r['shadowed_by']})" if r["shadowed_by"] else "")
        if "error" in r:
            table.append((r["name"], "-", "-", "-", "-", source, f"unreadable: {r['error']}"))
            continue
        approx = "≈" if r["holding_from"] != "holding_torque_nm" else ""
        table.append((r["name"], str(r["steps_per_rev"]), f"{approx}{r['holding_torque_nm']:.3g}",
                      f"{r['top_pps']:.6g}", f"{r['top_rpm']:.4g}", source, r["description"]))
    widths = [max(len(row[i]) for row in table) for i in range(len(head) - 1)]
    right = {1, 2, 3, 4}
    lines = ["  ".join([(c.rjust(w) if i in right else c.ljust(w))
                        for i, (c, w) in enumerate(zip(row, widths, strict=False))]
                       + [row[-1]]).rstrip() for row in table]
    if any(r.get("holding_from", "holding_torque_nm") != "holding_torque_nm" for r in rows):
        lines.append("≈: the pull-out torque at 0 pps (the file gives no holding_torque_nm)")
    if len(rows) == 0:
        lines.append("(no motors)")
    return "\n".join(lines) + "\n"


def _do_show(args: argparse.Namespace) -> int:
    from profiles.errors import FormatError
    from profiles.motor.catalogue import find, is_name, resolve
    from profiles.reading import display_path
    from verify.output import write_output

    from ._common import load_motor

    if args.plot and not args.plot.lower().endswith((".png", ".svg")):
        raise FormatError(f"--plot {args.plot}: the figure format is taken from the "
                          "extension: .png or .svg")
    motor = load_motor(args.motor)
    entry = find(args.motor) if is_name(args.motor) else None
    where = (f"{display_path(entry.path)} ({entry.source})" if entry is not None
             else display_path(resolve(args.motor)))
    write_output(None, _show_text(args.motor, where, motor))
    if args.plot:
        from pathlib import Path

        from verify.plot import motor_figure, save_figure

        save_figure(motor_figure(motor, Path(args.motor).stem), args.plot)
    return EXIT_OK


def _travel_text(m: Any) -> str:
    """The axis's travel per motor revolution and where it came from, or "rotary"."""
    from profiles.motor.travel import axis_units

    units = axis_units(m)
    if not units.linear:
        return (f"axis: rotary (no travel_mm_per_rev): lengths in rev, speeds in rpm; top "
                f"{units.speed_text(m.top_pps)}")
    came = (m.sources or {}).get("travel_mm_per_rev", [])
    source = f" ({came[0]['from']})" if came else ""
    return (f"axis: {units.describe()}{source}; top {units.speed_text(m.top_pps)}, "
            f"at start {units.accel_text(float(m.a_acc_pps2(0.0)))}")


def _show_text(spec: str, where: str, m: Any) -> str:
    import numpy as np

    from profiles.motor.travel import axis_units

    rpm = 60.0 / m.steps_per_rev
    lines = [f"{spec}: {m.name}" if m.name else spec, f"file: {where}",
             f"{m.steps_per_rev} steps/rev, {m.phases} phases, inertia {m.inertia_kgm2:.4g} "
             f"kg·m², friction {m.friction_torque_nm:.4g} N·m, load {m.load_torque_nm:.4g} N·m, "
             f"safety factor {m.safety_factor:g}",
             f"start {m.start_pps:.6g} pps, largest jump {m.jump_pps:.6g} pps, top "
             f"{m.top_pps:.6g} pps ({m.top_pps * rpm:.4g} rpm)"
             + ("" if m.holding_torque_nm is None else
                f", holding torque {m.holding_torque_nm:.4g} N·m")]
    lines.append(_travel_text(m))
    if m.tolerances:
        lines.append("tolerances: " + ", ".join(f"{k} {lo:.4g}..{hi:.4g}"
                                               for k, lo, hi in m.tolerances))
    if m.resonance_bands_pps:
        lines.append("resonance bands: " + ", ".join(f"{lo:.6g}–{hi:.6g} pps"
                                                     for lo, hi in m.resonance_bands_pps))
    v = np.asarray(m.curve_speed_pps)
    units = axis_units(m)
    head: tuple[str, ...] = ("speed [pps]", "[rpm]", "pull-out [N·m]",
                             f"× {m.safety_factor:g} [N·m]", "a_acc [pps²]", "a_dec [pps²]")
    cols = [[f"{x:.6g}" for x in v], [f"{x * rpm:.4g}" for x in v],
            [f"{x:.4g}" for x in m.curve_torque_nm],
            [f"{m.safety_factor * x:.4g}" for x in m.curve_torque_nm],
            [f"{x:.4g}" for x in m.a_acc_pps2(v)], [f"{x:.4g}" for x in m.a_dec_pps2(v)]]
    if units.linear:  # the axis's own units beside the pulses'
        head += ("[mm/s]", "a_acc [mm/s²]")
        cols += [[f"{x:.4g}" for x in units.speed(v)],
                 [f"{x:.4g}" for x in units.accel(m.a_acc_pps2(v))]]
    widths = [max(len(h), *(len(c) for c in col)) for h, col in zip(head, cols, strict=True)]
    lines.append("  ".join(h.rjust(w) for h, w in zip(head, widths, strict=True)))
    lines += ["  ".join(col[i].rjust(w) for col, w in zip(cols, widths, strict=True))
              for i in range(len(v))]
    return "\n".join(lines) + "\n"
