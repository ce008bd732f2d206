"""Streamed outputs: peak memory does not grow with the stream's length.

Runs `stepramp simulate --pulse-times` (and `mc200 stream` in every file format
when given --mc200) as
subprocesses at growing lengths and prints each run's peak RSS (the kernel's
ru_maxrss of that child alone) next to the output size, and the ratio of the peak
at the longest length to the peak at the shortest (1.0 = flat). Goal: a 4 M-pulse
stream in < 200 MB.

Then the longest MC-200 stream (in hex, bin and ihex) is read back by
`stepramp check` and `stepramp mc200 decode`, each run's peak RSS printed against the
file's size (the readers go a chunk at a time: memory a small multiple of the file).

    python bench/bench_streams.py [--lengths 100000,1000000,4000000] [--mc200] [--no-read]
"""

from __future__ import annotations

import argparse
import os
import subprocess
import sys
import tempfile
import time
from collections.abc import Callable
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))

from benchlib import Results, count  # noqa: E402

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


def cases(mc200: bool) -> list[tuple[str, Callable[[int, str], list[str]]]]:
    whole = ("import sys; from profiles.ppmc312.table import load_table; "
             "from profiles.ppmc312.execution import simulate_move, pulse_times_csv; "
             "open(sys.argv[2], 'w').write(pulse_times_csv(simulate_move(load_table("
             f"{str(TABLE)!r}), int(sys.argv[1]))))")
    out: list[tuple[str, Callable[[int, str], list[str]]]] = [
        ("built whole (before)", lambda n, o: [sys.executable, "-c", whole, str(n), o]),
        ("streamed", lambda n, o: [sys.executable, "-m", "verify.cli", "simulate", str(TABLE),
                                   "--pulses", str(n), "--pulse-times", o])]
    if mc200:
        # every stream format renders chunk-wise (its CRC-32 running): each should stay flat
        for fmt in ("bin", "hex", "json", "c", "ihex"):
            out.append((f"mc200 stream --format {fmt}", lambda n, o, fmt=fmt: [
                sys.executable, "-m", "verify.cli", "mc200", "stream", "--vmax", "200000",
                "--amax", "2000000", "--jmax", "50000000", "--pulses", str(n),
                "--period-us", "50", "--format", fmt, "-o", o]))
    return out


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--lengths", default="100000,1000000,4000000",
                    help="comma-separated stream lengths [pulses]")
    ap.add_argument("--mc200", action="store_true", help="also time mc200 stream")
    ap.add_argument("--no-read", action="store_true",
                    help="skip reading the longest MC-200 stream back (check, mc200 decode)")
    args = ap.parse_args()
    lengths = [int(x) for x in args.lengths.split(",")]
    res = Results("streams")
    measured: dict[str, list[dict[str, float]]] = {}
    with tempfile.TemporaryDirectory() as tmp:
        for name, make in cases(args.mc200):
            for n in lengths:
                out = os.path.join(tmp, "out")
                rss = peak_rss_mb(make(n, out))
                measured.setdefault(name, []).append(
                    {"pulses": n, "output_mb": os.path.getsize(out) / 1e6, "peak_rss_mb": rss})
                os.unlink(out)
                print(f"{name}: {n} pulses, peak RSS {rss:.0f} MB", flush=True)
    res.values["pulse_times"] = measured
    whole, streamed = measured["built whole (before)"], measured["streamed"]
    res.section("pulse_times", ["pulses", "output", "built whole (before)", "streamed"],
                [[count(w["pulses"]), f"{w['output_mb']:.1f} MB", f"{w['peak_rss_mb']:.0f} MB",
                  f"{st['peak_rss_mb']:.0f} MB"] for w, st in zip(whole, streamed, strict=True)],
                note=f"Peak RSS of the process; at {count(lengths[-1])} / at "
                     f"{count(lengths[0])} pulses: "
                     f"{whole[-1]['peak_rss_mb'] / whole[0]['peak_rss_mb']:.2f} built whole, "
                     f"{streamed[-1]['peak_rss_mb'] / streamed[0]['peak_rss_mb']:.2f} streamed.")
    if args.mc200:
        res.section("mc200_formats", ["`mc200 stream`", *(count(n) for n in lengths)],
                    [[name, *(f"{r['peak_rss_mb']:.0f} MB" for r in runs)]
                     for name, runs in measured.items() if name.startswith("mc200")])
    if not args.no_read:
        read_back(res, lengths[-1])
    res.write()
    return 0


def read_back(res: Results, pulses: int) -> None:
    """Peak RSS of `check` and `mc200 decode` on one long stream, per file format."""
    cli = f"{sys.executable} -m verify.cli"
    rows, out = [], []
    with tempfile.TemporaryDirectory() as tmp:
        for fmt in ("hex", "bin", "ihex"):
            path = os.path.join(tmp, f"stream.{fmt}")
            # 20 kpps top speed at 50 µs: one packet per 50 µs of a 200 s move
            subprocess.run([sys.executable, "-m", "verify.cli", "mc200", "stream", "--vmax",
                            "20000", "--amax", "200000", "--jmax", "5000000", "--pulses",
                            str(pulses), "--period-us", "50", "--format", fmt, "-o", path],
                           cwd=ROOT, check=True)
            size = os.path.getsize(path) / 1e6
            t0 = time.perf_counter()
            check = peak_rss_mb(["sh", "-c", f"{cli} check {path} > /dev/null"])
            t1 = time.perf_counter()
            row = {"format": fmt, "file_mb": size, "check_mb": check, "check_s": t1 - t0}
            if fmt == "hex":  # decode writes a line per packet: minutes; one format shows it
                row["decode_mb"] = peak_rss_mb(["sh", "-c", f"{cli} mc200 decode {path} "
                                                "> /dev/null"])
                row["decode_s"] = time.perf_counter() - t1
            out.append(row)
            decode = (f"{row['decode_mb']:.0f} MB ({row['decode_s']:.0f} s)"
                      if "decode_mb" in row else "—")
            rows.append([fmt, f"{size:.0f} MB", f"{check:.0f} MB ({t1 - t0:.0f} s)", decode,
                         f"{check / size:.1f}×" + (f" / {row['decode_mb'] / size:.1f}×"
                                                   if "decode_mb" in row else "")])
            print(f"read back {fmt}: check {check:.0f} MB, decode {decode}", flush=True)
    res.values["read_back"] = {"pulses": pulses, "formats": out}
    res.section("read_back", ["format", "file", "`stepramp check`: peak RSS (time)",
                              "`stepramp mc200 decode`: peak RSS (time)",
                              "peak / file size (check / decode)"], rows,
                note=f"Reading back an MC-200 stream of {count(pulses)} pulses (one packet per "
                     "50 µs). The readers go a chunk at a time, so memory is a small multiple "
                     "of the file, and files are bounded by the input cap (256 MiB for hex, "
                     "bin and ihex, 16 MiB for json and c).")


if __name__ == "__main__":
    sys.exit(main())
