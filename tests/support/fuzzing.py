"""The fuzz campaign's generators: hostile files and command lines for `stepramp`,
run in-process and held to the CLI's contract.

Every case runs `verify.cli.main(argv)` on a mutated input file (tables, motors, upload
files in each format, table-read answers, MC-200 packet files, A-Link settings, axes
files, duty-cycle and vendor-curve CSVs) or a mutated command line, and `judge` lists
every way it breaks the contract:
- the exit code is 0, 1 or 2;
- no traceback and no "internal error" (the error contract's catch-all: a bug);
- exit 2 prints exactly one line on stderr, naming the command;
- after exit 2, no output file and no temp file is left behind (check's report excepted:
  it is written on exit 2 too, naming the unusable file);
- `check` on a free-curve table gives the verdict of a plain re-statement of the chip's
  rules written here (exit 1 exactly when one is broken);
- an answer within `CASE_TIMEOUT_S` (a hostile input must not buy unbounded work).

Every command of `verify.cli.COMMANDS` has templates here (`covered_commands`;
tests/contract/test_fuzz.py checks it: a new command needs its templates here). The
planner-bound ones (sync, plan, compare, sweep, a motor's plan) are in the HEAVY lists.
Every choice a case makes (the template, the edits, the hostile values) is drawn from
the `rnd` it is given: hypothesis's `st.randoms()` (`file_cases`, `argv_cases`), so a
failing case shrinks and replays from hypothesis's database. The campaign is
tests/contract/test_fuzz.py under the `fuzz` hypothesis profile (tests/conftest.py).
"""

from __future__ import annotations

import contextlib
import io
import json
import os
import random
import re
import shutil
import signal
import sys
import tempfile
import threading
from collections.abc import Callable, Iterator
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

from hypothesis import strategies as st

from tests.support.paths import ROOT

EXAMPLES = ROOT / "examples"
MOTORS = sorted((ROOT / "profiles" / "data").glob("motor-*.json"))
CASE_TIMEOUT_S = 120.0  # a case that runs longer is a problem ("no answer")

# Values a hostile JSON number or option can take.
NUMBERS = ["0", "-1", "1", "2", "255", "256", "65535", "65536", "1048575", "1048576",
           "4294967295", "4294967296", "18446744073709551616", "1e308", "-1e308", "1e-320",
           "1.5", "0.0", "-0", "1e999", "NaN", "Infinity", "1" * 50, "1" * 4301,
           '"12"', "null", "true", "[]", "{}"]
OPTION_VALUES = ["0", "1", "-1", "3", "30", "31", "0x10", "1e-9", "1e9", "nan", "inf", "-inf",
                 "", "-", "abc", "1" * 30, "4294967296", "65535", "8MHz", "EXTCK", "15.625kHz"]
PATH_NAMES = ["", "-", "/dev/zero", "/dev/null", "/", "missing.json",
              os.fsdecode(b"odd\xff.json"), "a" * 300]


@dataclass
class Outcome:
    command: str
    argv: list[str]
    code: int
    out: str
    err: str
    problems: list[str] = field(default_factory=list)


