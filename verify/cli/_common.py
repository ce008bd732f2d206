"""What every `stepramp` command module shares: exit codes, argument types and
option helpers. Command modules import from here, never from each other.

Units in help texts are spelled one way: pps, pps², pps³, s, ms, µs, Hz, in
square brackets after the quantity.
"""

from __future__ import annotations

import argparse
import shlex
import sys
from collections.abc import Iterator, Mapping
from contextlib import contextmanager
from typing import TYPE_CHECKING, Any

from profiles.errors import echo
from verify.check_options import DEFAULT_SAMPLES

if TYPE_CHECKING:
    from profiles.ppmc312.clock import Clock
    from profiles.progress import Progress

EXIT_OK, EXIT_FINDINGS, EXIT_UNUSABLE = 0, 1, 2

CLOCK_NAMES = "8MHz, 1MHz, 500kHz, 250kHz, 62.5kHz or 15.625kHz (any case)"
PROGRESS_DELAY_S = 1.0  # a bar appears only for work that has run this long


SAMPLES_MAX = 100_000  # Monte Carlo samples of a tolerance box (each one a row of the kernel)


def sample_count(text: str) -> int:
    """A number of Monte Carlo samples, 0..SAMPLES_MAX (a huge one would exhaust memory)."""
    value = positive_int(text)
    if value > SAMPLES_MAX:
        raise argparse.ArgumentTypeError(f"{value} samples: at most {SAMPLES_MAX}")
    return value


def positive_int(text: str) -> int:
    """A non-negative integer, decimal or with a 0x/0o/0b prefix."""
    try:
        value = int(text, 0)
    except ValueError:
        raise argparse.ArgumentTypeError(f"{echo(text)} is not an integer") from None
    if value < 0:
        raise argparse.ArgumentTypeError(f"{echo(text)} is negative")
    return value


def pulse_list(text: str) -> list[int]:
    """Move lengths "N[,M…]", each 1..0xFFFFFFFF."""
    out = []
    for part in text.split(","):
        value = positive_int(part.strip())
        if not 1 <= value <= 0xFFFFFFFF:
            raise argparse.ArgumentTypeError(f"{echo(part.strip())} is not a move length "
                                             "(1..4294967295 pulses)")
        out.append(value)
    return out


def number(text: str) -> float:
    try:
        return float(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"{echo(text)} is not a number") from None


def add_cruise_reserve_option(p: argparse.ArgumentParser, what: str = "plan") -> None:
    """`--cruise-reserve`: the torque reserve a plan keeps at its top speed
    (profiles/motor/reserve.py), parsed where it is used (the parser needs no numpy)."""
    p.add_argument("--cruise-reserve", default="2x,10%", metavar="Nx,S%|off",
                   help=f"{what} with this torque reserve at the top speed: the pull-out "
                        "torque there ≥ N × what cruising needs (friction + load torque) and "
                        "≥ S %% of the standstill pull-out torque (default 2x,10%%; 3x or 15%% "
                        "sets one, off: none, the curve's top)")


def cruise_reserve(args: argparse.Namespace) -> Any:
    """The `CruiseReserve` of `--cruise-reserve` (one line naming the option when wrong)."""
    from profiles.motor.reserve import parse_cruise_reserve

    return parse_cruise_reserve(args.cruise_reserve)


def planned_for(spec: str, motor: Any, *, pulses: tuple[int, ...] | None,
                aim_deg: float | None, reserve: Any, moves_file: Any = None,
                commands: tuple[str, ...] | None = None) -> Any:
    """The `PlanProvenance` of a planned file (profiles/provenance.py): the motor as typed
    (`spec`) and the hash of its content, the move lengths, the aim, its safety factor,
    the cruise reserve, the motion commands judged (names; None: all), this version and
    the date (SOURCE_DATE_EPOCH when set: the reproducible-builds convention, so a
    planned file can be rebuilt byte for byte)."""
    import os
    from datetime import UTC, datetime

    from profiles.provenance import FileRef, PlanProvenance, content_sha256

    epoch = os.environ.get("SOURCE_DATE_EPOCH", "")
    when = datetime.fromtimestamp(int(epoch), UTC) if epoch.isdigit() else datetime.now(UTC)
    return PlanProvenance(FileRef(spec, content_sha256(motor.to_json())), version(),
                          when.strftime("%Y-%m-%dT%H:%M:%SZ"), pulses, moves_file, aim_deg,
                          motor.safety_factor, reserve.spec, commands)


def internal_clock(text: str) -> Clock:
    """An internal PPMC-312 clock by name, any case ("8mhz")."""
    from profiles.errors import FormatError
    from profiles.ppmc312.clock import Clock

    try:
        return Clock.named(text)
    except FormatError as e:  # argparse already names the option: drop the field prefix
        raise argparse.ArgumentTypeError(str(e).removeprefix("clock: ")) from None


