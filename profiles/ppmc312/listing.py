"""A table's stages as a person reads them (`stepramp show`).

One row per stage in the order the move runs them from rest: the slowest stage
first, the fastest last. `stage` is the index into the table's fastest-first
lists (the number findings and the file use). Per side, a stage lasts
pulses × rate / clock; the cumulative time is that of this stage and every
slower one on the side: the time from rest to the end of the stage when
accelerating, and from its start down to rest when decelerating. An init table
lists the staircase `init_model` says the chip builds (`modelled` is True).
"""

from __future__ import annotations

import csv
import io
import json
from dataclasses import asdict, dataclass
from typing import Any

from ..errors import FieldRangeError, FormatError, echo
from ..motor.travel import AxisUnits
from .init_model import as_free_curve
from .table import RATE_FIELD_MAX, FreeCurveTable, InitTable

FORMATS = ("text", "json", "csv")


@dataclass(frozen=True)
class StageRow:
    stage: int
    rate: int
    speed_pps: float
    speed_rpm: float | None      # with a motor's steps per revolution
    accel_pulses: int | None     # None: the accel side has fewer stages
    accel_s: float | None
    accel_cum_s: float | None
    decel_pulses: int | None
    decel_s: float | None
    decel_cum_s: float | None
    # with a motor file's travel_mm_per_rev (profiles/motor/travel.py); listed only then
    speed_mm_s: float | None = None


@dataclass(frozen=True)
class StageListing:
    table: FreeCurveTable | InitTable
    stages: FreeCurveTable       # what the chip runs (the model's, for an init table)
    rows: tuple[StageRow, ...]   # slowest first
    # the axis's real units (with a motor): the ramps in mm or rev, a linear axis's
    # stages in mm/s too
    units: AxisUnits | None = None

    @property
    def linear(self) -> bool:
        return self.units is not None and self.units.linear

    @property
    def modelled(self) -> bool:
        return isinstance(self.table, InitTable)

    @property
    def accel_s(self) -> float:
        return _total(r.accel_s for r in self.rows)

    @property
    def decel_s(self) -> float:
        return _total(r.decel_s for r in self.rows)

    def to_json(self) -> dict[str, Any]:
        out: dict[str, Any] = {
            "kind": self.table.kind, "modelled": self.modelled,
            "clock": self.stages.clock.to_json(), "separate_decel": self.stages.separate,
            "accel_pulses": self.stages.accel_total, "decel_pulses": self.stages.decel_total,
            "accel_s": self.accel_s, "decel_s": self.decel_s,
            "stages": [self._row(r) for r in self.rows]}
        u = self.units
        if u is not None:  # the ramps' lengths in mm (or rev), beside their pulses
            out[f"accel_{u.distance_key}"] = u.distance(self.stages.accel_total)
            out[f"decel_{u.distance_key}"] = u.distance(self.stages.decel_total)
            if u.linear:
                out["travel_mm_per_rev"] = u.mm_per_rev
        if isinstance(self.table, InitTable):
            out["init"] = self.table.to_json()
        return out

    def _row(self, row: StageRow) -> dict[str, Any]:
        """A stage's JSON object (`speed_mm_s` only on a linear axis)."""
        out = asdict(row)
        if not self.linear:
            del out["speed_mm_s"]
        return out

    def to_csv(self) -> str:
        buf = io.StringIO()
        writer = csv.writer(buf, lineterminator="\n")
        names = [n for n in StageRow.__dataclass_fields__ if self.linear or n != "speed_mm_s"]
        writer.writerow(names)
        for r in self.rows:
            writer.writerow(["" if v is None else repr(v) if isinstance(v, float) else v
                             for v in (getattr(r, n) for n in names)])
        return buf.getvalue()

    def to_text(self) -> str:
        s = self.stages
        u = self.units
        acc, dec = ((f" ({u.distance_text(s.accel_total)})", f" ({u.distance_text(s.decel_total)})")
                    if u is not None else ("", ""))
        head = (f"{'init' if self.modelled else 'free-curve'} table, clock {s.clock.name}, "
                f"{len(s.rates)} stages: accel {s.accel_total} pulses{acc} in "
                f"{self.accel_s * 1e3:.6g} ms, decel {s.decel_total} pulses{dec} in "
                f"{self.decel_s * 1e3:.6g} ms"
                + ("" if s.separate else " (decel counts = accel counts)"))
        lines = [head]
        if isinstance(self.table, InitTable):
            t = self.table
            lines.append(f"init parameters: {t.shape}, start rate {t.start_rate}, high rate "
                         f"{t.high_rate}, accel {t.accel_pulses} pulses"
                         + (f", stop rate {t.stop_rate}, decel {t.decel_pulses} pulses"
                            if t.separate else ""))
            lines.append("the stages below are modelled: the staircase the chip is modelled "
                         "to build (docs/manual-notes.md), not read from the chip")
        rpm = any(r.speed_rpm is not None for r in self.rows)
        mm = self.linear
        cols = ["stage", "rate", "speed [pps]"] + (["speed [rpm]"] if rpm else []) + (
            ["speed [mm/s]"] if mm else []) + [
            "accel pulses", "accel [ms]", "accel cum [ms]",
            "decel pulses", "decel [ms]", "decel cum [ms]"]
        table = [cols]
        for r in self.rows:
            table.append([str(r.stage), str(r.rate), f"{r.speed_pps:.6g}"]
                         + ([_num(r.speed_rpm)] if rpm else [])
                         + ([_num(r.speed_mm_s)] if mm else [])
                         + [_num(r.accel_pulses), _ms(r.accel_s), _ms(r.accel_cum_s),
                            _num(r.decel_pulses), _ms(r.decel_s), _ms(r.decel_cum_s)])
        widths = [max(len(row[i]) for row in table) for i in range(len(cols))]
        lines += ["  ".join(c.rjust(w) for c, w in zip(row, widths, strict=True))
                  for row in table]
        return "\n".join(lines) + "\n"

    def render(self, fmt: str) -> str:
        if fmt == "json":
            return json.dumps(self.to_json(), indent=1) + "\n"
        if fmt == "csv":
            return self.to_csv()
        if fmt == "text":
            return self.to_text()
        raise FormatError(f"format: {echo(fmt)} is not one of {', '.join(FORMATS)}")