def seeds() -> dict[str, bytes]:
    """Valid inputs of every kind, made with the CLI itself (so they follow its formats)."""
    out: dict[str, bytes] = {
        "table-free": (EXAMPLES / "free-curve-nema17.json").read_bytes(),
        "table-bad": (EXAMPLES / "free-curve-bad.json").read_bytes(),
        "table-init": (EXAMPLES / "init-linear.json").read_bytes(),
        "table-read": (EXAMPLES / "free-curve-nema17.read.hex").read_bytes(),
        "motor": MOTORS[0].read_bytes(),
        "mix": (EXAMPLES / "duty-cycle.csv").read_bytes(),
        "curve": (EXAMPLES / "curve-example.csv").read_bytes(),
        # motors by absolute path: the case's file lives in a temporary folder
        "axes-alink": json.dumps({"format": "stepramp.axes/1", "mode": "line",
                                  "device": "alink", "axes": [
                                      {"name": "a", "motor": str(MOTORS[0]), "pulses": 4000},
                                      {"name": "b", "motor": str(MOTORS[0]), "pulses": -1500}]},
                                 indent=1).encode(),
        "axes-ppmc": json.dumps({"format": "stepramp.axes/1", "mode": "time", "axes": [
            {"name": "x", "motor": str(MOTORS[0]), "pulses": 3000},
            {"name": "y", "motor": str(MOTORS[-1]), "pulses": -1200}]}, indent=1).encode(),
    }
    with tempfile.TemporaryDirectory() as tmp:
        for fmt in ("hex", "bin", "json", "c", "bus"):
            target = Path(tmp) / f"u.{fmt}"
            run_cli(["export", str(EXAMPLES / "free-curve-nema17.json"), "--format", fmt,
                     "-o", str(target)])
            if target.exists():
                out[f"upload-{fmt}"] = target.read_bytes()
        target = Path(tmp) / "init.hex"
        run_cli(["export", str(EXAMPLES / "init-linear.json"), "-o", str(target)])
        out["upload-init"] = target.read_bytes()
        for fmt in ("hex", "bin", "json", "c", "ihex"):
            target = Path(tmp) / f"s.{fmt}"
            run_cli(["mc200", "stream", "--vmax", "20000", "--amax", "200000", "--jmax",
                     "5000000", "--pulses", "400", "--period-us", "1000", "--format", fmt,
                     "-o", str(target)])
            if target.exists():
                out[f"mc200-{fmt}"] = target.read_bytes()
        # the guide's stream and the driver's replies to it (mc200 follow)
        out["mc200-guide"] = (EXAMPLES / "move.mc200.hex").read_bytes()
        out["mc200-replies"] = (EXAMPLES / "move.mc200.replies.hex").read_bytes()
        for fmt in ("text", "json", "hex", "c"):
            target = Path(tmp) / f"a.{fmt}"
            run_cli(["alink", "settings", "--start-pps", "500", "--high-pps", "10000",
                     "--accel-ms-per-kpps", "20", "--address", "3", "--format", fmt,
                     "-o", str(target)])
            if target.exists():
                out[f"alink-{fmt}"] = target.read_bytes()
        target = Path(tmp) / "homing.txt"
        run_cli(["alink", "homing", "--motor", str(MOTORS[0]), "-o", str(target)])
        out["alink-homing"] = target.read_bytes()
    out["alink-list"] = _alink_list()
    return out


def _alink_list() -> bytes:
    """A command list `check` judges by the unit's answers: homing, a soft limit, moves,
    a speed change, a delay (the words as `alink command` writes them, in a hex file)."""
    from profiles.alink import encode_command
    from profiles.alink.formats import render

    spec = [("ol-speed", 200, None), ("oh-speed", 800, None), ("home", None, 1),
            ("read-stat", 0, None), ("setting", 10000, 30), ("move-a", 5000, None),
            ("change-speed", 3000, None), ("read-stat", 9, None), ("delay", 20, None),
            ("read-stat", 0, None), ("move-r", -1000, None)]
    commands = [encode_command(name, value, nn, pair=k % 3 + 1)
                for k, (name, value, nn) in enumerate(spec)]
    return render(commands, "hex")


# --- mutations -----------------------------------------------------------------------
def mutate(data: bytes, rnd: random.Random) -> bytes:
    """One to three random edits: bit flips, bytes set, cut, repeated or spliced, and for
    text, numbers replaced by hostile ones or nesting deepened."""
    for _ in range(rnd.randint(1, 3)):
        data = rnd.choice(_MUTATIONS)(bytearray(data), rnd)
    return bytes(data)


def _flip(d: bytearray, rnd: random.Random) -> bytes:
    if d:
        d[rnd.randrange(len(d))] ^= 1 << rnd.randrange(8)
    return bytes(d)


def _set_byte(d: bytearray, rnd: random.Random) -> bytes:
    if d:
        d[rnd.randrange(len(d))] = rnd.choice([0, 0xFF, 0x80, 0x7F, ord("{"), ord("["),
                                               ord('"'), rnd.randrange(256)])
    return bytes(d)


def _cut(d: bytearray, rnd: random.Random) -> bytes:
    if not d:
        return b""
    i = rnd.randrange(len(d))
    j = min(len(d), i + rnd.randint(1, 64))
    return bytes(d[:i] + d[j:]) if rnd.random() < 0.7 else bytes(d[:i])


def _repeat(d: bytearray, rnd: random.Random) -> bytes:
    if not d:
        return b""
    i = rnd.randrange(len(d))
    j = min(len(d), i + rnd.randint(1, 64))
    return bytes(d[:j] + d[i:j] * rnd.randint(1, 8) + d[j:])


def _splice(d: bytearray, rnd: random.Random) -> bytes:
    junk = rnd.choice([b"\x00", b"\xff\xfe", "é".encode(), b"\n", b",", b"-", b"0x",
                       bytes(rnd.randrange(256) for _ in range(rnd.randint(1, 16)))])
    i = rnd.randrange(len(d) + 1)
    return bytes(d[:i] + junk + d[i:])


