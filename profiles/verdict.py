"""The one safety verdict's nouns: what every device's judge gives `verify.safety.judge_safety`
(issue 34 item 2: each device's judge lives in its own folder, beside its rules, and
speaks these, as it speaks `profiles.findings.Finding`).

- `SafetyVerdict`: the criterion's findings, the load angle's worst case (`LoadAngle`),
  the tolerance box's (`BoxVerdict`), resonance dwells and each command family's own
  verdict (a `CommandVerdict`), as one JSON object wherever a verdict is shown;
- `DEFAULT_SAMPLES`: the Monte Carlo samples of a motor's tolerance box unless told
  otherwise (check's and sweep's --samples, every judge's default).

Importable without numpy (the CLI reads `DEFAULT_SAMPLES` for its --help): the load
angle's landmarks are read where they are used.
"""

from __future__ import annotations

from collections.abc import Iterable
from dataclasses import dataclass
from typing import TYPE_CHECKING, Any, Protocol

from .findings import Finding

if TYPE_CHECKING:
    from .motor import Motor
    from .progress import Progress

# Monte Carlo samples of a motor's tolerance box, unless told otherwise: the default of
# check's and sweep's --samples and of the library's judges
DEFAULT_SAMPLES = 1000
CONFIDENCE = 0.95  # the stall probability's one-sided Clopper–Pearson bound


def _peak_deg() -> float:
    """The 90° peak (profiles.motor.angles), read on use: importing the motor loads numpy."""
    from .motor.angles import PEAK_DEG

    return PEAK_DEG


class JudgeOptions(Protocol):
    """What a device's file judge is told (`stepramp check`'s options,
    `verify.check_options.CheckOptions`): the motor whose verdict to add (None: the rules
    alone), the moves, the load angle or not, the tolerance box's samples and seed,
    resonance dwells as errors, progress, the motion commands judged; the external clock
    of EXTCK uploads and the clock of a table-read answer."""

    @property
    def motor(self) -> Motor | None: ...

    @property
    def extck_hz(self) -> float | None: ...

    @property
    def clock(self) -> str | None: ...

    @property
    def pulses(self) -> Iterable[int] | None: ...

    @property
    def physics(self) -> bool: ...

    @property
    def samples(self) -> int: ...

    @property
    def seed(self) -> int: ...

    @property
    def strict(self) -> bool: ...

    @property
    def progress(self) -> Progress | None: ...

    @property
    def commands(self) -> tuple[str, ...] | None: ...


class CommandVerdict(Protocol):
    """What every family's verdict gives the one safety verdict."""

    @property
    def safe(self) -> bool: ...

    @property
    def within_aim(self) -> bool: ...

    def findings(self) -> list[Finding]: ...

    def describe(self) -> str: ...

    def to_json(self) -> dict[str, Any]: ...



def require_aim(aim_deg: float) -> None:
    """Refuse a load-angle aim outside [1°, the 90° peak] (every device's judge asks)."""
    from .errors import FieldRangeError

    if not 1.0 <= aim_deg <= _peak_deg():
        raise FieldRangeError("load angle aim [°]", aim_deg, 1, _peak_deg())


@dataclass(frozen=True)
class LoadAngle:
    """The load-angle judge's worst case over what was judged."""

    worst_deg: float                     # |load angle|, electrical degrees
    worst_pulses: int                    # the move length where it happens
    worst_direction: int                 # 1 forward, −1 backward
    worst_at: str                        # "nominal", or the corner or sample of the box
    first_unstable_pulses: int | None    # the shortest move past the 90° peak
    slips: bool                          # some move slips a pole (≥ 180°)
    executions: int                      # (move, rotor) pairs integrated
    sample_failures: int = 0             # Monte Carlo samples past the 90° peak

    @property
    def margin_deg(self) -> float:
        """Distance of the worst angle to the 90° peak (negative: past it)."""
        return _peak_deg() - self.worst_deg

    @property
    def stable(self) -> bool:
        return self.worst_deg < _peak_deg() and self.sample_failures == 0

    def describe(self) -> str:
        way = "forward" if self.worst_direction > 0 else "backward"
        where = "" if self.worst_at == "nominal" else f" at {self.worst_at}"
        text = (f"worst load angle {self.worst_deg:.1f}° electrical ({way} move of "
                f"{self.worst_pulses} pulses{where}), margin {self.margin_deg:+.1f}° to the "
                f"90° peak")
        if self.first_unstable_pulses is not None:
            text += (f"; the rotor leaves the stable side of the torque–angle curve from moves "
                     f"of {self.first_unstable_pulses} pulses"
                     + (" and slips a pole" if self.slips else ""))
        if self.sample_failures:
            text += f"; {self.sample_failures} Monte Carlo samples past the peak"
        return text


