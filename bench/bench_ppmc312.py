"""PPMC-312 throughput, as rates and ratios measured in one run.

    python bench/bench_ppmc312.py [--seconds 1.0]

- table checks per second on random valid 127-stage free curves (goal ≥ 40 000 on one
  core, CPU time), against references measured in the same run: a JSON round trip of
  the same table (with and without building the table), the least a tool must do to
  read one; and on finding-free tables;
- encode + decode of the same tables' uploads per second (goal ≥ 20 000), and with
  chip-emulator acceptance.
(`stepramp check`'s cold start: bench_safety.py.)
"""

from __future__ import annotations

import argparse
import json
import random
import sys
import time
from collections.abc import Callable
from pathlib import Path

ROOT = Path(__file__).resolve().parent.parent
sys.path.insert(0, str(ROOT))

from benchlib import Results, count, verdict  # noqa: E402

from profiles.ppmc312.chip_rules import check_table  # noqa: E402
from profiles.ppmc312.clock import Clock  # noqa: E402
from profiles.ppmc312.emulator import accept_upload  # noqa: E402
from profiles.ppmc312.table import FreeCurveTable, table_from_json  # noqa: E402
from profiles.ppmc312.upload import decode_free_curve, encode_free_curve  # noqa: E402


def random_table(rng: random.Random, stages: int = 127) -> FreeCurveTable:
    rates = sorted(rng.sample(range(300, 60000), stages))
    accel = [rng.randint(2, 8000) for _ in rates]
    decel = [rng.randint(2, 8000) for _ in rates] if rng.random() < 0.5 else None
    return FreeCurveTable(Clock.internal("8MHz"), rates, accel, decel)


def smooth_table(rng: random.Random, stages: int = 127) -> FreeCurveTable:
    """A chip-legal 127-stage ramp without findings (as a planner writes): the same
    checks with no warning to word."""
    rates = [rng.randint(300, 600)]
    for _ in range(stages - 1):
        rates.append(rates[-1] + rng.randint(40, 60))
    accel = [rng.randint(40, 44) for _ in rates]
    return FreeCurveTable(Clock.internal("8MHz"), rates, accel)


def rate(fn: Callable[[FreeCurveTable], object], tables: list[FreeCurveTable],
         seconds: float) -> float:
    # Process CPU time: on a shared machine wall time also counts other processes.
    n, start = 0, time.process_time()
    while True:
        for t in tables:
            fn(t)
        n += len(tables)
        elapsed = time.process_time() - start
        if elapsed >= seconds:
            return n / elapsed


def main() -> None:
    ap = argparse.ArgumentParser()
    ap.add_argument("--seconds", type=float, default=1.0)
    args = ap.parse_args()
    res = Results("ppmc312")
    rng = random.Random(1)
    tables = [random_table(rng) for _ in range(200)]
    assert all(not [f for f in check_table(t) if f.severity == "error"] for t in tables)

    ref = rate(lambda t: table_from_json(json.loads(json.dumps(t.to_json()))), tables,
               args.seconds)
    # The same JSON round trip without building the table: a reference none of
    # stepramp's code is in (the one above got faster with the table constructor).
    raw_ref = rate(lambda t: json.loads(json.dumps(t.to_json())), tables, args.seconds)
    warnings = sum(len(check_table(t)) for t in tables) / len(tables)
    checks = rate(check_table, tables, args.seconds)
    clean = [smooth_table(rng) for _ in range(200)]
    assert not any(check_table(t) for t in clean)
    clean_checks = rate(check_table, clean, args.seconds)

    def codec(t: FreeCurveTable) -> None:
        assert decode_free_curve(encode_free_curve(t)) == t

    def accept(t: FreeCurveTable) -> None:
        assert accept_upload(encode_free_curve(t)).ok

    rt = rate(codec, tables, args.seconds)
    em = rate(accept, tables, args.seconds)
    res.values.update(checks_per_s=checks, warnings_per_table=warnings,
                      json_load_per_s=ref, json_round_trip_per_s=raw_ref,
                      clean_checks_per_s=clean_checks, codec_per_s=rt, emulated_per_s=em)
    res.section("throughput", ["what (random 127-stage tables, one core, CPU time)",
                               "per second", "reference in the same run", "goal"], [
        [f"table checks ({warnings:.1f} warnings a table)", f"{count(checks)}",
         f"{checks / raw_ref:.2f}× a bare JSON round trip of the table ({count(raw_ref)}/s), "
         f"{checks / ref:.2f}× a JSON load into a table ({count(ref)}/s)",
         f"≥ 40 000: {verdict(checks >= 40_000)}"],
        ["table checks, finding-free tables", f"{count(clean_checks)}",
         f"{clean_checks / raw_ref:.2f}× the JSON round trip", "—"],
        ["encode + decode of a 127-stage upload", f"{count(rt)}",
         f"{rt / ref:.2f}× the JSON load, {rt / raw_ref:.2f}× the JSON round trip",
         f"≥ 20 000: {verdict(rt >= 20_000)}"],
        ["encode + the emulated chip's acceptance", f"{count(em)}", f"{em / ref:.2f}× the JSON "
         "load", "—"]])
    res.write()


if __name__ == "__main__":
    main()
