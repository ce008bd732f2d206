"""Mutation testing: do the tests notice a wrong rule?

For each module of profiles/ and verify/ (tools/mutation.toml maps each to the tests
that exercise it, or excludes it with the reason), every mutant of tools/mutants.py is
run against the module's tests: a forked child imports the mutant in place of the
module (the parent has imported the heavy libraries once; the Python processes its tests
start get the same mutant, tools/mutant_finder.py) and runs pytest (-x, slow
tests deselected, example tests before hypothesis ones, hypothesis derandomised and
never shrinking: a failing example is enough). A mutant is *killed* when a test fails,
*timeout* when it runs past the module's limit (counted as killed), *survived*
otherwise. A survivor listed in tools/mutation.toml's `[[equivalent]]` (by the mutant's
id: its code, never its line) with the reason it cannot change behaviour is
*equivalent*. Score = (killed + timeout) / (mutants − equivalent).

Why not mutmut or cosmic-ray (measured on this repository, profiles/ppmc312/chip_rules.py and its
two test files, on the shared 2-core machine): mutmut 3.8 skips every decorated
function, so it makes no mutant of the numba kernels (profiles/motor/rotor_kernel.py:
0 of its 406 sites); cosmic-ray 8.7 mutates them but makes 981 mutants of chip_rules
(every arithmetic operator into every other) and starts a fresh interpreter for each:
12 mutants in 180 s (15 s each) against 20 in 94 s here (forked, imports paid once).

A whole-package run is every mutant of every module (the report's total, a few seconds
each and a survivor the module's whole test run: too long for the shared 2-core
machine), so the
load-angle model is run whole and the other modules by a random sample (`--sample N`:
a fixed random order per module, so a sample is reproducible and a larger one extends
it); a sampled module's score is over the mutants it ran.

Each mutant's verdict is appended, as one JSON line, to bench/results/mutation/
<module>.jsonl (with the hash of the module's source: a verdict of an older source is
not reused). `--report` turns the logs into bench/results/mutation.json (the shared
results format: `per-module` table) and bench/results/mutation.md (the survivors and the
equivalent mutants with their reasons), without running anything.

Usage:
    python tools/mutation.py [MODULE …] [--jobs N] [--resume] [--again survived,timeout]
                             [--sample N]
    python tools/mutation.py --list MODULE        # every mutant id
    python tools/mutation.py --show MODULE ID     # the mutant's diff
    python tools/mutation.py --report
(MODULE: a dotted name such as profiles.motor.rotor; default every mapped module, in
the order of tools/mutation.toml.)
"""

from __future__ import annotations

import argparse
import ast
import difflib
import os
import subprocess
import sys
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(Path(__file__).resolve().parent))

import mutants  # noqa: E402
import mutation_report  # noqa: E402
import mutation_run  # noqa: E402
from mutation_config import LOGS, Module, load_config, module_path, modules  # noqa: E402


def show(name: str, wanted: str) -> int:
    source = module_path(name).read_text()
    plain = ast.unparse(ast.parse(source)).splitlines(keepends=True)
    for site in mutants.sites(source):
        if site.id == wanted or str(site.index) == wanted:
            changed = mutants.mutant(source, site.index).splitlines(keepends=True)
            print(f"# {site.id} (line {site.line})")
            sys.stdout.writelines(difflib.unified_diff(plain, changed, n=2))
            return 0
    print(f"no mutant {wanted!r} in {name}", file=sys.stderr)
    return 2


def run_many(chosen: list[Module], jobs: int, resume: bool, again: str, sample: int) -> None:
    """Each module in a worker process of its own (its env set before numba loads), at
    most `jobs` at once."""
    LOGS.mkdir(parents=True, exist_ok=True)
    queue = list(chosen)
    running: list[tuple[Module, subprocess.Popen[bytes]]] = []
    while queue or running:
        while queue and len(running) < jobs:
            m = queue.pop(0)
            argv = [sys.executable, __file__, "--worker", m.name]
            argv += ["--resume"] if resume else []
            argv += ["--again", again] if again else []
            argv += ["--sample", str(sample)] if sample else []
            running.append((m, subprocess.Popen(argv, env={**os.environ, **m.env}, cwd=ROOT)))
        for m, p in list(running):
            if p.poll() is not None:
                running.remove((m, p))
                print(f"{m.name}: worker exit {p.returncode}", file=sys.stderr, flush=True)
        time.sleep(0.5)


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("modules", nargs="*", default=[])
    ap.add_argument("--jobs", type=int, default=1, help="modules run at once")
    ap.add_argument("--resume", action="store_true",
                    help="skip mutants already logged for the current source")
    ap.add_argument("--again", metavar="VERDICTS", default="",
                    help="run only the mutants whose last verdict is one of these "
                         "(comma-separated: survived,timeout), e.g. after new tests")
    ap.add_argument("--sample", type=int, default=0, metavar="N",
                    help="judge a random sample of N mutants per module (fixed per module: "
                         "a larger N extends it; those already judged are kept)")
    ap.add_argument("--list", action="store_true", help="print the mutant ids")
    ap.add_argument("--show", metavar="ID", help="print one mutant's diff (id or index)")
    ap.add_argument("--report", action="store_true", help="write the results from the logs")
    ap.add_argument("--worker", metavar="MODULE", help=argparse.SUPPRESS)
    args = ap.parse_args()
    config = load_config()
    mapped = {m.name: m for m in modules(config)}
    if args.worker:
        again = {v for v in args.again.split(",") if v}
        return mutation_run.worker(mapped[args.worker], args.resume, again, args.sample)
    unknown = set(args.modules) - set(mapped)
    if unknown:
        ap.error(f"not in tools/mutation.toml: {sorted(unknown)}")
    chosen = [mapped[n] for n in args.modules] if args.modules else list(mapped.values())
    if args.list:
        for m in chosen:
            for s in mutants.sites(m.path.read_text()):
                print(f"{m.name} #{s.index} line {s.line}: {s.id}")
        return 0
    if args.show:
        return show(chosen[0].name, args.show)
    if not args.report:
        run_many(chosen, args.jobs, args.resume, args.again, args.sample)
    command = ("python tools/mutation.py --jobs 2 --resume (every mutant of the load-angle "
               "model), --sample N (a random sample of every other module's), then --again "
               "survived,timeout after new tests; --report rewrites this from the verdict logs")
    mutation_report.write(config, command)
    return 0


if __name__ == "__main__":
    sys.exit(main())
