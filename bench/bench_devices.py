"""A-Link ALUM and MC-200: packet throughput and settings quality, as ratios.

    python bench/bench_devices.py [--seconds 1.0]

- MC-200 packets encoded (and decoded) per second of CPU time, against a reference
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

from benchlib import Results, count, verdict  # noqa: E402

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
    """Calls per second of process CPU time (wall time would count other processes)."""
    n, start = 0, time.process_time()
    while True:
        for i in range(1000):
            fn(i)
        n += 1000
        elapsed = time.process_time() - start
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


def packets(res: Results, seconds: float) -> None:
    ref = per_second(reference_pack, seconds)
    enc = per_second(lambda i: mc200.HostPacket(0, True, 0, i, "position").encode(), seconds)
    raw = [mc200.HostPacket(0, True, 0, i, "position").encode() for i in range(1000)]
    dec = per_second(lambda i: mc200.HostPacket.decode(raw[i]), seconds)
    position_at, duration_s = mc200.ruckig_profile(100_000, 50_000, 500_000, 5e7)
    t0 = time.process_time()
    packets = mc200.stream_move(position_at, duration_s, 100_000, period_us=250)
    data = mc200.encode_stream(packets)
    objects_s = time.process_time() - t0
    t0 = time.process_time()
    chunked = mc200.stream_bytes(position_at, duration_s, 100_000, period_us=250)
    chunked_s = time.process_time() - t0
    assert chunked == data
    res.values["mc200"] = {"encoded_per_s": enc, "decoded_per_s": dec,
                           "reference_per_s": ref, "stream_packets": len(packets),
                           "chunked_per_s": len(packets) / chunked_s,
                           "objects_per_s": len(packets) / objects_s}
    res.section("mc200", ["what (one core, CPU time)", "per second",
                          "reference in the same run"], [
        ["MC-200 packets encoded", count(enc),
         f"{enc / ref:.2f}× `struct.pack` of the same 12 bytes with a hand-written checksum "
         f"({count(ref)}/s)"],
        ["MC-200 packets decoded", count(dec), f"{dec / ref:.2f}× that reference"],
        [f"MC-200 stream of a 100 000-pulse move ({len(packets)} packets), sampled and "
         "encoded chunk by chunk", count(len(packets) / chunked_s),
         f"{objects_s / chunked_s:.1f}× one packet object at a time "
         f"({count(len(packets) / objects_s)}/s)"]])


def memory(res: Results) -> None:
    short_mb, short_s, short_bytes = stream_peak_rss(SHORT_STREAM)
    long_mb, long_s, long_bytes = stream_peak_rss(LONG_STREAM)
    res.values["stream_rss"] = {"long_mb": long_mb, "long_s": long_s, "long_bytes": long_bytes,
                                "short_mb": short_mb, "short_s": short_s,
                                "short_bytes": short_bytes}
    res.section("memory", ["what", "peak RSS", "reference in the same run", "goal"], [
        [f"`stepramp mc200 stream`, 4 M pulses (4 M packets, {long_bytes / 1e6:.0f} MB hex, "
         f"{long_s:.0f} s)", f"{long_mb:.0f} MB",
         f"{long_mb / short_mb:.2f}× the same command for 4 000 pulses ({short_mb:.0f} MB)",
         f"< {RSS_GOAL_MB} MB: {verdict(long_mb < RSS_GOAL_MB)}"]])


def settings(res: Results) -> None:
    rows, out = [], []
    for path in bundled_motor_paths():
        motor = load_motor(path)
        for pulses in MOVES:
            opt = exact_optimum(motor, pulses).duration_s
            lin = alink.plan_settings(motor, pulses=pulses)
            s = alink.plan_settings(motor, pulses=pulses, s_curve=True)
            st = lin.table
            assert lin.duration_s is not None and s.duration_s is not None
            name = path.stem.removeprefix("motor-")
            out.append({"motor": name, "pulses": pulses, "linear": lin.duration_s / opt,
                        "s_curve": s.duration_s / opt})
            rows.append([name, f"{pulses}", f"{lin.duration_s / opt:.3f}",
                         f"{s.duration_s / opt:.3f}", f"×{st.multiplier} start {st.start_pps} "
                         f"high {st.high_pps} para {st.accel_para}"])
    res.values["alink"] = out
    res.section("alink", ["motor", "pulses", "linear / optimum", "S-curve / optimum",
                          "linear settings"], rows,
                note="A-Link settings' predicted move time / the continuous optimum (exact, "
                     "jerk-free).")


def summary(res: Results) -> None:
    mc = res.values["mc200"]
    rss = res.values["stream_rss"]
    lin = [r["linear"] for r in res.values["alink"]]
    s = [r["s_curve"] for r in res.values["alink"]]
    res.section("summary", ["what", "measured", "goal"], [
        ["MC-200 packets encoded per second (one core, CPU time)",
         f"{count(mc['encoded_per_s'])} ({mc['encoded_per_s'] / mc['reference_per_s']:.2f}× "
         "`struct.pack` of the same bytes)", "—"],
        ["peak memory of `stepramp mc200 stream`, 4 M pulses (4 M packets, "
         f"{rss['long_bytes'] / 1e6:.0f} MB hex)", f"{rss['long_mb']:.0f} MB "
         f"({rss['long_mb'] / rss['short_mb']:.2f}× the same command for 4 000 pulses)",
         f"< {RSS_GOAL_MB} MB: {verdict(rss['long_mb'] < RSS_GOAL_MB)}"],
        [f"A-Link settings move time / continuous optimum ({len(lin)} moves)",
         f"{min(lin):.2f}–{max(lin):.2f} (linear), {min(s):.2f}–{max(s):.2f} (S-curve)",
         "—"]])


def main() -> None:
    ap = argparse.ArgumentParser()
    ap.add_argument("--seconds", type=float, default=1.0)
    args = ap.parse_args()
    res = Results("devices")
    packets(res, args.seconds)
    memory(res)
    settings(res)
    summary(res)
    res.write()


if __name__ == "__main__":
    main()
