"""The joint timeline of a set of PPMC-312 executions (`stepramp simulate --axes`): every
segment boundary of every axis in time order, then the finish spread and the line
deviation."""

from __future__ import annotations

from collections.abc import Sequence

from profiles.ppmc312.execution import Execution
from profiles.ppmc312.sync import line_deviation


def joint_timeline(names: Sequence[str], executions: Sequence[Execution]) -> str:
    """Every segment boundary of every axis in time order: what each axis runs from then."""
    events = []
    for name, e in zip(names, executions, strict=True):
        hz = e.clock.hz
        for s in e.segments:
            events.append((s.start_tick / hz, name, f"{s.phase} {hz / s.rate:.6g} pps "
                           f"(rate {s.rate}) × {s.pulses}"))
        events.append((e.duration_s, name, f"done: {e.pulses} pulses"))
    events.sort(key=lambda ev: (ev[0], names.index(ev[1])))
    width = max(len(n) for n in names)
    lines = [f"{t * 1e3:12.6f} ms  {name:<{width}}  {what}" for t, name, what in events]
    dev = line_deviation(executions)[0]
    d = [e.duration_s for e in executions]
    lines.append(f"finish spread {(max(d) - min(d)) * 1e6:.3f} µs, line deviation "
                 f"{dev:.4g} pulses")
    return "\n".join(lines) + "\n"
