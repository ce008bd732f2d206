"""A-Link ALUM and MC-200: packet throughput and settings quality, as ratios.

    python bench/bench_devices.py [--seconds 1.0]

- MC-200 packets encoded (and decoded) per second, against a reference
  measured in the same run: `struct.pack` of the same 12 bytes with a
  hand-written checksum, the least any encoder must do;
- A-Link settings planned for the bundled motors: predicted move time
  (linear and S-curve) against the continuous optimum (verify.references
  exact_optimum) for moves of 300 … 100 000 pulses.
"""

from __future__ import annotations

import argparse
import struct
import sys
import time
from collections.abc import Callable
from pathlib import Path

ROOT = Path(__file__).resolve().parent.parent
sys.path.insert(0, str(ROOT))

from profiles import alink, mc200  # noqa: E402
from profiles.motor import bundled_motor_paths, load_motor  # noqa: E402
from verify.references import exact_optimum  # noqa: E402

MOVES = (300, 2_000, 10_000, 100_000)


def per_second(fn: Callable[[int], object], seconds: float) -> float:
    n, start = 0, time.perf_counter()
    while True:
        for i in range(1000):
            fn(i)
        n += 1000
        elapsed = time.perf_counter() - start
        if elapsed >= seconds:
            return n / elapsed


def reference_pack(i: int) -> bytes:
    body = struct.pack("<BxxiBxx", 0x08, i, 0)
    words = struct.unpack("<5H", body)
    return body + struct.pack("<H", (sum(words) & 0x7FFF) | 0x8000)


def main() -> None:
    ap = argparse.ArgumentParser()
    ap.add_argument("--seconds", type=float, default=1.0)
    args = ap.parse_args()

    ref = per_second(reference_pack, args.seconds)
    enc = per_second(lambda i: mc200.HostPacket(0, True, 0, i, "position").encode(),
                     args.seconds)
    raw = [mc200.HostPacket(0, True, 0, i, "position").encode() for i in range(1000)]
    dec = per_second(lambda i: mc200.HostPacket.decode(raw[i]), args.seconds)
    print(f"MC-200 packets encoded/s:  {enc:10.0f}  ratio to struct.pack reference "
          f"{enc / ref:.3f} (reference {ref:.0f}/s)")
    print(f"MC-200 packets decoded/s:  {dec:10.0f}  ratio to reference {dec / ref:.3f}")
    position_at, duration_s = mc200.ruckig_profile(100_000, 50_000, 500_000, 5e7)
    t0 = time.perf_counter()
    packets = mc200.stream_move(position_at, duration_s, 100_000, period_us=250)
    data = mc200.encode_stream(packets)
    stream_s = time.perf_counter() - t0
    print(f"MC-200 stream of {len(packets)} packets ({len(data)} bytes): "
          f"{len(packets) / stream_s:.0f} packets/s including sampling")

    print("\nA-Link settings: predicted move time / continuous optimum (exact, jerk-free)")
    print(f"{'motor':10s} {'pulses':>7s} {'linear':>8s} {'s-curve':>8s}  settings")
    for path in bundled_motor_paths():
        motor = load_motor(path)
        for pulses in MOVES:
            opt = exact_optimum(motor, pulses).duration_s
            lin = alink.plan_settings(motor, pulses=pulses, compare=False)
            s = alink.plan_settings(motor, pulses=pulses, s_curve=True, compare=False)
            st = lin.settings
            print(f"{path.stem[6:16]:10s} {pulses:7d} {lin.predicted_time_s / opt:8.3f} "
                  f"{s.predicted_time_s / opt:8.3f}  ×{st.multiplier} start {st.start_pps} "
                  f"high {st.high_pps} para {st.accel_para}")


if __name__ == "__main__":
    main()
