"""Issues #17 and #32: how long a safe plan takes, against references timed in the same run.

    python bench/bench_plantime.py [--quick] [--no-sweep] [--no-cold]

- `stepramp plan --pulses 10000` (in-process, warm: every execution judged, tightened to
  75°, the verdict, the file written) against a 1-DOF toppra solve of the same move
  (`verify.references.toppra_reference`, 1 000 gridpoints, its 6 re-linearisations of
  the torque curve; and one linearisation alone) timed alternately in the same run, per
  motor: the bundled motors and a datasheet motor (issue 32's new user's 17HS19-like
  NEMA17 on a T8 screw, made in this run by `stepramp motor new`, in-process, from the
  flags in DATASHEET: a motor file as a user's own). Goal: ≤ 4 for every motor;
- cold (issue 32), fresh processes as installed (bytecode written), the numba cache
  warm, against the same motor's toppra solve timed above: `stepramp plan --pulses 10000`
  less `stepramp --version` (the interpreter and the CLI's own start; goal ≤ 15×), and
  what `--motor` adds to `stepramp check` on that plan's table (`check T --motor M` less
  `check T`; goal ≤ 5×; the issue names no reference for it: the one the other two
  ratios use, and `check T`'s own time beside it);
- the first run on a machine (issue 32): `stepramp plan --motor <datasheet> --pulses
  10000` in a fresh process with an empty numba cache folder (NUMBA_CACHE_DIR: every
  kernel the command runs is compiled), then again (loaded from that cache): what the
  compile notice and the guide promise;
- `stepramp plan --moves` on a mix of 4 lengths (goal ≤ 0.5 s) and a toleranced motor's
  plan (`--motor examples/motor-nema17-tolerances.json --pulses 3200`: planned over the
  box's corners, judged at the corners and on 1 000 samples; goal ≤ 1 s), in-process;
- sweep rows per second, before and after: the same jobs (the bundled motors × 4 lengths,
  and the toleranced motor with 1 000 samples) run in-process by this tree and by commit
  c096f0b (before the compiled model: a `git worktree` of it in a temporary folder), each
  in a fresh process with one warm-up job; goal ≥ 10×.
"""

from __future__ import annotations

import argparse
import contextlib
import io
import json
import os
import statistics
import subprocess
import sys
import tempfile
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parent.parent
sys.path.insert(0, str(ROOT))

from benchlib import INSTALLED, Results, forget, fresh_processes, timed, verdict  # noqa: E402

from profiles.motor import bundled_motor_paths, load_motor  # noqa: E402
from verify.cli import main as stepramp  # noqa: E402
from verify.references import toppra_ref, toppra_reference  # noqa: E402

BEFORE = "c096f0b"
PLAN_GOAL = 4.0
COLD_PLAN_GOAL = 15.0
CHECK_MOTOR_GOAL = 5.0
# issue 32's new user's motor: a 17HS19-2004S1-like NEMA17 (0.59 N·m, 2 A, 1.4 Ω, 3.0 mH,
# 82 g·cm²) at 24 V, 1/8 step, 1.5 A, moving 4 kg on a T8 lead screw
DATASHEET_NAME = "17hs19"
DATASHEET = ("motor", "new", "--name", DATASHEET_NAME, "--holding-torque-nm", "0.59",
             "--rated-current-a", "2", "--current-a", "1.5", "--resistance-ohm", "1.4",
             "--inductance-mh", "3.0", "--rotor-inertia-gcm2", "82", "--supply-v", "24",
             "--microstep", "8", "--load", "screw:lead_mm=8,mass_kg=4")
CLI = (sys.executable, "-m", "verify.cli")
MOVES_GOAL_S = 0.5
TOLERANCED_GOAL_S = 1.0
SWEEP_GOAL = 10.0
TOLERANCED = ROOT / "examples" / "motor-nema17-tolerances.json"
MIX = ((300, 4.0), (2_000, 3.0), (10_000, 2.0), (100_000, 1.0))
SWEEP_LENGTHS = (1_000, 3_000, 10_000, 30_000)


