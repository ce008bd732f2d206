"""What the format tests of every device share: single-bit flips of a file, the
one-line parse errors, what every format reads from garbage, compiling C headers with the
system's compiler, `check`'s rules on a file, and A-Link command files to check."""

from __future__ import annotations

import shutil
import subprocess
from collections.abc import Callable, Iterable, Iterator
from pathlib import Path
from typing import Any

import pytest

from profiles.errors import DecodeError, FormatError, StepRampError

CC = shutil.which("gcc") or shutil.which("cc")
needs_cc = pytest.mark.skipif(CC is None, reason="no C compiler on this machine")


def flips(data: bytes) -> Iterator[bytes]:
    """`data` with one bit flipped, for every bit in turn."""
    for i in range(len(data)):
        for bit in range(8):
            yield data[:i] + bytes([data[i] ^ (1 << bit)]) + data[i + 1:]


def flip_verdicts(files: Iterable[tuple[bytes, Any]], read: Callable[[bytes], Any]
                  ) -> tuple[int, int]:
    """Flip every bit of every (file, what it reads as): each flipped file must be
    refused or read as the same thing, never as another. (refused, read the same)."""
    caught = same = 0
    for data, want in files:
        for flipped in flips(data):
            try:
                got = read(flipped)
            except StepRampError:
                caught += 1
                continue
            assert got == want
            same += 1
    return caught, same


def assert_one_line_error(read: Callable[[bytes], Any], data: bytes, words: str) -> None:
    """`read(data)` raises a one-line DecodeError or FormatError matching `words`."""
    with pytest.raises(StepRampError, match=words) as err:
        read(data)
    assert isinstance(err.value, DecodeError | FormatError)
    assert "\n" not in str(err.value)


def parsed_in_any_format(parse: Callable[..., Any], data: bytes,
                         formats: Iterable[str]) -> Iterator[list[Any]]:
    """The items `parse(data, fmt=…)` reads, by guess (fmt=None) and as each of `formats`,
    wherever it reads any: a StepRampError is a refusal, any other exception fails."""
    for fmt in (None, *formats):
        try:
            items = parse(data, fmt=fmt).items
        except StepRampError:
            continue
        yield items


def compile_and_run(folder: Path, files: dict[str, bytes], main_c: str
                    ) -> subprocess.CompletedProcess[str]:
    """Write the headers and main.c into `folder`, build with every warning an error,
    run the program; a failed build fails the test with the compiler's message."""
    assert CC is not None
    for name, data in files.items():
        (folder / name).write_bytes(data)
    (folder / "main.c").write_text(main_c)
    exe = folder / "replay"
    build = subprocess.run([CC, "-std=c99", "-Wall", "-Wextra", "-Werror", "-o", str(exe),
                            str(folder / "main.c")], capture_output=True, text=True,
                           timeout=60)
    assert build.returncode == 0, build.stderr
    return subprocess.run([str(exe)], capture_output=True, text=True, timeout=10)


def rules_of(path: Path) -> list[tuple[str, str]]:
    """`check_file`'s findings on `path` (read without error): (severity, rule) each."""
    from verify.check_file import check_file

    result = check_file(str(path))
    assert result.error is None, result.error
    return [(f.severity, f.rule) for f in result.findings]


def alink_file(tmp_path: Path, name: str, commands: list[Any], fmt: str = "hex") -> Path:
    """A-Link `commands` written as `fmt` into `tmp_path` / `name`."""
    from profiles.alink.formats import render

    path = tmp_path / name
    path.write_bytes(render(commands, fmt))
    return path
