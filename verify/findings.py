"""A finding: one thing a check has to say about a table, upload or plan."""

from __future__ import annotations

import math
import re
from collections.abc import Callable
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


# --- what a report needs to rank findings of one rule ---------------------------------------
# Findings carry no numbers besides their stage: the move and the shortfall are read back
# from the messages verify.criterion writes (tests/verify/test_report.py pins them on real findings,
# so a change of wording there fails a test instead of silently unranking a report).
_NUMBER = r"([0-9.]+(?:e[+-]?[0-9]+)?)"
_MOVE = re.compile(r"shortest move that runs it: (\d+) pulses")
_NEED_GIVES = re.compile(rf"needs {_NUMBER} pps², the motor gives {_NUMBER} pps²")
_JUMP = re.compile(rf"\(\+{_NUMBER}\), above the largest jump {_NUMBER} pps")
_TOP = re.compile(rf"runs {_NUMBER} pps, above the motor's top usable speed {_NUMBER} pps")
_START = re.compile(rf"\({_NUMBER} pps\), above the start speed {_NUMBER} pps")
_CANNOT = re.compile(r"the motor cannot (?:accel|decel)erate between .* at all")


def move_pulses(f: Finding) -> int | None:
    """The shortest move that runs the finding's problem [pulses], when it names one."""
    m = _MOVE.search(f.message)
    return int(m.group(1)) if m else None


def excess(f: Finding) -> float | None:
    """How far the finding is past its limit, need / capability (inf: the motor cannot make
    the step at all), when its message says; None for rules without such numbers."""
    text = f.message
    if _CANNOT.search(text):
        return math.inf
    for pattern in (_NEED_GIVES, _JUMP, _TOP, _START):
        m = pattern.search(text)
        if m:
            need, limit = float(m.group(1)), float(m.group(2))
            return need / limit if limit > 0 else math.inf
    return None
