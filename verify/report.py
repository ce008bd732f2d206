"""Per-file results of `stepramp check`, rendered as text, JSON or JUnit XML.

- text: one line per finding, `path: error [rule] stage 3 (chip 0x18): message`
  (the stage and chip parts only when known), `path: unusable: message` for a
  file that could not be read as a table, `path: note: …` for a verdict summary
  no finding already says, then one summary line. A rule with more than
  `FOLD_OVER` findings in one file is summarised in up to three lines: the count
  and the stages (the first few ranges), the worst finding (the largest need /
  capability, `excess`) and the one with the shortest move
  (`move_pulses`), or the first when the rule has no such numbers;
  `verbose` lists every finding in the order the checks found them.
- json: `{"files": [{"path", "ok", "findings": [...]}]}`, each finding as
  `Finding.to_json()` (chip_code as "0x18" or null); "error" only on files
  that were unusable.
- junit: one `<testsuite name="stepramp check">` (the document root), one
  `<testcase>` per file, a `<failure>` per error finding, warnings in
  `<system-out>`, an unusable file as `<error>`. Built with xml.etree, so text
  and attributes are escaped; characters XML 1.0 cannot carry are replaced.
"""

from __future__ import annotations

import math
import re
import xml.etree.ElementTree as ET
from collections.abc import Sequence
from dataclasses import dataclass, field

from profiles.errors import FormatError, echo
from profiles.findings import Finding
from profiles.reading import display_path, json_text

FORMATS: tuple[str, ...] = ("text", "json", "junit")
FOLD_OVER = 3       # more findings of one rule in one file than this: summarised (text)
STAGE_RANGES = 4    # stage ranges a summary names before "…"
SUITE_NAME = "stepramp check"

# XML 1.0 allows tab, LF, CR and everything from U+0020 except surrogates, FFFE, FFFF.
_XML_BAD = re.compile("[\x00-\x08\x0b\x0c\x0e-\x1f\ud800-\udfff\ufffe\uffff]")


@dataclass(frozen=True)
class FileResult:
    """One checked file: `ok` is False when it has an error finding or is unusable."""

    path: str
    ok: bool
    findings: list[Finding] = field(default_factory=list)
    error: str | None = None   # why the file could not be used as a table at all
    # verdict summaries that are no finding (e.g. a tolerance box's stall probability bound)
    notes: list[str] = field(default_factory=list)
    details: dict[str, object] = field(default_factory=dict)   # the same, for JSON

    def to_json(self) -> dict[str, object]:
        out: dict[str, object] = {"path": self.path, "ok": self.ok,
                                  "findings": [f.to_json() for f in self.findings]}
        if self.error is not None:
            out["error"] = self.error
        out.update(self.details)
        return out


def render(results: Sequence[FileResult], fmt: str, *, verbose: bool = False) -> str:
    """The report of `results` in `fmt` ("text", "json" or "junit"), ending in a newline;
    `verbose`: the text lists every finding (json and junit always do)."""
    if fmt == "text":
        return _text(results, verbose)
    if fmt == "json":
        # ASCII escapes keep the document valid even for paths with undecodable bytes.
        return json_text({"files": [r.to_json() for r in results]})
    if fmt == "junit":
        return _junit(results)
    raise FormatError(f"format: {echo(fmt)} is not one of {', '.join(FORMATS)}")


def finding_line(path: str, f: Finding) -> str:
    """`path: severity [rule] stage N (chip 0xNN): message`."""
    where = "" if f.stage is None else f" stage {f.stage}"
    chip = "" if f.chip_code is None else f" (chip {f.chip_code_hex})"
    return (f"{display_path(path)}: {f.severity} [{f.rule}]{where}{chip}: "
            f"{_one_line(f.message)}")


def _text(results: Sequence[FileResult], verbose: bool = False) -> str:
    lines: list[str] = []
    errors = warnings = folded = 0
    for r in results:
        own, n = file_lines(r, verbose)
        lines += own
        folded += n
        errors += sum(1 for f in r.findings if f.severity == "error")
        warnings += sum(1 for f in r.findings if f.severity != "error")
    failed = sum(1 for r in results if not r.ok)
    unusable = sum(1 for r in results if r.error is not None)
    summary = (f"{len(results)} file{_s(len(results))} checked: {len(results) - failed} ok, "
               f"{failed} failed ({errors} error{_s(errors)}, {warnings} warning{_s(warnings)}"
               f"{f', {unusable} unusable' if unusable else ''})")
    if folded:
        summary += f"; {folded} findings summarised by rule (--verbose lists each)"
    lines.append(summary)
    return "\n".join(lines) + "\n"


def file_lines(r: FileResult, verbose: bool = False) -> tuple[list[str], int]:
    """One file's lines of the text report (its findings, a rule's many folded, then the
    notes no finding says), and how many findings were folded. `compare` reports the
    verdict on every move the table can run with these lines, as `check` does."""
    name = display_path(r.path)
    lines = [] if r.error is None else [f"{name}: unusable: {_one_line(r.error)}"]
    folded = 0
    groups = [r.findings] if verbose else list(_by_rule(r.findings).values())
    for group in groups:
        if verbose or len(group) <= FOLD_OVER:
            lines += [finding_line(r.path, f) for f in group]
        else:
            lines += _summary_lines(name, group)
            folded += len(group)
    lines += [f"{name}: note: {_one_line(n)}" for n in _own_notes(r)]
    return lines, folded


def _by_rule(findings: Sequence[Finding]) -> dict[tuple[str, str], list[Finding]]:
    """Findings grouped by severity and rule, groups in the order they first appear."""
    out: dict[tuple[str, str], list[Finding]] = {}
    for f in findings:
        out.setdefault((f.severity, f.rule), []).append(f)
    return out


