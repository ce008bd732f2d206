"""What every device's judge shares: the warning for a file without a check and each
finding once (`profiles.findings`), and one file's result from its findings."""

from __future__ import annotations

from collections.abc import Iterable
from typing import TYPE_CHECKING

from profiles.findings import Finding, dedupe

from ..report import FileResult

if TYPE_CHECKING:
    from ..check_options import CheckOptions


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
