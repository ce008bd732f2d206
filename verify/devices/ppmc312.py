"""`stepramp check` for PPMC-312 files: the device's judge in the registry. What is said
of a file is the PPMC-312's own (`profiles.ppmc312.file_verdict`: tables, uploads, move
commands, table-read answers, programs, C headers of several uploads); here it becomes
the file's result. In sync's report, each axis's safety verdict (`axis_verdict`)."""

from __future__ import annotations

from typing import TYPE_CHECKING

from profiles.ppmc312.file_verdict import axis_verdict, file_findings

from ..report import FileResult

if TYPE_CHECKING:
    from ..check_options import CheckOptions


def check(raw: bytes, path: str, options: CheckOptions) -> FileResult:
    """The verdict on a PPMC-312 file as `check` reports it: its findings (each once), notes
    and details (the safety verdict's JSON in `details["safety"]`)."""
    verdict = file_findings(raw, path, options)
    return FileResult(path=path, ok=not any(f.severity == "error" for f in verdict.findings),
                      findings=verdict.findings, notes=verdict.notes, details=verdict.details)


__all__ = ["axis_verdict", "check"]
