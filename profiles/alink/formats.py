"""A-Link ALUM settings files: the command words in every format stepramp writes.

`FORMATS` is the settings' format table (see `profiles.formats`). Items are the
`Command`s (their words, pair codes applied, are what the unit receives); the
payload is the command words in order, each 16-bit little-endian (CMD, PARAM1,
PARAM2, CMD, …: 6 bytes a command, the bytes a little-endian host holds in a
`uint16_t [N][3]` array). Its CRC-32 is what each file carries:

| format | file | check |
|---|---|---|
| `text` | the settings line, summary, one command a line with its words | `# crc32` line |
| `json` | `settings_document` (settings, summary, commands) | the `crc32` field |
| `hex` | one command a line: three 4-digit hex words | `# crc32` line |
| `c` | a C header `NAME_words[N][3]`, symbols prefixed by `name` | `NAME_CRC32`, comment |

No `bin` or `ihex`: the unit takes one command at a time through the link
master's memory, each after the previous one's answer (pair-code handshake),
never as a memory image a loader writes (docs/manual-notes.md).

Parsing reads the words (the authority), checks the CRC, decodes each triple
(`parse_command`) and checks that what the file says beside the words (a row's
name, func and para; the JSON's settings) agrees with them.
"""

from __future__ import annotations

import json
import re
from collections.abc import Iterable, Sequence
from dataclasses import replace
from pathlib import Path
from typing import Any

from ..errors import CorruptedError, DecodeError, FormatError, StepRampError, echo
from ..formats import (
    Format,
    FormatTable,
    Parsed,
    RenderOptions,
    c_comment,
    c_crc,
    c_define,
    c_header,
    c_name,
    c_prefixes,
    c_rows,
    c_values,
    content_lines,
    crc_hex,
    find_crc_comment,
    first_content_line,
    looks_like_c,
    text_of,
    verify_crc,
)
from ..reading import parse_json
from .codec import (
    Command,
    command_name,
    command_rows,
    parse_command,
    settings_document,
    settings_from_commands,
)
from .model import AlinkSettings

C_NAME_DEFAULT = "stepramp_alink"
# the keys of settings_document that restate the settings (checked against the words)
SETTINGS_KEYS = ("multiplier", "start_pps", "high_pps", "up_time_para", "accel_ms_per_kpps",
                 "accel_pps2", "max_pps", "s_curve")
SUMMARY_KEYS = ("predicted_time_s", "linear_time_s", "s_curve_time_s", "ratio_to_optimum")

Words = tuple[int, int, int]


def payload_of(words: Iterable[Words]) -> bytes:
    """The command words in order, 16-bit little-endian: what the CRC-32 covers."""
    return b"".join(w.to_bytes(2, "little") for triple in words for w in triple)


def _commands(commands: Sequence[Command]) -> list[Command]:
    items = list(commands)
    if not items:
        raise FormatError("nothing to render: no commands")
    for i, c in enumerate(items):
        if not isinstance(c, Command):
            raise FormatError(f"commands[{i}]: expected a Command, got {type(c).__name__}")
    return items


def settings_of(commands: Sequence[Command]) -> AlinkSettings | None:
    """The settings `commands` program, or None when they are not exactly the five
    settings commands (a file may hold other commands)."""
    try:
        return settings_from_commands(commands)
    except StepRampError:
        return None


def document(commands: Sequence[Command], header: dict[str, Any] | None = None
             ) -> dict[str, Any]:
    """The JSON document of `commands`: `settings_document` when they program settings
    (else the commands alone), `header` holding the summary and warnings."""
    header = dict(header or {})
    warnings = header.pop("warnings", [])
    settings = settings_of(commands)
    if settings is None:
        return {**header, "warnings": list(warnings), "commands": command_rows(commands)}
    return settings_document(settings, commands, summary=header, warnings=warnings)


def _crc_comment(items: Sequence[Command]) -> str:
    payload = payload_of(c.words for c in items)
    return (f"# crc32 {crc_hex(payload)}: CRC-32 of the {3 * len(items)} command words above "
            f"(16-bit little-endian, {len(payload)} bytes)")