def run_cli(*argv: str) -> None:
    """One `stepramp` command in this process, its output swallowed; it must succeed."""
    with contextlib.redirect_stdout(io.StringIO()), contextlib.redirect_stderr(io.StringIO()):
        code = stepramp(list(argv))
    if code != 0:
        raise SystemExit(f"stepramp {' '.join(argv)}: exit {code}")


def toppra_solve_s(motor: object, iterations: int) -> float:
    """toppra_reference's own solve time with `iterations` linearisations."""
    saved = toppra_ref.TOPPRA_ITERATIONS
    toppra_ref.TOPPRA_ITERATIONS = iterations
    try:
        return toppra_reference(motor, 10_000).solve_s  # type: ignore[arg-type]
    finally:
        toppra_ref.TOPPRA_ITERATIONS = saved


def datasheet_motor(folder: str) -> str:
    """The datasheet motor's file, made by `stepramp motor new` (in this process) in
    `folder`."""
    path = os.path.join(folder, f"{DATASHEET_NAME}.json")
    run_cli(*DATASHEET, "-o", path)
    return path


def bench_motors(folder: str) -> list[tuple[str, str]]:
    """(label, --motor argument): the bundled motors by name, then the datasheet motor's
    file."""
    return [*((p.stem.removeprefix("motor-"),) * 2 for p in bundled_motor_paths()),
            (f"{DATASHEET_NAME} (datasheet)", datasheet_motor(folder))]


def plan_time(res: Results, quick: bool, out: str, motors: list[tuple[str, str]]) -> None:
    repeats = 3 if quick else 7
    per_motor = []
    for name, arg in motors:
        argv = ("plan", "--motor", arg, "--pulses", "10000", "-o", out)
        run_cli(*argv)  # warm
        toppra_solve_s(load_motor(arg), 6)
        plans, full, single = [], [], []
        for _ in range(repeats):  # alternately, so load changes hit both alike
            forget()  # the tables it judges are new to it, as on its first run
            t0 = time.perf_counter()
            run_cli(*argv)
            plans.append(time.perf_counter() - t0)
            full.append(toppra_solve_s(load_motor(arg), 6))
            single.append(toppra_solve_s(load_motor(arg), 1))
        med = statistics.median
        per_motor.append({"motor": name, "plan_s": med(plans), "toppra_s": med(full),
                          "toppra_one_linearisation_s": med(single),
                          "ratio": med(plans) / med(full),
                          "ratio_one_linearisation": med(plans) / med(single)})
    ratio = statistics.median(m["ratio"] for m in per_motor)
    worst = max(m["ratio"] for m in per_motor)
    one = statistics.median(m["ratio_one_linearisation"] for m in per_motor)
    res.values["plan_time"] = {"motors": per_motor, "median_ratio": ratio, "worst_ratio": worst,
                               "median_ratio_one_linearisation": one, "repeats": repeats,
                               "datasheet": list(DATASHEET)}
    rows = [[m["motor"], f"{m['plan_s'] * 1e3:.0f} ms", f"{m['toppra_s'] * 1e3:.0f} ms",
             f"{m['ratio']:.2f} (≤ 4: {verdict(m['ratio'] <= PLAN_GOAL)})",
             f"{m['toppra_one_linearisation_s'] * 1e3:.0f} ms",
             f"{m['ratio_one_linearisation']:.1f}"] for m in per_motor]
    rows.append(["**every motor**", "", "", f"**{worst:.2f}** at most, median {ratio:.2f} "
                 f"(goal ≤ 4 for every motor: {verdict(worst <= PLAN_GOAL)})", "", f"{one:.1f}"])
    res.section("plan_time", ["motor", "`stepramp plan --pulses 10000`",
                              "toppra solve (6 linearisations)", "plan / toppra",
                              "toppra, one linearisation", "plan / that"], rows,
                note=f"Wall time, medians of {repeats} alternating runs, warm, in one process. "
                     f"{DATASHEET_NAME}: made in the run by `stepramp {' '.join(DATASHEET)}`.")


