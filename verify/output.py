"""Output at the edge: write a file whole or not at all."""

from __future__ import annotations

import contextlib
import os
import sys
import tempfile
from collections.abc import Iterable
from pathlib import Path

from profiles.errors import FormatError


def write_output(out: str | None, data: str | bytes | Iterable[bytes]) -> None:
    """Write to `out` atomically (temp file + rename), or to stdout when `out` is None/'-'.

    `data` may be an iterable of byte chunks (a stream), written as it comes: memory
    stays one chunk. A failure half-way leaves no file behind: the temp file is removed.
    """
    if out is None or out == "-":
        if isinstance(data, str):
            sys.stdout.write(data)
            return
        for chunk in [data] if isinstance(data, bytes) else data:
            sys.stdout.buffer.write(chunk)
        sys.stdout.buffer.flush()
        return
    path = Path(out)
    directory = path.parent if str(path.parent) else Path(".")
    if not directory.is_dir():
        raise FormatError(f"{out}: the folder {directory} does not exist")
    fd, tmp = tempfile.mkstemp(prefix=f".{path.name}.", dir=directory)
    try:
        with os.fdopen(fd, "wb") as fh:
            if isinstance(data, str | bytes):
                fh.write(data.encode() if isinstance(data, str) else data)
            else:
                for chunk in data:
                    fh.write(chunk)
        os.replace(tmp, path)
    except BaseException:
        with contextlib.suppress(OSError):
            os.unlink(tmp)
        raise