def clock_or_extck(text: str) -> str:
    """An internal clock's exact name, or "EXTCK" (any case)."""
    if text.strip().lower() == "extck":
        return "EXTCK"
    return internal_clock(text).name


@contextmanager
def fields_as_options(options: Mapping[str, str],
                      scales: Mapping[str, float] | None = None) -> Iterator[None]:
    """Name the option a user typed, not the library's field: a FieldRangeError for a
    field in `options` is re-raised with the option in its place, keeping the value,
    the range and any chip code. A field matches exactly, by the last dotted part of
    a frame field (`mc200.host.position.header.driver_id`), or by its name before any
    parenthesised note with spaces as underscores (`high rate (0 = the table's)`).
    `scales[field]` converts a field's value and range back to the option's unit (the
    option in g·cm², the field in kg·m²: 1e7)."""
    from profiles.errors import FieldRangeError

    try:
        yield
    except FieldRangeError as e:
        last = e.field.rpartition(".")[2]
        base = last.split(" (")[0].strip().replace(" ", "_")
        option = options.get(e.field) or options.get(last) or options.get(base)
        if option is None or not str(e).startswith(e.field):
            raise
        scale = (scales or {}).get(base)
        note = last[len(last.split(" (")[0]):]  # "(0 excluded)" stays: it says why
        if scale is not None and all(isinstance(v, int | float) for v in (e.value, e.lo, e.hi)):
            raise FieldRangeError(option + note, _scaled(e.value, scale),
                                  _scaled(e.lo, scale), _scaled(e.hi, scale)) from None
        e.args = (option + note + str(e)[len(e.field):],)
        e.field = option + note
        raise


def _scaled(value: Any, scale: float) -> float:
    return float(f"{value * scale:.12g}")  # 5.7e-6 kg·m² × 1e7 is 57 g·cm², not 56.99…


def add_sample_options(p: argparse.ArgumentParser, scope: str) -> None:
    """`--samples` and `--seed`: the Monte Carlo sample of a motor's tolerance box."""
    p.add_argument("--samples", type=sample_count, default=DEFAULT_SAMPLES, metavar="N",
                   help=f"{scope}Monte Carlo samples of the motor's tolerance box for the load "
                        f"angle (default {DEFAULT_SAMPLES}; 0: its corners only; a motor "
                        "without tolerances has none)")
    p.add_argument("--seed", type=positive_int, default=0,
                   help="random seed of the samples (default 0: the same samples every run)")


# Every command's motor argument: a file or a catalogue name (profiles/motor/catalogue.py).
MOTOR_METAVAR = "MOTOR"
MOTOR_HELP = "the motor: a motor file (stepramp.motor/1) or a name from `stepramp motor list`"


def load_motor(spec: str) -> Any:
    """The motor of a file path or catalogue name (the one resolver every command uses)."""
    from profiles.motor import load_motor as load

    return load(spec)


@contextmanager
def progress_bar(desc: str, unit: str = "it") -> Iterator[Progress | None]:
    """A progress callback drawing a tqdm bar on stderr, or None when stderr is not a
    terminal (pipes, CI logs and tests stay clean). The bar shows up only once the
    work has run PROGRESS_DELAY_S and is erased when it ends."""
    if not sys.stderr.isatty():
        yield None
        return
    from tqdm import tqdm

    bar = tqdm(total=0, desc=desc, unit=unit, file=sys.stderr, leave=False,
               delay=PROGRESS_DELAY_S, dynamic_ncols=True)

    def update(done: int, total: int) -> None:
        if bar.total != total:
            bar.reset(total=total)
        bar.update(done - bar.n)
        if done >= total:  # tqdm throttles redraws; show the end before the bar is erased
            bar.refresh()

    try:
        yield update
    finally:
        bar.close()


class VersionAction(argparse.Action):
    """`--version`: the installed package's version, looked up only when asked (the
    metadata lookup would otherwise slow every start)."""

    def __init__(self, option_strings: list[str], dest: str = argparse.SUPPRESS,
                 **kwargs: Any) -> None:
        super().__init__(option_strings, dest=dest, nargs=0,
                         help="print stepramp's version and exit", **kwargs)

    def __call__(self, parser: argparse.ArgumentParser, namespace: argparse.Namespace,
                 values: Any, option_string: str | None = None) -> None:
        print(f"stepramp {version()}")
        parser.exit()


def version() -> str:
    from profiles.formats import tool_version

    return tool_version()


