"""`stepramp check` for stepramp's own documents that no device runs (each device's own
files are its judge's: verify/devices), and the one line naming the command that reads a
file `check` cannot judge.

- an axes file (`stepramp.axes/1`): a set of tables (`simulate --axes`) is judged like
  sync's output: each table's chip rules, then the finish spread of their moves from one
  trigger against its tolerance; a set of motors (`sync`) is judged by loading them;
  both at once is a file neither command runs;
- a sync report (`stepramp.sync-report/1`): the problems it records (a finish spread
  beyond its tolerance, an unsafe axis), sync's own exit 1;
- a motor file (`stepramp.motor/1`): the problems `stepramp motor check` names.
"""

from __future__ import annotations

import re
from collections.abc import Callable
from pathlib import Path
from typing import TYPE_CHECKING, Any

from profiles.errors import FormatError
from profiles.findings import Finding

from .report import FileResult

if TYPE_CHECKING:
    from profiles.axes import AxesFile

    from .check_options import CheckOptions

Judge = Callable[[bytes, str, "CheckOptions"], FileResult]


def judge_of(fmt: str | None) -> Judge | None:
    """The judge of a stepramp document of this "format" that no device runs (None: a
    device's document, or none of stepramp's)."""
    return {"stepramp.axes/1": axes_result, "stepramp.sync-report/1": report_result,
            "stepramp.motor/1": motor_result}.get(fmt or "")


def result(path: str, findings: list[Finding], notes: list[str]) -> FileResult:
    return FileResult(path=path, ok=not any(f.severity == "error" for f in findings),
                      findings=findings, notes=notes)


def axes_result(raw: bytes, path: str, options: CheckOptions) -> FileResult:
    """An axes file: its tables' chip rules and finish spread, or its motors (module)."""
    from profiles.axes import axes_from_json
    from profiles.reading import parse_json

    from .devices import axes_entries

    base = None if path == "-" else Path(path).parent
    axes = axes_from_json(parse_json(raw, path), axes_entries(), base)
    tables = [a for a in axes.axes if a.table_path is not None]
    note = f"axes file: {len(axes.axes)} axes, {axes.mode} mode, device {axes.device}"
    if not tables:
        return result(path, [], [note, "motors to plan: stepramp sync plans them"])
    if len(tables) < len(axes.axes):
        return result(path, [Finding("error", "axes-mixed",
                                     "some axes give motors, others tables: stepramp sync "
                                     "plans from motors, simulate --axes runs tables; "
                                     "neither takes both")], [note])
    findings, spread = table_axes(axes)
    return result(path, findings, [note, spread])


def table_axes(axes: AxesFile) -> tuple[list[Finding], str]:
    """Each table's chip rules (naming its axis) and the finish spread of their moves."""
    from profiles.joint import spread_tolerance_s
    from profiles.ppmc312.chip_rules import check_table
    from profiles.ppmc312.execution import simulate_move
    from profiles.ppmc312.table import load_table

    from .devices import get

    device = get(axes.device)
    if not device.simulates:
        raise FormatError(f"an axes file of {device.title} tables: simulate --axes runs "
                          "PPMC-312 tables only")
    findings: list[Finding] = []
    durations = []
    for a in axes.axes:
        assert a.table_path is not None
        table = load_table(a.table_path)
        found = check_table(table)
        findings += [Finding(f.severity, f.rule, f"axis {a.name}: {f.message}", f.chip_code,
                             f.stage) for f in found]
        if not any(f.severity == "error" for f in found):
            durations.append(simulate_move(table, a.distance).duration_s)
    if len(durations) < len(axes.axes):
        return findings, "finish spread not judged: a table breaks the chip's rules"
    spread, allowed = max(durations) - min(durations), spread_tolerance_s(max(durations))
    if spread > allowed:
        findings.append(Finding("error", "axes-finish-spread",
                                f"the axes finish {spread * 1e6:.3f} µs apart from one "
                                f"trigger, beyond the {allowed * 1e6:.0f} µs allowed"))
    return findings, f"finish spread {spread * 1e6:.3f} µs (allowed {allowed * 1e6:.0f} µs)"


