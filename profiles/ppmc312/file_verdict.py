"""What `stepramp check` says of a PPMC-312 file (`file_findings`; verify/devices/ppmc312.py
makes it the file's result): every file stepramp writes for the chip or reads from it, by
what its blocks (or ASCII frames) hold:

- a table file, or a table upload (free curve, init; parallel blocks or an ASCII init
  frame), asked first what the chip would answer (profiles/ppmc312/emulator.py), then
  the chip rules (profiles/ppmc312/chip_rules.py) and, with a motor, the device's safety
  verdict (profiles/ppmc312/safety.py);
- motion commands (80–88, 10, 11, 05: `stepramp move --command`), parallel or ASCII:
  the chip's rules for them (profiles/ppmc312/command_rules.py);
- the chip's table-read answer (41): the table it holds, judged like a table file; the
  answer does not carry the clock, so `--clock` says it;
- a program file (`stepramp.program/1`): what the chip runs for its commands, judged with
  the motor as the table's moves are (profiles/ppmc312/program_verdict.py);
- a C header of several uploads (sync's axes.h): each upload by its symbol prefix,
  verified against its own CRC-32 and judged as above.

In sync's report, each axis's safety verdict (`axis_verdict`).
"""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import TYPE_CHECKING, Any

from profiles.errors import CorruptedError, DecodeError, FormatError
from profiles.findings import Finding, dedupe, integrity_findings
from profiles.ppmc312.command_rules import (
    frame_payload,
    is_move_block,
    is_serial_move,
    move_block_findings,
    move_notes,
    serial_move_findings,
    serial_move_notes,
)

if TYPE_CHECKING:
    from profiles.ppmc312.clock import Clock
    from profiles.ppmc312.table import FreeCurveTable, InitTable
    from profiles.verdict import JudgeOptions as CheckOptions

TABLE_READ_HEAD = b"\x02\x0a\x41"   # the table-read answer's first block: PAL, length, 41
PROGRAM_FORMAT = "stepramp.program/1"


@dataclass
class FileFindings:
    """What the judges found in one file (or one upload of a C header)."""

    findings: list[Finding] = field(default_factory=list)
    notes: list[str] = field(default_factory=list)
    details: dict[str, object] = field(default_factory=dict)

    def add(self, other: FileFindings, prefix: str) -> None:
        """`other`'s findings and notes, each naming `prefix` (an upload's symbols)."""
        self.findings += [Finding(f.severity, f.rule, f"{prefix}: {f.message}", f.chip_code,
                                  f.stage) for f in other.findings]
        self.notes += [f"{prefix}: {n}" for n in other.notes]
        if other.details:
            uploads = self.details.setdefault("uploads", {})
            assert isinstance(uploads, dict)
            uploads[prefix] = other.details


def file_findings(raw: bytes, path: str, options: CheckOptions) -> FileFindings:
    """The verdict on a PPMC-312 file (see the module docstring), each finding once; its
    safety verdict's JSON form is `details["safety"]` (per upload of a C header:
    `details["uploads"][prefix]["safety"]`)."""
    from profiles.ppmc312.formats import c_upload_names
    from profiles.reading import display_path, require_size

    require_size(len(raw), display_path(path))
    if is_program(raw):
        verdict = program_file_verdict(raw, path, options)
    elif looks_like_table_json(raw):
        from profiles.ppmc312.table import table_from_json
        from profiles.reading import parse_json

        verdict = table_verdict(table_from_json(parse_json(raw, path)), options)
    elif len(names := c_upload_names(raw)) > 1:
        verdict = c_set_verdict(raw, names, options)
    else:
        verdict = file_verdict(raw, path, options)
    verdict.findings = dedupe(verdict.findings)
    return verdict


def is_program(raw: bytes) -> bool:
    """Whether `raw` is a program file (`profiles.ppmc312.program.FORMAT`, spelled here: a
    table's check imports no numpy, which the program's model does)."""
    from profiles.reading import document_format

    return document_format(raw) == PROGRAM_FORMAT


def program_file_verdict(raw: bytes, path: str, options: CheckOptions) -> FileFindings:
    """A program file: what the chip runs for it, judged with the motor
    (profiles/ppmc312/program_verdict.py)."""
    from profiles.ppmc312.program import load_program
    from profiles.ppmc312.program_verdict import program_verdict

    if options.pulses is not None:
        raise FormatError("--pulses names the moves of a table to judge: a program says what "
                          "it runs (give the program alone)")
    program = load_program(path, raw=raw)
    return FileFindings(*program_verdict(program, options.motor, physics=options.physics))


