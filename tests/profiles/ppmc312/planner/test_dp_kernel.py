"""The planner's compiled kernels (profiles.ppmc312.planner.dp_kernel) equal, to the bit,
the numpy they replaced, kept here as oracles: the DP's layers (which skip the nodes none
of whose predecessors improved), the refinement's move of every other stage, and the
search for switch-safe top pulses. Over random motors, shapings, LE variants and
staircases, so that a plan is the same table whichever runs it."""

from __future__ import annotations

import math
from dataclasses import replace

import numpy as np
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from profiles.motor import Motor
from profiles.motor.resonance import in_bands, narrow_bands
from profiles.ppmc312.criterion import switch_safe_rows
from profiles.ppmc312.limits import MIN_STAGE_TICKS, RATE_MAX, SIDE_TOTAL_MAX, STAGE_PULSES_MAX
from profiles.ppmc312.planner import Shaping, choose_clock, make_problem
from profiles.ppmc312.planner.dp_kernel import switch_safe_tops
from profiles.ppmc312.planner.problem import Problem
from profiles.ppmc312.planner.refine import OFFSETS, Staircase, _refine_inner, evaluate
from profiles.ppmc312.planner.search import GRID_TARGET, graph, grid_rates, run_dp
from tests.support.strategies import curve_motors as motors

SETTINGS = settings(max_examples=40, deadline=None,
                    suppress_health_check=[HealthCheck.too_slow, HealthCheck.filter_too_much])


def problem(motor: Motor, separate: bool, shaped: int, rng: np.random.Generator) -> Problem:
    shaping = (None, Shaping.uniform(float(rng.uniform(0.4, 1.0))),
               Shaping.bands(motor).scaled({1: float(rng.uniform(0.4, 1.0)),
                                            2: float(rng.uniform(0.4, 1.0))}))[shaped]
    slowest = replace(motor, start_pps=motor.start_pps * (shaping or Shaping()).start_scale)
    return make_problem(motor, choose_clock(slowest), separate, shaping)


