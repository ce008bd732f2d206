"""`stepramp mc200 follow`: a stream's following error against the driver's replies
(issue 33 item 4). Synthetic reply logs with a known lag give back exactly the error
built into them; the report as text, JSON and a figure; bad input one line, exit 2.

`examples/move.mc200.replies.hex` is such a log: the guide's stream (ruckig, 20 000 pps,
200 000 pps², 5e6 pps³, 3 200 pulses, one packet a ms) answered by a driver 3 packets
behind (`lagging_replies(GUIDE_STREAM, 3)`, both in tests/support/mc200_replies.py;
`test_the_example_reply_log_is_the_guides_stream_3_packets_behind` rewrites it when
STEPRAMP_WRITE_EXAMPLES=1).
"""

from __future__ import annotations

import os
from pathlib import Path

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from profiles import mc200 as M
from profiles.errors import DecodeError, FieldRangeError, FormatError, StepRampError
from profiles.mc200.follow import Following, commanded_positions, following_error
from profiles.mc200.formats import render
from profiles.motor import load_motor
from tests.support.figures import problems
from tests.support.mc200_replies import (
    DURATION,
    EXAMPLE_REPLIES,
    EXAMPLE_STREAM,
    GUIDE_STREAM,
    POSITION_AT,
    lagging_replies,
)
from tests.support.paths import ROOT
from verify.check_file import check_file

MOTOR = ROOT / "profiles" / "data" / "motor-nema17-1600.json"


def _write_replies(path: Path, replies: bytes, comment: str = "") -> None:
    packets = [replies[i:i + 12] for i in range(0, len(replies), 12)]
    text = render(packets, "hex")
    path.write_bytes(comment.encode() + text)


# --- the error built in is the error reported ----------------------------------------------------
@pytest.mark.parametrize("lag", [0, 1, 3, 10])
def test_a_known_lag_is_the_reported_following_error(lag: int) -> None:
    replies = lagging_replies(GUIDE_STREAM, lag)
    f = following_error(GUIDE_STREAM, replies, period_us=1000)
    reading = M.read_stream(GUIDE_STREAM)
    n = reading.packets
    commanded = commanded_positions(reading.commands, np.zeros(n), 1e-3)
    commanded = np.nan_to_num(commanded, nan=0.0)
    on = np.arange(n) > reading.servo_on_at
    lagged = commanded[np.maximum(np.arange(n) - lag, 0)]
    assert np.array_equal(f.error[on], (commanded - lagged)[on])
    assert np.all(np.isnan(f.error[~on]))
    worst = f.worst
    assert worst is not None and f.error[worst] == np.max(commanded - lagged)
    # in the cruise at 20 000 pps, one packet a ms: 20 pulses a packet of lag
    assert 20 * lag <= f.error[worst] <= 20 * lag + 1
    assert f.move_end is not None and f.command[f.move_end] == 3200
    # the stream holds 10 packets: a driver 10 behind is not in position by its end
    assert f.in_position_at == (f.move_end + lag if lag < 10 else None)
    assert f.replies == f.packets == n


@settings(max_examples=40, deadline=None)
@given(lag=st.integers(0, 40), pulses=st.integers(50, 40_000), v=st.floats(500.0, 50_000.0),
       period_us=st.sampled_from([15.0, 250.0, 1000.0]))
def test_any_lag_on_any_move(lag: int, pulses: int, v: float, period_us: float) -> None:
    try:
        position_at, duration = M.ruckig_profile(pulses, v, 10 * v, 200 * v)
    except StepRampError:  # a limit ruckig's numerics cannot take: not what is tested here
        return
    if duration / (period_us * 1e-6) > 20_000:
        return  # keep the test fast
    stream = M.stream_bytes(position_at, duration, pulses, period_us=period_us)
    f = following_error(stream, lagging_replies(stream, lag, period_s=period_us * 1e-6),
                        period_us=period_us)
    command = np.nan_to_num(f.command, nan=0.0)
    lagged = command[np.maximum(np.arange(len(command)) - lag, 0)]
    followed = f.followed
    assert np.array_equal(f.error[followed], (command - lagged)[followed])
    end = f.move_end
    assert end is not None
    assert f.in_position_at == (end + lag if end + lag < f.replies else None)


def test_a_velocity_stream_is_followed_by_its_integral() -> None:
    """Velocity commands [pps] integrate, from the encoder where velocity control began
    (here 1000: the encoder need not start at 0), to the profile's positions."""
    stream = M.stream_bytes(POSITION_AT, DURATION, 3200, period_us=1000,
                            drive=M.Drive("velocity"))
    f = following_error(stream, lagging_replies(stream, 2, origin=1000), period_us=1000)
    on = f.followed
    command = f.command[on]
    # the float32 velocities sent integrate to the move within a millionth of it
    assert command[-1] == pytest.approx(4200, abs=1e-6 * 3200)
    samples = M.iter_samples(POSITION_AT, DURATION, 3200, 1e-3, chunk=1 << 20)
    x = next(samples)
    # reply 5 + j sees velocity commands 0 … j − 1: the profile at j ms, from 1000
    assert np.allclose(f.command[5:5 + len(x)], 1000 + x, atol=1e-6 * 3200)
    lagged = np.floor(f.command[np.maximum(np.arange(f.replies) - 2, 0)])
    assert np.allclose(f.error[on], (f.command - lagged)[on], atol=1e-9)