def file_verdict(raw: bytes, path: str, options: CheckOptions) -> FileFindings:
    """The verdict on an upload, move or table-read file in any format."""
    from profiles.ppmc312.formats import parse_handshake
    from profiles.reading import require_shallow_json

    require_shallow_json(raw, path)  # a JSON upload is parsed by formats.parse
    try:
        parsed, answers = parse_handshake(raw, path)
    except CorruptedError as e:  # the file's own check failed: a verdict, not unusable input
        return FileFindings([Finding("error", "upload-corrupted", str(e))])
    # A file without a check (hand-made, or bin: no room for one) is judged, with a warning.
    blocks = list(parsed.items)
    verdict = blocks_verdict(blocks, options)
    if not is_table_read(blocks):  # a capture from the bus carries no check: none expected
        verdict.findings[:0] = integrity_findings("upload", parsed.format, parsed.integrity,
                                                  parsed.detail)
    # a refused upload has its finding already (the emulator ran): its answers would be
    # the refusal
    refused = any(f.rule == "chip-rejects-upload" for f in verdict.findings)
    verdict.notes += handshake_note(blocks, parsed.format, answers, refused)
    return verdict


def handshake_note(blocks: list[bytes], fmt: str, answers: list[bytes] | None,
                   refused: bool) -> list[str]:
    """A note for a table upload the chip accepts, in a format with room for its answers,
    that lists none (written before stepramp carried them): a host must still read each
    answer before the next block (manual §5-4, §5-8), and the file cannot say what to
    expect."""
    from profiles.ppmc312.emulator import is_table_upload

    if answers is not None or refused or fmt in ("bin", "ihex") or not is_table_upload(blocks):
        return []
    return ["the file lists no expected answers: the chip answers every block and raises "
            "alarm F4 01 when a block is written over an unread answer (§5-4, §7-2); "
            "re-export it for the answers and, in a bus script, the reads"]


def c_set_verdict(raw: bytes, names: list[str], options: CheckOptions) -> FileFindings:
    """Every upload of a C header of several (sync's axes.h), each by its prefix."""
    from profiles.ppmc312.formats import parse_c_set

    out = FileFindings(notes=[f"C header of {len(names)} uploads: {', '.join(names)}"])
    try:
        uploads = parse_c_set(raw)
    except CorruptedError as e:
        return FileFindings([Finding("error", "upload-corrupted", str(e))])
    for name, parsed in uploads.items():
        out.add(blocks_verdict(list(parsed.items), options), name)
    return out


def blocks_verdict(blocks: list[bytes], options: CheckOptions) -> FileFindings:
    """The verdict on the blocks (or ASCII frames) of one command file."""
    if not blocks:
        raise DecodeError("the file holds no blocks")
    if blocks[0][:1] and blocks[0][0] & 0x80:
        payloads = [frame_payload(f, i) for i, f in enumerate(blocks)]
        if all(is_serial_move(p) for p in payloads):
            return FileFindings([f for i, p in enumerate(payloads)
                            for f in serial_move_findings(p, i)],
                           serial_move_notes(payloads) + motor_note(options))
    elif all(is_move_block(b) for b in blocks):
        return FileFindings([f for i, b in enumerate(blocks) for f in move_block_findings(b, i)],
                       move_notes(blocks) + motor_note(options))
    elif is_table_read(blocks):
        from profiles.ppmc312.upload import decode_table_read

        out = table_verdict(decode_table_read(blocks, clock=read_clock(options)), options)
        out.notes.insert(0, "the chip's table-read answer (41): the table it holds")
        return out
    return upload_verdict(blocks, options)


def is_table_read(blocks: list[bytes]) -> bool:
    """Whether the blocks are the chip's table-read answer (41)."""
    return bool(blocks) and blocks[0][:3] == TABLE_READ_HEAD


def motor_note(options: CheckOptions) -> list[str]:
    return (["--motor judges tables: a move command carries none (check the table it runs "
             "with)"] if options.motor is not None else [])


def read_clock(options: CheckOptions) -> Clock:
    """The clock a table-read answer's table runs on: `--clock`, which the answer lacks."""
    from profiles.ppmc312.clock import Clock

    if options.clock is None:
        raise FormatError("a table-read answer (41) does not carry the table's clock: give "
                          "--clock CLK (8MHz, 1MHz, …, or EXTCK with --extck-hz)")
    if options.clock.upper() != "EXTCK":
        return Clock.named(options.clock)
    if options.extck_hz is None:
        raise FormatError("--clock EXTCK needs --extck-hz (the external frequency)")
    return Clock.extck(options.extck_hz, "rising")


