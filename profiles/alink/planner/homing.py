"""A-Link ALUM homing speeds for a motor: OL_SPEED, OH_SPEED and O_UPTIME (§11-2 (8)–(10)).

The model (appendix 1, §13-1, and §11-4): a search (P_SEARCH, M_SEARCH, the first legs of
HOME) runs at the origin high speed OH and stops *at once* where it meets the origin or a
limit (「ORG検出で即時停止します」); the alignment (P_ORG, M_ORG) runs at the origin low
speed OL, which the manual puts in the self-start range (「原点低速スピード (自起動範囲)
にて移動します」), and stops at the edge. Each of those stops is a step from speed to rest
with no ramp, which the motor makes within one step only from its self-start speed — the
bound the settings planner holds its start speed to (min(start_pps, jump_pps)). So both
speeds are held within it, and the ramp between them (O_UPTIME) then never leaves the
self-start range, whatever its rate.

Conservative on purpose: a search could run faster and decelerate before the origin only
with an SD input, which the unit has but a plan cannot count on. `plan_homing` is the one
place the choice is made; `tighten_homing` then lowers OH until the homing legs' load-angle
verdict (profiles.alink.safety.homing_judge, the kernel every verdict runs) is within the aim.

The unit's multiplier for the homing speeds is not documented (appendix 2 names the high
speed and MAX_SPEED only): every value chosen is a multiple of 20 — the largest
multiplier the unit can select — and O_UPTIME's para lies in 20..8000, inside every
multiplier's range (appendix 3), so the unit runs them unchanged whichever it applies.
"""

from __future__ import annotations

import math
import time
from collections.abc import Callable
from dataclasses import dataclass

from ...errors import PlanError
from ...motor import Motor
from ...result import PlanResult
from ..codec import (
    FUNC_ACCEL_PARA,
    FUNC_SPEED_PPS,
    Cmd,
    Command,
    CommandWriter,
    Duplex,
    command_address,
)
from ..model import PPS2_PER_INV_PARA, SPEED_MAX_PPS, STEPS_MAX, max_setting
from .settings import Judgement

STEP_PPS = 20            # ×20, the largest multiplier either table of appendix 2 selects
PARA_TOP = STEPS_MAX     # 8000: the top of ×1's para range, the narrowest (appendix 3)
CREEP_DIVISOR = 4        # OL = OH / 4: the alignment creeps to the edge at a quarter speed
MODEL = ("a search runs at OH and stops at once at the origin or a limit (§13-1), the "
         "alignment runs at OL (§11-4: the self-start range): both held within the motor's "
         "self-start speed min(start_pps, jump_pps), so every homing stop is one it makes "
         "within a step")


@dataclass(frozen=True)
class HomingSettings:
    """OL_SPEED and OH_SPEED [pps] (nn 1) and O_UPTIME's para (nn 2, × 0.01 ms/kpps)."""

    ol_pps: int
    oh_pps: int
    o_uptime_para: int

    @property
    def accel_pps2(self) -> float:
        return PPS2_PER_INV_PARA / self.o_uptime_para


