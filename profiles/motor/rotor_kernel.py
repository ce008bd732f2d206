"""The load-angle model's integrator, compiled (numba, cached on disk).

The equations, the step and the settling rule are those of `profiles.motor.rotor`
(its docstring states them); `profiles.motor.rotor_reference` is the same integrator
in plain Python, kept as the test oracle. This module is imported only when a
load angle is judged: importing numba and loading the cache costs a few hundred
milliseconds that `stepramp check` without `--motor` never pays.

A rotor is one row of `ROTOR_FIELDS` and one row of pull-out torques at speeds
shared by every row, so the corners of a tolerance box, both directions of a
loaded move and Monte Carlo samples are rows of one array, judged in one call.

Kernels
- `follow_spans`: one rotor over spans of (duration_s, command speed_pps) from a
  state, optionally recording every step (figures) and stopping where the state
  rejoins a reference's (the executions' shared tails).
- `references` and `executions`: every execution of a table (given as flat (rate,
  pulses) segment lists) for every rotor row: the reference is integrated once, the
  others from where their commands part from their source's (the reference's, or
  their family's longest member's) until they rejoin the reference. `executions`
  takes a range of (rotor, execution) pairs and releases the GIL, so ranges run on
  threads (profiles.ppmc312.load_angle.judge): plain threads rather than numba's
  parallel layer, which is neither fork- nor thread-safe with GNU OpenMP and triples
  the compile time.
"""

from __future__ import annotations

import math

import numba as nb
import numpy as np

from ..compiling import watch

watch()  # the first compilation on a machine is said (profiles.compiling)

# One rotor row: electrical radians per pulse, N·m → pps/s, friction and signed load
# [pps/s], damping [1/s]. Its pull-out curve is a row of torques at shared speeds.
C_E, K, FRICTION, LOAD, DAMPING = range(5)
ROTOR_FIELDS = ("c_e", "k", "friction_pps2", "load_pps2", "damping_per_s")

# An execution on the reference's tail stops where what it has seen is no less than the
# reference's rest plus this many times the amplitude of their difference (`follow_spans`):
# margin for the difference to grow as the stiffness falls with speed and sin δ bends.
BOUND = 3.0

# Status of an integration (returned as an int: numba raises nothing we want to catch).
OK, OUT_OF_STEPS, OUT_OF_ROOM = 0, 1, 2

# cached on disk beside this file (or in numba's user cache when that is read-only);
# `nogil`: ranges of (rotor, execution) pairs run on threads at once
_jit = nb.njit(cache=True, nogil=True, error_model="numpy")
# `follow_spans`, the loop over spans and steps, and the helpers it calls allocate
# nothing and run without numba's reference counting (`_plain`: `_nrt=False`): with it,
# every span counted its arrays up and down (an atomic add each way), half the kernel's
# time where spans last a step or two (a table's short stages). A span's and a step's
# own helpers are inlined into it (numba's IR: `_inline`); inlining the rest too only
# lengthened the first compilation (by a quarter).
# (`_nrt` is numba's own flag, which its stubs do not list)
_plain = nb.njit(cache=True, nogil=True, error_model="numpy",
                 _nrt=False)  # type: ignore[call-overload]
_inline = nb.njit(cache=True, nogil=True, error_model="numpy", inline="always",
                  _nrt=False)  # type: ignore[call-overload]


@_plain
def _piece(curve_v: np.ndarray, curve_t: np.ndarray, speed: float
           ) -> tuple[float, float, float, float]:
    """The curve's linear piece holding |speed| below its last point: (its speeds from,
    to; the torque at from; its slope), or an empty piece (from = to = 0) from there on."""
    v = abs(speed)
    last = len(curve_v) - 1
    if v >= curve_v[last]:
        return 0.0, 0.0, 0.0, 0.0
    lo, hi = 0, last
    while hi - lo > 1:  # curve_v[lo] <= v < curve_v[hi]
        mid = (lo + hi) >> 1
        if curve_v[mid] <= v:
            lo = mid
        else:
            hi = mid
    slope = (curve_t[lo + 1] - curve_t[lo]) / (curve_v[lo + 1] - curve_v[lo])
    return curve_v[lo], curve_v[lo + 1], curve_t[lo], slope


