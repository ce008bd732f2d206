"""Run every bench (each writes bench/results/<name>.json), then regenerate the README.

    python bench/run_all.py [--only safety,tighten] [--quick]

The benches run one after another (they time themselves: running them side by side
would measure each other), each in its own process; the first to fail stops the run
and the README is left as it was. About half an hour on the 2-core machine, most of
it `bench_streams.py` (reading a 4 M-packet stream back) and the sweep before/after
in `bench_plantime.py`.
"""

from __future__ import annotations

import argparse
import os
import subprocess
import sys
import time
from pathlib import Path

BENCH = Path(__file__).resolve().parent
ORDER = ("safety", "plantime", "tighten", "stops", "alink", "planner", "every_move", "robust",
         "designer", "sync", "sweep", "ppmc312", "devices", "streams")
QUICK = {"safety", "plantime", "tighten", "stops", "alink", "planner", "every_move", "robust",
         "sync", "sweep"}


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--only", help="comma-separated bench names (default: every one)")
    ap.add_argument("--quick", action="store_true", help="pass --quick where a bench takes it")
    args = ap.parse_args()
    names = args.only.split(",") if args.only else list(ORDER)
    unknown = set(names) - set(ORDER)
    if unknown:
        ap.error(f"unknown bench: {', '.join(sorted(unknown))} (known: {', '.join(ORDER)})")
    for name in names:
        cmd = [sys.executable, str(BENCH / f"bench_{name}.py")]
        if args.quick and name in QUICK:
            cmd.append("--quick")
        t0 = time.perf_counter()
        print(f"== bench_{name} (load average {os.getloadavg()[0]:.1f})", flush=True)
        if subprocess.run(cmd, cwd=BENCH.parent).returncode != 0:
            print(f"bench_{name} failed: the README is left as it was", file=sys.stderr)
            return 1
        print(f"== bench_{name}: {time.perf_counter() - t0:.0f} s", flush=True)
    return subprocess.run([sys.executable, str(BENCH / "readme.py")], cwd=BENCH.parent).returncode


if __name__ == "__main__":
    sys.exit(main())
