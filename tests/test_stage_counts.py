"""The planner's stage counts, compiled (`Problem.counts` → dp_kernel.stage_counts), equal
to the bit the counts written out here in numpy from the motor's own capability
(`Motor.min_a_acc_pps2` / `min_a_dec_pps2`, the criterion's): any curve, friction and
signed load, shaping, LE variant and resonance band."""

from __future__ import annotations

import math
from dataclasses import replace

import numpy as np
from hypothesis import HealthCheck, given, reject, settings
from hypothesis import strategies as st

from profiles.errors import FormatError
from profiles.motor import Motor
from profiles.motor.resonance import in_bands, narrow_bands
from profiles.ppmc312.limits import MIN_STAGE_TICKS, STAGE_PULSES_MAX
from profiles.ppmc312.planner import Shaping, choose_clock, make_problem
from profiles.ppmc312.planner.problem import Problem

SETTINGS = settings(max_examples=60, deadline=None,
                    suppress_health_check=[HealthCheck.too_slow])


def oracle(pb: Problem, r_slow: np.ndarray, r_fast: np.ndarray
           ) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """The counts as the planner defines them, from the capability over each step."""
    m = pb.motor
    f_slow = pb.hz / r_slow
    f_fast = pb.hz / np.where(r_fast > 0, r_fast, 1.0)
    delta = f_fast - f_slow
    a_acc = np.asarray(m.min_a_acc_pps2(f_slow, f_fast), dtype=float)
    a_dec = np.asarray(m.min_a_dec_pps2(f_slow, f_fast), dtype=float)
    jump = np.full(f_slow.shape, pb.jump)
    if not pb.shaping.plain:
        sigma = np.asarray(pb.shaping.scale)[np.searchsorted(pb.shaping.edges_pps, f_slow,
                                                             side="right")]
        k = m.steps_per_rev / (2 * math.pi * m.inertia_kgm2)
        c_acc = (m.friction_torque_nm + abs(m.load_torque_nm)) * k
        c_dec = (abs(m.load_torque_nm) - m.friction_torque_nm) * k
        a_acc = sigma * (a_acc + c_acc) - c_acc
        a_dec = sigma * (a_dec + c_dec) - c_dec
        jump = pb.jump * sigma
    base = np.maximum(2.0, np.ceil(MIN_STAGE_TICKS / r_slow))
    with np.errstate(divide="ignore", invalid="ignore", over="ignore"):
        n = np.where(a_acc > 0, np.ceil(delta * f_slow / a_acc), np.inf)
        d = np.where(a_dec > 0, np.ceil(delta * f_slow / a_dec), np.inf)
    n, d = np.maximum(n, base), np.maximum(d, base)
    if not pb.separate:
        n = d = np.maximum(n, d)
    valid = ((r_fast > 0) & (delta > 0) & (delta <= jump) & (n <= STAGE_PULSES_MAX)
             & (d <= STAGE_PULSES_MAX) & ~in_bands(f_slow, narrow_bands(m))
             & ~in_bands(f_fast, narrow_bands(m)))
    return n, d, valid


@st.composite
def motors(draw: st.DrawFn) -> Motor:
    """A pull-out curve of 2..30 points that may rise before it falls (as vendor curves
    do), friction, a signed load, and resonance bands narrower and wider than a jump."""
    points = draw(st.integers(2, 30))
    top = draw(st.floats(3_000, 80_000))
    inner = sorted(set(draw(st.lists(st.floats(0.01, 0.99), min_size=points - 2,
                                     max_size=points - 2))))
    speeds = np.unique([0.0, *(top * x for x in inner), top])
    torques = np.asarray(draw(st.lists(st.floats(0.05, 2.0), min_size=len(speeds),
                                       max_size=len(speeds))))
    if draw(st.booleans()):
        torques[-1] = 0.0
    start = draw(st.floats(100, 1000))
    bands = tuple(sorted((lo, lo + w) for lo, w in draw(st.lists(
        st.tuples(st.floats(start * 1.2, top * 0.9), st.floats(1.0, 3 * start)),
        max_size=2))))
    bands = tuple(b for i, b in enumerate(bands) if i == 0 or b[0] > bands[i - 1][1])
    t0 = float(torques[0])
    try:
        return Motor(steps_per_rev=draw(st.sampled_from([200, 400, 1600, 3200])),
                     curve_speed_pps=speeds, curve_torque_nm=torques,
                     inertia_kgm2=draw(st.floats(2e-6, 1e-3)),
                     safety_factor=draw(st.floats(0.3, 1.0)), start_pps=start,
                     friction_torque_nm=draw(st.floats(0.0, 0.2)) * t0,
                     load_torque_nm=draw(st.floats(-0.2, 0.2)) * t0,
                     max_jump_pps=draw(st.none() | st.floats(50, 2000)),
                     resonance_bands_pps=bands)
    except FormatError:  # friction and load above the torque at rest: no motor
        reject()


