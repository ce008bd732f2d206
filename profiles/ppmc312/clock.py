"""PPMC-312 reference clocks: the CLK field and the frequency it selects.

speed_pps = clock.hz / rate (SPEC §1.1). EXTCK codes carry a user-supplied
frequency, since the chip only sees edges.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any

from ..errors import FieldRangeError, FormatError, echo, require_number

INTERNAL_HZ: dict[str, float] = {
    "8MHz": 8_000_000.0,
    "1MHz": 1_000_000.0,
    "500kHz": 500_000.0,
    "250kHz": 250_000.0,
    "62.5kHz": 62_500.0,
    "15.625kHz": 15_625.0,
}
_CODES = {name: code for code, name in enumerate(INTERNAL_HZ)}
EXTCK_RISING, EXTCK_FALLING = 6, 7
MAX_OUTPUT_PPS = 2_000_000.0  # never above 2 Mpps, whatever the clock (SPEC §1.1)


@dataclass(frozen=True)
class Clock:
    """A CLK setting: `code` is the 3-bit field, `hz` the frequency it gives."""

    code: int
    hz: float

    @property
    def external(self) -> bool:
        return self.code >= EXTCK_RISING

    @property
    def name(self) -> str:
        if self.external:
            edge = "rising" if self.code == EXTCK_RISING else "falling"
            return f"EXTCK {self.hz:g} Hz {edge}"
        return list(INTERNAL_HZ)[self.code]

    def speed_pps(self, rate: int | float) -> float:
        return self.hz / rate

    def to_json(self) -> str | dict[str, Any]:
        if self.external:
            return {"extck_hz": self.hz, "edge": "rising" if self.code == EXTCK_RISING
                    else "falling"}
        return self.name

    @classmethod
    def internal(cls, name: str) -> Clock:
        if name not in INTERNAL_HZ:
            raise FormatError(f"clock: {echo(name)} is not one of {', '.join(INTERNAL_HZ)}")
        return cls(_CODES[name], INTERNAL_HZ[name])

    @classmethod
    def named(cls, text: str) -> Clock:
        """An internal clock by name as a person types it: case and spaces are ignored
        ("8mhz", "62.5 KHz"). Table files keep the exact spelling (`internal`)."""
        key = text.replace(" ", "").lower() if isinstance(text, str) else None
        for name in INTERNAL_HZ:
            if name.lower() == key:
                return cls.internal(name)
        raise FormatError(f"clock: {echo(text)} is not one of {', '.join(INTERNAL_HZ)} "
                          "(any case)")

    @classmethod
    def extck(cls, hz: float, edge: str = "rising") -> Clock:
        require_number("clock.extck_hz", hz, 0, 20_000_000, lo_open=True)
        if edge not in ("rising", "falling"):
            raise FormatError(f"clock.edge: {echo(edge)} is not 'rising' or 'falling'")
        return cls(EXTCK_RISING if edge == "rising" else EXTCK_FALLING, float(hz))

    @classmethod
    def from_code(cls, code: int, extck_hz: float | None = None) -> Clock:
        """The clock a decoded CLK field selects; EXTCK needs its frequency from the user."""
        if 0 <= code < EXTCK_RISING:
            return cls(code, list(INTERNAL_HZ.values())[code])
        if code in (EXTCK_RISING, EXTCK_FALLING):
            if extck_hz is None:
                raise FormatError("the upload uses the external clock (EXTCK); its frequency "
                                  "is not in the bytes: give it (--extck-hz)")
            return cls.extck(extck_hz, "rising" if code == EXTCK_RISING else "falling")
        raise FieldRangeError("CLK", code, 0, 7)

    @classmethod
    def from_json(cls, obj: Any) -> Clock:
        if isinstance(obj, str):
            return cls.internal(obj)
        if isinstance(obj, dict):
            extra = set(obj) - {"extck_hz", "edge"}
            if extra or "extck_hz" not in obj:
                raise FormatError("clock: an external clock is {\"extck_hz\": F, \"edge\": "
                                  "\"rising\"|\"falling\"}" + (f"; unknown key(s) {sorted(extra)}"
                                                               if extra else ""))
            return cls.extck(obj["extck_hz"], obj.get("edge", "rising"))
        raise FormatError(f"clock: {echo(obj)} is neither a clock name nor an external clock "
                          "object")