_NUMBER = re.compile(rb"-?\d+(?:\.\d+)?(?:[eE][-+]?\d+)?")


def _number(d: bytearray, rnd: random.Random) -> bytes:
    spans = [m.span() for m in _NUMBER.finditer(d)]
    if not spans:
        return bytes(d)
    i, j = rnd.choice(spans)
    return bytes(d[:i] + rnd.choice(NUMBERS).encode() + d[j:])


def _deepen(d: bytearray, rnd: random.Random) -> bytes:
    n = rnd.choice([10, 63, 64, 65, 1000, 100_000])
    i = rnd.randrange(len(d) + 1)
    return bytes(d[:i] + b"[" * n + b"1" + b"]" * n + d[i:])


_MUTATIONS: list[Callable[[bytearray, random.Random], bytes]] = [
    _flip, _flip, _set_byte, _cut, _repeat, _splice, _number, _number, _deepen]


# --- running the CLI in-process -----------------------------------------------------
class _Stdout(io.TextIOWrapper):
    def __init__(self) -> None:
        super().__init__(io.BytesIO(), encoding="utf-8", errors="strict", write_through=True)

    def text(self) -> str:
        self.flush()
        raw = self.buffer.getvalue()  # type: ignore[attr-defined]
        return raw.decode("utf-8", "backslashreplace")


class CaseTimeout(BaseException):
    """A case ran past its time budget (raised by SIGALRM, unwinding like Ctrl-C)."""


TIMED_OUT = -2  # the exit code run_cli reports for a case stopped by its budget


def run_cli(argv: list[str], timeout_s: float | None = None) -> tuple[int, str, str]:
    """`main(argv)` in-process with captured output; with `timeout_s`, stopped after that
    long (main thread only: SIGALRM)."""
    from verify.cli import main

    out, err = _Stdout(), _Stdout()
    stdin = io.TextIOWrapper(io.BytesIO(b""), encoding="utf-8")
    saved = sys.stdout, sys.stderr, sys.stdin
    sys.stdout, sys.stderr, sys.stdin = out, err, stdin
    timed = timeout_s is not None and threading.current_thread() is threading.main_thread()

    def alarm(_signum: int, _frame: object) -> None:
        raise CaseTimeout

    previous = signal.signal(signal.SIGALRM, alarm) if timed else None
    if timed:
        signal.setitimer(signal.ITIMER_REAL, float(timeout_s or 0))
    try:
        with _no_server(argv):
            code = main(argv)
    except SystemExit as e:  # main must not exit; report it as a problem below
        code = -1 if not isinstance(e.code, int) else 100 + e.code
    except CaseTimeout:
        code = TIMED_OUT
    finally:
        if timed:
            signal.setitimer(signal.ITIMER_REAL, 0)
            signal.signal(signal.SIGALRM, previous)
        sys.stdout, sys.stderr, sys.stdin = saved
    return code, out.text(), err.text()


@contextlib.contextmanager
def _no_server(argv: list[str]) -> Iterator[None]:
    """`design` checks every input, then serves its page until stopped: a case stops
    where the server would start (the page itself is tests/verify/designer/test_web.py's)."""
    if not argv or argv[0] != "design":
        yield
        return
    import verify.designer.web as web

    saved = web.serve
    web.serve = lambda *args, **kwargs: None
    try:
        yield
    finally:
        web.serve = saved


def judge(command: str, argv: list[str], folder: Path, before: set[str],
          expect: int | None = None) -> Outcome:
    """Run one case and list every way it breaks the contract."""
    code, out, err = run_cli(argv, CASE_TIMEOUT_S)
    o = Outcome(command, argv, code, out, err)
    if code == TIMED_OUT:
        o.problems.append(f"no answer within {CASE_TIMEOUT_S:g} s")
    elif code not in (0, 1, 2):
        o.problems.append(f"exit code {code}")
    if "Traceback" in err or "Traceback" in out:
        o.problems.append("traceback")
    if "internal error" in err:
        o.problems.append("internal error: " + err.strip()[:200])
    if code == 2:
        lines = err.splitlines()
        if len(lines) != 1:
            o.problems.append(f"exit 2 with {len(lines)} lines on stderr")
        elif not lines[0].startswith("stepramp" if command == "usage"
                                     else f"stepramp {command.split()[0]}"):
            o.problems.append(f"error line does not name the command: {lines[0][:80]}")
        # (check's report is the one output written on exit 2: it says which file was
        # unusable, e.g. as a JUnit <error>)
        left = sorted(n for n in set(os.listdir(folder)) - before
                      if not (command.startswith("check") and n == "out.txt"))
        if left:
            o.problems.append(f"exit 2 left files behind: {left}")
    if code in (0, 1):  # temp files, also in an output folder (sync's)
        hidden = [str(p.relative_to(folder)) for p in folder.rglob(".*")
                  if p.name not in before]
        if hidden:
            o.problems.append(f"temp files left: {hidden}")
    if expect is not None and code in (0, 1) and code != expect:
        o.problems.append(f"verdict {code}, the plain rules say {expect}")
    return o


