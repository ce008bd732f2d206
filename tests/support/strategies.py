"""Hypothesis strategies more than one test module draws from: motors, free-curve
tables, the tables the chip accepts, the fields of a PPMC-312 answer, A-Link commands."""

from __future__ import annotations

from typing import Any

import numpy as np
from hypothesis import reject
from hypothesis import strategies as st

from profiles.alink.commands import COMMANDS, Value
from profiles.errors import FormatError
from profiles.fields import Array, Bits, SInt, UInt
from profiles.motor import Motor
from profiles.ppmc312.answer_kinds import SOURCES, Kind
from profiles.ppmc312.clock import INTERNAL_HZ, Clock
from profiles.ppmc312.table import FreeCurveTable

MHZ1 = Clock.internal("1MHz")


@st.composite
def rotor_motors(draw: st.DrawFn) -> Motor:
    """A hybrid stepper: a falling pull-out curve (its last point may be 0), 2 or 5
    phases, light to heavy inertia, friction, a signed load, any damping."""
    steps = draw(st.sampled_from([200, 400, 1000, 1600, 3200]))
    points = draw(st.integers(2, 5))
    top = draw(st.floats(4_000, 60_000))
    speeds = np.linspace(0.0, top, points)
    t0 = draw(st.floats(0.1, 2.0))
    falls = np.sort(np.asarray(draw(st.lists(st.floats(0.05, 1.0), min_size=points - 1,
                                              max_size=points - 1))))[::-1]
    torques = np.concatenate(([t0], t0 * falls))
    if draw(st.booleans()):
        torques[-1] = 0.0
    friction = draw(st.floats(0.0, 0.15)) * t0
    load = draw(st.floats(-0.15, 0.15)) * t0
    return Motor(steps_per_rev=steps, curve_speed_pps=speeds, curve_torque_nm=torques,
                 inertia_kgm2=draw(st.floats(2e-6, 1e-3)), safety_factor=0.6,
                 start_pps=draw(st.floats(100, 1000)), friction_torque_nm=friction,
                 load_torque_nm=load, phases=draw(st.sampled_from([2, 5])),
                 damping_ratio=draw(st.floats(0.02, 1.0)),
                 holding_torque_nm=draw(st.none() | st.floats(0.5 * t0, 2 * t0)))


@st.composite
def rotor_tables(draw: st.DrawFn, top_pps: float = 20_000) -> FreeCurveTable:
    """A small free curve: 2..6 stages between 200 pps and `top_pps`, LE=0 or LE=1."""
    n = draw(st.integers(2, 6))
    speeds = sorted(draw(st.lists(st.floats(200, max(top_pps, 400)), min_size=n, max_size=n,
                                  unique=True)), reverse=True)
    rates = tuple(sorted({round(MHZ1.hz / v) for v in speeds}))
    if len(rates) < 2:  # the speeds drawn round to one rate: its two ends instead
        rates = (round(MHZ1.hz / max(top_pps, 400)), 5000)
    counts = st.integers(2, 40)
    acc = tuple(draw(st.lists(counts, min_size=len(rates), max_size=len(rates))))
    dec = tuple(draw(st.lists(counts, min_size=len(rates), max_size=len(rates))))
    return FreeCurveTable(MHZ1, rates, acc, dec if draw(st.booleans()) else None)


@st.composite
def stage_tables(draw: st.DrawFn) -> FreeCurveTable:
    n_acc = draw(st.integers(1, 8))
    n_dec = draw(st.integers(1, 8))
    n = max(n_acc, n_dec)
    rates = sorted(draw(st.lists(st.integers(2, 5000), min_size=n, max_size=n, unique=True)))
    counts = st.integers(0, 300)
    acc = draw(st.lists(counts, min_size=n_acc, max_size=n_acc))
    if draw(st.booleans()) and n_acc == n:
        return FreeCurveTable(MHZ1, tuple(rates), tuple(acc))
    dec = draw(st.lists(counts, min_size=n_dec, max_size=n_dec))
    return FreeCurveTable(MHZ1, tuple(rates), tuple(acc), tuple(dec))