def add_file_format_options(parser: argparse.ArgumentParser, formats: Any = None, *,
                            default: str = "text", c_default: str = "stepramp") -> None:
    """--format, --name and (formats with ihex) --base-address for the commands that
    write files of a format table (`profiles.formats.FormatTable`; default the PPMC-312
    upload's, `profiles.ppmc312.formats`)."""
    if formats is None:
        from profiles.ppmc312.formats import FORMATS as formats

    described = "; ".join(f"{f.name}: {f.description}" for f in formats.formats.values())
    extensions = ", ".join(f"{'/'.join(f.extensions)} {f.name}"
                           for f in formats.formats.values())
    aliases = "".join(f"; {a} is {t}'s other name" for a, t in formats.aliases.items())
    parser.add_argument("--format", choices=formats.names, default=None,
                        help=f"file format ({described}{aliases}). Default: from OUT's "
                             f"extension ({extensions}), else {default}")
    parser.add_argument("--name", metavar="PREFIX",
                        help="with --format c: prefix of the include guard and every symbol, "
                             "a C identifier (default: from OUT's file name, else "
                             f"{c_default})")
    if "ihex" in formats.formats:
        parser.add_argument("--base-address", type=positive_int, default=0, metavar="ADDR",
                            help="with --format ihex: address of the first byte, "
                                 "0..0xFFFFFFFF (default 0)")


def file_format(args: argparse.Namespace, formats: Any, provenance: Any, *,
                default: str = "text", c_default: str = "stepramp") -> tuple[str, Any]:
    """The format the options (or OUT's extension) ask for and its `RenderOptions`;
    --name and --base-address are refused for formats they do not apply to."""
    from profiles.errors import FormatError
    from profiles.formats import RenderOptions, c_name_for

    fmt = formats.get(args.format or getattr(formats.for_path(args.output), "name",
                                             default)).name
    base_address = getattr(args, "base_address", 0)
    if args.name is not None and fmt != "c":
        raise FormatError(f"--name names the symbols of a C header; the format is {fmt}")
    if base_address and fmt != "ihex":
        raise FormatError(f"--base-address places Intel HEX data; the format is {fmt}")
    options = RenderOptions(name=args.name if args.name is not None
                            else c_name_for(args.output, c_default),
                            base_address=base_address, provenance=provenance)
    return fmt, options


# Where each command's paths are: the options (by dest) that name files it writes, and the
# arguments that name files it reads. A command whose -o is a folder says so with
# `set_defaults(output_folder=True)`.
OUTPUT_OPTIONS = {"output": "-o", "csv": "--csv", "pulse_times": "--pulse-times",
                  "samples": "--samples", "plot": "--plot"}
INPUT_ARGUMENTS = ("files", "table", "upload", "file", "motor", "motors", "axes", "curve",
                   "moves")


def guard_paths(args: argparse.Namespace) -> None:
    """Refuse a command's unsafe output paths before it reads or writes anything
    (`verify.output.refuse_unsafe_outputs`): -o naming a folder or one of the inputs."""
    from verify.output import refuse_unsafe_outputs

    outputs = [(option, value) for dest, option in OUTPUT_OPTIONS.items()
               if isinstance(value := getattr(args, dest, None), str)]
    inputs: list[str] = []
    for dest in INPUT_ARGUMENTS:
        value = getattr(args, dest, None)
        inputs += [v for v in (value if isinstance(value, list) else [value])
                   if isinstance(v, str)]
    folders = [o for o in outputs if o[0] == "-o"] if getattr(args, "output_folder",
                                                               False) else []
    refuse_unsafe_outputs([o for o in outputs if o not in folders], inputs, folders=folders)


def refuse_table_errors(path: str, table: Any, remedy: str) -> bool:
    """Print the chip-rule errors of `table` (each as `check` states it) and a "refused"
    line on stderr, and say whether there were any: a command that turns a table into
    something the chip runs gives the same verdict as `check` (exit 1), never an error."""
    from profiles.ppmc312.chip_rules import check_table

    errors = [f for f in check_table(table) if f.severity == "error"]
    for f in errors:
        stage = "" if f.stage is None else f" stage {f.stage}"
        code = "" if f.chip_code is None else f" (chip {f.chip_code_hex})"
        print(f"{path}: error [{f.rule}]{stage}{code}: {f.message}", file=sys.stderr)
    if errors:
        print(f"{path}: refused: {len(errors)} error(s); {remedy}", file=sys.stderr)
    return bool(errors)


def command_line(args: argparse.Namespace) -> str:
    """The command line that ran, for the provenance a file carries."""
    return "stepramp " + " ".join(shlex.quote(a) for a in getattr(args, "argv", []))


