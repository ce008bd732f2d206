"""The A-Link unit stepped pulse by pulse in plain Python: the oracle its ramp model
(profiles/alink/ramp.py) and the verdicts built on it are checked against."""

from __future__ import annotations

import math


def stepped(start: float, high: float, accel: float, m: int, shape: str, n: int
            ) -> list[float]:
    """The unit stepped pulse by pulse, independently of the model's arrays: each pulse
    lasts one period of the speed step in force when it begins; a move of n pulses runs
    the first ⌈n/2⌉ pulses of the ramp up and the first ⌊n/2⌋ reversed down (or the
    whole ramp, a cruise at `high`, the ramp reversed). Returns each pulse's speed."""
    steps = int((high - start) // m)
    ramp_s = (high - start) / accel

    def speed(t: float) -> float:
        if shape == "linear":
            k = math.floor(accel * t / m + 1e-9)
        else:
            x = (1 - math.cos(math.pi * min(t, ramp_s) / ramp_s)) / 2 if ramp_s else 1.0
            k = math.floor(x * steps + 1e-9)
        return start + min(k, steps) * m

    ramp: list[float] = []
    t = 0.0
    top = start + steps * m
    while steps and len(ramp) < n:
        v = speed(t)
        if v >= top:
            break
        ramp.append(v)
        t += 1 / v
    if n >= 2 * len(ramp):
        return ramp + [high] * (n - 2 * len(ramp)) + ramp[::-1]
    return ramp[:(n + 1) // 2] + ramp[:n // 2][::-1]