@_plain
def _t_peak(curve_v: np.ndarray, curve_t: np.ndarray, speed: float) -> float:
    """The peak restoring torque at |speed| (linear between curve points, 0 beyond)."""
    v = abs(speed)
    last = len(curve_v) - 1
    if v >= curve_v[last]:
        return curve_t[last] if v == curve_v[last] else 0.0
    at, _, torque, slope = _piece(curve_v, curve_t, v)
    return torque + (v - at) * slope


@_inline
def _torque(curve_v: np.ndarray, curve_t: np.ndarray, piece: tuple[float, float, float, float],
            speed: float) -> float:
    """`_t_peak`, from `piece` when |speed| lies in it (a span's rotor speed stays near
    its command's: the same arithmetic, without the search)."""
    v = abs(speed)
    if piece[0] <= v < piece[1]:
        return piece[2] + (v - piece[0]) * piece[3]
    return _t_peak(curve_v, curve_t, v)


@_inline
def _accel(curve_v: np.ndarray, curve_t: np.ndarray, rotor: np.ndarray,
           piece: tuple[float, float, float, float], v: float, lag: float, s: float) -> float:
    """The rotor's acceleration relative to the command's (d²lag/dt² = −this); `piece`:
    the curve's piece at the command speed v (`_piece`)."""
    u = v - s  # the rotor's speed
    fr = rotor[FRICTION]
    a = (rotor[K] * _torque(curve_v, curve_t, piece, u) * math.sin(rotor[C_E] * lag)
         + rotor[DAMPING] * s - rotor[LOAD])
    if u > 0:
        return a - fr
    if u < 0:
        return a + fr
    if abs(a) <= fr:
        return 0.0  # at rest, friction holds the rotor until the drive exceeds it
    return a - math.copysign(fr, a)


@_plain
def natural_period_s(curve_v: np.ndarray, curve_t: np.ndarray, rotor: np.ndarray,
                     speed: float) -> float:
    return _period(rotor, _t_peak(curve_v, curve_t, speed))


@_plain
def _period(rotor: np.ndarray, torque: float) -> float:
    """The natural period where the peak restoring torque is `torque`."""
    stiffness = rotor[K] * rotor[C_E] * torque
    return 2 * math.pi / math.sqrt(stiffness) if stiffness > 0 else math.inf


@_inline
def _rk4(curve_v: np.ndarray, curve_t: np.ndarray, rotor: np.ndarray,
         piece: tuple[float, float, float, float], v: float, lag: float, s: float, h: float
         ) -> tuple[float, float]:
    """One RK4 step of (lag, s) under the command speed v (`piece`: its curve piece)."""
    k1l = s
    k1s = -_accel(curve_v, curve_t, rotor, piece, v, lag, s)
    k2l = s + 0.5 * h * k1s
    k2s = -_accel(curve_v, curve_t, rotor, piece, v, lag + 0.5 * h * k1l, s + 0.5 * h * k1s)
    k3l = s + 0.5 * h * k2s
    k3s = -_accel(curve_v, curve_t, rotor, piece, v, lag + 0.5 * h * k2l, s + 0.5 * h * k2s)
    k4l = s + h * k3s
    k4s = -_accel(curve_v, curve_t, rotor, piece, v, lag + h * k3l, s + h * k3s)
    return (lag + h / 6 * (k1l + 2 * k2l + 2 * k3l + k4l),
            s + h / 6 * (k1s + 2 * k2s + 2 * k3s + k4s))


@_plain
def _put(rec_t: np.ndarray, rec_lag: np.ndarray, recorded: int, t: float, lag: float) -> bool:
    """Record (t, lag) at `recorded`; False when the buffers are full."""
    if recorded == len(rec_t):
        return False
    rec_t[recorded] = t
    rec_lag[recorded] = lag
    return True


