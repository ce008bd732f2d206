"""A finding: one thing a check has to say about a table, upload, plan or any file of a
device; the shared noun every judge speaks in, wherever its rules live."""

from __future__ import annotations

from collections.abc import Callable, Iterable
from typing import Any, Literal, NoReturn

Severity = Literal["error", "warning"]


class Finding:
    """`error`: the chip rejects it or the motor cannot run it; `warning`: legal but suspect.

    `rule` is a stable kebab-case id, `chip_code` the chip's own parameter-error
    code where it has one, `stage` an index into the table's fastest-first lists
    (None when the finding is about the whole table), and `message` says what to
    change, with numbers.

    `message` may be given as a function that writes it: it is called once, when the
    message is first read. A check that finds many things (a random table has about
    nine short stages) then costs no string formatting until somebody reads the report
    (bench/bench_ppmc312.py). Findings are immutable and compare by their five values,
    the message included, so equal findings from two checks dedupe.
    """

    # Two slots, set once each: a check that finds many things builds a finding in
    # about 0.2 µs (five attributes of a frozen class cost twice that).
    __slots__ = ("_message", "_values")
    _values: tuple[Severity, str, int | None, int | None]
    _message: str | Callable[[], str]

    def __init__(self, severity: Severity, rule: str, message: str | Callable[[], str],
                 chip_code: int | None = None, stage: int | None = None) -> None:
        put = object.__setattr__  # immutable: __setattr__ refuses
        put(self, "_values", (severity, rule, chip_code, stage))
        put(self, "_message", message)

    @property
    def severity(self) -> Severity:
        return self._values[0]

    @property
    def rule(self) -> str:
        return self._values[1]

    @property
    def chip_code(self) -> int | None:
        return self._values[2]

    @property
    def stage(self) -> int | None:
        return self._values[3]

    @property
    def message(self) -> str:
        text = self._message
        if not isinstance(text, str):
            text = text()
            object.__setattr__(self, "_message", text)
        return text

    def _key(self) -> tuple[tuple[Severity, str, int | None, int | None], str]:
        return (self._values, self.message)

    def __eq__(self, other: object) -> bool:
        if not isinstance(other, Finding):
            return NotImplemented
        return self._key() == other._key()

    def __hash__(self) -> int:
        return hash(self._key())

    def __repr__(self) -> str:
        return (f"Finding(severity={self.severity!r}, rule={self.rule!r}, "
                f"message={self.message!r}, chip_code={self.chip_code!r}, "
                f"stage={self.stage!r})")

    def __setattr__(self, name: str, value: object) -> NoReturn:
        raise AttributeError(f"a Finding is immutable: cannot set {name}")

    def __delattr__(self, name: str) -> NoReturn:
        raise AttributeError(f"a Finding is immutable: cannot delete {name}")

    def __reduce__(self) -> tuple[type[Finding], tuple[Any, ...]]:
        # The message is written out: a function that writes it may not pickle (sweeps
        # send findings between processes).
        return (Finding, (self.severity, self.rule, self.message, self.chip_code, self.stage))

    def with_message(self, message: str) -> Finding:
        """The same finding saying `message` instead."""
        return Finding(self.severity, self.rule, message, self.chip_code, self.stage)

    @property
    def chip_code_hex(self) -> str | None:
        return None if self.chip_code is None else f"0x{self.chip_code:02X}"

    def to_json(self) -> dict[str, Any]:
        return {"severity": self.severity, "rule": self.rule, "chip_code": self.chip_code_hex,
                "stage": self.stage, "message": self.message}


def integrity_findings(prefix: str, fmt: str, integrity: str, detail: str) -> list[Finding]:
    """`PREFIX-unchecked` (a warning) for a file nothing vouches for; none for a verified
    one."""
    return ([] if integrity == "verified" else
            [Finding("warning", f"{prefix}-unchecked", f"{fmt} file: {detail}")])


def dedupe(findings: Iterable[Finding]) -> list[Finding]:
    """`findings` in order, each equal finding once (two checks may report the same)."""
    return list(dict.fromkeys(findings))