def report_result(raw: bytes, path: str, options: CheckOptions) -> FileResult:
    """A sync report: the problems it records, as sync's exit code says them."""
    from profiles.reading import parse_json

    from .sync.report import report_problems

    report = parse_json(raw, path)
    try:
        problems = report_problems(report)
        note = (f"sync report: {report['device']} {report['mode']} mode, "
                f"{len(report['axes'])} axes, {report['finish_spread_s'] * 1e6:.3f} µs "
                "finish spread")
    except (KeyError, TypeError) as e:
        raise FormatError(f"a sync report (stepramp.sync-report/1) without {e}: it is "
                          "written by stepramp sync") from None
    return result(path, [Finding("error", "sync-report", p) for p in problems], [note])


def motor_result(raw: bytes, path: str, options: CheckOptions) -> FileResult:
    """A motor file: the problems `stepramp motor check` names (schema, rules, loading)."""
    from profiles.motor.schema import problems
    from profiles.reading import parse_json

    obj: Any = parse_json(raw, path)
    found = [Finding("error", "motor-file", f"{where or '/'}: {message}")
             for where, message in problems(obj)]
    name = obj.get("name") if isinstance(obj, dict) else None
    return result(path, found, [f"motor file{f': {name}' if name else ''}"])


# A CSV header: cells of words, no C or JSON punctuation (a broken C upload is no CSV).
_OTHER_CSV = re.compile(r'["A-Za-z_][\w" .()/%-]*(?:[,;\t][\w" .()/%-]*)+')

# Files stepramp writes or reads that `check` does not judge: what each is and which
# command reads it (none: for people, or for CI).
_UNJUDGED: tuple[tuple[Callable[[bytes, str], bool], str], ...] = (
    (lambda raw, head: raw.startswith(b"\x89PNG"),
     "a PNG figure (written by --plot): for people, no stepramp command reads it"),
    (lambda raw, head: b"<svg" in raw[:4096],
     "an SVG figure (written by --plot): for people, no stepramp command reads it"),
    (lambda raw, head: raw.startswith(b"PAR1"),
     "sweep's results (Parquet): no stepramp command reads them"),
    (lambda raw, head: b"<testsuite" in raw[:4096],
     "check's JUnit report: for CI, no stepramp command reads it"),
    (lambda raw, head: re.match(rb'\s*\{\s*"files"\s*:', raw) is not None,
     "check's JSON report: no stepramp command reads it"),
    (lambda raw, head: head.startswith("pulses,weight"),
     "a duty cycle: stepramp plan --moves reads it"),
    (lambda raw, head: head.startswith(("speed_rpm,", "speed_pps,", "speed_rps,")),
     "a vendor curve: stepramp motor new --curve reads it"),
    (lambda raw, head: head.startswith("motor,pulses,move_time_s"),
     "sweep's results: no stepramp command reads them"),
    (lambda raw, head: head.startswith(("phase,rate,", "pulse,time_s", "t_s,x_pulses",
                                        "stage,rate,")),
     "a CSV that simulate or show writes: no stepramp command reads it"),
    # last: another tool's files, said as such rather than "not an upload in any format"
    (lambda raw, head: raw.lstrip()[:1] == b"[",
     "a JSON array, not one of stepramp's documents (a JSON object with its \"format\")"),
    (lambda raw, head: _OTHER_CSV.match(head) is not None,
     "a CSV file that is not one of stepramp's (CSV inputs: plan --moves' duty cycle, "
     "motor new --curve's vendor curve)"),
)


def unjudged(raw: bytes) -> str | None:
    """What a file `check` cannot judge is, naming the command that reads it (None: not
    one of stepramp's)."""
    head = _first_line(raw)
    return next((why for test, why in _UNJUDGED if test(raw, head)), None)


def _first_line(raw: bytes) -> str:
    text = raw[:4096].decode("utf-8", errors="replace")
    lines = (line.strip() for line in text.splitlines())
    return next((line for line in lines if line and not line.startswith("#")), "")