@_plain
def _held_lag(curve_v: np.ndarray, curve_t: np.ndarray, rotor: np.ndarray) -> float:
    """The largest |lag| [pulses] the rotor can come to rest at: where the restoring
    torque at rest balances the load and friction together. Below it, a ringing that
    fades may still be creeping up towards where the load holds it."""
    stiff = rotor[K] * _t_peak(curve_v, curve_t, 0.0)
    if not stiff > 0:
        return math.inf
    return math.asin(min(1.0, (abs(rotor[LOAD]) + rotor[FRICTION]) / stiff)) / rotor[C_E]


@_inline
def _span(curve_v: np.ndarray, curve_t: np.ndarray, rotor: np.ndarray, d: float, v: float,
          lag: float, s: float, t: float, step: float, slip: float, tol: float,
          settle_periods: int, limit: int, steps: int, resting: bool, record: bool,
          rec_t: np.ndarray, rec_lag: np.ndarray, recorded: int
          ) -> tuple[int, int, float, float, float, float, int, int]:
    """One span of command speed v for d seconds from (lag, s) at t (see `follow_spans`).

    Returns (status, slipped, slip time, lag, s, its largest |lag|, steps, recorded)."""
    peak = abs(lag)
    held = _held_lag(curve_v, curve_t, rotor) if resting else 0.0
    if not d > 0:  # (a NaN duration too: nothing to integrate)
        return OK, 0, 0.0, lag, s, peak, steps, recorded
    n = max(1, math.ceil(d / step))
    h = d / n
    piece = _piece(curve_v, curve_t, v)
    period = _period(rotor, _torque(curve_v, curve_t, piece, v))
    window = max(8, math.ceil(period / h)) if math.isfinite(period) else n + 1
    lo = lag
    hi = lag
    count = 0
    windows = 0
    last_window = math.inf
    for j in range(1, n + 1):
        lag, s = _rk4(curve_v, curve_t, rotor, piece, v, lag, s, h)
        tj = t + j * h
        if record:
            if not _put(rec_t, rec_lag, recorded, tj, lag):
                return OUT_OF_ROOM, 0, 0.0, lag, s, peak, steps, recorded
            recorded += 1
        steps += 1
        peak = max(peak, abs(lag))
        if abs(lag) > slip:
            return OK, 1, tj, lag, s, peak, steps, recorded
        lo = min(lo, lag)
        hi = max(hi, lag)
        count += 1
        # Held by static friction (the rotor at rest under a moving command) the lag
        # grows steadily however small its range over a window: not settled.
        if count >= window and (s != v or v == 0.0):
            windows += 1
            # Settled: the rest of a constant span repeats this state. An undamped rotor
            # never settles; after `settle_periods` windows its (periodic) oscillation
            # has shown its extremes, so it is skipped as well.
            if hi - lo < tol or windows >= settle_periods:
                if j < n and record:
                    if not _put(rec_t, rec_lag, recorded, t + d, lag):
                        return OUT_OF_ROOM, 0, 0.0, lag, s, peak, steps, recorded
                    recorded += 1
                break
            window_max = max(abs(lo), abs(hi))
            if resting and window_max < last_window and window_max >= held:
                break
            last_window = window_max
            lo = lag
            hi = lag
            count = 0
        if steps >= limit:
            return OUT_OF_STEPS, 0, 0.0, lag, s, peak, steps, recorded
    return OK, 0, 0.0, lag, s, peak, steps, recorded