# --- a plain statement of the free-curve rules (the verdict oracle) ------------------
def plain_verdict(raw: bytes) -> int | None:
    """1 if a free-curve table JSON breaks a chip rule, 0 if not, None if it is not a
    well-formed free-curve table (then only the contract is judged)."""
    try:
        doc = json.loads(raw)
    except (ValueError, RecursionError):
        return None
    if not isinstance(doc, dict) or doc.get("kind") != "free_curve":
        return None
    clock = {"8MHz": 8e6, "1MHz": 1e6, "500kHz": 5e5, "250kHz": 2.5e5, "62.5kHz": 62500.0,
             "15.625kHz": 15625.0}.get(doc.get("clock"))  # type: ignore[arg-type]
    rates, acc, dec = doc.get("rates"), doc.get("accel_pulses"), doc.get("decel_pulses")
    lists = [x for x in (rates, acc, dec) if x is not None]
    if clock is None or set(doc) - {"format", "device", "kind", "clock", "rates",
                                    "accel_pulses", "decel_pulses"} or doc.get(
            "format") != "stepramp.table/1" or doc.get("device") != "ppmc312":
        return None
    if not all(isinstance(x, list) and all(type(v) is int and 0 <= v <= 0xFFFFFF for v in x)
               for x in lists) or rates is None or acc is None:
        return None
    if any(v > 0xFFFF for v in rates) or len(rates) != max(len(acc), len(dec or [])) or any(
            len(x) > 255 for x in lists):
        return None
    sides = [acc] + ([dec] if dec is not None else [])
    broken = any(not 2 <= len(s) <= 127 for s in sides)
    broken |= any(r <= 1 or clock / r > 2e6 for r in rates)
    for s in sides:
        broken |= any(p <= 1 or p > 0xFFFFF for p in s) or sum(s) > 0xFFFFF
        broken |= any(p * r < 256 and p > 1 and r > 1 for p, r in zip(s, rates, strict=False))
    return int(broken)


