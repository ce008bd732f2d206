"""Moves assembled into flat segment arrays (`batch.MoveBatch`), compiled (numba, cached on
disk): the PPMC-312's executions and the A-Link unit's motions alike.

`move_batch._assemble` holds the method in numpy and stays the one every command uses;
this is its compiled twin for the load-angle verdict, which builds some 600 moves of
~150 segments per table and already pays for numba (the rotor kernel): there numpy's
passes over every segment were a third of a verdict. `stepramp simulate` and `show`
never import numba (its import and first call cost about a second). The twin is
pinned equal, array for array, by tests/profiles/motor/test_assemble_kernel.py.
"""

from __future__ import annotations

import numba as nb
import numpy as np

from ..compiling import watch

watch()  # the first compilation on a machine is said (profiles.compiling)

ACCEL, CRUISE, DECEL = 0, 1, 2   # batch.PHASES


@nb.njit(cache=True, nogil=True, inline="always")
def _whole(cum: np.ndarray, lo: int, hi: int, count: int) -> int:
    """np.searchsorted(cum[lo:hi], count, side="left"): the stages whose pulses stay
    below `count`."""
    a, b = lo, hi
    while a < b:
        mid = (a + b) >> 1
        if cum[mid] < count:
            a = mid + 1
        else:
            b = mid
    return a - lo


@nb.njit(cache=True, nogil=True)
def assemble(x: np.ndarray, starts: np.ndarray, rates: np.ndarray, counts: np.ndarray,
             cum: np.ndarray, cruise_rate: int, clamp: np.ndarray
             ) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """Moves from their five parts' pulses `x[part, move]` (accel, accel, cruise, decel,
    decel): part i's stages are rates/counts/cum[starts[i]:starts[i + 1]], slowest first;
    an accel part runs the first x pulses from the slow end, a decel part the last ones
    towards it, the last stage reached partly; the cruise is one segment at
    `cruise_rate`. Where `clamp`, decel pulses run no faster than the accel's peak. A
    segment at the phase and rate of the one before it in its move joins it. Returns
    (phase, rate, count, offsets)."""
    n_moves = x.shape[1]
    # pass 1: segments before joining, for the arrays' size
    size = 0
    for j in range(n_moves):
        for i in range(5):
            c = max(x[i, j], 0)
            if i == 2:
                size += 1 if c > 0 else 0
                continue
            lo, hi = starts[i], starts[i + 1]
            whole = _whole(cum, lo, hi, c)
            before = cum[lo + whole - 1] if whole > 0 else 0
            size += whole + (1 if whole < hi - lo and c - before > 0 else 0)
    phase = np.empty(size, np.int8)
    rate = np.empty(size, np.int64)
    count = np.empty(size, np.int64)
    offsets = np.empty(n_moves + 1, np.int64)
    offsets[0] = 0
    pos = 0
    for j in range(n_moves):
        first = pos
        accel = 0
        for i in range(5):
            c = max(x[i, j], 0)
            if i == 2:
                if c > 0:
                    phase[pos], rate[pos], count[pos] = CRUISE, cruise_rate, c
                    pos += 1
                continue
            lo, hi = starts[i], starts[i + 1]
            whole = _whole(cum, lo, hi, c)
            before = cum[lo + whole - 1] if whole > 0 else 0
            part = c - before if whole < hi - lo else 0
            n = whole + (1 if part > 0 else 0)
            for k in range(n):
                stage = k if i < 2 else n - 1 - k  # decelerating: fastest first
                phase[pos] = ACCEL if i < 2 else DECEL
                rate[pos] = rates[lo + stage]
                count[pos] = part if part > 0 and stage == whole else counts[lo + stage]
                pos += 1
            if i < 2:
                accel += n
        if clamp[j] and accel > 0:
            # LE=1's split can end the accel below the stage the decel share starts on;
            # decelerating never speeds up, so those pulses run at the peak rate
            peak = rate[first]
            for q in range(first + 1, first + accel):
                peak = min(peak, rate[q])
            for q in range(first + accel, pos):
                if phase[q] == DECEL:
                    rate[q] = max(rate[q], peak)
        joined = first
        for q in range(first, pos):
            if q > first and phase[q] == phase[joined - 1] and rate[q] == rate[joined - 1]:
                count[joined - 1] += count[q]
            else:
                phase[joined], rate[joined], count[joined] = phase[q], rate[q], count[q]
                joined += 1
        pos = joined
        offsets[j + 1] = pos
    # views, not copies: joining frees a few segments in 10⁵, and a copy faults in its pages
    return phase[:pos], rate[:pos], count[:pos], offsets