@_plain
def follow_spans(curve_v: np.ndarray, curve_t: np.ndarray, rotor: np.ndarray,
                 dur: np.ndarray, vel: np.ndarray, lag: float, s: float, previous: float,
                 t0: float, step: float, slip: float, tol: float, settle_periods: int,
                 limit: int, ref_kb: np.ndarray, ref_lag: np.ndarray, ref_s: np.ndarray,
                 tol_lag: float, tol_s: float, out_max: np.ndarray, out_lag: np.ndarray,
                 out_s: np.ndarray, record: bool, rec_t: np.ndarray, rec_lag: np.ndarray,
                 peak_only: bool, ref_suffix: np.ndarray, worst0: float, bound: float
                 ) -> tuple[int, int, int, float, int, int, int]:
    """Integrate over the spans (see `profiles.motor.rotor.follow`).

    Per span i: `out_max[i]` the largest |lag|, (`out_lag[i]`, `out_s[i]`) the state at
    its end. After span i, when `ref_kb[i]` ≥ 0 and the state is within (`tol_lag`,
    `tol_s`) of the reference's boundary `ref_kb[i]`, the integration stops there.
    `record`: every step's (t, lag) into `rec_t`/`rec_lag` (status OUT_OF_ROOM when
    they are full: the caller integrates again with longer ones).
    `peak_only`: only the worst |lag| is wanted, not the final state: the last span, at
    rest, stops once a natural period's largest |lag| falls below the previous period's
    while still no less than the lag the load and friction can hold (`_held_lag`): with
    no command left the ringing only decays towards that lag, so its worst has been
    seen; below it, the rotor may still creep up to where the load holds it.
    `bound` > 0 (with `peak_only`): the integration also stops at a reference boundary
    where the worst |lag| so far (at least `worst0`) is no less than the reference's
    worst from there on (`ref_suffix[kb + 1]`) plus `bound` times the amplitude of the
    difference of their states: both follow the same commands from there, the
    difference only rings down, so the rest cannot raise the worst.

    Returns (spans done, status, slipped, slip time, steps, rejoined boundary or −1,
    recorded points)."""
    t = t0
    steps = 0
    recorded = 0
    worst = worst0
    for i in range(len(dur)):
        v = vel[i]
        s += v - previous  # the command's speed steps; the lag is continuous
        previous = v
        resting = peak_only and v == 0.0 and i == len(dur) - 1
        status, slipped, slip_t, lag, s, peak, steps, recorded = _span(
            curve_v, curve_t, rotor, dur[i], v, lag, s, t, step, slip, tol, settle_periods,
            limit, steps, resting, record, rec_t, rec_lag, recorded)
        if status != OK:
            return i, status, 0, 0.0, steps, -1, recorded
        out_max[i] = peak
        out_lag[i] = lag
        out_s[i] = s
        if slipped:
            return i + 1, OK, 1, slip_t, steps, -1, recorded
        t += dur[i]
        worst = max(worst, peak)
        kb = ref_kb[i]
        if kb >= 0 and _joins(curve_v, curve_t, rotor, v, lag, s, worst, ref_lag[kb], ref_s[kb],
                              tol_lag, tol_s, ref_suffix[kb + 1], bound):
            return i + 1, OK, 0, 0.0, steps, kb, recorded
    return len(dur), OK, 0, 0.0, steps, -1, recorded


@_plain
def _joins(curve_v: np.ndarray, curve_t: np.ndarray, rotor: np.ndarray, v: float, lag: float,
           s: float, worst: float, ref_lag: float, ref_s: float, tol_lag: float, tol_s: float,
           ref_rest: float, bound: float) -> bool:
    """At a boundary of the reference's tail (its state there (`ref_lag`, `ref_s`), its
    worst from there on `ref_rest`): the state has rejoined the reference's, or (`bound`
    > 0) the worst so far bounds the rest (`follow_spans`)."""
    if abs(lag - ref_lag) <= tol_lag and abs(s - ref_s) <= tol_s:
        return True
    return bound > 0 and worst >= ref_rest + bound * _amplitude(
        curve_v, curve_t, rotor, v, lag - ref_lag, s - ref_s)


@_plain
def _amplitude(curve_v: np.ndarray, curve_t: np.ndarray, rotor: np.ndarray, v: float,
               lag: float, s: float) -> float:
    """The amplitude [pulses] of a free oscillation from (lag, s) at the natural frequency
    of the command speed v (infinite when the rotor has no stiffness there)."""
    period = natural_period_s(curve_v, curve_t, rotor, v)
    return math.hypot(lag, s * period / (2 * math.pi)) if math.isfinite(period) else math.inf