@st.composite
def curve_motors(draw: st.DrawFn) -> Motor:
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


@st.composite
def accepted_tables(draw: st.DrawFn, separate: bool | None = None) -> FreeCurveTable:
    """Free curves the chip accepts, LE=0 or LE=1 (unequal stage counts allowed)."""
    clock = draw(st.sampled_from(list(INTERNAL_HZ)).map(Clock.internal))

    def side(n: int) -> list[int]:
        return draw(st.lists(st.integers(2, 0xFFFFF // n), min_size=n, max_size=n))

    accel = side(draw(st.integers(2, 40)))
    le = draw(st.booleans()) if separate is None else separate
    decel = side(draw(st.integers(2, 40))) if le else None
    n_rates = max(len(accel), len(decel or ()))
    rates = draw(st.lists(st.integers(2, 0xFFFF), min_size=n_rates, max_size=n_rates))
    return FreeCurveTable(clock, tuple(rates), tuple(accel),
                          None if decel is None else tuple(decel))


# --- every kind round-trips ----------------------------------------------------------------------
def answer_fields(kind: Kind) -> st.SearchStrategy[dict[str, Any]]:
    """Values of every field `kind` carries, as the manual allows them."""
    frame = kind.frame
    assert frame is not None
    out: dict[str, st.SearchStrategy[Any]] = {}
    length = frame.fields[1] if len(frame.fields) > 1 else None
    fixed = sum(f.size for f in frame.fields[2:] if not isinstance(f, Array))
    for f in frame.fields:
        if isinstance(f, Bits) and f.name == "header":
            if kind.fixed_bit("resp") is None:
                out["source"] = st.sampled_from(sorted(SOURCES.values()))
            if kind.fixed_bit("next") is None:
                out["next"] = st.integers(0, 1)
        elif isinstance(f, UInt) and f.name != "length":
            texts = kind.choices.get(f.name)
            out[f.name] = st.sampled_from(sorted(texts)) if texts else \
                st.integers(f.lo, f.max)
        elif isinstance(f, SInt):
            out[f.name] = st.integers(-(1 << (8 * f.size - 1)), (1 << (8 * f.size - 1)) - 1)
        elif isinstance(f, Array):
            room = (length.max - fixed) // f.item.size if isinstance(length, UInt) else 8
            most = min(room, f.max_items if f.max_items is not None else room)
            out[f.name] = st.lists(st.integers(f.item.lo, f.item.max),
                                   min_size=f.min_items, max_size=most)
    return st.fixed_dictionaries(out)


def alink_values(v: Value) -> st.SearchStrategy[int]:
    """A value an A-Link command form takes (`v`), as §11 allows it (D8, the factory
    check, never written)."""
    if v.bits:
        optional = [b for b in v.bits if b != 8]  # D8 is the factory check: not written
        return st.sets(st.sampled_from(optional)).map(
            lambda bits: v.fixed | sum(1 << b for b in bits))
    if v.choices:
        plain = [k for k in v.choices if k not in (0xF, 0x3FFF)]
        opened = [] if v.open_from is None else [st.integers(v.open_from, v.hi - 1)]
        return st.one_of(st.sampled_from(plain), *opened)
    if not v.takes:
        return st.just(0)
    return st.integers(v.lo, v.hi).filter(lambda x: x not in v.refused)


@st.composite
def alink_commands(draw: st.DrawFn) -> tuple[str, int, int, int]:
    """An A-Link command: (its name, its form nn, a value it takes, a pair code 1–3)."""
    name = draw(st.sampled_from(sorted(COMMANDS)))
    nn = draw(st.sampled_from(sorted(COMMANDS[name].forms)))
    value = draw(alink_values(COMMANDS[name].forms[nn].value))
    return name, nn, value, draw(st.integers(1, 3))