@dataclass(frozen=True)
class BoxVerdict:
    """The load angle over a tolerance box."""

    worst_angle_deg: float           # over corners and samples
    worst_where: str                 # which corner or sample, with its parameters
    worst_pulses: int                # the move length there
    worst_direction: int             # 1 forward, −1 backward
    corners: int
    corner_worst_deg: float
    samples: int
    seed: int
    sample_worst_deg: float
    sample_failures: int             # samples past the 90° peak
    sampled_pulses: tuple[int, ...]  # the executions the samples were judged on
    stall_probability_upper: float   # Clopper–Pearson one-sided upper bound
    first_unstable_pulses: int | None
    slips: bool                      # some corner's move slips a pole
    executions: int                  # (move, rotor) pairs integrated

    @property
    def safe(self) -> bool:
        return self.worst_angle_deg < _peak_deg() and self.sample_failures == 0

    def describe(self) -> str:
        text = (f"tolerance box: {self.corners} corners over every move length"
                + (f", {self.samples} samples (seed {self.seed}) on the moves of "
                   f"{', '.join(map(str, self.sampled_pulses))} pulses" if self.samples else ""))
        if self.samples:
            text += (f"; {self.sample_failures} of {self.samples} samples past the 90° peak: "
                     f"stall probability < {self.stall_probability_upper:.3%} at "
                     f"{CONFIDENCE:.0%} (exact Clopper–Pearson bound)")
        return text

    def to_json(self) -> dict[str, object]:
        return {"worst_load_angle_deg": self.worst_angle_deg, "worst_at": self.worst_where,
                "worst_pulses": self.worst_pulses, "corners": self.corners,
                "corner_worst_deg": self.corner_worst_deg, "samples": self.samples,
                "seed": self.seed, "sample_worst_deg": self.sample_worst_deg,
                "sample_failures": self.sample_failures,
                "sampled_pulses": list(self.sampled_pulses),
                "stall_probability_upper": self.stall_probability_upper,
                "confidence": CONFIDENCE, "safe": self.safe}