# --- cases ------------------------------------------------------------------------------
FILE_COMMANDS: list[tuple[str, str, list[str]]] = [
    # (command label, seed kind, argv template: FILE and OUT are filled in)
    ("check", "table-free", ["check", "FILE"]),
    ("check", "table-bad", ["check", "FILE", "--format", "json"]),
    ("check", "table-init", ["check", "FILE", "--format", "junit", "-o", "OUT"]),
    ("check", "upload-hex", ["check", "FILE"]),
    ("check", "upload-bin", ["check", "FILE"]),
    ("check", "upload-json", ["check", "FILE"]),
    ("check", "upload-c", ["check", "FILE"]),
    ("check", "upload-init", ["check", "FILE"]),
    # (--no-physics: the load-angle judge of an odd but valid motor can run for minutes,
    # which is its business, not the contract's)
    ("check --motor", "motor", ["check", "EXAMPLE", "--motor", "FILE", "--no-physics"]),
    ("design", "motor", ["design", "--motor", "FILE", "--port", "0", "--no-browser"]),
    ("export", "table-free", ["export", "FILE", "-o", "OUT"]),
    ("export", "table-init", ["export", "FILE", "--format", "json", "-o", "OUT"]),
    ("decode", "upload-hex", ["decode", "FILE", "-o", "OUT"]),
    ("decode", "upload-bin", ["decode", "FILE"]),
    ("decode", "upload-init", ["decode", "FILE"]),
    ("decode --table-read", "table-read", ["decode", "FILE", "--table-read", "--clock", "8MHz"]),
    ("expand", "table-init", ["expand", "FILE", "-o", "OUT"]),
    ("simulate", "table-free", ["simulate", "FILE", "--pulses", "5000", "--csv", "OUT"]),
    ("simulate", "table-init", ["simulate", "FILE", "--pulses", "3000", "--format", "json"]),
    ("mc200 decode", "mc200-hex", ["mc200", "decode", "FILE", "--format", "json"]),
    ("mc200 decode", "mc200-bin", ["mc200", "decode", "FILE", "--direction", "host"]),
    ("mc200 decode", "mc200-c", ["mc200", "decode", "FILE"]),
    ("mc200 decode", "mc200-ihex", ["mc200", "decode", "FILE", "--format", "json"]),
    ("check", "mc200-json", ["check", "FILE"]),
    ("mc200 follow", "mc200-replies", ["mc200", "follow", "MC200STREAM", "FILE", "--period-us",
                                       "1000"]),
    ("mc200 follow", "mc200-guide", ["mc200", "follow", "FILE", "MC200REPLIES", "--period-us",
                                     "1000", "--format", "json"]),
    ("check", "mc200-bin", ["check", "FILE", "--format", "json"]),
    ("check", "alink-hex", ["check", "FILE"]),
    ("check", "alink-json", ["check", "FILE"]),
    ("alink read", "alink-text", ["alink", "read", "FILE"]),
    ("alink read", "alink-c", ["alink", "read", "FILE", "--format", "json"]),
    ("check", "alink-list", ["check", "FILE"]),
    ("alink read", "alink-homing", ["alink", "read", "FILE"]),
    ("alink homing", "motor", ["alink", "homing", "--motor", "FILE", "--format", "json"]),
    ("simulate", "alink-text", ["simulate", "FILE", "--pulses", "3000", "--pulse-times",
                                "OUT"]),
    ("check --motor", "alink-json", ["check", "FILE", "--motor", "nema17-1600",
                                     "--samples", "0"]),
    ("check --motor", "alink-hex", ["check", "FILE", "--motor", "nema17-1600",
                                    "--samples", "0", "--commands", "stop,limit"]),
    ("show", "table-free", ["show", "FILE", "--format", "json"]),
    ("show", "table-init", ["show", "FILE", "--format", "csv", "-o", "OUT"]),
    ("show --motor", "motor", ["show", "EXAMPLE", "--motor", "FILE"]),
    ("motor new", "curve", ["motor", "new", "--curve", "FILE", "--speed-unit", "rpm",
                            "--torque-unit", "oz-in", "--rotor-inertia-gcm2", "50", "-o", "OUT"]),
    ("motor check", "motor", ["motor", "check", "FILE"]),
    ("link init", "table-init", ["link", "--port", "loop://", "--address", "1", "--timeout-s",
                                 "0.01", "--retries", "0", "init", "FILE"]),
]

# planner-bound: each valid case plans (seconds); the slow tests and the campaign run them
HEAVY_FILE_COMMANDS: list[tuple[str, str, list[str]]] = [
    ("sync", "axes-alink", ["sync", "FILE", "-o", "OUTDIR", "--no-ruckig"]),
    ("sync", "axes-ppmc", ["sync", "FILE", "-o", "OUTDIR", "--no-ruckig", "--format", "json"]),
    ("plan --moves", "mix", ["plan", "--motor", "MOTOR", "--moves", "FILE", "--max-stages",
                             "12", "-o", "OUT"]),
    ("plan", "motor", ["plan", "--motor", "FILE", "--pulses", "3000", "--max-stages", "12"]),
    ("compare", "table-free", ["compare", "FILE", "--motor", "MOTOR", "--pulses", "3000",
                               "--references", "ruckig", "--no-physics"]),
    ("sweep", "motor", ["sweep", "--motors", "FILE", "--pulses", "3000", "--samples", "0",
                        "-o", "OUT"]),
    ("alink settings --motor", "motor", ["alink", "settings", "--motor", "FILE", "--pulses",
                                         "4000", "-o", "OUT"]),
]

