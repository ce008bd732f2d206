"""C headers: symbol prefixes (`c_name`), whole headers with their include guard and
comment, and read back: the rows of a 2-D array, `#define` values, the CRC constant."""

from __future__ import annotations

import re
from collections.abc import Sequence
from pathlib import Path

from ..errors import CorruptedError, DecodeError, FormatError, echo
from .text import first_content_line

_C_IDENTIFIER = re.compile(r"[A-Za-z][A-Za-z0-9_]*\Z")
C_NAME_MAX = 40  # + "_block_lengths" stays within C99's 63 significant characters
C_KEYWORDS = frozenset("""auto break case char const continue default do double else enum
extern float for goto if inline int long register restrict return short signed sizeof static
struct switch typedef union unsigned void volatile while _Bool _Complex _Imaginary""".split())


def c_name(name: str, what: str = "--name") -> str:
    """`name` if it can prefix C symbols: a letter, then letters, digits, underscores;
    `what` names where it came from in the error."""
    if not isinstance(name, str) or not _C_IDENTIFIER.match(name) or name in C_KEYWORDS \
            or len(name) > C_NAME_MAX:
        raise FormatError(f"{what} {echo(name)}: a C prefix is a letter followed by letters, "
                          f"digits or underscores, at most {C_NAME_MAX} characters, not a C "
                          "keyword (e.g. x_axis)")
    return name


def c_header(comment: Sequence[str], name: str, body: Sequence[str],
             includes: Sequence[str] = ("stdint.h",)) -> bytes:
    """A whole C header: the comment, the include guard NAME_H, the includes, `body`."""
    macro = c_name(name).upper()
    return "\n".join([c_comment(comment), f"#ifndef {macro}_H", f"#define {macro}_H", "",
                      *(f"#include <{h}>" for h in includes), "", *body,
                      "", f"#endif /* {macro}_H */", ""]).encode("ascii")


def c_prefixes(text: str, array: re.Pattern[str]) -> list[str]:
    """The distinct symbol prefixes (`array`'s group 1) of a header, in order."""
    return list(dict.fromkeys(m.group(1) for m in array.finditer(text)))


def c_name_for(path: str | Path | None, default: str = "stepramp") -> str:
    """A C prefix from an output file name (`x-axis.upload.h` → `x_axis_upload`)."""
    if path is None:
        return default
    stem = Path(str(path)).name.split(".")[0]
    name = re.sub(r"[^A-Za-z0-9_]", "_", stem).strip("_")[:C_NAME_MAX]
    if not name or not name[0].isalpha() or name in C_KEYWORDS:
        return default
    return name


def c_comment(lines: Sequence[str]) -> str:
    """A C block comment holding `lines` (made ASCII, never closing early)."""
    safe = [line.encode("ascii", "backslashreplace").decode("ascii").replace("*/", "* /")
            for line in lines]
    return "/* " + "\n * ".join(safe) + "\n */"


def c_values(row: str, where: str, hi: int) -> list[int]:
    """The integers of one C initializer list (`0x12, 7, …`; a `u` suffix allowed),
    each 0..`hi`; errors name `where`."""
    values = []
    for t in (t.strip() for t in row.split(",")):
        if not t:
            continue
        try:
            value = int(t.rstrip("uU"), 0)
        except ValueError:
            raise DecodeError(f"{where}: {echo(t)} is not a C integer") from None
        if not 0 <= value <= hi:
            raise DecodeError(f"{where}: {t} is not a " + ("byte (0..0xFF)" if hi == 0xFF else
                                                            f"{hi.bit_length()}-bit word"))
        values.append(value)
    return values


_C_ROW = re.compile(r"\{([^{}]*)\}")


def c_rows(text: str, array: re.Pattern[str], example: str) -> tuple[str, list[str]]:
    """The prefix (`array`'s group 1) and the rows `{…}` of the first 2-D array
    `array` finds in a C header, comments dropped; `example` shows what was looked for."""
    m = array.search(text)
    if m is None:
        raise DecodeError(f"a C header declares {example} (as stepramp writes); none found")
    end = text.find("};", m.end())
    if end < 0:
        raise CorruptedError(f"{m.group(1)}: the array is not closed by '}};': the file is "
                             "truncated")
    body = re.sub(r"/\*.*?\*/", "", text[m.end():end], flags=re.S)
    return m.group(1), [row.group(1) for row in _C_ROW.finditer(body)]


def c_define(text: str, macro: str, value: str = r"(\d+)\b") -> str | None:
    """The value of the last `#define MACRO value` in `text` (`value`: its regex with one
    group), if any."""
    found = None
    for m in re.finditer(rf"#define\s+{re.escape(macro)}\s+{value}", text):
        found = m.group(1)
    return found


def c_crc(text: str, macro: str) -> str | None:
    """The CRC-32 a header's `#define MACRO_CRC32 0x…UL` gives, as 8 hex digits."""
    found = c_define(text, f"{macro}_CRC32", r"0x([0-9A-Fa-f]{1,8})[uUlL]*\b")
    return None if found is None else f"{int(found, 16):08X}"


def looks_like_c(raw: bytes) -> bool:
    line = first_content_line(raw)
    return line.startswith(("/*", "//", "#ifndef", "#include", "#define", "#pragma",
                            "static ", "const "))