@SETTINGS
@given(motors(), st.booleans(), st.integers(0, 2), st.integers(0, 2**32 - 1))
def test_compiled_counts_equal_the_capabilitys_to_the_bit(motor: Motor, separate: bool,
                                                         shaped: int, seed: int) -> None:
    rng = np.random.default_rng(seed)
    shaping = (None, Shaping.uniform(float(rng.uniform(0.4, 1.0))),
               Shaping.bands(motor).scaled({1: float(rng.uniform(0.4, 1.0))},
                                           float(rng.uniform(0.5, 1.0))))[shaped]
    slowest = replace(motor, start_pps=motor.start_pps * (shaping or Shaping()).start_scale)
    pb = make_problem(motor, choose_clock(slowest), separate, shaping)
    r_slow = rng.integers(pb.r_fast, 0xFFFF, 3000).astype(float)
    # steps up, down, none, a zero fast rate, and steps ending exactly on a breakpoint
    r_fast = r_slow - rng.integers(-3, max(4, int(r_slow.min()) // 2), 3000)
    r_fast[:20] = 0.0
    on_points = np.round(pb.hz / motor.curve_speed_pps[1:])
    r_fast[20:20 + len(on_points)] = np.maximum(on_points, 1.0)
    got, want = pb.counts(r_slow, r_fast), oracle(pb, r_slow, r_fast)
    for g, w, name in zip(got, want, ("accel", "decel", "valid"), strict=True):
        assert np.array_equal(g, w), name


def test_counts_keep_the_callers_shape() -> None:
    motor = Motor(steps_per_rev=400, curve_speed_pps=np.array([0.0, 2000.0, 8000.0]),
                  curve_torque_nm=np.array([0.5, 0.45, 0.1]), inertia_kgm2=1e-5,
                  safety_factor=0.5, start_pps=300.0)
    pb = make_problem(motor, choose_clock(motor), True)
    r_slow = np.array([[4000.0], [3000.0]])
    r_fast = np.array([3500.0, 2500.0, 1000.0])
    n, d, valid = pb.counts(r_slow, r_fast)
    assert n.shape == d.shape == valid.shape == (2, 3)
    want = oracle(pb, *np.broadcast_arrays(r_slow, r_fast))
    assert all(np.array_equal(g, w) for g, w in zip((n, d, valid), want, strict=True))


def test_a_stage_exactly_on_a_band_edge_is_in_the_band() -> None:
    """Bands are closed: a stage whose speed is a band's edge is in it, at either end
    of a step."""
    motor0 = Motor(steps_per_rev=400, curve_speed_pps=np.array([0.0, 5000.0, 9000.0]),
                   curve_torque_nm=np.array([0.5, 0.4, 0.1]), inertia_kgm2=1e-5,
                   safety_factor=0.5, start_pps=300.0, max_jump_pps=500.0)
    hz = choose_clock(motor0).hz
    band = (hz / 4000, hz / 3990)  # narrower than a jump: no stage may lie in it
    motor = replace(motor0, resonance_bands_pps=(band,))
    pb = make_problem(motor, choose_clock(motor), True)
    # steps: into the band, from its low edge out of it, within it, from its high edge,
    # wholly above it, onto its low edge, onto its high edge
    r_slow = np.array([4001.0, 4000.0, 3995.0, 3990.0, 3989.0, 4010.0, 4003.0])
    r_fast = np.array([3996.0, 3985.0, 3992.0, 3985.0, 3985.0, 4000.0, 3990.0])
    got, want = pb.counts(r_slow, r_fast), oracle(pb, r_slow, r_fast)
    for g, w in zip(got, want, strict=True):
        assert np.array_equal(g, w)
    assert got[2].tolist() == [False, False, False, False, True, False, False]


def test_a_count_exactly_at_its_field_limit_is_valid_and_one_past_it_is_not() -> None:
    """The counts are valid up to the field's limit inclusive: with the limit set to a
    step's own accel (decel) count, that step stays valid; one below it, it does not."""
    from profiles.ppmc312.planner.dp_kernel import stage_counts

    motor = Motor(steps_per_rev=400, curve_speed_pps=np.array([0.0, 2000.0, 8000.0]),
                  curve_torque_nm=np.array([0.5, 0.45, 0.1]), inertia_kgm2=1e-5,
                  safety_factor=0.5, start_pps=300.0, friction_torque_nm=0.05)
    for separate in (True, False):
        pb = make_problem(motor, choose_clock(motor), separate)
        consts = list(pb.count_constants)
        r_slow, r_fast = np.array([1200.0]), np.array([1170.0])  # accel 6, decel 2 pulses
        n, d, valid = pb.counts(r_slow, r_fast)
        assert valid[0]
        for limit in (float(n[0]), float(d[0])):
            for most, want in ((limit, bool(limit >= max(n[0], d[0]))), (limit - 1, False)):
                consts[-1] = most
                out = np.empty(1), np.empty(1), np.empty(1, dtype=bool)
                stage_counts(r_slow, r_fast, *consts, *out)
                assert bool(out[2][0]) is want, (separate, limit, most)


@SETTINGS
@given(motors(), st.booleans(), st.integers(0, 2), st.integers(0, 2**32 - 1))
def test_the_graphs_counts_equal_the_step_by_step_counts(motor: Motor, separate: bool,
                                                         shaped: int, seed: int) -> None:
    """The planner's graph counts every step at once (dp_kernel.graph_counts: the torque
    once per node, the breakpoints' least carried from one predecessor to the next); the
    reference is `Problem.counts` step by step on the same steps, to the bit, and each
    node's reach stops at its last valid predecessor."""
    from profiles.ppmc312.planner.search import GRID_TARGET, grid_rates

    rng = np.random.default_rng(seed)
    shaping = (None, Shaping.uniform(float(rng.uniform(0.4, 1.0))),
               Shaping.bands(motor).scaled({1: float(rng.uniform(0.4, 1.0))},
                                           float(rng.uniform(0.5, 1.0))))[shaped]
    slowest = replace(motor, start_pps=motor.start_pps * (shaping or Shaping()).start_scale)
    pb = make_problem(motor, choose_clock(slowest), separate, shaping)
    rates = grid_rates(pb, int(rng.integers(20, GRID_TARGET)))
    width = int(rng.integers(1, 60))
    w, wa, packed_w, valid, reach = pb.graph_counts(rates, width)
    pred = np.arange(len(rates))[:, None] - 1 - np.arange(width)[None, :]
    has = pred >= 0
    n, d, want_valid = pb.counts(rates[np.where(has, pred, 0)].astype(float),
                                 np.broadcast_to(rates[:, None], pred.shape).astype(float))
    want_valid &= has
    assert np.array_equal(valid, want_valid)
    assert np.array_equal(w, np.where(want_valid, n + d, 0.0))
    assert np.array_equal(wa, np.where(want_valid, n, 0.0))
    assert np.array_equal(packed_w, (np.where(want_valid, n + d, 0.0).astype(np.int64) << 32)
                          + np.where(want_valid, n, 0.0).astype(np.int64))
    last = np.where(valid.any(axis=1), width - np.argmax(valid[:, ::-1], axis=1), 0)
    assert np.array_equal(reach, last)


def test_a_datasheet_motors_graph_counts_equal_the_step_by_step_counts() -> None:
    """A motor that starts fast (a jump limit of hundreds of grid steps, the case the
    graph's own pass is for; curve breakpoints between many steps' ends) and the
    reference, the step-by-step counts over every step of its graph."""
    from profiles.ppmc312.planner.search import GRID_TARGET, graph, grid_rates

    speeds = np.array([0.0, 11464.0, 12335.0, 13308.0, 14390.0, 15601.0, 16968.0, 18520.0,
                       20282.0, 22303.0, 24636.0, 27215.0])
    torques = np.array([0.4425, 0.441, 0.3904, 0.342, 0.2953, 0.2506, 0.2075, 0.1663,
                        0.1269, 0.0893, 0.0535, 0.0216])
    motor = Motor(steps_per_rev=1600, curve_speed_pps=speeds, curve_torque_nm=torques,
                  inertia_kgm2=1.468e-5, safety_factor=0.6, start_pps=5546.0,
                  friction_torque_nm=0.0438)
    for shaping in (None, Shaping.bands(motor).scaled({1: 0.7, 3: 0.8}, 0.8)):
        pb = make_problem(motor, choose_clock(motor), True, shaping)
        gr = graph(pb, grid_rates(pb, GRID_TARGET))
        assert gr.pred.shape[1] > 200
        n, d, valid = pb.counts(gr.rates[gr.pred].astype(float),
                                np.broadcast_to(gr.rates[:, None], gr.pred.shape)
                                .astype(float))
        valid &= np.arange(len(gr.rates))[:, None] - 1 - np.arange(gr.pred.shape[1]) >= 0
        assert np.array_equal(gr.valid, valid)
        assert np.array_equal(gr.w, np.where(valid, n + d, 0.0))
        assert np.array_equal(gr.wa, np.where(valid, n, 0.0))


def test_a_shaped_graph_is_as_wide_as_its_largest_jump_and_loses_no_step() -> None:
    """A uniformly tightened plan's graph is narrower (no band allows the full jump), and
    every step it leaves out is invalid in the full-width counts."""
    from profiles.ppmc312.planner.search import GRID_TARGET, graph, grid_rates

    motor = Motor(steps_per_rev=1600, curve_speed_pps=np.array([0.0, 11464.0, 27215.0]),
                  curve_torque_nm=np.array([0.44, 0.44, 0.02]), inertia_kgm2=1.5e-5,
                  safety_factor=0.6, start_pps=5546.0, friction_torque_nm=0.04)
    plain = make_problem(motor, choose_clock(motor), True)
    shaped = make_problem(motor, choose_clock(motor), True, Shaping.uniform(0.6))
    rates = grid_rates(plain, GRID_TARGET)
    full, narrow = graph(plain, rates), graph(shaped, rates)
    assert narrow.width < 0.7 * full.width
    _, _, _, valid, _ = shaped.graph_counts(rates, full.width)
    assert not valid[:, narrow.width:].any()
    assert np.array_equal(valid[:, :narrow.width], narrow.valid)