ARGV_TEMPLATES: list[tuple[str, list[str]]] = [
    ("check", ["check", "EXAMPLE", "--extck-hz", "V"]),
    ("check", ["check", "PATH"]),
    ("check --motor", ["check", "EXAMPLE", "--motor", "PATH", "--no-physics"]),
    ("export", ["export", "EXAMPLE", "--format", "hex", "--max-block-data", "V", "-o", "OUT"]),
    ("export", ["export", "INIT", "--to", "ascii", "--address", "V"]),
    ("export", ["export", "EXAMPLE", "-o", "PATH"]),
    ("decode", ["decode", "PATH"]),
    ("decode --table-read", ["decode", "READ", "--table-read", "--clock", "V", "--extck-hz",
                             "V"]),
    ("move", ["move", "--pulses", "V", "--high-rate", "V"]),
    ("move", ["move", "--pulses", "V", "--to", "ascii", "--address", "V"]),
    ("expand", ["expand", "PATH"]),
    ("answer", ["answer", "V", "V", "V"]),
    ("answer", ["answer", "--serial", "V", "--format", "V"]),
    ("answer", ["answer", "--file", "PATH"]),
    ("move --command", ["move", "--command", "V", "--rate", "V", "--pulses", "V"]),
    ("simulate", ["simulate", "EXAMPLE", "--pulses", "V", "--high-rate", "V"]),
    ("alink decode", ["alink", "decode", "V", "V", "V"]),
    ("alink decode --command", ["alink", "decode", "--command", "V", "V", "V"]),
    ("alink command", ["alink", "command", "ALINKCMD", "--value", "V"]),
    ("alink command", ["alink", "command", "ALINKCMD", "--nn", "V", "--pair", "V"]),
    ("alink command", ["alink", "command", "ALINKCMD", "--value", "V", "--address", "V",
                       "--format", "V", "-o", "PATH"]),
    ("alink homing", ["alink", "homing", "--motor", "PATH", "--max-pps", "V"]),
    ("alink homing", ["alink", "homing", "--motor", "MOTOR", "--max-pps", "V", "--address",
                      "V"]),
    ("alink settings", ["alink", "settings", "--start-pps", "V", "--high-pps", "V",
                        "--accel-ms-per-kpps", "V"]),
    # (limits kept where a stream stays small: a slow move at a short period is
    # legitimately millions of packets, a benchmark's job, not a fuzz case's)
    ("mc200 stream", ["mc200", "stream", "--vmax", "VMAX", "--amax", "200000", "--jmax",
                      "5000000", "--pulses", "400", "--period-us", "PERIOD"]),
    ("mc200 stream", ["mc200", "stream", "--vmax", "20000", "--amax", "200000", "--jmax",
                      "5000000", "--pulses", "400", "--period-us", "PERIOD", "--mode", "V",
                      "--din", "V", "--magic", "V"]),
    ("mc200 stream", ["mc200", "stream", "--motor", "MOTOR", "--vmax", "20000", "--amax",
                      "200000", "--jmax", "5000000", "--pulses", "400", "--period-us", "1000",
                      "--mode", "current", "--torque-constant-nm-per-a", "V"]),
    ("mc200 decode", ["mc200", "decode", "PATH"]),
    ("mc200 decode", ["mc200", "decode", "MC200STREAM", "--magic", "V"]),
    ("mc200 follow", ["mc200", "follow", "MC200STREAM", "MC200REPLIES", "--period-us", "PERIOD",
                      "--magic", "V"]),
    ("mc200 follow", ["mc200", "follow", "PATH", "MC200REPLIES", "--plot", "PATH"]),
    ("usage", ["V", "V"]),
    ("usage", ["check"]),
    ("usage", ["export", "EXAMPLE", "--format", "V"]),
    ("show", ["show", "PATH", "-o", "PATH"]),
    ("move", ["move", "--pulses", "V", "-o", "PATH"]),
    ("plan", ["plan", "--motor", "PATH"]),
    ("plan --moves", ["plan", "--motor", "MOTOR", "--moves", "PATH"]),
    ("compare", ["compare", "PATH", "--motor", "MOTOR", "--pulses", "V"]),
    ("sync", ["sync", "PATH", "-o", "OUTDIR"]),
    ("sweep", ["sweep", "--motors", "PATH", "--pulses", "V", "-o", "OUT"]),
    ("motor new", ["motor", "new", "--microstep", "V", "--phases", "V", "--rotor-inertia-gcm2",
                   "V", "--curve", "CURVE", "--speed-unit", "rpm", "--torque-unit", "oz-in"]),
    ("motor check", ["motor", "check", "PATH"]),
    ("link", ["link", "--port", "V", "--address", "V", "--timeout-s", "0.01", "--retries",
              "0", "poll"]),
    # no chip on the loop port: a good request times out (exit 2), a bad one is refused first
    ("link move --command", ["link", "--port", "loop://", "--address", "1", "--timeout-s",
                             "0.01", "--retries", "0", "move", "--command", "V", "--rate", "V",
                             "--pulses", "V"]),
    ("emulate", ["emulate", "--address", "V"]),           # without --pty: a usage error
    ("emulate", ["emulate", "--pty", "--address", "BADADDR"]),
    ("emulate", ["emulate", "--pty", "--origin-at", "V", "--address", "BADADDR"]),
    ("emulate", ["emulate", "--bus", "PATH", "--origin-at", "V"]),  # --pty's option
    # design serves until Ctrl-C once its options are good: the port is never a usable one
    ("design", ["design", "--motor", "PATH", "--pulses", "V", "--port", "BADPORT",
                "--no-browser"]),
    ("design", ["design", "--motor", "MOTOR", "--port", "V", "--pulses", "V", "--no-browser"]),
]