def upload_verdict(blocks: list[bytes], options: CheckOptions) -> FileFindings:
    """A table upload, judged first by what the chip would answer, then as its table."""
    from profiles.ppmc312.upload import decode_upload

    refused = chip_refusal(blocks)
    if refused is not None:
        return FileFindings([refused])
    out = table_verdict(decode_upload(blocks, extck_hz=options.extck_hz), options)
    out.findings[:0] = block_size_findings(blocks)
    return out


def block_size_findings(blocks: list[bytes]) -> list[Finding]:
    """A warning for parallel blocks over REV 1.3's size (manual §5-5: code and parameters
    [0]–[12], 14 bytes after the length byte). Error 0x15 still only refuses 31 or more,
    and REV 1.1 chips took 30: files written for them are judged, not refused, but a
    REV 1.3 chip is not documented to take them (docs/manual-notes.md)."""
    from profiles.ppmc312.frames import REV13_BLOCK_DATA

    if blocks[0][:1] not in (b"\x00", b"\x01", b"\x02", b"\x03"):  # ASCII: no blocks
        return []
    over = [i for i, b in enumerate(blocks) if len(b) > 1 and b[1] > REV13_BLOCK_DATA]
    if not over:
        return []
    largest = max(blocks[i][1] for i in over)
    where = ", ".join(map(str, over[:6])) + (", …" if len(over) > 6 else "")
    return [Finding("warning", "upload-block-size",
                    f"{len(over)} block(s) carry more than {REV13_BLOCK_DATA} bytes after the "
                    f"length byte (up to {largest}; blocks {where}): the REV 1.3 manual "
                    f"(§5-5) limits a block to the code and parameters [0]–[12]; only chips "
                    f"known to take REV 1.1 blocks accept them. Re-export with the default "
                    f"--max-block-data {REV13_BLOCK_DATA}")]


def chip_refusal(blocks: list[bytes]) -> Finding | None:
    """The chip's refusal of a parallel table upload (its emulator's answer), or None."""
    from profiles.ppmc312.emulator import accept_upload

    if blocks[0][:1] not in (b"\x02", b"\x03"):  # an ASCII frame: no emulator answer
        return None
    answer = accept_upload(blocks)
    if answer.ok:
        return None
    # F0 carries a parameter-error code; F1/F6 (state, size) are the code themselves.
    code = answer.error_code if answer.response_code == 0xF0 else answer.response_code
    return Finding("error", "chip-rejects-upload", answer.message, chip_code=code, stage=None)


def table_verdict(table: FreeCurveTable | InitTable, options: CheckOptions) -> FileFindings:
    """The chip rules of a table and, with a motor, its safety verdict."""
    from profiles.ppmc312.chip_rules import check_table

    out = FileFindings(check_table(table))
    out.findings += provenance_findings(table, options, out.notes)
    if options.motor is not None:
        out.findings += safety_findings(table, options, out.notes, out.details)
    return out


def provenance_findings(table: FreeCurveTable | InitTable, options: CheckOptions,
                        notes: list[str]) -> list[Finding]:
    """A motor without friction draws `motor-friction-zero` (issue 32 item 1); a planned
    table names the motor it was planned for (a note) and, judged with a motor whose
    content differs, warns `motor-mismatch`: its verdict is on another machine (item 4)."""
    found = [] if options.motor is None else friction_findings(options.motor)
    planned = table.provenance
    if planned is None:
        return found
    notes.append(planned.describe())
    if options.motor is None:
        return found
    from profiles.provenance import content_sha256

    digest = content_sha256(options.motor.to_json())
    if digest == planned.motor.sha256:
        return found
    judged = options.motor.name or "the --motor file"
    return [*found, Finding(
        "warning", "motor-mismatch",
        f"planned for motor {planned.motor.short}, judged with {judged} (sha256 "
        f"{digest[:12]}): another motor, or the same one changed since; re-plan for this "
        "motor or judge with the one it was planned for")]


def friction_findings(motor: Any) -> list[Finding]:
    from profiles.motor.loads import friction_warning

    warned = friction_warning(motor.friction_torque_nm, motor.tolerance("friction_torque_nm")[1])
    return [Finding("warning", "motor-friction-zero", warned)] if warned else []


