"""What `stepramp sync` writes into its folder: each device's files (through its format
table, each with its check: profiles/<device>/sync/files.py) and report.json (a document,
no device takes it: no check)."""

from __future__ import annotations

import json
from collections.abc import Sequence
from typing import Any

from ..devices import get

REPORT_FILE = "report.json"


def output_names(names: Sequence[str], device: str) -> list[str]:
    """The names of every file sync writes into its folder for axes `names`."""
    return [*get(device).sync_module().output_names(names), REPORT_FILE]


def check_axis_names(names: Sequence[str], device: str) -> None:
    """Refuse axis names the device's files cannot carry, before any planning."""
    get(device).sync_module().check_axis_names(names)


def plan_files(plan: Any, device: str, report: dict[str, Any], *,
               command: str | None = None) -> dict[str, bytes]:
    """Every file of `plan` by name: the device's, and report.json."""
    files = get(device).sync_module().sync_files(plan, command=command)
    files[REPORT_FILE] = (json.dumps(report, indent=1) + "\n").encode()
    return files
