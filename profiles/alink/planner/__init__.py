"""The A-Link ALUM's planners, in one place: its settings (`settings`: the fastest
stall-safe start speed, ramp and high speed for a motor, then tightened on the unit's
load-angle verdict) and its homing speeds (`homing`: OL, OH and O_UPTIME, tightened
alike)."""

from .homing import HomingSettings, homing_commands, plan_homing, tighten_homing
from .settings import (
    S_CURVE_PEAK_FACTOR,
    Judgement,
    SettingsJudge,
    Tightened,
    plan_settings,
    tighten_settings,
)

__all__ = ["S_CURVE_PEAK_FACTOR", "HomingSettings", "Judgement", "SettingsJudge",
           "Tightened", "homing_commands", "plan_homing", "plan_settings",
           "tighten_homing", "tighten_settings"]