def plan_homing(motor: Motor, *, max_pps: float = 0) -> PlanResult[HomingSettings]:
    """Homing speeds for `motor` whose every stop is safe (module doc: the model);
    `max_pps`: the MAX_SPEED the unit holds (OH above it is a Nak). Refused (PlanError,
    naming what would help) when the motor's self-start speed is below 40 pps."""
    started = time.perf_counter()
    top = max_setting(max_pps) or SPEED_MAX_PPS
    stop_cap = min(motor.start_pps, motor.jump_pps)
    oh = math.floor(min(stop_cap, top) / STEP_PPS) * STEP_PPS
    if oh < 2 * STEP_PPS:
        raise PlanError(f"{motor.name or 'motor'}: no safe homing speed on the unit: the "
                        f"motor starts and stops within a step only up to {stop_cap:g} pps"
                        + ("" if stop_cap <= top else f" (MAX_SPEED {top} pps)")
                        + f", below {2 * STEP_PPS} pps (OL and OH multiples of ×{STEP_PPS}); "
                        "a coarser microstep raises it")
    ol = max(STEP_PPS, math.floor(oh / CREEP_DIVISOR / STEP_PPS) * STEP_PPS)
    a_lim = float(min(motor.min_a_acc_pps2(ol, oh), motor.min_a_dec_pps2(ol, oh)))
    warnings = []
    para = (math.ceil(PPS2_PER_INV_PARA / a_lim / STEP_PPS) * STEP_PPS if a_lim > 0
            else PARA_TOP)
    para = max(para, STEP_PPS)
    if para > PARA_TOP:
        warnings.append(f"O_UPTIME para {PARA_TOP} ({PPS2_PER_INV_PARA / PARA_TOP:g} pps²), "
                        f"faster than the motor's {a_lim:.6g} pps²: the unit's slowest "
                        "setting under every multiplier; safe since OL..OH lies within the "
                        "self-start speed")
        para = PARA_TOP
    homing = HomingSettings(ol, oh, para)
    binds = (f"the motor's self-start speed ({stop_cap:g} pps): a search stops at once at "
             "the origin" if stop_cap <= top else f"MAX_SPEED ({top} pps)")
    info = (f"OL {ol} pps, OH {oh} pps, O_UPTIME para {para} "
            f"({homing.accel_pps2:.6g} pps²); {MODEL}")
    return PlanResult(homing, None, binds, info, None, None, time.perf_counter() - started,
                      tuple(warnings), {"stop_cap_pps": float(stop_cap),
                                        "accel_limit_pps2": a_lim, "model": MODEL})


HOMING_FACTOR = 0.85   # a tightening round: OH × this (OL = OH / CREEP_DIVISOR again)


def tighten_homing(motor: Motor, homing: HomingSettings,
                   judge: Callable[[HomingSettings], Judgement], *, aim_deg: float
                   ) -> tuple[HomingSettings, Judgement, str]:
    """`homing` with OH (and OL with it) lowered, a round at a time, until `judge` (the
    homing legs on the load angle: profiles.alink.safety.homing_judge) finds them within the
    aim: (the settings, the judgement, the price in plain words, "" when nothing changed).
    Refused (PlanError, naming what would help) below OH = 40 pps."""
    h = homing
    while True:
        verdict = judge(h)
        if verdict.within_aim:
            break
        oh = math.floor(h.oh_pps * HOMING_FACTOR / STEP_PPS) * STEP_PPS
        if oh < 2 * STEP_PPS:
            raise PlanError(f"{motor.name or 'motor'}: no homing speed keeps the stop at the "
                            f"origin within {aim_deg:g}° (OH {h.oh_pps} pps: "
                            f"{verdict.worst_deg:.1f}°); less load inertia, a higher drive "
                            "current or a coarser microstep would help")
        ol = max(STEP_PPS, math.floor(oh / CREEP_DIVISOR / STEP_PPS) * STEP_PPS)
        h = HomingSettings(ol, oh, h.o_uptime_para)
    price = ("" if h == homing else
             f"origin high speed lowered to {h.oh_pps} pps (from {homing.oh_pps}; OL "
             f"{h.ol_pps}) to keep the stop at the origin within {aim_deg:g}° (worst now "
             f"{verdict.worst_deg:.1f}°): a search runs {homing.oh_pps / h.oh_pps:.2f}× as "
             "long")
    return h, verdict, price


def homing_commands(homing: HomingSettings, *, slave_address: int | None = None,
                    axis: int = 0, duplex: Duplex = "full",
                    writer: CommandWriter | None = None) -> list[Command]:
    """The commands that set `homing`: OL_SPEED, OH_SPEED, O_UPTIME (the unit checks OH ≥
    OL and OH ≤ MAX_SPEED at the homing command, not per setting)."""
    if writer is None:
        address = (None if slave_address is None
                   else command_address(slave_address, axis, duplex))
        writer = CommandWriter(address=address)
    return [writer.put(Cmd.OL_SPEED, FUNC_SPEED_PPS, homing.ol_pps),
            writer.put(Cmd.OH_SPEED, FUNC_SPEED_PPS, homing.oh_pps),
            writer.put(Cmd.O_UPTIME, FUNC_ACCEL_PARA, homing.o_uptime_para)]