def cold(res: Results, quick: bool, folder: str, motors: list[tuple[str, str]]) -> None:
    """Fresh processes (numba's cache warm): `stepramp plan` less `stepramp --version`, and
    what `--motor` adds to `stepramp check`, each against the motor's toppra solve timed
    in plan_time."""
    repeats = 3 if quick else 7
    toppra = {m["motor"]: m["toppra_s"] for m in res.values["plan_time"]["motors"]}
    version, version_cpu = fresh_processes((*CLI, "--version"), repeats)
    rows, values = [], {"version_wall_s": version, "version_cpu_s": version_cpu,
                        "repeats": repeats, "motors": []}
    for name, arg in (motors[0], motors[-1]):  # a bundled motor and the datasheet one
        table = os.path.join(folder, f"cold-{len(values['motors'])}.json")
        plan, plan_cpu = fresh_processes((*CLI, "plan", "--motor", arg, "--pulses", "10000",
                                          "-o", table), repeats)
        bare, _ = fresh_processes((*CLI, "check", table), repeats)
        judged, judged_cpu = fresh_processes((*CLI, "check", table, "--motor", arg), repeats)
        ref = toppra[name]
        v = {"motor": name, "plan_wall_s": plan, "plan_cpu_s": plan_cpu,
             "plan_less_version_s": plan - version, "plan_ratio": (plan - version) / ref,
             "check_wall_s": bare, "check_motor_wall_s": judged, "check_motor_cpu_s": judged_cpu,
             "check_motor_extra_s": judged - bare, "check_motor_ratio": (judged - bare) / ref,
             "check_motor_extra_over_check": (judged - bare) / bare, "toppra_s": ref}
        values["motors"].append(v)
        rows.append([f"`stepramp plan --motor {name.split()[0]} --pulses 10000` less "
                     f"`stepramp --version` ({version * 1e3:.0f} ms)",
                     f"{v['plan_less_version_s'] * 1e3:.0f} ms (wall {plan * 1e3:.0f}, "
                     f"CPU {plan_cpu * 1e3:.0f})", f"{ref * 1e3:.0f} ms",
                     f"{v['plan_ratio']:.1f}× "
                     f"(≤ 15: {verdict(v['plan_ratio'] <= COLD_PLAN_GOAL)})"])
        rows.append([f"what `--motor {name.split()[0]}` adds to `stepramp check` on that plan",
                     f"{v['check_motor_extra_s'] * 1e3:.0f} ms ({judged * 1e3:.0f} against "
                     f"{bare * 1e3:.0f}; {v['check_motor_extra_over_check']:.1f}× `check` "
                     "alone)", f"{ref * 1e3:.0f} ms",
                     f"{v['check_motor_ratio']:.1f}× (≤ 5: "
                     f"{verdict(v['check_motor_ratio'] <= CHECK_MOTOR_GOAL)})"])
    res.values["cold"] = values
    res.section("cold", ["what (fresh processes, numba's cache warm)", "measured",
                         "toppra solve, same motor (plan_time)", "ratio (goal)"], rows,
                note=f"Medians of {repeats} fresh processes each, as installed (bytecode "
                     "written), after one untimed run; wall time.")


FIRST = """
import json, os, sys, time
from verify.cli import main
t0 = time.perf_counter()
sys.argv = ["stepramp", *sys.argv[1:]]
rc = main()  # as the stepramp command runs it
print(json.dumps({"rc": rc, "s": time.perf_counter() - t0,
                  "kernels": sum(len(f) for _, _, f in os.walk(os.environ["NUMBA_CACHE_DIR"]))}),
      file=sys.stderr)
"""


