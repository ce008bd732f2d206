"""What every device's judge shares: the warning for a file without a check, and one
file's result from its findings."""

from __future__ import annotations

from collections.abc import Iterable
from typing import TYPE_CHECKING

from profiles.findings import Finding

from ..report import FileResult

if TYPE_CHECKING:
    from ..check_options import CheckOptions


def integrity_findings(prefix: str, fmt: str, integrity: str, detail: str) -> list[Finding]:
    """`PREFIX-unchecked` (a warning) for a file nothing vouches for; none for a verified
    one."""
    return ([] if integrity == "verified" else
            [Finding("warning", f"{prefix}-unchecked", f"{fmt} file: {detail}")])


def dedupe(findings: Iterable[Finding]) -> list[Finding]:
    """`findings` in order, each equal finding once (two checks may report the same)."""
    return list(dict.fromkeys(findings))


def device_result(path: str, findings: Iterable[Finding], title: str,
                  options: CheckOptions) -> FileResult:
    """The result of a file whose device has no stall verdict (a note says so when a
    motor was given)."""
    found = dedupe(findings)
    notes = [f"{title} file"] + (
        ["--motor judges PPMC-312 tables and A-Link settings: not this file's stall "
         "safety"]
        if options.motor is not None else [])
    return FileResult(path=path, ok=not any(f.severity == "error" for f in found),
                      findings=found, notes=notes)