def safety_findings(table: FreeCurveTable | InitTable, options: CheckOptions,
                    notes: list[str], details: dict[str, object]) -> list[Finding]:
    """The safety verdict's findings for `table` (none for an init table the chip cannot
    build: check_table has said why, with the code); its summaries go to `notes`, its
    JSON to `details["safety"]`."""
    from profiles.errors import InitBuildError
    from profiles.ppmc312.init_model import as_free_curve
    from profiles.ppmc312.safety import judge_table

    assert options.motor is not None
    try:
        stages = as_free_curve(table)
    except InitBuildError:
        return []
    commands, found = planned_commands(table, options.commands, notes)
    verdict = judge_table(stages, options.motor, pulses=options.pulses,
                          samples=options.samples, seed=options.seed, strict=options.strict,
                          load_angle=options.physics, commands=commands,
                          progress=options.progress)
    found += verdict.findings()
    details["safety"] = verdict.to_json()
    notes.extend(verdict.notes())
    return found


def planned_commands(table: FreeCurveTable | InitTable, given: tuple[str, ...] | None,
                     notes: list[str]) -> tuple[tuple[str, ...] | None, list[Finding]]:
    """The motion commands the verdict judges (docs/manual-notes.md, "The commands a table
    was planned for"): `--commands` when given, else those the table's provenance records
    (`plan --commands`; said in a note), else every command. Given, and leaving out a
    recorded one, it draws `commands-narrower`: the verdict no longer covers a command the
    machine was planned to run. Wider than the record (or with no record) judges more than
    was planned for: no warning, whatever it finds is the machine's to answer."""
    from profiles.ppmc312.command_verdicts import command_names

    planned = table.provenance
    recorded = None if planned is None else planned.commands
    if recorded is None:
        return given, []
    try:
        names = command_names(recorded)
    except FormatError as e:
        raise FormatError(f"provenance.{e}") from None
    if given is None:
        notes.append(f"judged for the commands it was planned for: {command_codes(names)} "
                     "(provenance); --commands to change")
        return names, []
    left_out = [n for n in names if n not in command_names(given)]
    if not left_out:
        return given, []
    return given, [Finding(
        "warning", "commands-narrower",
        f"planned for the commands {command_codes(names)}, judged for "
        f"{command_codes(command_names(given))}: the verdict leaves out "
        f"{command_codes(tuple(left_out))}, which the machine was planned to run; judge "
        "without --commands (the recorded ones) or re-plan with the commands it runs")]


def command_codes(names: tuple[str, ...]) -> str:
    """Motion commands by their hex codes, as `--commands` takes them ("81,82")."""
    from profiles.ppmc312.motion import COMMANDS

    return ",".join(f"{COMMANDS[n].code:02X}" for n in names)


def axis_verdict(axis: Any) -> tuple[bool, dict[str, Any]]:
    """Whether one axis of a synchronised move is safe, and what sync's report says of it:
    the safety verdict of its table over every move length (over the motor's tolerance box
    when it has one)."""
    from profiles.ppmc312.safety import judge_table

    verdict = judge_table(axis.table, axis.motor)
    return verdict.safe, {"safety": verdict.to_json()}


def load_checkable(path: str, extck_hz: float | None = None, *, raw: bytes | None = None
                   ) -> tuple[FreeCurveTable | InitTable | None, list[Finding]]:
    """A table file, or a table upload judged first by what the chip would answer:
    (the table, [its file's integrity findings]) or, for an upload the chip refuses or
    whose check fails, (None, [its finding, …]). `raw`: the file's bytes, when the caller
    has read them."""
    from profiles.ppmc312.formats import parse
    from profiles.ppmc312.table import table_from_json
    from profiles.ppmc312.upload import decode_upload
    from profiles.reading import parse_json, read_bytes, require_shallow_json

    raw = read_bytes(path) if raw is None else raw
    if looks_like_table_json(raw):
        return table_from_json(parse_json(raw, path)), []
    require_shallow_json(raw, path)
    try:
        parsed = parse(raw, path)
    except CorruptedError as e:
        return None, [Finding("error", "upload-corrupted", str(e))]
    integrity = integrity_findings("upload", parsed.format, parsed.integrity, parsed.detail)
    blocks = list(parsed.items)
    if blocks and (refused := chip_refusal(blocks)) is not None:
        return None, [refused, *integrity]
    return decode_upload(blocks, extck_hz=extck_hz), integrity


def looks_like_table_json(raw: bytes) -> bool:
    """A JSON object that is not a `{"blocks": …}` upload is judged as a table file, so
    a wrong or missing "format" is reported as such."""
    if raw.lstrip()[:1] != b"{":
        return False
    return b"stepramp.table/1" in raw or b'"blocks"' not in raw