# --- text -------------------------------------------------------------------------------------
def _render_text(commands: Sequence[Command], options: RenderOptions) -> bytes:
    items = _commands(commands)
    doc = document(items, dict(options.header))
    lines = []
    if "multiplier" in doc:
        lines.append(f"multiplier ×{doc['multiplier']}: start {doc['start_pps']} pps, high "
                     f"{doc['high_pps']} pps, UP_TIME para {doc['up_time_para']} "
                     f"({doc['accel_ms_per_kpps']:g} ms/kpps = {doc['accel_pps2']:.6g} pps²)")
    for key in SUMMARY_KEYS:
        if doc.get(key) is not None:
            lines.append(f"{key}: {doc[key]:.6g}")
    if isinstance(doc.get("homing"), dict):  # `alink homing`: the plan and its model
        h = doc["homing"]
        lines += [f"homing: OL {h['ol_pps']} pps, OH {h['oh_pps']} pps, O_UPTIME para "
                  f"{h['o_uptime_para']} ({h['accel_pps2']:.6g} pps²); bound by {h['binds']}",
                  f"homing_model: {h['model']}"]
    lines += [f"warning: {w}" for w in doc["warnings"]]
    lines += [f"{c.name:10s} func {c.func:2d} para {c.para:8d}  "
              + " ".join(f"0x{w:04X}" for w in c.words) for c in items]
    lines.append(_crc_comment(items))
    return ("\n".join(lines) + "\n").encode("utf-8")


_ROW = re.compile(r"\s*([A-Z][A-Z0-9_]*)\s+func\s+(\d{1,9})\s+para\s+(-?\d{1,12})\s+"
                  r"0x([0-9A-Fa-f]{4})\s+0x([0-9A-Fa-f]{4})\s+0x([0-9A-Fa-f]{4})\s*\Z")
_SUMMARY = re.compile(r"\s*(multiplier ×|warning: |[a-z][a-z0-9_]*: )")


def _parse_text(raw: bytes) -> Parsed[Command]:
    lines, comments = content_lines(raw)
    rows: list[tuple[str, Words, tuple[str, int, int]]] = []
    for number, content in lines:
        m = _ROW.match(content)
        if m:
            words = (int(m.group(4), 16), int(m.group(5), 16), int(m.group(6), 16))
            rows.append((f"line {number}", words, (m.group(1), int(m.group(2)),
                                                    int(m.group(3)))))
        elif not _SUMMARY.match(content):
            raise DecodeError(f"line {number}: neither a command row (NAME func F para P "
                              "0xCMD 0xPARAM1 0xPARAM2) nor a settings line")
    return _parsed("text", rows, find_crc_comment(comments), "the crc32 comment")


def _parsed(fmt: str, rows: Sequence[tuple[str, Words, tuple[str, int, int] | None]],
            claimed: str | None, where: str,
            addresses: Sequence[int | None] | None = None) -> Parsed[Command]:
    """Commands from word triples: the CRC first (a changed word is `corrupted`), then
    each triple decoded and checked against what its row says beside it."""
    if not rows:
        raise DecodeError("the settings file holds no commands")
    integrity, detail = verify_crc(payload_of(w for _, w, _ in rows), claimed, where)
    out = []
    for k, (at, words, said) in enumerate(rows):
        try:
            cmd, func, para, pair = parse_command(*words)
        except StepRampError as e:
            raise DecodeError(f"{at}: {e}") from None
        name = command_name(cmd)
        if said is not None and said != (name, func, para):
            raise CorruptedError(f"{at} says {said[0]} func {said[1]} para {said[2]}, its words "
                                 f"encode {name} func {func} para {para}")
        address = None if addresses is None else addresses[k]
        out.append(Command(name, cmd, func, para, words, pair, address))
    return Parsed(out, fmt, integrity, detail)


def _looks_like_text(raw: bytes) -> bool:
    line = first_content_line(raw)
    return bool(_ROW.match(line) or _SUMMARY.match(line)
                or (line.startswith("#") and _ROW.match(_first_row_line(raw))))


def _first_row_line(raw: bytes) -> str:
    for line in raw[:4096].decode("utf-8", errors="replace").splitlines():
        content = line.partition("#")[0].strip()
        if content:
            return content
    return ""


# --- hex --------------------------------------------------------------------------------------
def _render_hex(commands: Sequence[Command], options: RenderOptions) -> bytes:
    items = _commands(commands)
    lines = [" ".join(f"{w:04X}" for w in c.words) for c in items]
    lines.append(_crc_comment(items))
    return ("\n".join(lines) + "\n").encode("ascii")