# --- the DP's layers -------------------------------------------------------------------------
def layers_oracle(pred: np.ndarray, cost: np.ndarray, packed_w: np.ndarray, start: np.ndarray,
                  f: np.ndarray, start_f: float, jump: float, max_stages: int
                  ) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Every node of every layer computed (numpy per layer): (value, packed, parents)."""
    g = len(f)
    value = np.where(start, 0.0, np.inf)
    packed = np.zeros(g, dtype=np.int64)
    parents = np.full((max_stages + 1, g), -1, dtype=np.int32)
    rows = np.arange(g)
    for m in range(2, max_stages + 1):
        hi = min(int(np.searchsorted(f, start_f + (m - 1) * jump * (1 + 1e-9), side="right")),
                 g)
        prev, prev_packed = value.copy(), packed.copy()
        total = prev[pred[:hi]] + cost[:hi]
        pick = np.argmin(total, axis=1)
        best = total[rows[:hi], pick]
        src = pred[rows[:hi], pick]
        if m == 2:
            better = np.isfinite(best)
            value[:hi] = best
            packed[:hi] = np.where(better, packed_w[rows[:hi], pick], 0)
        else:
            better = best < prev[:hi]
            value[:hi] = np.where(better, best, prev[:hi])
            packed[:hi] = np.where(better, prev_packed[src] + packed_w[rows[:hi], pick],
                                   prev_packed[:hi])
        parents[m, :hi] = np.where(better, src, -1)
        if m > 2 and hi == g and not better.any():
            return value, packed, parents[:m]
    return value, packed, parents


@SETTINGS
@given(motors(), st.booleans(), st.integers(0, 2), st.integers(2, 127),
       st.integers(0, 2**32 - 1))
def test_layers_equal_every_node_computed(motor: Motor, separate: bool, shaped: int,
                                          max_stages: int, seed: int) -> None:
    rng = np.random.default_rng(seed)
    pb = problem(motor, separate, shaped, rng)
    gr = graph(pb, grid_rates(pb, int(rng.integers(50, GRID_TARGET))))
    lam = float(rng.choice([0.0, 1.0 / gr.f[-1], 1.0 / gr.f[len(gr.f) // 2]]))
    dp = run_dp(gr, lam, max_stages, pb.start, pb.jump)
    cost = np.where(gr.valid, gr.w * (1.0 / gr.f[gr.pred] - lam), np.inf)
    packed_w = (gr.w.astype(np.int64) << 32) + gr.wa.astype(np.int64)
    value, packed, parents = layers_oracle(gr.pred, cost, packed_w, gr.start, gr.f,
                                           pb.start, pb.jump, max_stages)
    assert np.array_equal(dp.value, value)
    assert np.array_equal(dp.pulses, (packed >> 32).astype(float))
    assert np.array_equal(dp.accel, (packed & 0xFFFFFFFF).astype(float))
    assert np.array_equal(dp.parent, parents)


def test_layers_skip_most_nodes_yet_find_the_same_paths() -> None:
    """A bundled motor's DP: the same layers as every node computed (the skip is the
    point: most nodes of a late layer have no predecessor that improved)."""
    from profiles.motor import bundled_motor_paths, load_motor

    motor = load_motor(next(p for p in bundled_motor_paths() if "nema23" in p.name))
    pb = make_problem(motor, choose_clock(motor), False)
    gr = graph(pb, grid_rates(pb, GRID_TARGET))
    lam = 1.0 / gr.f[-1]
    dp = run_dp(gr, lam, 127, pb.start, pb.jump)
    cost = np.where(gr.valid, gr.w * (1.0 / gr.f[gr.pred] - lam), np.inf)
    packed_w = (gr.w.astype(np.int64) << 32) + gr.wa.astype(np.int64)
    value, _, parents = layers_oracle(gr.pred, cost, packed_w, gr.start, gr.f, pb.start,
                                      pb.jump, 127)
    assert np.array_equal(dp.value, value) and np.array_equal(dp.parent, parents)
    assert len(dp.parent) > 100  # many layers: the skip has work to save


# --- the refinement --------------------------------------------------------------------------
def refine_inner_oracle(pb: Problem, ev: Staircase, budget: int, parity: int,
                        offsets: np.ndarray) -> Staircase | None:
    """`refine._refine_inner` as numpy over every stage and offset at once."""
    r = ev.rates
    m = len(r)
    ks = np.arange(parity, m - 1, 2)
    if len(ks) == 0:
        return None
    lam = r[-1] / pb.hz
    cand = r[ks][:, None] + offsets[None, :]
    upper = np.where(ks > 0, r[np.maximum(ks - 1, 0)], RATE_MAX + 1)[:, None]
    lower = r[ks + 1][:, None]
    ok = (cand > lower) & (cand < upper) & (cand <= RATE_MAX)
    ok &= np.where(ks[:, None] == 0, cand >= pb.r_start, True)
    cand = np.where(ok, cand, r[ks][:, None])
    f_c = pb.hz / cand.astype(float)
    n_out, d_out, v_out = pb.counts(cand, np.broadcast_to(lower, cand.shape))
    with np.errstate(invalid="ignore"):
        cost = (n_out + d_out) * (1.0 / f_c - lam)
        w = n_out + d_out
        has_in = ks > 0
        r_in = np.broadcast_to(upper, cand.shape)
        n_in, d_in, v_in = pb.counts(np.where(has_in[:, None], r_in, cand + 1), cand)
        f_in = pb.hz / r_in.astype(float)
        cost = cost + np.where(has_in[:, None], (n_in + d_in) * (1.0 / f_in - lam), 0.0)
        w = w + np.where(has_in[:, None], n_in + d_in, 0.0)
        feasible = ok & v_out & np.where(has_in[:, None], v_in, True)
        cost = np.where(feasible, cost, np.inf)
        cur = np.flatnonzero(offsets == 0)[0]
        pick = np.argmin(cost, axis=1)
        rows = np.arange(len(ks))
        gain = cost[rows, cur] - cost[rows, pick]
        dw = w[rows, pick] - w[rows, cur]
    slack = budget - ev.total
    move = (gain > 0) & np.isfinite(cost[rows, pick])
    if np.sum(np.where(move, dw, 0)) > slack:
        move &= dw <= 0
    if not np.any(move):
        return None
    new = r.copy()
    new[ks[move]] = cand[rows[move], pick[move]]
    return evaluate(pb, new, budget)


def staircase(pb: Problem, rng: np.random.Generator, budget: int) -> Staircase | None:
    """A random valid staircase of the problem's grid: rates rising in speed, each step
    within the jump limit, the slowest at or below the start speed."""
    rates = grid_rates(pb, 400)
    gr = graph(pb, rates)
    starts = np.flatnonzero(gr.start)
    if not len(starts):
        return None
    path = [int(rng.choice(starts))]
    while path[-1] < len(rates) - 1 and rng.random() > 0.03:
        j = path[-1]
        nxt = np.flatnonzero(gr.valid[:, :] & (gr.pred == j))
        succ = nxt // gr.pred.shape[1]
        succ = succ[succ > j]
        if not len(succ):
            break
        path.append(int(rng.choice(succ)))
    return evaluate(pb, rates[path], budget)


@SETTINGS
@given(motors(), st.booleans(), st.integers(0, 2), st.integers(0, 2**32 - 1))
def test_refinement_moves_the_stages_numpy_moved(motor: Motor, separate: bool, shaped: int,
                                                 seed: int) -> None:
    rng = np.random.default_rng(seed)
    pb = problem(motor, separate, shaped, rng)
    budget = int(rng.choice([100, 2_000, 50_000, 10_000_000]))
    ev = staircase(pb, rng, 10 * SIDE_TOTAL_MAX)
    if ev is None:
        return
    for parity in (0, 1):
        for slack_budget in (budget, ev.total, 10 * SIDE_TOTAL_MAX):
            got = _refine_inner(pb, ev, slack_budget, parity, OFFSETS)
            want = refine_inner_oracle(pb, ev, slack_budget, parity, OFFSETS)
            assert (got is None) == (want is None)
            if got is not None and want is not None:
                assert np.array_equal(got.rates, want.rates)
                assert got.time_s == want.time_s


# --- switch-safe top pulses ------------------------------------------------------------------
def switch_safe_tops_oracle(n: np.ndarray, d0: np.ndarray, room: np.ndarray
                            ) -> tuple[np.ndarray, np.ndarray]:
    """Every row at once with `switch_safe_rows`: doubling until safe, then bisection."""
    def safe(extra: np.ndarray) -> np.ndarray:
        d = d0.copy()
        d[:, -1] += extra
        return switch_safe_rows(n, d)

    hi = np.zeros(len(d0), dtype=np.int64)
    found = safe(hi)
    searching = ~found & (room >= 1)
    hi[searching] = 1
    while searching.any():
        ok = safe(hi) & searching
        found |= ok
        searching &= ~ok
        hi = np.where(searching, hi * 2, hi)
        searching &= hi <= room
    lo = np.where(found & (hi > 0), hi // 2, 0)
    while True:
        open_ = found & (hi - lo > 1)
        if not open_.any():
            break
        mid = (lo + hi) // 2
        ok = safe(np.where(open_, mid, hi))
        hi = np.where(open_ & ok, mid, hi)
        lo = np.where(open_ & ~ok, mid, lo)
    return hi, found


@settings(max_examples=300, deadline=None)
@given(st.lists(st.integers(1, 3000), min_size=1, max_size=12), st.integers(0, 2**32 - 1))
def test_switch_safe_tops_equal_every_row_at_once(n: list[int], seed: int) -> None:
    rng = np.random.default_rng(seed)
    accel = np.asarray(n, dtype=np.int64)
    floors = np.linspace(0.0, 1.0, 11)
    d0 = np.maximum(rng.integers(1, 3000, len(n))[None, :],
                    np.ceil(floors[:, None] * accel[None, :])).astype(np.int64)
    room = int(rng.choice([0, 1, 50, 5_000, SIDE_TOTAL_MAX])) - d0.sum(axis=1)
    hi = np.zeros(len(floors), dtype=np.int64)
    found = np.zeros(len(floors), dtype=np.bool_)
    switch_safe_tops(accel, d0, room, hi, found)
    want_hi, want_found = switch_safe_tops_oracle(accel, d0, room)
    assert np.array_equal(found, want_found)
    assert np.array_equal(hi[found], want_hi[want_found])
    for k in np.flatnonzero(found):  # the top pulses found are safe, one fewer is not
        d = d0[k].copy()
        d[-1] += hi[k]
        assert switch_safe_rows(accel, d[None, :])[0]
        if hi[k] > 0:
            d[-1] -= 1
            assert not switch_safe_rows(accel, d[None, :])[0]


SETTINGS_COUNTS = settings(max_examples=60, deadline=None,
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

def counts_problem(motor: Motor, separate: bool, shaped: int,
                   rng: np.random.Generator) -> Problem:
    """The problem the counts are compared on: unshaped, uniformly shaped, or its first
    band scaled (and the rest by a common factor), as `shaped` picks."""
    shaping = (None, Shaping.uniform(float(rng.uniform(0.4, 1.0))),
               Shaping.bands(motor).scaled({1: float(rng.uniform(0.4, 1.0))},
                                           float(rng.uniform(0.5, 1.0))))[shaped]
    slowest = replace(motor, start_pps=motor.start_pps * (shaping or Shaping()).start_scale)
    return make_problem(motor, choose_clock(slowest), separate, shaping)



@SETTINGS_COUNTS
@given(motors(), st.booleans(), st.integers(0, 2), st.integers(0, 2**32 - 1))
def test_compiled_counts_equal_the_capabilitys_to_the_bit(motor: Motor, separate: bool,
                                                         shaped: int, seed: int) -> None:
    rng = np.random.default_rng(seed)
    pb = counts_problem(motor, separate, shaped, rng)
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


@SETTINGS_COUNTS
@given(motors(), st.booleans(), st.integers(0, 2), st.integers(0, 2**32 - 1))
def test_the_graphs_counts_equal_the_step_by_step_counts(motor: Motor, separate: bool,
                                                         shaped: int, seed: int) -> None:
    """The planner's graph counts every step at once (dp_kernel.graph_counts: the torque
    once per node, the breakpoints' least carried from one predecessor to the next); the
    reference is `Problem.counts` step by step on the same steps, to the bit, and each
    node's reach stops at its last valid predecessor."""
    from profiles.ppmc312.planner.search import GRID_TARGET, grid_rates

    rng = np.random.default_rng(seed)
    pb = counts_problem(motor, separate, shaped, rng)
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