@_jit
def _spans(rates: np.ndarray, counts: np.ndarray, lo: int, hi: int, hz: float,
           settle: float) -> tuple[np.ndarray, np.ndarray]:
    """An execution's segments lo..hi as (duration_s, speed_pps), then rest for `settle`."""
    n = hi - lo
    dur = np.empty(n + 1)
    vel = np.empty(n + 1)
    for i in range(n):
        dur[i] = (counts[lo + i] * rates[lo + i]) / hz
        vel[i] = hz / rates[lo + i]
    dur[n] = settle
    vel[n] = 0.0
    return dur, vel


@_jit
def _reference(curve_v: np.ndarray, curve_t: np.ndarray, rotor: np.ndarray, dur: np.ndarray,
               vel: np.ndarray, step: float, slip: float, tol: float, settle_periods: int,
               limit: int, ref_max: np.ndarray, ref_lag: np.ndarray, ref_s: np.ndarray,
               suffix: np.ndarray) -> tuple[int, int, int, int]:
    """The reference execution from rest: its spans' worst |lag| and end states, and
    `suffix[k]` its worst from span k on. Returns (status, slipped, steps, spans whose end
    states are known: every one before a slip)."""
    no_kb = np.full(len(dur), -1, dtype=np.int64)
    no_record = np.empty(0)
    done, status, slipped, _, used, _, _ = follow_spans(
        curve_v, curve_t, rotor, dur, vel, 0.0, 0.0, 0.0, 0.0, step, slip, tol, settle_periods,
        limit, no_kb, ref_lag, ref_s, 0.0, 0.0, ref_max, ref_lag, ref_s, False, no_record,
        no_record, True, suffix, 0.0, 0.0)
    suffix[:] = 0.0
    for k in range(done - 1, -1, -1):
        suffix[k] = max(suffix[k + 1], ref_max[k])
    return status, slipped, used, done - 1 if slipped else done


@_plain
def _boundary(rates: np.ndarray, at: int, remaining: int, tail: int, r0: int, m: int,
              ref_slipped: bool) -> int:
    """The reference's boundary (the end of its segment r0 + k) matching the end of
    segment `at`, which `remaining` segments follow, or −1: the commands after it are the
    same (the common tail of `tail` segments) and so is the one before it (a state is
    compared relative to its command)."""
    k = m - 1 - remaining
    if ref_slipped or remaining < 0 or remaining > tail or k < 0:
        return -1
    if remaining < tail or rates[at] == rates[r0 + k]:
        return k
    return -1


