"""File formats: one `Format` record per format, one `FormatTable` per device.

Learned from cantools (`database/can/formats/`: one module per format, each with
load and dump, dispatched from one table): a device module lists its formats in
a `FormatTable`; each `Format` has a `render` (items → file bytes) and a `parse`
(file bytes → items), so every file stepramp writes can be read back and
checked. `FormatTable.detect` tells the formats apart by content (the file
name's extension only breaks ties).

Integrity. The device protocols carry little or no check (the PPMC-312
parallel upload none at all), so the files carry one the wire lacks:
a CRC-32 of the payload in the text formats (a comment line), JSON (a field)
and C (a comment and a constant), Intel HEX its record checksums. `parse`
verifies it and raises `CorruptedError` on a mismatch; a file without one
(hand-made) parses with `Parsed.integrity == "absent"`, for a warning. Raw
binary has no room for a check (it must be exactly the bytes the device
takes): `integrity == "none"`.

The helpers below (CRC-32, hex text, Intel HEX, C identifiers, provenance) are
shared by the device tables.

Streams. A format may also render chunk-wise (`Format.render_chunks`: the
payload's bytes in chunks → the file's bytes in chunks), for files of millions
of items (an MC-200 stream) whose memory must not grow with their length; its
CRC-32 is then computed as the chunks go (`RunningCrc`) and written at the end.
`render` of such a format is its `render_chunks` of the whole payload (`chunked`),
so the two can never disagree.
"""

from .c_header import (
    C_KEYWORDS,
    C_NAME_MAX,
    c_comment,
    c_crc,
    c_define,
    c_header,
    c_name,
    c_name_for,
    c_prefixes,
    c_rows,
    c_values,
    looks_like_c,
)
from .crc import (
    Integrity,
    RunningCrc,
    crc32,
    crc_comment,
    crc_hex,
    find_crc_comment,
    verify_crc,
)
from .hex_text import hex_bytes, hex_line
from .ihex import (
    IHEX_ADDRESS_MAX,
    IHEX_RECORD_BYTES,
    looks_like_ihex,
    parse_ihex,
    render_ihex,
    render_ihex_chunks,
)
from .table import (
    ChunkRender,
    Format,
    FormatTable,
    Parsed,
    Provenance,
    RenderOptions,
    chunked,
    tool_version,
)
from .text import (
    TEXT_CHUNK_BYTES,
    content_lines,
    first_content_line,
    looks_like_binary,
    text_chunks,
    text_lines,
    text_of,
)

__all__ = [
    "C_KEYWORDS", "C_NAME_MAX", "IHEX_ADDRESS_MAX", "IHEX_RECORD_BYTES", "TEXT_CHUNK_BYTES",
    "ChunkRender", "Format", "FormatTable", "Integrity", "Parsed", "Provenance",
    "RenderOptions", "RunningCrc", "c_comment", "c_crc", "c_define", "c_header", "c_name",
    "c_name_for", "c_prefixes", "c_rows", "c_values", "chunked", "content_lines", "crc32",
    "crc_comment", "crc_hex", "find_crc_comment", "first_content_line", "hex_bytes",
    "hex_line", "looks_like_binary", "looks_like_c", "looks_like_ihex", "parse_ihex",
    "render_ihex", "render_ihex_chunks", "text_chunks", "text_lines", "text_of",
    "tool_version", "verify_crc",
]