def test_a_current_stream_commands_no_position() -> None:
    model = M.CurrentModel.from_motor(load_motor(MOTOR), 0.3)
    stream = M.stream_bytes(POSITION_AT, DURATION, 3200, period_us=1000,
                            drive=M.Drive("current", current=model))
    f = following_error(stream, lagging_replies(stream, 2), period_us=1000)
    assert not len(f.followed) and f.worst is None and f.move_end is None
    assert "no reply follows a position" in f.describe()
    assert f.to_json()["worst"] is None


def test_a_capture_that_stops_early_and_one_with_more_replies() -> None:
    replies = lagging_replies(GUIDE_STREAM, 3)
    short = following_error(GUIDE_STREAM, replies[:12 * 200], period_us=1000)
    assert (short.replies, short.packets) == (200, 315)
    assert "200 replies to 315 packets" in short.describe()
    assert short.in_position_at is None  # the move had not ended
    with pytest.raises(FormatError, match="316 replies to a stream of 315 packets"):
        following_error(GUIDE_STREAM, replies + replies[:12], period_us=1000)


def test_alarms_in_the_replies_are_reported() -> None:
    f = following_error(GUIDE_STREAM, lagging_replies(GUIDE_STREAM, 3, alarm_at=100),
                        period_us=1000)
    assert f.alarms == (("alarm", 1, 100),)
    assert "alarm: 1 replies, the first 100 (100 ms)" in f.describe()
    assert f.to_json()["alarms"] == {"alarm": {"replies": 1, "first": 100}}


def test_what_follow_refuses() -> None:
    replies = lagging_replies(GUIDE_STREAM, 3)
    with pytest.raises(FieldRangeError, match=r"period_us \(µs"):
        following_error(GUIDE_STREAM, replies, period_us=10)
    bad = bytearray(replies)
    bad[12 * 7 + 4] ^= 1
    with pytest.raises(DecodeError, match="block 7, byte 10"):
        following_error(GUIDE_STREAM, bytes(bad), period_us=1000)
    with pytest.raises(DecodeError, match="not a whole, non-zero number"):
        following_error(GUIDE_STREAM, replies[:-1], period_us=1000)
    with pytest.raises(FormatError, match="is the stream the driver's replies"):
        following_error(replies, replies, period_us=1000)
    with pytest.raises(FormatError, match="are they the host's packets"):
        following_error(GUIDE_STREAM, GUIDE_STREAM, period_us=1000)


# --- the example and the command line -------------------------------------------------------------
def test_the_example_reply_log_is_the_guides_stream_3_packets_behind() -> None:
    comment = ("# synthetic MC-200 replies to the guide's move.mc200.hex: the encoder 3 packets "
               "behind the command\n# (tests/profiles/mc200/test_follow.py, lagging_replies)\n")
    want = lagging_replies(GUIDE_STREAM, 3)
    if os.environ.get("STEPRAMP_WRITE_EXAMPLES") == "1":
        _write_replies(EXAMPLE_REPLIES, want, comment)
    from profiles.mc200.formats import parse, payload_of_parsed

    assert payload_of_parsed(parse(EXAMPLE_REPLIES.read_bytes())) == want
    assert EXAMPLE_REPLIES.read_text().startswith(comment)


def test_check_names_the_command_that_reads_a_reply_log() -> None:
    result = check_file(str(EXAMPLE_REPLIES))
    assert result.error == ("not judged: MC-200 replies (the driver's answers, byte 9 saying "
                            "the control mode): stepramp mc200 follow STREAM REPLIES reads them")
    assert M.looks_like_replies(lagging_replies(GUIDE_STREAM, 0))
    assert not M.looks_like_replies(GUIDE_STREAM)
    assert check_file(str(EXAMPLE_STREAM)).findings == []


@pytest.mark.parametrize("n", [10, 8000, 8001, 4_000_295])
def test_the_figure_draws_every_peak_of_a_long_log(n: int) -> None:
    """A log of millions of replies is drawn as each bucket's smallest and largest value:
    the worst error is still on the figure, and every bucket starts inside the log."""
    from verify.plot import ENVELOPE_BUCKETS, envelope

    rng = np.random.default_rng(n)
    t = np.arange(n) * 5e-4
    y = rng.normal(size=n)
    y[rng.integers(n)] = 50.0
    y[: min(n, 3)] = np.nan  # the servo still off
    tt, yy = envelope(t, y)
    assert np.nanmax(yy) == np.nanmax(y) and np.nanmin(yy) == np.nanmin(y)
    assert len(yy) <= max(n, 2 * ENVELOPE_BUCKETS) and tt[-1] <= t[-1]
    assert np.all(np.diff(tt) >= 0)


def test_a_long_log_is_drawn_in_seconds(tmp_path: Path) -> None:
    from verify.plot import fit_texts, following_figure

    f = following_error(GUIDE_STREAM, lagging_replies(GUIDE_STREAM, 3), period_us=1000)
    long_log = Following(**{**f.__dict__, "t_s": f.t_s * 100})  # 31.5 s instead of 315 ms
    fig = following_figure(long_log)
    fit_texts(fig)  # as saving lays it out
    assert fig.axes[-1].get_xlabel() == "time [s]" and problems(fig) == []
    assert following_figure(f).axes[-1].get_xlabel() == "time [ms]"