@_jit
def _execution(curve_v: np.ndarray, curve_t: np.ndarray, rotor: np.ndarray, rates: np.ndarray,
               counts: np.ndarray, a0: int, a1: int, s0: int, s1: int, src_lag: np.ndarray,
               src_s: np.ndarray, src_worst: np.ndarray, src_valid: int, r0: int, r1: int,
               hz: float, step: float, settle: float, slip: float, tol: float,
               settle_periods: int, rejoin_lag: float, tol_s: float, limit: int,
               ref_slipped: bool, ref_lag: np.ndarray, ref_s: np.ndarray, suffix: np.ndarray,
               rec_lag: np.ndarray, rec_s: np.ndarray, rec_worst: np.ndarray
               ) -> tuple[int, float, bool, int, int]:
    """One execution (segments a0..a1) from where its command parts from its source's
    (segments s0..s1, whose state and worst |lag| so far at the end of each of its first
    `src_valid` segments are `src_*`) until its state rejoins the reference's (segments
    r0..r1) on their common tail. With `rec_lag` non-empty, the state and worst so far at
    the end of each of its own segments go there.

    Returns (status, worst |lag|, slipped, steps, segments whose `rec_*` are known)."""
    length = a1 - a0
    m = r1 - r0
    lim = min(length, s1 - s0, src_valid)
    head = 0
    while head < lim and rates[a0 + head] == rates[s0 + head] and \
            counts[a0 + head] == counts[s0 + head]:
        head += 1
    tail = 0
    if not ref_slipped:  # a slipped reference has no tail to share (its head: src_valid)
        lim = min(length, m) - (head if s0 == r0 else 0)
        while tail < lim and rates[a1 - 1 - tail] == rates[r1 - 1 - tail] and \
                counts[a1 - 1 - tail] == counts[r1 - 1 - tail]:
            tail += 1
        if s0 == r0 and head == length and length == m:
            return OK, suffix[0], False, 0, 0
    record = len(rec_lag) > 0
    for k in range(head if record else 0):
        rec_lag[k] = src_lag[k]
        rec_s[k] = src_s[k]
        rec_worst[k] = src_worst[k]
    dur, vel = _spans(rates, counts, a0 + head, a1, hz, settle)
    spans = len(dur)
    kb = np.full(spans, -1, dtype=np.int64)
    for i in range(spans):
        kb[i] = _boundary(rates, a0 + head + i, length - 1 - (head + i), tail, r0, m,
                          ref_slipped)
    lag0 = src_lag[head - 1] if head else 0.0
    s0_ = src_s[head - 1] if head else 0.0
    prev = hz / rates[a0 + head - 1] if head else 0.0
    worst = src_worst[head - 1] if head else 0.0
    # where it starts may already be such a boundary (a trapezoid's decel, started from
    # the reference's state at the end of its own cruise)
    k = _boundary(rates, a0 + head - 1, length - head, tail, r0, m, ref_slipped) if head else -1
    if k >= 0 and _joins(curve_v, curve_t, rotor, prev, lag0, s0_, worst, ref_lag[k], ref_s[k],
                         rejoin_lag, tol_s, suffix[k + 1], BOUND):
        return OK, max(worst, suffix[k + 1]), False, 0, head
    out_max = np.zeros(spans)
    out_lag = np.zeros(spans)
    out_s = np.zeros(spans)
    no_record = np.empty(0)
    done, status, slip_flag, _, used, rejoined, _ = follow_spans(
        curve_v, curve_t, rotor, dur, vel, lag0, s0_, prev, 0.0, step, slip, tol,
        settle_periods, limit, kb, ref_lag, ref_s, rejoin_lag, tol_s, out_max, out_lag, out_s,
        False, no_record, no_record, True, suffix, worst, BOUND)
    known = head
    for k in range(done):
        worst = max(worst, out_max[k])
        if record and head + k < length and (status == OK and not (
                slip_flag == 1 and k == done - 1)):
            rec_lag[head + k] = out_lag[k]
            rec_s[head + k] = out_s[k]
            rec_worst[head + k] = worst
            known = head + k + 1
    if rejoined >= 0:
        worst = max(worst, suffix[rejoined + 1])
    return status, worst, slip_flag == 1, used, known


@_jit
def references(curve_v: np.ndarray, curve_t: np.ndarray, rotors: np.ndarray, steps: np.ndarray,
               settles: np.ndarray, rates: np.ndarray, counts: np.ndarray, r0: int, r1: int,
               hz: float, slip_deg: float, tol_deg: float, settle_periods: int,
               rejoin_deg: float, max_trace_steps: int, ref_max: np.ndarray,
               ref_lag: np.ndarray, ref_s: np.ndarray, suffix: np.ndarray, limits: np.ndarray,
               status: np.ndarray, slipped: np.ndarray, used: np.ndarray,
               valid: np.ndarray) -> None:
    """Each rotor row's reference execution (segments r0..r1) from rest, into the per-rotor
    rows of `ref_*` and `suffix`; `limits` gets each rotor's (slip, settle tolerance,
    rejoin tolerance of the lag, of its rate) in pulses; `valid` how many of its segments'
    end states are known (all of them unless it slipped: those before the slip, which
    executions still start from — a stop at once that slips from the top speed leaves
    every state of the ramp below it)."""
    for r in range(rotors.shape[0]):
        c_e = rotors[r, C_E]
        limits[r, 0] = math.radians(slip_deg) / c_e
        limits[r, 1] = math.radians(tol_deg) / c_e
        limits[r, 2] = math.radians(rejoin_deg) / c_e
        period = natural_period_s(curve_v, curve_t[r], rotors[r], 0.0)
        limits[r, 3] = limits[r, 2] * (2 * math.pi / period if math.isfinite(period) else 1.0)
        dur, vel = _spans(rates, counts, r0, r1, hz, settles[r])
        st, sl, u, known = _reference(curve_v, curve_t[r], rotors[r], dur, vel, steps[r],
                                      limits[r, 0], limits[r, 1], settle_periods,
                                      max_trace_steps, ref_max[r], ref_lag[r], ref_s[r],
                                      suffix[r])
        status[r] = st
        slipped[r] = sl == 1
        used[r] = u
        valid[r] = min(known, r1 - r0)


