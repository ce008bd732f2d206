"""A finding: one thing a check has to say about a table, upload or plan."""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any, Literal

Severity = Literal["error", "warning"]


@dataclass(frozen=True)
class Finding:
    """`error`: the chip rejects it or the motor cannot run it; `warning`: legal but suspect.

    `rule` is a stable kebab-case id, `chip_code` the chip's own parameter-error
    code where it has one, `stage` an index into the table's fastest-first lists
    (None when the finding is about the whole table), and `message` says what to
    change, with numbers.
    """

    severity: Severity
    rule: str
    message: str
    chip_code: int | None = None
    stage: int | None = None

    @property
    def chip_code_hex(self) -> str | None:
        return None if self.chip_code is None else f"0x{self.chip_code:02X}"

    def to_json(self) -> dict[str, Any]:
        return {"severity": self.severity, "rule": self.rule, "chip_code": self.chip_code_hex,
                "stage": self.stage, "message": self.message}
