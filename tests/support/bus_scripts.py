"""Reading the PPMC-312 bus scripts `export --format bus` writes: where each block's
answer is read and where each block is issued."""

from __future__ import annotations


def read_groups(lines: list[str]) -> list[int]:
    """The index of each answer's first line (its MREF wait)."""
    return [k for k, line in enumerate(lines) if line.startswith("WAIT CSR.MREF")]


def header_lines(lines: list[str]) -> list[int]:
    """The line number (from 1) of each block's last DWR write: its header, which issues it."""
    out = []
    for k, line in enumerate(lines):
        if line.startswith("DWR") and (k + 1 == len(lines) or not lines[k + 1].startswith("DWR")):
            out.append(k + 1)
    return out
