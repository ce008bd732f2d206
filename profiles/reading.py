"""Reading input files: one place that turns a path into bytes or JSON.

Every reader raises a one-line `FormatError` naming the file, never a traceback.
"""

from __future__ import annotations

import json
from pathlib import Path
from typing import Any

from .errors import FormatError


def read_bytes(path: str | Path) -> bytes:
    """A file's bytes; a missing, unreadable or empty file is a one-line FormatError."""
    p = Path(path)
    try:
        data = p.read_bytes()
    except FileNotFoundError:
        raise FormatError(f"{p}: no such file") from None
    except OSError as e:
        raise FormatError(f"{p}: cannot read ({e.__class__.__name__}: {e})") from None
    if not data.strip():
        raise FormatError(f"{p}: the file is empty")
    return data


def parse_json(data: bytes, path: str | Path) -> Any:
    """JSON from a file's bytes (read once); `path` names it in errors."""
    try:
        return json.loads(data.decode("utf-8"))
    except UnicodeDecodeError as e:
        raise FormatError(f"{path}: cannot read ({e.__class__.__name__}: {e})") from None
    except json.JSONDecodeError as e:
        raise FormatError(f"{path}: not valid JSON (line {e.lineno}, column {e.colno}: "
                          f"{e.msg})") from None


def read_json(path: str | Path) -> Any:
    return parse_json(read_bytes(path), path)