_HEX_ROW = re.compile(r"\s*([0-9A-Fa-f]{4})\s+([0-9A-Fa-f]{4})\s+([0-9A-Fa-f]{4})\s*\Z")


def _hex_rows(raw: bytes) -> tuple[list[tuple[str, Words, None]], list[str]]:
    lines, comments = content_lines(raw)
    rows: list[tuple[str, Words, None]] = []
    for number, content in lines:
        m = _HEX_ROW.match(content)
        if not m:
            raise DecodeError(f"line {number}: a command is three 4-digit hex words "
                              "(CMD PARAM1 PARAM2)")
        rows.append((f"line {number}", (int(m.group(1), 16), int(m.group(2), 16),
                                        int(m.group(3), 16)), None))
    return rows, comments


def _parse_hex(raw: bytes) -> Parsed[Command]:
    rows, comments = _hex_rows(raw)
    return _parsed("hex", rows, find_crc_comment(comments), "the crc32 comment")


def _looks_like_hex(raw: bytes) -> bool:
    return bool(_HEX_ROW.match(_first_row_line(raw)))


# --- JSON -------------------------------------------------------------------------------------
def _render_json(commands: Sequence[Command], options: RenderOptions) -> bytes:
    items = _commands(commands)
    doc = document(items, dict(options.header))
    doc["crc32"] = crc_hex(payload_of(c.words for c in items))
    return (json.dumps(doc, indent=1) + "\n").encode("ascii")


def _word(value: object, where: str) -> int:
    if isinstance(value, str) and re.fullmatch(r"(0x)?[0-9A-Fa-f]{1,4}", value):
        return int(value, 16)
    if isinstance(value, int) and not isinstance(value, bool) and 0 <= value <= 0xFFFF:
        return value
    raise FormatError(f"{where}: {echo(value)} is not a 16-bit word (\"0x4115\")")


def _json_rows(obj: object) -> tuple[list[tuple[str, Words, tuple[str, int, int] | None]],
                                     list[int | None]]:
    if not isinstance(obj, dict) or not isinstance(obj.get("commands"), list) \
            or "blocks" in obj or "packets" in obj:
        raise FormatError('a JSON settings file is {…, "commands": [{"name": …, "words": '
                          '["0x4115", "0x4000", "0x4000"]}, …], "crc32": "…"}')
    rows: list[tuple[str, Words, tuple[str, int, int] | None]] = []
    addresses: list[int | None] = []
    for i, c in enumerate(obj["commands"]):
        where = f"commands[{i}]"
        if not isinstance(c, dict) or not isinstance(c.get("words"), list) \
                or len(c["words"]) != 3:
            raise FormatError(f"{where}: expected {{\"words\": [CMD, PARAM1, PARAM2], …}}")
        w0, w1, w2 = (_word(w, f"{where}.words[{k}]") for k, w in enumerate(c["words"]))
        said = None
        if {"name", "func", "para"} <= set(c):
            said = (c["name"], c["func"], c["para"])
        if "cmd" in c and said is not None and c["cmd"] != (w0 & 0xFF):
            raise CorruptedError(f"{where}: cmd {echo(c['cmd'])}, its words encode "
                                 f"0x{w0 & 0xFF:02X}")
        address = c.get("address")
        if address is not None:
            address = _word(address, f"{where}.address")
        rows.append((where, (w0, w1, w2), said))
        addresses.append(address)
    return rows, addresses


def _parse_json(raw: bytes) -> Parsed[Command]:
    obj = parse_json(raw, "the JSON settings file")
    rows, addresses = _json_rows(obj)
    assert isinstance(obj, dict)
    claimed = obj.get("crc32")
    if claimed is not None and (not isinstance(claimed, str)
                                or not re.fullmatch(r"[0-9A-Fa-f]{8}", claimed)):
        raise CorruptedError(f"crc32: {echo(claimed)} is not 8 hex digits")
    parsed = _parsed("json", rows, claimed, "the crc32 field", addresses)
    said = {k: obj[k] for k in SETTINGS_KEYS if k in obj}
    if said:  # the settings the document states must be the ones its words program
        try:
            settings = settings_from_commands(parsed.items)
        except StepRampError as e:
            raise CorruptedError(f"the document states settings ({', '.join(said)}) but its "
                                 f"commands program none ({e})") from None
        actual = settings_document(settings, [])
        for key, value in said.items():
            if value != actual[key]:
                raise CorruptedError(f"{key} says {echo(value)}, the commands set "
                                     f"{echo(actual[key])}")
    return parsed