def render_upload(args: argparse.Namespace, blocks: list[bytes], table: Any = None,
                  motor: str | None = None) -> bytes:
    """The upload file the format options ask for, with its provenance."""
    from profiles.ppmc312.formats import FORMATS, provenance

    fmt, options = file_format(args, FORMATS, provenance(table, command=command_line(args),
                                                         motor=motor))
    return FORMATS.render(blocks, fmt, options)


# --- motion commands (stepramp move, stepramp link move) ---------------------------
# The option that sets each of the registry's parameters (`--high-rate` and `--override`
# are the accel move's older spellings of `--rate` and `--on`).
MOTION_OPTIONS = {"rate": "--rate", "pulses": "--pulses", "ccw": "--ccw", "index": "--index",
           "override_at": "--override-at", "on": "--on"}
MOTION_TRIGGERS = {1: "evt1", 3: "evt2"}  # --override TRG: the TRG bits of an event trigger


def motion_params(args: argparse.Namespace, command: Any, usage: str = "stepramp move"
                  ) -> tuple[dict[str, Any], dict[str, str]]:
    """The registry's parameters the options give, and the option that gave each; an
    option the command does not take, two options for one parameter or a missing one is
    one line naming the option (and `usage`, whose help lists them). `stepramp link move`
    shares it; an option its parser lacks counts as not given."""
    from profiles.errors import FormatError

    given = {"--pulses": args.pulses, "--ccw": args.ccw or None, "--rate": args.rate,
             "--high-rate": args.high_rate, "--index": args.index or None,
             "--override-at": getattr(args, "override_at", None),
             "--on": getattr(args, "on", None),
             "--override": MOTION_TRIGGERS.get(getattr(args, "override", None) or 0)}
    params: dict[str, Any] = {}
    typed: dict[str, str] = {}
    for option, value in given.items():
        if value is None:
            continue
        param = {"--high-rate": "rate", "--override": "on"}.get(option, option[2:]
                                                                 .replace("-", "_"))
        if param not in command.takes or (option == "--high-rate"
                                          and command.rate_field != "high_rate"):
            raise FormatError(f"{option}: {command.label} does not take it "
                              f"({motion_takes(command, args)})")
        exclusive = {"on": "override_at", "override_at": "on"}.get(param, param)
        clash = typed.get(param) or typed.get(exclusive)
        if clash:
            raise FormatError(f"{option}: give {clash} or {option}, not both")
        params[param] = value
        typed[param] = option
    missing = [MOTION_OPTIONS[p] for p in command.needs if p not in params]
    if missing:
        scope = "" if args.motion is None else f" by --command {command.name}"
        raise FormatError(f"the following arguments are required{scope}: "
                          f"{', '.join(missing)} (see {usage} --help)")
    return params, typed


def motion_takes(command: Any, args: argparse.Namespace) -> str:
    # only the options this parser has
    options = [MOTION_OPTIONS[p] for p in MOTION_OPTIONS if p in command.takes and hasattr(args, p)]
    return f"it takes {', '.join(options)}" if options else "it takes no option"


def add_motion_options(p: argparse.ArgumentParser, *, command_help: str, override_at_help: str,
                       on_help: str) -> None:
    """The options that choose a PPMC-312 motion command and its parameters, shared by
    `stepramp move` (its bytes) and `stepramp link move` (sent); `motion_params` reads
    them. The helps that differ say what each command does with a registered form."""
    from profiles.ppmc312.motion import COMMANDS, DEFAULT

    p.add_argument("--command", dest="motion", choices=tuple(COMMANDS), default=None,
                   metavar="NAME",
                   help=f"the motion command{command_help}: " + ", ".join(
                       f"{c.name} ({c.code:02X})" for c in COMMANDS.values())
                   + f" (default {DEFAULT})")
    p.add_argument("--pulses", type=positive_int,
                   help="the move length [pulses] (accel, constant: required), 1..0xFFFFFFFF")
    p.add_argument("--ccw", action="store_true", help="direction CCW (default CW)")
    p.add_argument("--rate", type=positive_int, metavar="R",
                   help="a rate divisor; 0 = the table's high rate where the manual allows "
                        "it (accel, constant, continuous, continuous-constant, origin-return:"
                        " the default there); required by change-speed, set-speed, "
                        "origin-search and high-speed-limit")
    p.add_argument("--high-rate", type=positive_int, metavar="R",
                   help="accel's high-rate override (its name for --rate; 0 = the table's)")
    p.add_argument("--index", action="store_true",
                   help="origin search/return: find /ORG and /INDEX low together (IDX = 1)")
    p.add_argument("--override-at", type=positive_int, metavar="POS",
                   help="stop, decel-stop, change-speed, set-speed: " + override_at_help)
    p.add_argument("--on", choices=("evt1", "evt2"),
                   help="stop, decel-stop, change-speed, set-speed: " + on_help)