def first_run(res: Results, folder: str, motors: list[tuple[str, str]]) -> None:
    """The datasheet motor's plan in a fresh process with an empty numba cache folder
    (compile), then again (load)."""
    name, arg = motors[-1]
    argv = ("plan", "--motor", arg, "--pulses", "10000", "-o", os.path.join(folder, "first.json"))
    runs = {}
    with tempfile.TemporaryDirectory() as cache:
        env = {**INSTALLED, "NUMBA_CACHE_DIR": cache, "STEPRAMP_COMPILE_NOTICE": "0"}
        for label in ("compile", "cache load"):
            t0 = time.perf_counter()
            proc = subprocess.Popen([sys.executable, "-c", FIRST, *argv], cwd=ROOT, env=env,
                                    stdout=subprocess.DEVNULL, stderr=subprocess.PIPE, text=True)
            _, err = proc.communicate()
            wall = time.perf_counter() - t0
            if proc.returncode != 0:
                raise SystemExit(f"first run ({label}): exit {proc.returncode}: {err[-500:]}")
            inner = json.loads(err.strip().splitlines()[-1])
            runs[label] = {"wall_s": wall, "command_s": inner["s"], "cache_files": inner["kernels"]}
    res.values["first_run"] = {"motor": name, "argv": list(argv[:5]), **runs}
    rows = [[f"`stepramp plan --motor {name.split()[0]} --pulses 10000`, a fresh process, "
             f"{label} ({r['cache_files']} files in the cache after it)",
             f"{r['wall_s']:.1f} s", f"{r['command_s']:.1f} s"] for label, r in runs.items()]
    res.section("first_run", ["what", "wall (the whole process)", "the command"], rows,
                note="The first run: an empty numba cache folder (NUMBA_CACHE_DIR), so every "
                     "kernel the plan and its verdict run is compiled and written; the second "
                     "process loads them.")


def moves_and_box(res: Results, quick: bool, out: str, folder: str) -> None:
    """plan --moves per bundled motor (against that motor's single `plan --pulses 10000`
    timed in plan_time), and the toleranced motor's plan (against the same motor without
    its tolerances, timed here)."""
    mix = os.path.join(folder, "mix.csv")
    Path(mix).write_text("pulses,weight\n" + "".join(f"{n},{w}\n" for n, w in MIX))
    repeats = 3 if quick else 5
    single = {m["motor"]: m["plan_s"] for m in res.values["plan_time"]["motors"]}
    rows, values = [], {}
    for path in bundled_motor_paths():
        name = path.stem.removeprefix("motor-")
        argv = ("plan", "--motor", name, "--moves", mix, "-o", out)
        run_cli(*argv)
        wall, cpu, _ = timed(lambda a=argv: run_cli(*a), repeats)  # type: ignore[misc]
        values[name] = {"wall_s": wall, "cpu_s": cpu, "single_plan_s": single[name]}
        rows.append([f"`plan --moves` (4 lengths: {', '.join(str(n) for n, _ in MIX)}), {name}",
                     f"{wall * 1e3:.0f} ms (CPU {cpu * 1e3:.0f})",
                     f"{wall / single[name]:.1f}× its `plan --pulses 10000`",
                     f"≤ 0.5 s: {verdict(wall <= MOVES_GOAL_S)}"])
    nominal = os.path.join(folder, "nominal.json")
    obj = json.loads(TOLERANCED.read_text())
    obj.pop("tolerances")
    Path(nominal).write_text(json.dumps(obj))
    argv = ("plan", "--motor", str(TOLERANCED), "--pulses", "3200", "-o", out)
    plain = ("plan", "--motor", nominal, "--pulses", "3200", "-o", out)
    run_cli(*argv)
    run_cli(*plain)
    wall, cpu, _ = timed(lambda: run_cli(*argv), repeats)
    ref, _, _ = timed(lambda: run_cli(*plain), repeats)
    values["toleranced"] = {"wall_s": wall, "cpu_s": cpu, "without_tolerances_s": ref}
    rows.append(["toleranced motor's plan (`plan --motor examples/motor-nema17-tolerances.json "
                 "--pulses 3200`: planned over the corners, judged at the corners and on "
                 "1 000 samples)", f"{wall * 1e3:.0f} ms (CPU {cpu * 1e3:.0f})",
                 f"{wall / ref:.1f}× the same motor without tolerances ({ref * 1e3:.0f} ms)",
                 f"≤ 1 s: {verdict(wall <= TOLERANCED_GOAL_S)}"])
    res.values["moves_and_box"] = values
    res.section("moves", ["what (in-process, warm, wall time, median)", "measured",
                          "reference in the same run", "goal"], rows)


