"""The envelope motor: one motor that several axes can all follow, each at its own scale.

Line-synchronised moves keep positions proportional: axis i runs at c_i × the leading
axis's speed (c_i = N_i / N_lead). A plan for the envelope motor, in the leader's
pulses, asks of every axis at most what its own motor can do. Used by every device's
line mode (profiles/ppmc312/sync, profiles/alink/sync).
"""

from __future__ import annotations

import math
from collections.abc import Sequence

import numpy as np

from ..errors import SyncError
from .model import Motor

ENVELOPE_GRID = 49   # uniform speeds sampled (plus every curve point) for the envelope


def envelope_motor(motors: Sequence[Motor], scales: Sequence[float], *,
                   margin: float = 1.0) -> Motor:
    """A motor in the leading axis's pulses that every axis i can follow at c_i × its speed:
    capability min_i a_i(c_i·v)/c_i (times `margin`), start, jump, top, jerk likewise.

    Between the sample speeds (every curve point of every axis, plus a uniform grid) the
    true minimum is concave on each piece, so the linear interpolation lies below it: safe.
    """
    c = np.asarray(scales, dtype=float)
    pairs = list(zip(motors, c, strict=True))
    top = min(m.top_pps / ci for m, ci in pairs)
    pts = [np.linspace(0.0, top, ENVELOPE_GRID)] + [m.curve_speed_pps / ci for m, ci in pairs]
    v = np.unique(np.concatenate(pts))
    v = v[v <= top]
    a_acc = margin * np.min([m.a_acc_pps2(ci * v) / ci for m, ci in pairs], axis=0)
    a_dec = margin * np.min([m.a_dec_pps2(ci * v) / ci for m, ci in pairs], axis=0)
    dead = np.flatnonzero(a_acc <= 0)
    if len(dead):
        if dead[0] == 0:
            raise SyncError("the axes' motors cannot accelerate together from rest")
        v, a_acc, a_dec = v[: dead[0] + 1], a_acc[: dead[0] + 1], a_dec[: dead[0] + 1]
        top = float(v[-1])
    friction = max(0.0, float(np.min(a_dec - a_acc)) / 2)
    torque = np.maximum(a_acc + friction, 0.0)
    lead = motors[int(np.argmax(c))]
    # torque units chosen so the largest is 10 (Motor's fields have sane ranges):
    # acceleration = torque × k, k = steps_per_rev / (2π·inertia)
    k = max(float(np.max(torque)), 1e-9) / 10
    jerks = [m.max_jerk_pps3 / ci for m, ci in pairs if m.max_jerk_pps3 is not None]
    return Motor(steps_per_rev=lead.steps_per_rev, curve_speed_pps=v, curve_torque_nm=torque / k,
                 inertia_kgm2=lead.steps_per_rev / (2 * math.pi * k), safety_factor=1.0,
                 start_pps=min(m.start_pps / ci for m, ci in pairs),
                 friction_torque_nm=friction / k,
                 max_jump_pps=min(m.jump_pps / ci for m, ci in pairs),
                 max_pps=top, max_jerk_pps3=min(jerks) if jerks else None,
                 name="envelope of " + ", ".join(m.name or "motor" for m in motors))
