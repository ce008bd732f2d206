"""PPMC-312 throughput and CLI cold start, printed as rates and ratios.

    python bench/bench_ppmc312.py [--seconds 1.0]

- table checks per second on random valid 127-stage free curves
  (goal ≥ 40 000 on one core), against a reference measured in the same run:
  json round-trip of the same table, the least a tool must do to read one;
- encode + decode of the same tables' uploads per second (goal ≥ 20 000), and
  with chip-emulator acceptance;
- every upload file format: render + parse per second;
- cold start of `stepramp check` on one table (goal ≤ 0.3 s), against a bare
  `python -c pass` measured in the same run.
"""

from __future__ import annotations

import argparse
import json
import random
import statistics
import subprocess
import sys
import tempfile
import time
from collections.abc import Callable
from pathlib import Path

ROOT = Path(__file__).resolve().parent.parent
sys.path.insert(0, str(ROOT))

from profiles.ppmc312.clock import Clock  # noqa: E402
from profiles.ppmc312.emulator import accept_upload  # noqa: E402
from profiles.ppmc312.table import FreeCurveTable, table_from_json  # noqa: E402
from profiles.ppmc312.upload import decode_free_curve, encode_free_curve  # noqa: E402
from verify.chip_rules import check_table  # noqa: E402


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


def cold_start(cmd: list[str], repeats: int = 7) -> float:
    times = []
    for _ in range(repeats):
        t0 = time.perf_counter()
        subprocess.run(cmd, check=False, capture_output=True, cwd=ROOT)
        times.append(time.perf_counter() - t0)
    return statistics.median(times)


def main() -> None:
    ap = argparse.ArgumentParser()
    ap.add_argument("--seconds", type=float, default=1.0)
    args = ap.parse_args()
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
    print(f"table checks/s (127 stages):      {checks:10.0f}   goal ≥ 40000 "
          f"{'OK' if checks >= 40000 else 'MISSED'} ({warnings:.1f} warnings a table)")
    print(f"  reference json load/s:          {ref:10.0f}   ratio checks/ref {checks / ref:.2f}")
    print(f"  reference json round trip/s:    {raw_ref:10.0f}   ratio checks/ref "
          f"{checks / raw_ref:.2f}")
    clean = [smooth_table(rng) for _ in range(200)]
    assert not any(check_table(t) for t in clean)
    clean_checks = rate(check_table, clean, args.seconds)
    print(f"table checks/s, no findings:      {clean_checks:10.0f}   ratio to json round trip "
          f"{clean_checks / raw_ref:.2f}")

    def codec(t: FreeCurveTable) -> None:
        assert decode_free_curve(encode_free_curve(t)) == t

    def accept(t: FreeCurveTable) -> None:
        assert accept_upload(encode_free_curve(t)).ok

    rt = rate(codec, tables, args.seconds)
    em = rate(accept, tables, args.seconds)
    print(f"encode+decode/s:                  {rt:10.0f}   goal ≥ 20000 "
          f"{'OK' if rt >= 20000 else 'MISSED'}; ratio to json load {rt / ref:.2f}, to json "
          f"round trip {rt / raw_ref:.2f}")
    print(f"encode+emulated upload/s:         {em:10.0f}   ratio to json load {em / ref:.2f}")

    with tempfile.TemporaryDirectory() as tmp:
        path = Path(tmp) / "t.json"
        path.write_text(json.dumps(tables[0].to_json()))
        bare = cold_start([sys.executable, "-c", "pass"])
        check = cold_start([sys.executable, "-m", "verify.cli", "check", str(path)])
    print(f"cold start `stepramp check`:      {check:10.3f} s goal ≤ 0.3 s "
          f"{'OK' if check <= 0.3 else 'MISSED'}")
    print(f"  reference `python -c pass`:     {bare:10.3f} s ratio {check / bare:.1f}")
    heavy = subprocess.run(
        [sys.executable, "-c", "import sys, verify.cli as c; c.build_parser(); "
         "import verify.chip_rules, verify.report, profiles.ppmc312.upload; "
         "print(sorted(m for m in ('toppra','casadi','matplotlib','ruckig','scipy') "
         "if m in sys.modules))"], capture_output=True, text=True, cwd=ROOT)
    print(f"heavy modules imported by check:  {heavy.stdout.strip() or heavy.stderr.strip()}")


if __name__ == "__main__":
    main()