def _looks_like_json(raw: bytes) -> bool:
    return first_content_line(raw).startswith("{")


# --- C ----------------------------------------------------------------------------------------
def c_symbols(commands: Sequence[Command], name: str) -> list[str]:
    """The C declarations of one command list, every symbol prefixed by `name`
    (NAME_COMMAND_COUNT, NAME_CRC32, NAME_words[N][3]): a header holds one
    (`--format c`) or several (one per axis, `render_c_set`)."""
    items = _commands(commands)
    name = c_name(name)
    macro = name.upper()
    # The separating comma goes before each row's comment: "}, /* … */," is not C.
    last = len(items) - 1
    rows = [f"    {{{', '.join(f'0x{w:04X}' for w in c.words)}}}" + ("," if i < last else " ")
            + f"  /* {c.name} func {c.func} para {c.para} */" for i, c in enumerate(items)]
    return [f"#define {macro}_COMMAND_COUNT {len(items)}",
            f"#define {macro}_CRC32 0x{crc_hex(payload_of(c.words for c in items))}UL",
            f"static const uint16_t {name}_words[{macro}_COMMAND_COUNT][3] = {{", *rows, "};"]


def _payload_line(items: Sequence[Command], name: str) -> str:
    payload = payload_of(c.words for c in items)
    return (f"payload: {len(items)} commands, {len(payload)} bytes, CRC-32 "
            f"{crc_hex(payload)} (zlib/IEEE 802.3 over the words in order, 16-bit "
            f"little-endian: the array's bytes on a little-endian host; {name.upper()}_CRC32)")


_SEND = ("Send the commands in order (CMD, PARAM1, PARAM2), each after the answer to the "
         "one before.")


def _render_c(commands: Sequence[Command], options: RenderOptions) -> bytes:
    items = _commands(commands)
    name = c_name(C_NAME_DEFAULT if options.name is None else options.name)
    settings = settings_of(items)
    prov = options.provenance
    what = ("" if settings is None else
            f": start {settings.start_pps} pps, high {settings.high_pps} pps, multiplier "
            f"{settings.multiplier}, UP_TIME para {settings.accel_para}")
    kind = "commands" if settings is None else "settings"  # a command list, or settings
    comment = [f"A-Link ALUM {kind} generated by {prov.tool}{what}.", _SEND,
               *([f"command: {prov.command}"] if prov.command else []), *prov.lines,
               _payload_line(items, name)]
    return c_header(comment, name, c_symbols(items, name))


def render_c_set(sets: Sequence[tuple[str, Sequence[Command], str]],
                 options: RenderOptions) -> bytes:
    """One C header holding several command lists (name, commands, a comment line), each
    with its own prefix and CRC-32 (`parse_c_set` reads them back, each verified); the
    include guard is `options.name`'s."""
    prov = options.provenance
    body: list[str] = []
    for name, commands, note in sets:
        body += [c_comment([note, _payload_line(_commands(commands), name)]),
                 *c_symbols(commands, name), ""]
    comment = [f"A-Link ALUM command words generated by {prov.tool}.", _SEND,
               *([f"command: {prov.command}"] if prov.command else []), *prov.lines]
    return c_header(comment, options.name or C_NAME_DEFAULT, body[:-1])


_C_ARRAY = re.compile(r"\b([A-Za-z][A-Za-z0-9_]*)_words\s*\[[^\]]*\]\s*\[\s*3\s*\]\s*=\s*\{")


def _parse_c(raw: bytes) -> Parsed[Command]:
    return _parse_c_words(text_of(raw), _C_ARRAY)


def parse_c_set(raw: bytes) -> dict[str, Parsed[Command]]:
    """Every command list of a C header of several (`render_c_set`) by prefix, each
    verified against its own CRC-32 (`CorruptedError` on a mismatch)."""
    text = text_of(raw)
    names = c_prefixes(text, _C_ARRAY)
    if not names:
        return {"": _parse_c_words(text, _C_ARRAY)}  # the one-line "none found" error
    return {name: _parse_c_words(text, re.compile(
        rf"\b({re.escape(name)})_words\s*\[[^\]]*\]\s*\[\s*3\s*\]\s*=\s*\{{"))
        for name in names}