HEAVY_ARGV_TEMPLATES: list[tuple[str, list[str]]] = [
    ("sync", ["sync", "AXES", "-o", "PATH", "--no-ruckig"]),
    ("sweep", ["sweep", "--motors", "MOTOR", "--pulses", "V", "--samples", "0", "--load-angle",
               "V", "-o", "OUT"]),
    ("plan", ["plan", "--motor", "MOTOR", "--kind", "linear", "--pulses", "V", "--clock", "V"]),
    ("plan", ["plan", "--motor", "MOTOR", "--kind", "s-curve", "--pulses", "V", "--commands",
              "V", "--load-angle", "V"]),
]


def covered_commands() -> set[str]:
    """The commands the templates run (the first word of each label; usage aside)."""
    labels = [c[0] for c in (*FILE_COMMANDS, *HEAVY_FILE_COMMANDS)] + [
        t[0] for t in (*ARGV_TEMPLATES, *HEAVY_ARGV_TEMPLATES)]
    return {label.split()[0] for label in labels} - {"usage"}


_SUFFIX = {"hex": ".hex", "bin": ".bin", "c": ".h", "bus": ".txt", "read": ".hex",
           "guide": ".hex", "replies": ".hex",
           "list": ".hex", "homing": ".txt",
           "init": ".hex", "mix": ".csv", "curve": ".csv"}


def file_case(rnd: random.Random, seed_data: dict[str, bytes], folder: Path,
              index: int | None = None,
              commands: list[tuple[str, str, list[str]]] | None = None) -> Outcome:
    commands = FILE_COMMANDS if commands is None else commands
    label, kind, template = commands[rnd.randrange(len(commands)) if index is None else index]
    raw = seed_data[kind]
    roll = rnd.random()
    if roll < 0.45 and raw.lstrip()[:1] == b"{":  # numbers only: the JSON stays valid
        for _ in range(rnd.randint(1, 2)):
            raw = _number(bytearray(raw), rnd)
    elif roll < 0.95:
        raw = mutate(raw, rnd)
    path = folder / ("input" + _SUFFIX.get(kind.rsplit("-", 1)[-1], ".json"))
    path.write_bytes(raw)
    argv = [_fill(a, folder, path) for a in template]
    before = set(os.listdir(folder))
    expect = plain_verdict(raw) if template[:2] == ["check", "FILE"] and kind.startswith(
        "table") and "--motor" not in template else None
    outcome = judge(label, argv, folder, before, expect)
    path.unlink()
    _clean(folder)
    return outcome


def argv_case(rnd: random.Random, folder: Path, index: int | None = None,
              templates: list[tuple[str, list[str]]] | None = None) -> Outcome:
    templates = ARGV_TEMPLATES if templates is None else templates
    label, template = templates[rnd.randrange(len(templates)) if index is None else index]
    argv = []
    for a in template:
        if a == "V":
            argv.append(rnd.choice(OPTION_VALUES))
        elif a == "BADADDR":  # emulate --pty with a valid address serves until Ctrl-C
            argv.append(rnd.choice(["16", "99", "-1", "abc", "", "0x100"]))
        elif a == "BADPORT":  # design with a usable port serves until Ctrl-C
            argv.append(rnd.choice(["-1", "65536", "abc", "", "1e3", "0x1FFFF"]))
        elif a == "ALINKCMD":  # every command of §11 by name, and names that are none
            from profiles.alink.commands import COMMANDS

            argv.append(rnd.choice([*COMMANDS, "MOVE_A", "move_a", "", "x" * 300]))
        elif a == "VMAX":
            argv.append(rnd.choice(["1e-9", "0", "-1", "nan", "inf", "", "20000", "1e9"]))
        elif a == "PERIOD":
            argv.append(rnd.choice(["1000", "10", "9.99", "1000001", "nan", "0", "-5", "x"]))
        elif a == "PATH":
            name = rnd.choice([*PATH_NAMES, str(folder)])
            # relative names live in the case's folder, never in the working directory
            relative = name not in ("", "-") and not name.startswith("/")
            argv.append(str(folder / name) if relative else name)
        else:
            argv.append(_fill(a, folder, None))
    before = set(os.listdir(folder))
    outcome = judge(label, argv, folder, before)
    _clean(folder)
    return outcome