@dataclass(frozen=True)
class SafetyVerdict:
    """Both judges over every execution (or the moves of `moves`), and the box."""

    moves: tuple[int, ...] | None        # None: every move length the chip can run
    aim_deg: float
    criterion: tuple[Finding, ...]       # the criterion's findings (errors)
    load_angle: LoadAngle | None         # None: not judged (asked not to, or the stages
    #                                      are out of order: the criterion says why)
    box: BoxVerdict | None               # over a tolerance box, else None
    resonance: tuple[Finding, ...]       # resonance dwells (errors with `strict`)
    # the motion commands' own verdicts (each device's families), by family name
    commands: tuple[tuple[str, CommandVerdict], ...] = ()

    @property
    def failed(self) -> tuple[str, ...]:
        """The judges that fail: "criterion", "load angle", "resonance" (strict only), and
        each command family whose own verdict fails ("decel-stop")."""
        out = []
        if any(f.severity == "error" for f in self.criterion):
            out.append("criterion")
        if self.load_angle is not None and not self.load_angle.stable:
            out.append("load angle")
        if any(f.severity == "error" for f in self.resonance):
            out.append("resonance")
        return tuple(out) + tuple(name for name, v in self.commands if not v.safe)

    @property
    def safe(self) -> bool:
        return not self.failed

    @property
    def within_aim(self) -> bool:
        """Every move, and every command family judged, within the aim."""
        return (self.load_angle is not None and self.load_angle.worst_deg <= self.aim_deg
                and all(v.within_aim for _, v in self.commands))

    def findings(self) -> list[Finding]:
        """The verdict as `check` reports it: the criterion's findings, `load-angle`
        (error) past the 90° peak or `load-angle-margin` (warning) past the aim, and the
        resonance dwells."""
        out = list(self.criterion)
        la = self.load_angle
        if la is not None and not la.stable:
            hint = ("; the criterion passes: the rotor rings after a step at this damping "
                    "(raise the counts around the steps, or lower the safety factor and plan "
                    "again)" if not self.criterion else "")
            out.append(Finding("error", "load-angle", la.describe() + hint))
        elif la is not None and la.worst_deg > self.aim_deg:
            out.append(Finding("warning", "load-angle-margin",
                               la.describe() + f" (stepramp plan aims at ≤ {self.aim_deg:g}°)"))
        return out + list(self.resonance) + [f for _, v in self.commands for f in v.findings()]

    def notes(self) -> list[str]:
        """What `check` notes beside the findings: the worst load angle (when no
        load-angle finding says it), the tolerance box's summary, and each command family
        with nothing to find (its findings say it otherwise), when the load angle was judged."""
        out = []
        if self.load_angle is not None and \
                not any(f.rule.startswith("load-angle") for f in self.findings()):
            out.append(self.load_angle.describe())
        if self.box is not None:
            out.append(self.box.describe())
        if self.load_angle is None:  # judged without the load angle: the criterion's alone
            return out
        return out + [v.describe() for _, v in self.commands if not v.findings()]

    def describe(self) -> str:
        """One paragraph: the verdict, which judge fails, the worst angle."""
        head = "SAFE" if self.safe else "UNSAFE (failed: " + ", ".join(self.failed) + ")"
        scope = ("every move length" if self.moves is None
                 else "moves of " + ", ".join(map(str, self.moves)) + " pulses")
        parts = [f"{head} over {scope}"]
        if self.criterion:
            parts.append(f"criterion: {len(self.criterion)} finding(s)")
        if self.load_angle is not None:
            parts.append(self.load_angle.describe())
        if self.box is not None:
            parts.append(self.box.describe())
        parts += [v.describe() for _, v in self.commands]
        return "; ".join(parts)

    def to_json(self) -> dict[str, Any]:
        """The same object wherever a verdict is shown (check, plan, compare, sync,
        sweep, the designer)."""
        la = self.load_angle
        return {
            "safe": self.safe, "failed": list(self.failed),
            "moves": "every" if self.moves is None else list(self.moves),
            "aim_deg": self.aim_deg, "within_aim": self.within_aim,
            "worst_load_angle_deg": None if la is None else la.worst_deg,
            "margin_deg": None if la is None else la.margin_deg,
            "worst_pulses": None if la is None else la.worst_pulses,
            "worst_direction": None if la is None else (
                "forward" if la.worst_direction > 0 else "backward"),
            "worst_at": None if la is None else la.worst_at,
            "first_unstable_pulses": None if la is None else la.first_unstable_pulses,
            "slips": None if la is None else la.slips,
            "executions": None if la is None else la.executions,
            "criterion_findings": [f.to_json() for f in self.criterion],
            "resonance_findings": [f.to_json() for f in self.resonance],
            "tolerance_box": None if self.box is None else self.box.to_json(),
            "commands": {name: v.to_json() for name, v in self.commands},
        }



def envelope_findings(rule: str, described: str, source: str, *, safe: bool,
                      within_aim: bool, aim_deg: float) -> list[Finding]:
    """A command family's finding, on any device: none while some use of it stays within
    the aim, a warning when none does, an error when none even stays below the 90° peak
    with `source` (the table or the settings)."""
    if within_aim:
        return []
    if not safe:
        return [Finding("error", rule, f"{described}: no use of it keeps the rotor below "
                        f"the 90° peak with {source}")]
    return [Finding("warning", rule, f"{described}: no use of it keeps the rotor within "
                    f"the {aim_deg:g}° aim")]


__all__ = ["CONFIDENCE", "DEFAULT_SAMPLES", "BoxVerdict", "CommandVerdict", "JudgeOptions",
           "LoadAngle",
           "SafetyVerdict", "envelope_findings", "require_aim"]