def _parse_c_words(text: str, array: re.Pattern[str]) -> Parsed[Command]:
    name, body = c_rows(text, array, "NAME_words[N][3] = {{0x…, 0x…, 0x…}, …}")
    rows: list[tuple[str, Words, None]] = []
    for k, row in enumerate(body):
        where = f"{name}_words[{k}]"
        values = c_values(row, where, 0xFFFF)
        if len(values) != 3:
            raise DecodeError(f"{where}: {len(values)} values, a command is 3 words")
        rows.append((where, (values[0], values[1], values[2]), None))
    macro = name.upper()
    count = c_define(text, f"{macro}_COMMAND_COUNT")
    if count is not None and int(count) != len(rows):
        raise CorruptedError(f"{macro}_COMMAND_COUNT is {count}, the header holds {len(rows)} "
                             "commands")
    return _parsed("c", rows, c_crc(text, macro), f"{macro}_CRC32")


# --- the table ----------------------------------------------------------------------------------
FORMATS: FormatTable[Command] = FormatTable("A-Link settings", [
    Format("json", "the settings document with the commands' words and a crc32 field",
           (".json",), _render_json, _parse_json, _looks_like_json),
    Format("c", "C header NAME_words[N][3] (symbols prefixed by --name, CRC-32 constant)",
           (".h", ".c"), _render_c, _parse_c, looks_like_c),
    Format("hex", "one command a line, three 4-digit hex words (CRC-32 comment)",
           (".hex",), _render_hex, _parse_hex, _looks_like_hex),
    Format("text", "settings, summary and one command a line with its words (CRC-32 "
           "comment)", (".txt",), _render_text, _parse_text, _looks_like_text),
])
SETTINGS_FORMATS = tuple(FORMATS.names)


def render(commands: Sequence[Command], fmt: str, options: RenderOptions | None = None
           ) -> bytes:
    """The settings file of `commands` in format `fmt` (`options.header`: summary keys
    and "warnings" for text and JSON)."""
    return FORMATS.render(commands, fmt, options)


def parse(data: bytes, path: str | Path | None = None, fmt: str | None = None
          ) -> Parsed[Command]:
    """The commands of a settings file in any format, told apart by content, with what
    its check said (`CorruptedError` on a mismatch)."""
    return FORMATS.parse(data, path, fmt)


def render_settings(doc: dict[str, Any], fmt: str, options: RenderOptions | None = None
                    ) -> str:
    """A `settings_document` as a file of the table (text, json, hex or c)."""
    commands = commands_of_document(doc)
    header = {k: v for k, v in doc.items() if k not in (*SETTINGS_KEYS, "commands", "crc32")}
    return render(commands, fmt, replace(options or RenderOptions(), header=header)
                  ).decode("utf-8")


def commands_of_document(doc: dict[str, Any]) -> list[Command]:
    """The `Command`s a `settings_document` lists (decoded from their words)."""
    rows, addresses = _json_rows(doc)
    return list(_parsed("document", rows, None, "", addresses).items)


def is_settings_file(raw: bytes) -> bool:
    """Whether `raw` is an A-Link settings file of the table, to tell the devices' files
    apart (nothing is verified here): JSON by its "commands" list, C by its
    NAME_words[N][3] array, text by its command rows, hex by lines of three 4-digit
    words that decode as commands (a PPMC-312 text upload has 2-digit bytes)."""
    try:
        fmt = FORMATS.detect(raw).name
        if fmt == "json":
            obj = parse_json(raw, "the file")
            return isinstance(obj, dict) and isinstance(obj.get("commands"), list) \
                and not {"blocks", "packets", "format"} & set(obj)
        if fmt == "c":
            return _C_ARRAY.search(text_of(raw)) is not None
        if fmt == "text":
            return any(_ROW.match(content) for _, content in content_lines(raw)[0])
        rows, _ = _hex_rows(raw)
        for _, words, _ in rows:
            parse_command(*words)
    except StepRampError:
        return False
    return True

__all__ = ["FORMATS", "SETTINGS_FORMATS", "c_symbols", "commands_of_document", "document",
           "is_settings_file", "parse", "parse_c_set", "payload_of", "render", "render_c_set",
           "render_settings", "settings_of"]
