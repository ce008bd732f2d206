"""report.json of a synchronised move, and the problems it records (sync's exit 1;
`stepramp check` gives the same verdict on the file)."""

from __future__ import annotations

from collections.abc import Sequence
from typing import Any

from profiles.joint import spread_tolerance_s
from profiles.pulses import line_deviation

from ..devices import get
from ..references.ruckig_sync import RuckigSync

REPORT_FORMAT = "stepramp.sync-report/1"


def sync_report(plan: Any, *, device: str, ruckig: RuckigSync | None = None,
                commands: Sequence[bytes | list[tuple[int, int, int]]] | None = None
                ) -> dict[str, Any]:
    """report.json: per axis its duration (as simulate computes it), what its device runs
    (`facts`), its safety verdict (the device's judge: a PPMC-312 table's over every move
    length, over the motor's tolerance box when it has one) and whether it is `safe`; the
    finish spread and its tolerance, the line deviation, and ruckig's synchronised
    durations beside ours."""
    judge = get(device).sync_judge()
    dev = line_deviation([a.pulse_train() for a in plan.axes])[0]
    d = [a.duration_s for a in plan.axes]
    axes = []
    for i, a in enumerate(plan.axes):
        item: dict[str, Any] = {"name": a.name, "pulses": a.pulses, "duration_s": d[i],
                                "fastest_s": a.fastest_s, "how": a.how, **a.facts()}
        safe, verdict = judge.axis_verdict(a)
        item.update(verdict, safe=safe)
        if commands is not None:
            item["move_command"] = command_text(commands[i])
        axes.append(item)
    out: dict[str, Any] = {
        "format": REPORT_FORMAT, "device": device, "mode": plan.mode,
        "duration_s": max(d), "unsynchronised_s": plan.unsynchronised_s,
        "finish_spread_s": max(d) - min(d), "finish_spread_tolerance_s":
            spread_tolerance_s(max(d)),
        "max_line_deviation_pulses": dev, "info": plan.info, "axes": axes}
    if ruckig is not None:
        out["ruckig"] = ruckig.to_json()
    return out


def command_text(command: bytes | list[tuple[int, int, int]]) -> str | list[str]:
    """A move command as the report shows it: a PPMC-312 block's bytes, or an A-Link
    axis's command words, one string per command."""
    if isinstance(command, bytes):
        return " ".join(f"{b:02X}" for b in command)
    return [" ".join(f"{w:04X}" for w in ws) for ws in command]


def report_problems(report: dict[str, Any]) -> list[str]:
    """What the report records as wrong, one line each: a finish spread beyond its
    tolerance, an axis whose safety verdict failed."""
    out = []
    spread, allowed = report["finish_spread_s"], report["finish_spread_tolerance_s"]
    if spread > allowed:
        out.append(f"finish spread {spread * 1e6:.3f} µs exceeds its tolerance "
                   f"{allowed * 1e6:.0f} µs")
    for a in report["axes"]:
        if not a["safe"]:
            failed = a.get("safety", {}).get("failed") or ["stall criterion"]
            out.append(f"axis {a['name']}: unsafe ({', '.join(failed)})")
    return out
