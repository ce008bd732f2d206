"""`stepramp check` for PPMC-312 files: a table file, or an upload file asked first what
the chip would answer (profiles/ppmc312/emulator.py), then the chip rules
(verify/chip_rules.py) and, with a motor, the one safety verdict (verify/safety.py); in
sync's report, each axis's safety verdict."""

from __future__ import annotations

from typing import TYPE_CHECKING, Any

from ..findings import Finding
from ..report import FileResult
from .common import dedupe, integrity_findings

if TYPE_CHECKING:
    from profiles.ppmc312.table import FreeCurveTable, InitTable

    from ..check_options import CheckOptions


def check(raw: bytes, path: str, options: CheckOptions) -> FileResult:
    """The findings for a table or upload file: chip rules, then (with a motor) the safety
    verdict over every execution the chip can run with the table (its JSON form is the
    result's `details["safety"]`)."""
    from profiles.reading import display_path, require_size
    from verify.chip_rules import check_table

    require_size(len(raw), display_path(path))
    table, chip_findings = load_checkable(path, options.extck_hz, raw=raw)
    findings = list(chip_findings)
    notes: list[str] = []
    details: dict[str, object] = {}
    if table is not None:
        findings += check_table(table)
        if options.motor is not None:
            findings += safety_findings(table, options, notes, details)
    findings = dedupe(findings)
    ok = not any(f.severity == "error" for f in findings)
    return FileResult(path=path, ok=ok, findings=findings, notes=notes, details=details)


def safety_findings(table: FreeCurveTable | InitTable, options: CheckOptions,
                    notes: list[str], details: dict[str, object]) -> list[Finding]:
    """The safety verdict's findings for `table` (none for an init table the chip cannot
    build: check_table has said why, with the code); its summaries go to `notes`, its
    JSON to `details["safety"]`."""
    from profiles.errors import InitBuildError
    from profiles.ppmc312.init_model import as_free_curve
    from verify.safety import judge_safety

    assert options.motor is not None
    try:
        stages = as_free_curve(table)
    except InitBuildError:
        return []
    verdict = judge_safety(stages, options.motor, pulses=options.pulses,
                           samples=options.samples, seed=options.seed, strict=options.strict,
                           load_angle=options.physics, progress=options.progress)
    found = verdict.findings()
    details["safety"] = verdict.to_json()
    if not any(f.rule.startswith("load-angle") for f in found) and \
            verdict.load_angle is not None:
        notes.append(verdict.load_angle.describe())
    if verdict.box is not None:
        notes.append(verdict.box.describe())
    return found


def axis_verdict(axis: Any) -> dict[str, Any]:
    """What sync's report says of one axis's safety: the safety verdict of its table over
    every move length (over the motor's tolerance box when it has one)."""
    from verify.safety import judge_safety

    return {"safety": judge_safety(axis.table, axis.motor).to_json()}


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
    integrity = integrity_findings("upload", parsed.format, parsed.integrity, parsed.detail)
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
