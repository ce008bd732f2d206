"""A-Link ALUM and MC-200: packet throughput and settings quality, as ratios.

    python bench/bench_devices.py [--seconds 1.0]

- MC-200 packets encoded (and decoded) per second, against a reference
  measured in the same run: `struct.pack` of the same 12 bytes with a
  hand-written checksum, the least any encoder must do;
- MC-200 stream memory: peak RSS of `stepramp mc200 stream` for a 4 M-pulse
  move (4 M packets, hex to a file) against the same command for a 4 000-pulse
  move, measured in the same run: the streams are written a chunk at a time, so
  the ratio stays near 1 (goal: the long stream < 200 MB);
- A-Link settings planned for the bundled motors: predicted move time
  (linear and S-curve) against the continuous optimum (verify.references
  exact_optimum) for moves of 300 … 100 000 pulses.
"""

from __future__ import annotations

import argparse
import os
import struct
import subprocess
import sys
import tempfile
import time
from collections.abc import Callable
from pathlib import Path

ROOT = Path(__file__).resolve().parent.parent
sys.path.insert(0, str(ROOT))

from profiles import alink, mc200  # noqa: E402
from profiles.motor import bundled_motor_paths, load_motor  # noqa: E402
from verify.references import exact_optimum  # noqa: E402

MOVES = (300, 2_000, 10_000, 100_000)
RSS_GOAL_MB = 200
# The long stream: 4 M pulses at ≤ 20 kpps with a 50 µs SPI period, ≈ 4 M packets.
LONG_STREAM = ("--vmax", "20000", "--amax", "200000", "--jmax", "5000000",
               "--pulses", "4000000", "--period-us", "50")
SHORT_STREAM = ("--vmax", "20000", "--amax", "200000", "--jmax", "5000000",
                "--pulses", "4000", "--period-us", "50")


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


def stream_peak_rss(args: tuple[str, ...]) -> tuple[float, float, int]:
    """(peak RSS MB, seconds, output bytes) of one `stepramp mc200 stream` in a fresh
    process (ru_maxrss of the child alone: each run is the only child waited for)."""
    code = "import sys; from verify.cli import main; sys.exit(main(sys.argv[1:]))"
    with tempfile.TemporaryDirectory() as tmp:
        out = os.path.join(tmp, "stream.hex")
        cmd = [sys.executable, "-c", code, "mc200", "stream", *args, "-o", out]
        start = time.perf_counter()
        proc = subprocess.Popen(cmd, cwd=ROOT, env={**os.environ, "PYTHONPATH": str(ROOT)})
        _, status, usage = os.wait4(proc.pid, 0)
        elapsed = time.perf_counter() - start
        if os.waitstatus_to_exitcode(status) != 0:
            raise SystemExit(f"stream failed: {' '.join(cmd)}")
        size = os.path.getsize(out)
    # ru_maxrss is in kB on Linux
    return usage.ru_maxrss / 1024, elapsed, size


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
    objects_s = time.perf_counter() - t0
    t0 = time.perf_counter()
    chunked = mc200.stream_bytes(position_at, duration_s, 100_000, period_us=250)
    chunked_s = time.perf_counter() - t0
    assert chunked == data
    print(f"MC-200 stream of {len(packets)} packets ({len(data)} bytes), sampling included: "
          f"{len(packets) / chunked_s:.0f} packets/s chunked, ratio to one object per packet "
          f"{objects_s / chunked_s:.1f} (reference {len(packets) / objects_s:.0f} packets/s)")

    short_mb, short_s, short_bytes = stream_peak_rss(SHORT_STREAM)
    long_mb, long_s, long_bytes = stream_peak_rss(LONG_STREAM)
    print(f"MC-200 stream peak RSS: 4 M pulses {long_mb:.0f} MB ({long_bytes / 1e6:.0f} MB hex "
          f"in {long_s:.1f} s), ratio to the 4 000-pulse stream {long_mb / short_mb:.2f} "
          f"(reference {short_mb:.0f} MB, {short_bytes / 1e3:.0f} kB in {short_s:.1f} s); "
          f"goal < {RSS_GOAL_MB} MB: {'met' if long_mb < RSS_GOAL_MB else 'NOT met'}")

    print("\nA-Link settings: predicted move time / continuous optimum (exact, jerk-free)")
    print(f"{'motor':10s} {'pulses':>7s} {'linear':>8s} {'s-curve':>8s}  settings")
    for path in bundled_motor_paths():
        motor = load_motor(path)
        for pulses in MOVES:
            opt = exact_optimum(motor, pulses).duration_s
            lin = alink.plan_settings(motor, pulses=pulses)
            s = alink.plan_settings(motor, pulses=pulses, s_curve=True)
            st = lin.table
            assert lin.duration_s is not None and s.duration_s is not None
            print(f"{path.stem[6:16]:10s} {pulses:7d} {lin.duration_s / opt:8.3f} "
                  f"{s.duration_s / opt:8.3f}  ×{st.multiplier} start {st.start_pps} "
                  f"high {st.high_pps} para {st.accel_para}")


if __name__ == "__main__":
    main()
