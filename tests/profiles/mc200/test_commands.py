"""MC-200 in every control mode (issue 33 item 4): velocity and current packets from the
sheet's figures by hand, streams of either along a profile (their values, round trips, the
driver's reading, `check`), DIN bits, the SPI-error reset, the velocity page's magic, the
≥ 15 µs CS→CLK bound on the period, and byte 9 of a reply read by the sheet's line."""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from profiles import mc200 as M
from profiles.errors import FieldRangeError, FormatError, StepRampError
from profiles.motor import load_motor
from tests.support.paths import ROOT
from verify.check_file import check_file

MOTOR = ROOT / "profiles" / "data" / "motor-nema17-1600.json"


POSITION_AT, DURATION = M.ruckig_profile(3200, 20000.0, 2e5, 5e6)


# --- streams in every mode ------------------------------------------------------------------------
def _current_model() -> M.CurrentModel:
    return M.CurrentModel.from_motor(load_motor(MOTOR), 0.3)


def _drive(mode: M.Mode, **kw: object) -> M.Drive:
    return M.Drive(mode, current=_current_model() if mode == "current" else None,
                   **kw)  # type: ignore[arg-type]


def test_velocities_integrate_to_the_profile() -> None:
    period = 1e-3
    v = M.sample_velocities(POSITION_AT, DURATION, 3200, period)
    x = M.iter_samples(POSITION_AT, DURATION, 3200, period, chunk=1 << 20)
    samples = next(x)
    assert len(v) == len(samples) - 1 == math.ceil(DURATION / period - 1e-9)
    assert np.allclose(np.concatenate(([0.0], np.cumsum(v) * period)), samples, atol=1e-9)
    assert np.sum(v) * period == pytest.approx(3200, abs=1e-9)
    assert v.max() <= 20000 * (1 + 1e-6) and v.min() >= 0
    # float32 on the wire: the sum of what is sent stays within a millionth of the move
    sent = np.array(v, dtype=np.float32).astype(np.float64)
    assert abs(np.sum(sent) * period - 3200) < 1e-6 * 3200


def test_currents_are_the_torque_the_move_needs_over_kt() -> None:
    """I_k = (J·α_k·2π/ppr + friction (moving) + load) / Kt, α_k the central difference of
    the mean speeds: written out in plain Python for every period."""
    motor, kt, period = load_motor(MOTOR), 0.3, 1e-3
    v = M.sample_velocities(POSITION_AT, DURATION, 3200, period).tolist()
    got = M.sample_currents(POSITION_AT, DURATION, 3200, period, _current_model())
    padded = [0.0, *v, 0.0]
    for k, speed in enumerate(v):
        alpha = (padded[k + 2] - padded[k]) / (2 * period) * 2 * math.pi / motor.steps_per_rev
        torque = motor.inertia_kgm2 * alpha + (motor.friction_torque_nm if speed > 0 else 0.0)
        assert got[k] == pytest.approx((torque + motor.load_torque_nm) / kt, rel=1e-12,
                                       abs=1e-15)
    # the accelerations sum to nothing: the move starts and ends at rest
    inertial = got - np.where(np.array(v) > 0, motor.friction_torque_nm / kt, 0.0)
    assert abs(float(np.sum(inertial))) < 1e-9


@settings(max_examples=40, deadline=None)
@given(pulses=st.integers(1, 200_000), v=st.floats(100.0, 1e5), a=st.floats(1e3, 1e7),
       period_us=st.sampled_from([15.0, 100.0, 333.0, 1000.0]),
       mode=st.sampled_from(["velocity", "current"]))
def test_stream_round_trips(pulses: int, v: float, a: float, period_us: float,
                            mode: M.Mode) -> None:
    """Any ruckig move: the stream decodes back to its commands (float32 of the values),
    and a velocity stream's commands integrate to the move's length."""
    try:
        position_at, duration = M.ruckig_profile(pulses, v, a, 50 * a)
    except StepRampError:  # a limit ruckig's numerics cannot take: not what is tested here
        return
    if duration / (period_us * 1e-6) > 50_000:
        return  # keep the test fast
    drive = _drive(mode)
    data = M.stream_bytes(position_at, duration, pulses, period_us=period_us, drive=drive)
    values = (M.sample_velocities(position_at, duration, pulses, period_us * 1e-6)
              if mode == "velocity" else
              M.sample_currents(position_at, duration, pulses, period_us * 1e-6,
                                drive.current))  # type: ignore[arg-type]
    packets = M.decode_stream(data)
    commands = [p.value for p in packets[5:5 + len(values)]]
    assert commands == np.asarray(values, np.float32).astype(np.float64).tolist()
    if mode == "velocity":
        assert abs(math.fsum(commands) * period_us * 1e-6 - pulses) <= 1e-6 * pulses + 1e-6


def test_the_drive_refuses_what_the_sheet_does_not_have() -> None:
    with pytest.raises(FieldRangeError, match="magic"):
        M.Drive(magic=0x12345678)
    with pytest.raises(FieldRangeError, match="din"):
        M.Drive(din=16)
    with pytest.raises(FormatError, match="current model"):
        M.Drive("current")
    with pytest.raises(FormatError, match="current model"):
        M.Drive("velocity", current=_current_model())
    with pytest.raises(FormatError, match="mode"):
        M.Drive("torque")  # type: ignore[arg-type]
    with pytest.raises(FieldRangeError, match="torque_constant_nm_per_a"):
        M.CurrentModel(0.0, 1e-5, 200)


# --- the period: ≥ 15 µs from CS to CLK -----------------------------------------------------------
def test_the_period_leaves_15_us_from_cs_to_clk() -> None:
    """The wiring page: 「CS信号=ONからCLKを入れるまでのwait時間：15usec以上」."""
    assert M.CS_TO_CLK_US == 15.0 and M.PERIOD_US_RANGE[0] == 15.0
    M.stream_chunks(POSITION_AT, DURATION, 3200, period_us=15.0)
    for period in (14.99, 10.0, 0.0, -1.0, math.nan):
        with pytest.raises(FieldRangeError, match=r"^period_us \(µs; .*15 µs from CS to CLK"):
            M.stream_chunks(POSITION_AT, DURATION, 3200, period_us=period)


def test_check_says_a_velocity_stream_that_ends_turning(tmp_path: Path) -> None:
    data = M.stream_bytes(POSITION_AT, DURATION, 3200, period_us=1000,
                          drive=M.Drive("velocity"))
    turning = data + M.encode_stream([M.HostPacket(0, True, 0, 100.0, "velocity")] * 6)
    path = tmp_path / "turning.mc200.bin"
    path.write_bytes(turning)
    result = check_file(str(path))
    rules = [(f.severity, f.rule, f.message) for f in result.findings]
    assert ("error", "mc200-hold", "the stream ends commanding velocity 100 pps, not 0: the "
            "motor keeps turning") in rules
