"""`stepramp plan`'s text summary: a few short lines a user reads at a glance.

What was planned (stages, top speed, move time), what holds it back or what the
load-angle tightening gave up (profiles.ppmc312.planner: `Plan.binds` and
`extras["shaping"]`) in plain words, the cruise reserve, the verdict in one line, and one
line pointing at `check --motor` for what the other motion commands may run. Each line
is at most LINE_MAX characters and says what no other line says; `--format json` keeps
every number.
"""

from __future__ import annotations

import math
from typing import Any

LINE_MAX = 120   # characters a summary line may have
LENGTHS_SHOWN = 4  # a mix's move lengths named before "…"


def pps(x: float) -> str:
    """A speed as the user reads it: `2 840 pps` (whole pulses, thousands spaced)."""
    return f"{x:,.0f}".replace(",", " ") + " pps"


def ms(seconds: float) -> str:
    return f"{seconds * 1e3:.4g} ms"


def plain_summary(summary: dict[str, Any], plan: Any, table: Any, motor: Any, kept: Any,
                  verdict: Any, *, aim_deg: float, check: str) -> list[str]:
    """The text summary of a plan: `summary` is what `--format json` prints, `plan` the
    planner's Plan, `motor` the motor planned for, `kept` the cruise reserve at the top
    speed (profiles.motor.reserve.ReserveAt), `verdict` the safety verdict, `check` the
    command that lists the command families' limits."""
    lines = [_planned(summary, table), in_real_units(summary, table, motor)]
    lines += _held_back(plan, motor, aim_deg)
    lines.append(_reserve(kept))
    lines.append(_verdict(verdict))
    lines += _commands(verdict, check)
    return lines


def _planned(summary: dict[str, Any], table: Any) -> str:

    stages = summary.get("stages", summary.get("modelled_stages"))
    kind = summary.get("kind")
    article = "an" if kind == "s-curve" else "a"
    what = (f"{article} {kind} init table ({stages} modelled stages)" if kind
            else f"{stages} stages")
    side = "separate decel (LE=1)" if summary.get("separate_decel") else "shared decel (LE=0)"
    head = f"planned: {what}, {side}, top {pps(top_pps(table))}"
    if "weighted_time_s" in summary:
        lengths = list(summary.get("move_times_s", {}))
        shown = ", ".join(lengths[:LENGTHS_SHOWN]) + (", …" if len(lengths) > LENGTHS_SHOWN
                                                      else "")
        return (f"{head}; weighted move time {ms(summary['weighted_time_s'])} over "
                f"{len(lengths)} lengths ({shown} pulses)")
    move = f"{head}; a move of {summary['pulses']} pulses takes {ms(summary['move_time_s'])}"
    if "source" in summary:
        move += (f", {summary['table/reference']:.3g}× the {summary['source']} reference "
                 f"it follows")
    return move


_BINDS = {
    "stage budget": "all {stages} stages are used: --max-stages with more would go faster",
    "move length": "the move is short: its ramps use every pulse before the top speed",
    "top speed": "it reaches the top speed the motor keeps its cruise reserve at",
    "stall criterion (capability and jump limit)": "the motor's torque sets the ramp "
                                                   "(the stall criterion)",
}


def _held_back(plan: Any, motor: Any, aim_deg: float) -> list[str]:
    """What limits the table, and what the tightening for the load angle changed."""
    extras = getattr(plan, "extras", {}) or {}
    shaping = extras.get("shaping")
    lines = []
    binds = str(getattr(plan, "binds", "") or "")
    if binds in _BINDS:
        stages = len(plan.table.rates) if hasattr(plan.table, "rates") else "the"
        lines.append("limited by: " + _BINDS[binds].format(stages=stages))
    if shaping is not None and not shaping.plain:
        lines += _tightening(shaping, motor, aim_deg)
    if extras.get("untightened_s") is not None:  # the free curve's last lever was pulled
        lines += top_lowered(plan, aim_deg)
    levers = extras.get("levers")
    if levers is not None and not levers.plain:
        lines += init_tightening(plan, aim_deg)
    worst = extras.get("worst_load_angle_deg")
    if worst is not None and worst > aim_deg:
        lines.append(f"the {aim_deg:g}° aim was not reached: the closest table reaches "
                     f"{worst:.1f}°")
    if extras.get("fix"):
        lines += fix_lines(str(extras["fix"]))
    return lines


def fix_lines(fix: str) -> list[str]:
    """What would help (the init planner's `fix`: changes joined by "; "), on one line
    when it fits, else a change a line under a heading."""
    line = f"what would help: {fix}"
    if len(line) <= LINE_MAX:
        return [line]
    return ["what would help, any of:", *(f"  {part}" for part in fix.split("; "))]


