"""Judging one file as `stepramp check` does: the file is read once; stepramp's documents
that no device runs (axes files, sync reports, motor files) go to their judges
(verify/documents.py), every other file to its device's (verify/devices: its own
documents, then each device's detection); a file none can judge is named with the
command that reads it. One `FileResult` per file; a file that cannot be judged is a
result with `error` set, never an exception."""

from __future__ import annotations

from collections.abc import Iterable
from typing import TYPE_CHECKING

from profiles.errors import FormatError, StepRampError

from .check_options import DEFAULT_SAMPLES, CheckOptions
from .devices.common import dedupe
from .report import FileResult

if TYPE_CHECKING:
    from profiles.motor import Motor
    from profiles.progress import Progress

__all__ = ["CheckOptions", "check_file", "dedupe", "judge_file"]


def check_file(path: str, motor: Motor | None = None, extck_hz: float | None = None, *,
               pulses: Iterable[int] | None = None, physics: bool = True,
               samples: int = DEFAULT_SAMPLES, seed: int = 0, strict: bool = False,
               clock: str | None = None, progress: Progress | None = None,
               commands: tuple[str, ...] | None = None) -> FileResult:
    """The verdict on the file at `path` (see `CheckOptions` for the options)."""
    return judge_file(path, CheckOptions(motor, extck_hz, clock, pulses, physics, samples,
                                         seed, strict, progress, commands))


def judge_file(path: str, options: CheckOptions) -> FileResult:
    """`check_file` with its options as one value: stepramp's documents that no device runs
    by their own judge (verify/documents.py), every other file by its device's."""
    from profiles.reading import STREAM_INPUT_MAX_BYTES, read_bytes

    from .devices import DEFAULT, detect, document_format
    from .documents import judge_of, unjudged

    try:
        # Read once (stdin cannot be read twice), up to the cap of MC-200 streams, which
        # may be longer than other inputs; a device's judge holds its files to its cap.
        raw = read_bytes(path, limit=STREAM_INPUT_MAX_BYTES)
        document = judge_of(document_format(raw))
        if document is not None:
            return document(raw, path, options)
        device = detect(raw)
        try:
            return device.judge_module().check(raw, path, options)
        except StepRampError as e:
            # the default device reads what no other claims: a file it cannot read may be
            # one stepramp writes for people or another command (say which)
            what = unjudged(raw) if device is DEFAULT else None
            raise e if what is None else FormatError(f"not judged: {what}") from None
    except StepRampError as e:
        return FileResult(path=path, ok=False, findings=[], error=str(e))
