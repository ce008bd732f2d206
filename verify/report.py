"""Per-file results of `stepramp check`, rendered as text, JSON or JUnit XML.

- text: one line per finding, `path: error [rule] stage 3 (chip 0x18): message`
  (the stage and chip parts only when known), `path: unusable: message` for a
  file that could not be read as a table, then one summary line.
- json: `{"files": [{"path", "ok", "findings": [...]}]}`, each finding as
  `Finding.to_json()` (chip_code as "0x18" or null); "error" only on files
  that were unusable.
- junit: one `<testsuite name="stepramp check">` (the document root), one
  `<testcase>` per file, a `<failure>` per error finding, warnings in
  `<system-out>`, an unusable file as `<error>`. Built with xml.etree, so text
  and attributes are escaped; characters XML 1.0 cannot carry are replaced.
"""

from __future__ import annotations

import re
import xml.etree.ElementTree as ET
from collections.abc import Sequence
from dataclasses import dataclass, field

from profiles.errors import FormatError, echo
from profiles.reading import display_path, json_text

from .findings import Finding

FORMATS: tuple[str, ...] = ("text", "json", "junit")
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


def render(results: Sequence[FileResult], fmt: str) -> str:
    """The report of `results` in `fmt` ("text", "json" or "junit"), ending in a newline."""
    if fmt == "text":
        return _text(results)
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


def _text(results: Sequence[FileResult]) -> str:
    lines: list[str] = []
    errors = warnings = 0
    for r in results:
        if r.error is not None:
            lines.append(f"{display_path(r.path)}: unusable: {_one_line(r.error)}")
        for f in r.findings:
            lines.append(finding_line(r.path, f))
            if f.severity == "error":
                errors += 1
            else:
                warnings += 1
        lines += [f"{r.path}: note: {_one_line(n)}" for n in r.notes]
    failed = sum(1 for r in results if not r.ok)
    unusable = sum(1 for r in results if r.error is not None)
    summary = (f"{len(results)} file{_s(len(results))} checked: {len(results) - failed} ok, "
               f"{failed} failed ({errors} error{_s(errors)}, {warnings} warning{_s(warnings)}"
               f"{f', {unusable} unusable' if unusable else ''})")
    lines.append(summary)
    return "\n".join(lines) + "\n"


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