def init_tightening(plan: Any, aim_deg: float) -> list[str]:
    """What tightening an init table changed (profiles.ppmc312.planner.init_planner.Levers:
    `extras["levers"]`, against the plain table `extras["untightened"]`) and its price,
    in plain words: `start speed lowered to 4 540 pps (from 5 544 pps) to keep the rotor
    within 75° under every command judged` and `price: a move of 4000 pulses takes
    224.1 ms, 3.2 % longer than the untightened table's 217.1 ms`."""
    levers, plain = plan.extras["levers"], plan.extras["untightened"]
    table, before = plan.table, plain.table
    hz = table.clock.hz
    parts = []
    if levers.start < 1.0:
        parts.append(f"start speed lowered to {pps(hz / table.start_rate)} (from "
                     f"{pps(before.clock.hz / before.start_rate)})")
    if levers.ramp < 1.0:
        parts.append(f"ramp made gentler ({levers.ramp:.0%} of the torque it could use)")
    if levers.top < 1.0:
        parts.append(f"top speed lowered to {pps(hz / table.high_rate)} (from "
                     f"{pps(before.clock.hz / before.high_rate)})")
    why = f" to keep the rotor within {aim_deg:g}° under every command judged"
    line = ", ".join(parts) + why
    lines = [line] if len(line) <= LINE_MAX else [*parts[:-1], parts[-1] + why]
    lines.append(price(plan.pulses, plan.duration_s, plain.duration_s))
    return lines


def price(pulses: int | None, duration_s: float, plain_s: float) -> str:
    """`price: a move of 4000 pulses takes 224.1 ms, 3.2 % longer than the untightened
    table's 217.1 ms` (pulses None: the reference move)."""
    slower = duration_s / plain_s - 1.0
    change = (f"{slower + 1:.3g}× as long as" if slower >= 0.5 else
              f"{slower:.1%} longer than" if slower > 5e-4 else
              f"{-slower:.1%} shorter than" if slower < -5e-4 else "as long as")
    move = "the reference move" if pulses is None else f"a move of {pulses} pulses"
    return f"price: {move} takes {ms(duration_s)}, {change} the untightened table's {ms(plain_s)}"


def top_lowered(plan: Any, aim_deg: float) -> list[str]:
    """The free curve's last lever (profiles.ppmc312.planner.free_curve.lower_top): the top
    speed lowered (`extras["top_lowered_pps"]`, when it was), and the price against the
    plain table (`extras["untightened_s"]`)."""
    extras = plan.extras
    lines = []
    if extras.get("top_lowered_pps") is not None:
        was, now = extras["top_lowered_pps"]
        lines.append(f"top speed lowered to {pps(now)} (from {pps(was)}) to keep the rotor "
                     f"within {aim_deg:g}°: the start and the ramp alone did not")
    return [*lines, price(plan.pulses, plan.duration_s, extras["untightened_s"])]


def _tightening(shaping: Any, motor: Any, aim_deg: float) -> list[str]:
    """What the load-angle tightening changed (profiles.ppmc312.planner.problem.Shaping),
    in one line when it fits: the start speed lowered, the ramp made gentler (where)."""
    parts = []
    if shaping.start_scale < 1.0:
        parts.append(f"start speed lowered to {pps(motor.start_pps * shaping.start_scale)} "
                     f"(from {pps(motor.start_pps)})")
    gentler = [(lo, hi, s) for lo, hi, s in
               zip((0.0, *shaping.edges_pps), (*shaping.edges_pps, math.inf), shaping.scale,
                   strict=True) if s < 1.0]
    if gentler and not shaping.edges_pps:
        parts.append(f"ramp made gentler everywhere ({gentler[0][2]:.0%} of the torque it "
                     f"could use)")
    elif gentler:
        lo, hi = gentler[0][0], gentler[-1][1]
        least = min(s for _, _, s in gentler)
        span = (f"from {pps(lo)} up" if not math.isfinite(hi)
                else f"between {pps(lo)[:-4]} and {pps(hi)}")
        parts.append(f"ramp made gentler {span} (down to {least:.0%} of the torque it could "
                     f"use)")
    why = f" to keep the rotor within {aim_deg:g}°"
    line = ", ".join(parts) + why
    if len(line) <= LINE_MAX:
        return [line]
    return [*parts[:-1], parts[-1] + why]


def _reserve(kept: Any) -> str:
    if kept.reserve.is_off:
        return f"cruise reserve: off (--cruise-reserve off); top {pps(kept.speed_pps)}"
    times = ("nothing to carry" if kept.need_nm == 0
             else f"{kept.times_need:.3g}× the cruising need")
    asked = kept.reserve
    return ("cruise reserve at the top speed " + ("kept" if kept.kept else "NOT kept")
            + f" (≥ {asked.need_factor:g}×, ≥ {asked.standstill_share * 100:g} %): pull-out "
            f"{kept.pullout_nm:.3g} N·m, {times}, {kept.share * 100:.3g} % of standstill")