def _fill(a: str, folder: Path, path: Path | None) -> str:
    return {"FILE": str(path), "OUT": str(folder / "out.txt"),
            "OUTDIR": str(folder / "out"),
            "EXAMPLE": str(EXAMPLES / "free-curve-nema17.json"),
            "INIT": str(EXAMPLES / "init-linear.json"),
            "READ": str(EXAMPLES / "free-curve-nema17.read.hex"),
            "MOTOR": str(MOTORS[0]), "CURVE": str(EXAMPLES / "curve-example.csv"),
            "AXES": str(EXAMPLES / "axes-alink.json"),
            "MC200STREAM": str(EXAMPLES / "move.mc200.hex"),
            "MC200REPLIES": str(EXAMPLES / "move.mc200.replies.hex")}.get(a, a)


def _clean(folder: Path) -> None:
    for p in folder.iterdir():
        with contextlib.suppress(OSError):
            if p.is_dir() and not p.is_symlink():
                shutil.rmtree(p)
            else:
                p.unlink()


@contextlib.contextmanager
def case_folder() -> Iterator[Path]:
    """A temporary folder, also the working directory while it lasts: whatever a case
    writes by a relative name lands in it, never beside the repository."""
    with tempfile.TemporaryDirectory(prefix="stepramp-fuzz-") as tmp:
        folder = Path(tmp)
        before = os.getcwd()
        os.chdir(folder)
        try:
            yield folder
        finally:
            os.chdir(before)


# --- hypothesis strategies and the campaign's summary ------------------------------------
ALL_FILE_COMMANDS = FILE_COMMANDS + HEAVY_FILE_COMMANDS
ALL_ARGV_TEMPLATES = ARGV_TEMPLATES + HEAVY_ARGV_TEMPLATES


def case_randoms() -> st.SearchStrategy[random.Random]:
    """The source of a case's choices: hypothesis's own, so a case shrinks and replays."""
    return st.randoms(use_true_random=False)


SUMMARY_ENV = "STEPRAMP_FUZZ_SUMMARY"  # where the campaign writes its summary, if set
SUMMARY_COMMAND = ("HYPOTHESIS_PROFILE=fuzz STEPRAMP_FUZZ_SUMMARY=reports/fuzz.json "
                   "python -m pytest -p no:tests.support.repo_clean -q "
                   "tests/contract/test_fuzz.py")


class Tally:
    """Every case a test module ran, by command and exit code, and the contract's breaks."""

    def __init__(self) -> None:
        self.counts: dict[str, dict[str, int]] = {}
        self.load_before = os.getloadavg()[0]

    def add(self, outcome: Outcome) -> None:
        c = self.counts.setdefault(outcome.command, {})
        for key in ("cases", f"exit {outcome.code}") + (("problems",) if outcome.problems
                                                        else ()):
            c[key] = c.get(key, 0) + 1

    def document(self, seconds: float, examples: int) -> dict[str, Any]:
        """The summary in the README generator's format (bench/readme.py)."""
        import datetime as dt
        import platform

        import hypothesis

        rows, total = [], {"cases": 0, "exit 0": 0, "exit 1": 0, "exit 2": 0, "problems": 0}
        for name in sorted(self.counts):
            c = self.counts[name]
            for key in total:
                total[key] += c.get(key, 0)
            rows.append([name, *(str(c.get(k, 0)) for k in total)])
        rows.append(["**all**", *(str(v) for v in total.values())])
        note = (f"{total['cases']} cases in {seconds:.0f} s: hypothesis {hypothesis.__version__}, "
                f"profile fuzz, {examples} examples a template (readers on mutated and random "
                "bytes too, not counted here).")
        return {"name": "fuzz", "command": SUMMARY_COMMAND,
                "measured_at": dt.datetime.now(dt.UTC).isoformat(timespec="seconds"),
                "machine": {"cpus": os.cpu_count(), "python": platform.python_version(),
                            "load_avg_before": round(self.load_before, 2),
                            "load_avg_after": round(os.getloadavg()[0], 2),
                            "note": "2-core machine shared with other sessions"},
                "values": {"examples": examples, "seconds": round(seconds),
                           "per_command": self.counts},
                "sections": {"campaign": {
                    "columns": ["command", "cases", "exit 0", "exit 1", "exit 2",
                                "contract broken"], "rows": rows, "note": note}}}

    def write(self, path: Path, seconds: float, examples: int) -> None:
        """`path`, whole or not at all."""
        text = json.dumps(self.document(seconds, examples), indent=1, ensure_ascii=False)
        path.parent.mkdir(parents=True, exist_ok=True)
        fd, tmp = tempfile.mkstemp(dir=path.parent, prefix=f".{path.name}.", suffix=".tmp")
        with os.fdopen(fd, "w", encoding="utf-8") as f:
            f.write(text + "\n")
        os.replace(tmp, path)
