"""The command families a table's verdict reports besides its moves and decel stops (issue
31 item 4): constant (83), origin-search (10), origin-return (11), stop (80, and the /FL
/BL limits), change-speed (87), set-speed (88), each judged by the rotor model
(`profiles.ppmc312.command_angles`) and given to the one safety verdict
(`profiles.ppmc312.command_verdicts.FAMILIES`, `judge_safety(commands=…)`).

These commands run at a rate, or at a moment, the machine chooses: what a table owes them
is a safe way to run them, and what the user needs is how far that goes (the envelope).
So each family is:

- **safe** when the table leaves a way to run it below the 90° peak: constant runs,
  origin searches and immediate stops from its slowest rate, an immediate speed change
  of nothing at its top, an origin return at its high rate with its reversal; **within
  the aim** likewise within 75°. Past the peak: `command-envelope` error; past the aim:
  warning. A change-speed (87) always has a safe use (in a continuous run, where no decel
  point is kept): its §8-8 stop is reported, never a failure of the table.
- the **envelope** (JSON, and a note): the fastest rate a constant run or an origin
  search may use, the fastest rate an immediate stop or a /FL /BL limit keeps within the
  aim (and the 05 rate to set), the largest immediate speed change at the top, the speed
  a speed-up to the top leaves a counted move stopping from (§8-8), the origin return's
  reversal; over a tolerance box's corners too (`"box"`: what every corner allows).
  The worst angle and where are the table's own use: the command at the table's high
  rate.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import TYPE_CHECKING, Any

from profiles.findings import Finding
from profiles.motor.angles import PEAK_DEG
from profiles.verdict import envelope_findings

if TYPE_CHECKING:
    from profiles.motor import Motor
    from profiles.ppmc312.command_angles import Family
    from profiles.ppmc312.table import FreeCurveTable

CODES = {"constant": "83", "origin-search": "10", "origin-return": "11", "stop": "80",
         "change-speed": "87", "set-speed": "88"}
TITLES = {"constant": "constant runs (83)", "origin-search": "origin searches (10)",
          "origin-return": "high-speed origin returns (11)",
          "stop": "immediate stops (80, /FL, /BL)", "change-speed": "speed changes (87)",
          "set-speed": "immediate speed changes (88)"}


@dataclass(frozen=True)
class FamilyVerdict:
    """One family's verdict on a table (module docstring); `family` None: not judged."""

    name: str
    aim_deg: float
    family: Family | None
    box: Family | None              # over the tolerance box's corners (None: no box)

    @property
    def judged(self) -> Family | None:
        """The family as the verdict counts it: over the box when there is one."""
        return self.box if self.box is not None else self.family

    @property
    def use_deg(self) -> float | None:
        """The angle of the use the table always leaves (no change at all, the return at
        its high rate, or the slowest rate), which the verdict counts; None: not judged, or
        a change-speed (87), which always has a safe use."""
        f = self.judged
        if f is None or self.name == "change-speed":
            return None
        e = f.envelope
        return (f.worst_deg if self.name == "origin-return" else
                float(e["no_change_deg" if self.name == "set-speed" else "slowest_rate_deg"]))

    def _usable(self, limit: float) -> bool:
        deg = self.use_deg
        if deg is None:
            return True
        return deg < limit if limit >= PEAK_DEG else deg <= limit

    @property
    def safe(self) -> bool:
        return self._usable(PEAK_DEG)

    @property
    def within_aim(self) -> bool:
        return self._usable(self.aim_deg)

    def describe(self) -> str:
        f = self.judged
        head = f"{TITLES[self.name]}"
        if f is None:
            return f"{head}: the load angle not judged"
        box = " over the tolerance box" if self.box is not None else ""
        return f"{head}{box}: {_envelope_text(self.name, f, self.aim_deg)}"

    def findings(self) -> list[Finding]:
        if self.judged is None:
            return []
        return envelope_findings("command-envelope", self.describe(), "this table",
                                 safe=self.safe, within_aim=self.within_aim,
                                 aim_deg=self.aim_deg)

    def to_json(self) -> dict[str, Any]:
        f = self.family
        return {"command": self.name, "code": CODES[self.name], "safe": self.safe,
                "within_aim": self.within_aim,
                **({} if f is None else f.to_json()),
                "box": None if self.box is None else self.box.to_json()}


def _envelope_text(name: str, f: Family, aim: float) -> str:
    """The envelope as a note says it, then the table's own use (worst and where)."""
    e = f.envelope
    own = f"; {f.where}: {f.worst_deg:.1f}°"
    if name in ("constant", "origin-search", "stop"):
        if e["fastest_rate"] is None:
            text = f"none within the {aim:g}° aim, even at rate {e['slowest_rate']}"
        else:
            text = (f"within the {aim:g}° aim at rate {e['fastest_rate']} "
                    f"({e['fastest_pps']:.6g} pps) and slower")
        if name == "stop" and e["high_speed_limit_rate"] is not None:
            text += (f"; set the high-speed limit (05) to {e['high_speed_limit_rate']} so "
                     "that /FHL, /BHL decelerate faster than that")
        return text + own
    if name == "set-speed":
        change = e["largest_change_pps"]
        return (f"none within the {aim:g}° aim at the top speed" if change is None else
                f"up to {change:.6g} pps at once at the top speed within the {aim:g}° aim") + own
    if name == "change-speed":
        if e["stops_from_pps"] is None:
            return f.where
        return (f"{f.where}: {f.worst_deg:.1f}°; change speed in a continuous run (85, 86), "
                "or not above a counted move's own high rate")
    return (f"reverses at once by {e['reversal_pps']:.6g} pps (the stop rate forward, the "
            f"start rate back)" + own)


def family_judge(name: str) -> Any:
    """The judge `profiles.ppmc312.command_verdicts.FAMILIES` takes for family `name`."""
    def judge(table: FreeCurveTable, motor: Motor, *, aim_deg: float, load_angle: bool,
              **_: Any) -> FamilyVerdict:
        return judge_family(name, table, motor, aim_deg=aim_deg, load_angle=load_angle)

    return judge


def judge_family(name: str, table: FreeCurveTable, motor: Motor, *, aim_deg: float,
                 load_angle: bool = True) -> FamilyVerdict:
    """Family `name`'s verdict on `table` for `motor` (over its box's corners too); the
    families of a table and motor are computed together once (`command_families`)."""
    from profiles.motor.tolerance import corners
    from profiles.ppmc312.command_angles import command_families

    if not load_angle:
        return FamilyVerdict(name, aim_deg, None, None)
    nominal = command_families(table, [motor], aim_deg=aim_deg)[name]
    box = None
    if motor.tolerances:
        box = command_families(table, [c.motor for c in corners(motor)], aim_deg=aim_deg)[name]
    return FamilyVerdict(name, aim_deg, nominal, box)


__all__ = ["CODES", "FamilyVerdict", "family_judge", "judge_family"]
