"""profiles.progress and the library work that reports through it."""

from __future__ import annotations

import pytest

from profiles import mc200 as M
from profiles.motor import load_motor
from profiles.ppmc312.planner.init_planner import init_candidates
from profiles.progress import Progress, chunks, track
from tests.support.paths import ROOT

MOTOR = ROOT / "profiles" / "data" / "motor-nema17-1600.json"


def _recorder() -> tuple[list[tuple[int, int]], Progress]:
    calls: list[tuple[int, int]] = []
    return calls, lambda done, total: calls.append((done, total))


def test_track_reports_before_and_after_each_item() -> None:
    calls, cb = _recorder()
    seen = []
    for item in track("abc", cb):
        seen.append((item, calls[-1]))
    assert seen == [("a", (0, 3)), ("b", (1, 3)), ("c", (2, 3))]
    assert calls[-1] == (3, 3)
    assert list(track([1, 2], None)) == [1, 2]


def test_chunks_cover_the_range_once() -> None:
    calls, cb = _recorder()
    parts = list(chunks(10, 4, cb))
    assert [list(r) for r in parts] == [[0, 1, 2, 3], [4, 5, 6, 7], [8, 9]]
    assert calls == [(0, 10), (4, 10), (8, 10), (10, 10)]


def test_init_candidates_report_each_high_speed() -> None:
    calls, cb = _recorder()
    motor = load_motor(MOTOR)
    cands = init_candidates(motor, "linear", highs=2, separate_decel=False, progress=cb)
    total = calls[0][1]
    assert calls == [(k, total) for k in range(total + 1)]
    assert 1 <= len(cands) <= total <= 2


@pytest.mark.slow  # 2–4 s: the quick suite's budget; CI runs it
def test_render_stream_reports_packets_encoded() -> None:
    calls, cb = _recorder()
    packets = M.servo_on(1) * 15_000  # more than one 20 000-packet chunk
    out = M.render_stream(packets, "bin", period_us=10, duration_s=1.0, pulses=1,
                          progress=cb)
    assert out == M.encode_stream(packets)
    assert calls[0] == (0, len(packets)) and calls[-1] == (len(packets), len(packets))
    assert [d for d, _ in calls] == sorted(d for d, _ in calls) and len(calls) > 2


def test_references_report_each_solver() -> None:
    from verify.references import references

    calls, cb = _recorder()
    refs = references(load_motor(MOTOR), 3200, include=("ruckig",), progress=cb)
    assert calls == [(0, 1), (1, 1)] and set(refs) == {"exact", "ruckig"}