def list_stages(table: FreeCurveTable | InitTable, steps_per_rev: int | None = None,
                units: AxisUnits | None = None) -> StageListing:
    """The per-stage listing of `table`; `steps_per_rev` adds each stage's speed in rpm,
    `units` of a linear axis (a motor file's travel_mm_per_rev) its speed in mm/s and the
    ramps' lengths in mm."""
    stages = as_free_curve(table)
    hz = stages.clock.hz
    for i, rate in enumerate(stages.rates):
        if rate < 1:  # a rate divides the clock: 0 has no speed (the chip wants ≥ 2, code 18)
            raise FieldRangeError(f"rates[{i}]", rate, 1, RATE_FIELD_MAX)
    n = len(stages.rates)

    def side(pulses: tuple[int, ...]) -> tuple[list[float | None], list[float | None]]:
        dur: list[float | None] = [None] * n
        cum: list[float | None] = [None] * n
        ticks = 0
        for i in reversed(range(len(pulses))):  # slowest of the side first
            step = pulses[i] * stages.rates[i]
            ticks += step
            dur[i], cum[i] = step / hz, ticks / hz
        return dur, cum

    acc_s, acc_cum = side(stages.accel_pulses)
    dec_s, dec_cum = side(stages.decel)
    rows = tuple(
        StageRow(stage=i, rate=rate, speed_pps=hz / rate,
                 speed_rpm=None if steps_per_rev is None else hz / rate * 60 / steps_per_rev,
                 accel_pulses=_at(stages.accel_pulses, i), accel_s=acc_s[i],
                 accel_cum_s=acc_cum[i], decel_pulses=_at(stages.decel, i),
                 decel_s=dec_s[i], decel_cum_s=dec_cum[i],
                 speed_mm_s=units.speed(hz / rate) if units is not None and units.linear
                 else None)
        for i, rate in reversed(list(enumerate(stages.rates))))
    return StageListing(table, stages, rows, units)


def _at(seq: tuple[int, ...], i: int) -> int | None:
    return seq[i] if i < len(seq) else None


def _total(values: Any) -> float:
    return sum(v for v in values if v is not None)


def _num(v: float | int | None) -> str:
    if v is None:
        return "-"
    return str(v) if isinstance(v, int) else f"{v:.6g}"


def _ms(v: float | None) -> str:
    return "-" if v is None else f"{v * 1e3:.6g}"