SWEEP = """
import json, sys, time
import verify
from profiles.motor import bundled_motor_paths
from verify.sweep import jobs_of, run_sweep
lengths = [int(n) for n in sys.argv[1].split(",")]
motors = [(p.stem, json.loads(p.read_text())) for p in bundled_motor_paths()]
box = [("toleranced", json.load(open(sys.argv[2])))]
jobs = jobs_of(motors, lengths, samples=0) + jobs_of(box, [3000], samples=1000)
run_sweep(jobs[:1])  # imports, compiled kernels' cache
w0, c0 = time.perf_counter(), time.process_time()
rows = run_sweep(jobs)
print(json.dumps({"wall_s": time.perf_counter() - w0, "cpu_s": time.process_time() - c0,
                  "rows": len(rows), "code": verify.__file__,
                  "errors": [r["error"] for r in rows if r["error"]],
                  "move_time_s": [r["move_time_s"] for r in rows],
                  "worst_deg": [r["worst_load_angle_deg"] for r in rows],
                  "safe": [r["safe"] for r in rows]}))
"""


def sweep_in(tree: Path) -> dict[str, object]:
    """The sweep's jobs run by the code in `tree`, in a fresh process."""
    env = {**os.environ, "PYTHONPATH": str(tree)}
    out = subprocess.run([sys.executable, "-c", SWEEP, ",".join(map(str, SWEEP_LENGTHS)),
                          str(TOLERANCED)], cwd=tree, env=env, capture_output=True, text=True,
                         check=True)
    result = json.loads(out.stdout.splitlines()[-1])
    if not str(result["code"]).startswith(str(tree)):
        raise SystemExit(f"the sweep ran {result['code']}, not the code in {tree}")
    return result


def sweep(res: Results) -> None:
    after = sweep_in(ROOT)
    with tempfile.TemporaryDirectory() as tmp:
        old = Path(tmp) / BEFORE
        subprocess.run(["git", "-C", str(ROOT), "worktree", "add", "--detach", str(old),
                        BEFORE], check=True, capture_output=True)
        try:
            before = sweep_in(old)
        finally:
            subprocess.run(["git", "-C", str(ROOT), "worktree", "remove", "--force", str(old)],
                           check=True, capture_output=True)
    rows_s = {k: r["rows"] / r["wall_s"] for k, r in (("before", before), ("after", after))}
    ratio = rows_s["after"] / rows_s["before"]
    res.values["sweep"] = {"before_commit": BEFORE, "before": before, "after": after,
                           "rows_per_s": rows_s, "ratio": ratio,
                           "cpu_ratio": before["cpu_s"] / after["cpu_s"]}
    jobs = (f"{after['rows']} rows: 3 bundled motors × {len(SWEEP_LENGTHS)} lengths "
            f"({', '.join(map(str, SWEEP_LENGTHS))}; load angle ≤ 75°) and the toleranced "
            "motor at 3 000 pulses with 1 000 samples")
    res.section("sweep", ["what", f"before ({BEFORE})", "after", "after / before", "goal"], [
        [f"sweep rows per second, in-process ({jobs})",
         f"{rows_s['before']:.2f} rows/s ({before['wall_s']:.1f} s)",
         f"{rows_s['after']:.2f} rows/s ({after['wall_s']:.1f} s)", f"{ratio:.1f}×",
         f"≥ 10×: {verdict(ratio >= SWEEP_GOAL)}"]],
        note=f"The same jobs run by commit {BEFORE} (a git worktree of it) and by this tree, "
             f"each in a fresh process after one warm-up job; CPU time ratio "
             f"{before['cpu_s'] / after['cpu_s']:.1f}×.")


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--quick", action="store_true", help="fewer repeats")
    ap.add_argument("--no-sweep", action="store_true", help="skip the before/after sweep")
    ap.add_argument("--no-cold", action="store_true",
                    help="skip the fresh processes (cold start, first run)")
    args = ap.parse_args()
    res = Results("plantime")
    with tempfile.TemporaryDirectory() as folder:
        out = os.path.join(folder, "table.json")
        motors = bench_motors(folder)
        plan_time(res, args.quick, out, motors)
        moves_and_box(res, args.quick, out, folder)
        if not args.no_cold:
            cold(res, args.quick, folder, motors)
            first_run(res, folder, motors)
    if not args.no_sweep:
        sweep(res)
    res.write()


if __name__ == "__main__":
    main()