def _own_notes(r: FileResult) -> list[str]:
    """The notes no finding already says (the load-angle finding carries the tolerance
    box's summary, which is also the file's note)."""
    return [n for n in r.notes if not any(n in f.message for f in r.findings)]


def _summary_lines(name: str, group: list[Finding]) -> list[str]:
    """A rule's many findings in one file: count and stages, the worst, the shortest move."""
    first = group[0]
    codes = {f.chip_code_hex for f in group}
    chip = f" (chip {next(iter(codes))})" if len(codes) == 1 and None not in codes else ""
    stages = sorted({f.stage for f in group if f.stage is not None})
    where = f" at stages {_stage_ranges(stages)}" if stages else ""
    out = [f"{name}: {first.severity} [{first.rule}]{chip}: {len(group)} findings{where}"]
    ranked = [(x, -i) for i, f in enumerate(group) if (x := excess(f)) is not None]
    worst = group[-max(ranked)[1]] if ranked else None
    moves = [(m, i) for i, f in enumerate(group) if (m := move_pulses(f)) is not None]
    shortest = group[min(moves)[1]] if moves else None
    picks = ([(worst, "worst" + (", and the shortest move" if shortest is worst else ""))]
             if worst is not None else [])
    if shortest is not None and shortest is not worst:
        picks.append((shortest, "shortest move"))
    for f, label in picks or [(first, "first")]:
        at = "" if f.stage is None else f", stage {f.stage}"
        out.append(f"{name}:   {label}{at}: {_one_line(f.message)}")
    return out


def _stage_ranges(stages: list[int]) -> str:
    """`1–30, 32, 35–40, …` : consecutive stages as ranges, the first STAGE_RANGES of them."""
    runs: list[list[int]] = []
    for k in stages:
        if runs and k == runs[-1][1] + 1:
            runs[-1][1] = k
        else:
            runs.append([k, k])
    shown = [f"{a}–{b}" if b > a else f"{a}" for a, b in runs[:STAGE_RANGES]]
    return ", ".join(shown) + (", …" if len(runs) > STAGE_RANGES else "")


def _junit(results: Sequence[FileResult]) -> str:
    # JUnit counts failed test cases (files), however many <failure> elements each holds.
    failures = sum(1 for r in results if any(f.severity == "error" for f in r.findings))
    errors = sum(1 for r in results if r.error is not None)
    suite = ET.Element("testsuite", {"name": SUITE_NAME, "tests": str(len(results)),
                                     "failures": str(failures), "errors": str(errors),
                                     "skipped": "0"})
    for r in results:
        case = ET.SubElement(suite, "testcase", {"classname": "stepramp.check",
                                                 "name": _xml_text(display_path(r.path))})
        if r.error is not None:
            err = ET.SubElement(case, "error", {"type": "unusable",
                                                "message": _xml_text(_one_line(r.error))})
            err.text = _xml_text(r.error)
        warning_lines = []
        for f in r.findings:
            if f.severity == "error":
                fail = ET.SubElement(case, "failure", {"type": f.rule,
                                                       "message": _xml_text(_one_line(f.message))})
                fail.text = _xml_text(finding_line(r.path, f))
            else:
                warning_lines.append(_xml_text(finding_line(r.path, f)))
        if warning_lines:
            out = ET.SubElement(case, "system-out")
            out.text = "\n".join(warning_lines)
    ET.indent(suite)
    body = ET.tostring(suite, encoding="unicode")
    return '<?xml version="1.0" encoding="UTF-8"?>\n' + body + "\n"


def _xml_text(s: str) -> str:
    return _XML_BAD.sub("\ufffd", s)


def _one_line(s: str) -> str:
    return " ".join(s.splitlines()) if "\n" in s or "\r" in s else s


def _s(n: int) -> str:
    return "" if n == 1 else "s"


# --- what a report needs to rank findings of one rule ---------------------------------------
# Findings carry no numbers besides their stage: the move and the shortfall are read back
# from the messages profiles.ppmc312.criterion writes (tests/verify/test_report.py pins
# them on real findings, so a change of wording there fails a test instead of silently
# unranking a report).
_NUMBER = r"([0-9.]+(?:e[+-]?[0-9]+)?)"
_MOVE = re.compile(r"shortest move that runs it: (\d+) pulses")
_NEED_GIVES = re.compile(rf"needs {_NUMBER} pps², the motor gives {_NUMBER} pps²")
_JUMP = re.compile(rf"\(\+{_NUMBER}\), above the largest jump {_NUMBER} pps")
_TOP = re.compile(rf"runs {_NUMBER} pps, above the motor's top usable speed {_NUMBER} pps")
_START = re.compile(rf"\({_NUMBER} pps\), above the start speed {_NUMBER} pps")
_CANNOT = re.compile(r"the motor cannot (?:accel|decel)erate between .* at all")


def move_pulses(f: Finding) -> int | None:
    """The shortest move that runs the finding's problem [pulses], when it names one."""
    m = _MOVE.search(f.message)
    return int(m.group(1)) if m else None


def excess(f: Finding) -> float | None:
    """How far the finding is past its limit, need / capability (inf: the motor cannot make
    the step at all), when its message says; None for rules without such numbers."""
    text = f.message
    if _CANNOT.search(text):
        return math.inf
    for pattern in (_NEED_GIVES, _JUMP, _TOP, _START):
        m = pattern.search(text)
        if m:
            need, limit = float(m.group(1)), float(m.group(2))
            return need / limit if limit > 0 else math.inf
    return None