def _verdict(verdict: Any) -> str:
    """`verdict: SAFE for every move length: worst load angle 70.0° (a decel stop, stage
    89), margin +5.0° to the 75° aim` (the 90° peak is beyond the aim)."""
    from profiles.ppmc312.command_verdicts import DECEL_STOP

    head = "SAFE" if verdict.safe else "UNSAFE (failed: " + ", ".join(verdict.failed) + ")"
    scope = ("every move length" if verdict.moves is None
             else "moves of " + ", ".join(map(str, verdict.moves)) + " pulses")
    la = verdict.load_angle
    if la is None:
        return f"verdict: {head} for {scope}; the load angle not judged"
    worst, where = la.worst_deg, f"a move of {la.worst_pulses} pulses"
    stop = dict(verdict.commands).get(DECEL_STOP)
    if stop is not None and stop.worst_deg is not None and stop.worst_deg > worst:
        worst, where = stop.worst_deg, f"a decel stop, stage {stop.stage}"
    return (f"verdict: {head} for {scope}: worst load angle {worst:.1f}° ({where}), "
            f"margin {verdict.aim_deg - worst:+.1f}° to the {verdict.aim_deg:g}° aim")


def _commands(verdict: Any, check: str) -> list[str]:
    """The other motion commands (their codes) have their own speed limits: one line, and
    the command that lists each one's limit."""
    from profiles.ppmc312.command_families import CODES
    from profiles.ppmc312.command_verdicts import DECEL_STOP

    codes = [CODES.get(name, name) for name, _ in verdict.commands if name != DECEL_STOP]
    if not codes:
        return []
    return [f"other motion commands ({', '.join(codes)}) have their own speed limits, listed by:",
            f"  {check}"]


def top_pps(table: Any) -> float:
    """The fastest speed a table runs [pps]: its first rate (a free curve) or its high
    rate (an init table)."""
    rate = table.rates[0] if table.kind == "free_curve" else table.high_rate
    return float(table.clock.hz / rate)


# --- real units (issue 32 item 5) --------------------------------------------------------

def ramp(table: Any) -> tuple[float, float, float]:
    """A table's accelerating ramp as the chip runs it (an init table's modelled
    staircase): its start speed and top speed [pps] and its mean acceleration [pps²], the
    speed it gains over the time it spends below the top stage."""
    from profiles.ppmc312.init_model import as_free_curve

    stages = as_free_curve(table)
    hz = stages.clock.hz
    k = len(stages.accel_pulses)
    start, top = hz / stages.rates[k - 1], hz / stages.rates[0]
    ticks = sum(stages.accel_pulses[i] * stages.rates[i] for i in range(1, k))
    return float(start), float(top), float((top - start) * hz / ticks) if ticks else 0.0


def real_units(summary: dict[str, Any], table: Any, motor: Any) -> dict[str, Any]:
    """`plan --format json`'s real-unit keys (profiles/motor/travel.py), beside the pulse
    keys, never instead of them: the start and top speed and the ramp's mean acceleration
    in pps and in mm/s, mm/s² (the motor file's `travel_mm_per_rev`) or rpm, rev/s², and
    the move in mm or rev."""
    from profiles.motor.travel import axis_units

    u = axis_units(motor)
    start, top, accel = ramp(table)
    out: dict[str, Any] = {"travel_mm_per_rev": u.mm_per_rev, "start_speed_pps": start,
                           "top_speed_pps": top, "ramp_accel_pps2": accel,
                           f"start_speed_{u.speed_key}": u.speed(start),
                           f"top_speed_{u.speed_key}": u.speed(top),
                           f"ramp_accel_{u.accel_key}": u.accel(accel)}
    if summary.get("pulses") is not None:
        out[f"move_{u.distance_key}"] = u.distance(summary["pulses"])
    elif "move_times_s" in summary:
        out[f"move_lengths_{u.distance_key}"] = {n: u.distance(int(n))
                                                 for n in summary["move_times_s"]}
    return out


def in_real_units(summary: dict[str, Any], table: Any, motor: Any) -> str:
    """`in mm: top 100 mm/s (from 4 mm/s), ramp 1 234 mm/s² on average, a move of 3200
    pulses = 16 mm (0.005 mm per pulse)`, or in rev and rpm for a rotary axis."""
    from profiles.motor.travel import axis_units

    u = axis_units(motor)
    start, top, accel = ramp(table)
    line = (f"in {u.distance_unit}: top {u.speed_text(top)} (from {u.speed_text(start)}), "
            f"ramp {u.accel_text(accel)} on average")
    if summary.get("pulses") is not None:
        line += f", a move of {summary['pulses']} pulses = {u.distance_text(summary['pulses'])}"
    per = f" ({u.per_pulse:.4g} {u.distance_unit} per pulse)"
    return line + per if len(line + per) <= LINE_MAX else line
