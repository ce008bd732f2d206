"""Judging one file as `stepramp check` does: a table file, or an upload file asked
first what the chip would answer, then the chip rules and (with a motor) the
stall criterion; an MC-200 stream or A-Link settings file by its device's rules
(verify/device_checks.py). One `FileResult` per file; a file that cannot be read as a
table is a result with `error` set, never an exception."""

from __future__ import annotations

from collections.abc import Iterable
from typing import TYPE_CHECKING

from profiles.errors import StepRampError

from .findings import Finding
from .report import FileResult

if TYPE_CHECKING:
    from profiles.motor import Motor
    from profiles.ppmc312.table import FreeCurveTable, InitTable
    from profiles.progress import Progress


def check_file(path: str, motor: Motor | None = None, extck_hz: float | None = None, *,
               pulses: Iterable[int] | None = None, physics: bool = True,
               samples: int = 1000, seed: int = 0, strict: bool = False,
               progress: Progress | None = None) -> FileResult:
    """The findings for the table or upload file at `path`.

    `motor` adds the safety verdict (verify.safety.judge_safety) as findings, over every
    execution the chip can run with the table (`pulses`: only the moves of those
    lengths): the criterion, and (`physics`) the load angle; its JSON form is the
    result's `details["safety"]`. `extck_hz` is the external clock of EXTCK uploads (a
    table file carries its own).
    """
    from profiles.reading import STREAM_INPUT_MAX_BYTES, display_path, read_bytes, require_size
    from verify.chip_rules import check_table

    try:
        # Read once (stdin cannot be read twice), up to the cap of MC-200 streams, which
        # may be longer than other inputs; any other file is held to the usual cap.
        raw = read_bytes(path, limit=STREAM_INPUT_MAX_BYTES)
        device = _device_result(raw, path, motor is not None)
        if device is not None:
            return device
        require_size(len(raw), display_path(path))
        table, chip_findings = load_checkable(path, extck_hz, raw=raw)
        findings = list(chip_findings)
        notes: list[str] = []
        details: dict[str, object] = {}
        if table is not None:
            findings += check_table(table)
        if motor is not None and table is not None:
            from profiles.errors import InitBuildError
            from profiles.ppmc312.init_model import as_free_curve
            from verify.safety import judge_safety

            try:
                stages = as_free_curve(table)
            except InitBuildError:
                stages = None  # no stages to judge: check_table has said why, with the code
            if stages is not None:
                verdict = judge_safety(stages, motor, pulses=pulses, samples=samples,
                                       seed=seed, strict=strict, load_angle=physics,
                                       progress=progress)
                findings += verdict.findings()
                details["safety"] = verdict.to_json()
                if not any(f.rule.startswith("load-angle") for f in findings) and \
                        verdict.load_angle is not None:
                    notes.append(verdict.load_angle.describe())
                if verdict.box is not None:
                    notes.append(verdict.box.describe())
    except StepRampError as e:
        return FileResult(path=path, ok=False, findings=[], error=str(e))
    findings = dedupe(findings)
    ok = not any(f.severity == "error" for f in findings)
    return FileResult(path=path, ok=ok, findings=findings, notes=notes, details=details)


def _device_result(raw: bytes, path: str, motor: bool) -> FileResult | None:
    """The result for an MC-200 stream or A-Link settings file (None for the others)."""
    from verify.device_checks import check_device_file

    found = check_device_file(raw, path)
    if found is None:
        return None
    device, findings = found
    names = {"mc200": "MC-200 stream", "alink": "A-Link settings"}
    notes = [f"{names[device]} file"] + (
        ["--motor judges PPMC-312 tables only: not this file's stall safety"] if motor else [])
    findings = dedupe(findings)
    return FileResult(path=path, ok=not any(f.severity == "error" for f in findings),
                      findings=findings, notes=notes)


def dedupe(findings: Iterable[Finding]) -> list[Finding]:
    """`findings` in order, each equal finding once (two checks may report the same)."""
    return list(dict.fromkeys(findings))


def load_checkable(path: str, extck_hz: float | None = None, *, raw: bytes | None = None
                   ) -> tuple[FreeCurveTable | InitTable | None, list[Finding]]:
    """A table file, or an upload file judged first by what the chip would answer:
    (the table, []) or, for an upload the chip refuses, (None, [its finding]). `raw`:
    the file's bytes, when the caller has read them."""
    from profiles.ppmc312.table import table_from_json
    from profiles.reading import parse_json, read_bytes, require_shallow_json

    raw = read_bytes(path) if raw is None else raw
    if looks_like_table_json(raw):
        return table_from_json(parse_json(raw, path)), []
    from profiles.errors import CorruptedError
    from profiles.ppmc312.emulator import accept_upload
    from profiles.ppmc312.formats import parse
    from profiles.ppmc312.upload import decode_upload

    require_shallow_json(raw, path)  # a JSON upload is parsed by formats.parse
    try:
        parsed = parse(raw, path)
    except CorruptedError as e:  # the file's own check failed: a verdict, not unusable input
        return None, [Finding("error", "upload-corrupted", str(e))]
    # A file without a check (hand-made, or bin: no room for one) is judged, with a warning.
    integrity = ([] if parsed.integrity == "verified" else
                 [Finding("warning", "upload-unchecked", f"{parsed.format} file: {parsed.detail}")])
    blocks = parsed.items
    if blocks and blocks[0][:1] in (b"\x02", b"\x03"):  # parallel blocks: ask the chip model
        verdict = accept_upload(blocks)
        if not verdict.ok:
            # F0 carries a parameter-error code; F1/F6 (state, size) are the code themselves.
            code = verdict.error_code if verdict.response_code == 0xF0 else verdict.response_code
            return None, [Finding("error", "chip-rejects-upload", verdict.message,
                                  chip_code=code, stage=None), *integrity]
    return decode_upload(blocks, extck_hz=extck_hz), integrity


def looks_like_table_json(raw: bytes) -> bool:
    """A JSON object that is not a `{"blocks": …}` upload is judged as a table file, so
    a wrong or missing "format" is reported as such."""
    if raw.lstrip()[:1] != b"{":
        return False
    return b"stepramp.table/1" in raw or b'"blocks"' not in raw