@_jit
def executions(curve_v: np.ndarray, curve_t: np.ndarray, rotors: np.ndarray, steps: np.ndarray,
               settles: np.ndarray, rates: np.ndarray, counts: np.ndarray, offsets: np.ndarray,
               ref: int, source: np.ndarray, slot: np.ndarray, hz: float, settle_periods: int,
               max_trace_steps: int, ref_worst: np.ndarray, ref_lag: np.ndarray,
               ref_s: np.ndarray, suffix: np.ndarray, limits: np.ndarray,
               ref_status: np.ndarray, ref_slipped: np.ndarray, ref_valid: np.ndarray,
               fam_lag: np.ndarray,
               fam_s: np.ndarray, fam_worst: np.ndarray, fam_known: np.ndarray,
               order: np.ndarray, first: int, last: int, worst: np.ndarray,
               slipped: np.ndarray, status: np.ndarray, used: np.ndarray) -> None:
    """The (rotor, execution) pairs first..last−1 of the rotors × `order` grid (row major:
    execution `order[i]`) against each rotor's reference (`references`; `ref_worst`: its
    worst |lag| up to each span's end): worst |lag| [pulses], slipped, status and RK4
    steps into those cells.

    An execution starts from its source's state where their commands part: the
    reference's, or (`source[e]` ≥ 0) that of a family's longest member, whose states
    at the end of each of its segments are kept from `slot[source]` on in the `fam_*`
    rows (`fam_known[r, source]` of them known). A source comes before its members in
    `order`, and a range of cells never splits a family. Releases the GIL: disjoint
    ranges run on threads at once."""
    n_order = len(order)
    r0, r1 = offsets[ref], offsets[ref + 1]
    empty = np.empty(0)
    for job in range(first, last):
        r = job // n_order
        e = order[job % n_order]
        if ref_status[r] != OK:
            status[r, e] = ref_status[r]
            continue
        if e == ref:
            worst[r, e] = suffix[r, 0]
            slipped[r, e] = ref_slipped[r]
            continue
        p = source[e]
        if p >= 0:
            k0, k1 = slot[p], slot[p] + offsets[p + 1] - offsets[p]
            src = (offsets[p], offsets[p + 1], fam_lag[r, k0:k1], fam_s[r, k0:k1],
                   fam_worst[r, k0:k1], fam_known[r, p])
        else:
            src = (r0, r1, ref_lag[r], ref_s[r], ref_worst[r], ref_valid[r])
        if slot[e] >= 0:
            k0, k1 = slot[e], slot[e] + offsets[e + 1] - offsets[e]
            rec = (fam_lag[r, k0:k1], fam_s[r, k0:k1], fam_worst[r, k0:k1])
        else:
            rec = (empty, empty, empty)
        st, w, sl, u, known = _execution(
            curve_v, curve_t[r], rotors[r], rates, counts, offsets[e], offsets[e + 1], src[0],
            src[1], src[2], src[3], src[4], src[5], r0, r1, hz, steps[r], settles[r],
            limits[r, 0], limits[r, 1], settle_periods, limits[r, 2], limits[r, 3],
            max_trace_steps, ref_slipped[r], ref_lag[r], ref_s[r], suffix[r], rec[0], rec[1],
            rec[2])
        if slot[e] >= 0:
            fam_known[r, e] = known
        status[r, e] = st
        worst[r, e] = w
        slipped[r, e] = sl
        used[r, e] = u
