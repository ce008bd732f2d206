"""Streamed outputs: peak memory does not grow with the stream's length.

Runs `stepramp simulate --pulse-times` (and `mc200 stream` in every file format
when given --mc200) as
subprocesses at growing lengths and prints each run's peak RSS (the kernel's
ru_maxrss of that child alone) next to the output size, and the ratio of the peak
at the longest length to the peak at the shortest (1.0 = flat). Goal: a 4 M-pulse
stream in < 200 MB.

With --read, the longest MC-200 stream (in hex, bin and ihex) is read back by
`stepramp check` and `stepramp mc200 decode`, each run's peak RSS printed against the
file's size (the readers go a chunk at a time: memory a small multiple of the file).

    python bench/bench_streams.py [--lengths 100000,1000000,4000000] [--mc200] [--read]
"""

from __future__ import annotations

import argparse
import os
import subprocess
import sys
import tempfile
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
TABLE = ROOT / "examples" / "free-curve-nema17.json"


def peak_rss_mb(argv: list[str]) -> float:
    """Peak RSS [MB] of one child process running `argv` (measured in a fresh
    intermediate process, so earlier runs do not count)."""
    probe = ("import resource, subprocess, sys; "
             "r = subprocess.run(sys.argv[1:]); "
             "print(resource.getrusage(resource.RUSAGE_CHILDREN).ru_maxrss); "
             "sys.exit(r.returncode)")
    out = subprocess.run([sys.executable, "-c", probe, *argv], capture_output=True, text=True,
                         cwd=ROOT, check=True)
    return int(out.stdout.split()[-1]) / 1024.0


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--lengths", default="100000,1000000,4000000",
                    help="comma-separated stream lengths [pulses]")
    ap.add_argument("--mc200", action="store_true", help="also time mc200 stream")
    ap.add_argument("--read", action="store_true",
                    help="read the longest MC-200 stream back (check, mc200 decode)")
    args = ap.parse_args()
    lengths = [int(x) for x in args.lengths.split(",")]
    whole = ("import sys; from profiles.ppmc312.table import load_table; "
             "from profiles.ppmc312.execution import simulate_move, pulse_times_csv; "
             "open(sys.argv[2], 'w').write(pulse_times_csv(simulate_move(load_table("
             f"{str(TABLE)!r}), int(sys.argv[1]))))")
    cases = [("pulse times built whole (before)",
              lambda n, out: [sys.executable, "-c", whole, str(n), out]),
             ("simulate --pulse-times",
              lambda n, out: [sys.executable, "-m", "verify.cli", "simulate", str(TABLE),
                              "--pulses", str(n), "--pulse-times", out])]
    if args.mc200:
        # every stream format renders chunk-wise (its CRC-32 running): each should stay flat
        for fmt in ("bin", "hex", "json", "c", "ihex"):
            cases.append((f"mc200 stream --format {fmt}",
                          lambda n, out, fmt=fmt: [
                              sys.executable, "-m", "verify.cli", "mc200", "stream",
                              "--vmax", "200000", "--amax", "2000000", "--jmax", "50000000",
                              "--pulses", str(n), "--period-us", "50", "--format", fmt,
                              "-o", out]))
    print("| stream | pulses | output MB | peak RSS MB |")
    print("|---|---|---|---|")
    ratios = []
    with tempfile.TemporaryDirectory() as tmp:
        for name, make in cases:
            peaks = []
            for n in lengths:
                out = os.path.join(tmp, "out")
                rss = peak_rss_mb(make(n, out))
                size = os.path.getsize(out) / 1e6
                os.unlink(out)
                peaks.append(rss)
                print(f"| {name} | {n} | {size:.1f} | {rss:.0f} |", flush=True)
            ratios.append((name, peaks[-1] / peaks[0]))
    for name, ratio in ratios:
        print(f"{name}: peak RSS at {lengths[-1]} pulses / at {lengths[0]} = {ratio:.2f}")
    if args.read:
        read_back(lengths[-1])
    return 0


def read_back(pulses: int) -> None:
    """Peak RSS of `check` and `mc200 decode` on one long stream, per file format."""
    print("\n| format | packets | file MB | check peak MB | ratio | decode peak MB | ratio |")
    print("|---|---|---|---|---|---|---|")
    cli = f"{sys.executable} -m verify.cli"
    with tempfile.TemporaryDirectory() as tmp:
        for fmt in ("hex", "bin", "ihex"):
            path = os.path.join(tmp, f"stream.{fmt}")
            # 20 kpps top speed at 50 µs: one packet per 50 µs of a 200 s move
            subprocess.run([sys.executable, "-m", "verify.cli", "mc200", "stream", "--vmax",
                            "20000", "--amax", "200000", "--jmax", "5000000", "--pulses",
                            str(pulses), "--period-us", "50", "--format", fmt, "-o", path],
                           cwd=ROOT, check=True)
            size = os.path.getsize(path) / 1e6
            check = peak_rss_mb(["sh", "-c", f"{cli} check {path} > /dev/null"])
            decode = peak_rss_mb(["sh", "-c", f"{cli} mc200 decode {path} > /dev/null"])
            packets = {"bin": size * 1e6 / 12}.get(fmt)
            shown = f"{packets:.0f}" if packets else "(as bin)"
            print(f"| {fmt} | {shown} | {size:.0f} | {check:.0f} | {check / size:.1f} | "
                  f"{decode:.0f} | {decode / size:.1f} |", flush=True)


if __name__ == "__main__":
    sys.exit(main())
