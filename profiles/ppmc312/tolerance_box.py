"""The load angle over a motor's tolerance box (profiles.motor.tolerance), for
the table's verdict (`safety.judge_table`: the criterion over the box is judged there, at
its worst case).

- every corner of the box over every move length: the corners are rows of one call of
  the compiled model (profiles.ppmc312.load_angle);
- a seeded Monte Carlo sample of the box on the move lengths worst at some corner, each
  sample judged exactly as its own motor would be (rows of one call again);
- the stall probability: samples past the 90° peak, with the exact Clopper–Pearson
  one-sided 95 % upper bound (0 of N → 1 − 0.05^(1/N) ≈ 3/N).
"""

from __future__ import annotations

from collections.abc import Iterable, Sequence

import numpy as np

from profiles.motor import Motor
from profiles.motor.angles import PEAK_DEG
from profiles.motor.batch_angle import batch_sample_peaks
from profiles.motor.tolerance import clopper_pearson_upper, corners, sample_params
from profiles.ppmc312.load_angle import worst_load_angles
from profiles.ppmc312.move_batch import moves
from profiles.ppmc312.table import FreeCurveTable
from profiles.progress import Progress, report
from profiles.verdict import CONFIDENCE, DEFAULT_SAMPLES, BoxVerdict


def judge_box(table: FreeCurveTable, motor: Motor, *, pulses: Iterable[int] | None = None,
              samples: int = DEFAULT_SAMPLES, seed: int = 0,
              progress: Progress | None = None) -> BoxVerdict:
    """The load angle of `table` over `motor`'s tolerance box (every move length, or the
    moves of the given lengths)."""
    lengths = None if pulses is None else sorted(set(pulses))
    box_corners = corners(motor)
    total = len(box_corners) + (1 if samples else 0)
    verdicts = worst_load_angles(table, [c.motor for c in box_corners], pulses=lengths)
    k = int(np.argmax([w.worst_angle_deg for w in verdicts]))
    corner_worst = verdicts[k].worst_angle_deg
    worst = (corner_worst, box_corners[k].describe(), verdicts[k].worst_pulses,
             verdicts[k].worst_direction)
    unstable = [w.first_unstable_pulses for w in verdicts if w.first_unstable_pulses]
    report(progress, len(box_corners), total)
    # Samples are judged on the moves worst at some corner (given lengths: all of them)
    sampled = tuple(sorted({w.worst_pulses for w in verdicts} if lengths is None
                           or len(lengths) > 8 else lengths))
    sample_worst, failures = -1.0, 0
    if samples:
        peaks, where, way = sample_peaks(table, motor, sampled, samples, seed)
        failures = int(np.sum(peaks >= PEAK_DEG))
        i = int(np.argmax(peaks))
        sample_worst = float(peaks[i])
        if sample_worst > worst[0]:
            params = sample_params(motor, samples, seed)
            values = ", ".join(f"{key} {params[key][i]:.4g}" for key in params
                               if motor.tolerance(key)[1] > motor.tolerance(key)[0])
            worst = (sample_worst, f"sample {i} ({values})", int(where[i]), int(way[i]))
        if failures:
            unstable.append(int(np.min(where[peaks >= PEAK_DEG])))
        report(progress, total, total)
    bound = clopper_pearson_upper(failures, samples, CONFIDENCE) if samples else 1.0
    return BoxVerdict(worst[0], worst[1], worst[2], worst[3], len(box_corners), corner_worst,
                      samples, seed, sample_worst, failures, sampled, bound,
                      min(unstable) if unstable else None, any(w.slipped for w in verdicts),
                      sum(w.executions for w in verdicts) + samples * len(sampled))


def sample_peaks(table: FreeCurveTable, motor: Motor, lengths: Iterable[int], samples: int,
                 seed: int) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Each sample's worst |load angle| over the moves of `lengths` (both directions when
    the box or the motor has a load torque), the move length and the direction where it
    is worst: sample i judged exactly as the motor `tolerance.samples(motor, …)[i]`."""
    runs = moves(table, sorted({int(n) for n in lengths}))
    peaks, which, way = batch_sample_peaks(runs, table.clock.hz, motor, samples, seed)
    return peaks, runs.pulses[which], way


def stop_sample_peaks(table: FreeCurveTable, motor: Motor, stops: Sequence[tuple[int, int]],
                      samples: int, seed: int) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """`sample_peaks` on decel stops (profiles.ppmc312.stops: (stage, dwell) each): each
    sample's worst angle, the index into `stops` and the direction where it is worst."""
    from profiles.ppmc312.stops import stop_batch

    pairs = np.asarray(stops, dtype=np.int64).reshape(-1, 2)
    return batch_sample_peaks(stop_batch(table, pairs[:, 0], pairs[:, 1]), table.clock.hz,
                              motor, samples, seed)


