"""Issue #17: what judging safety costs, warm and cold, against references in the same run.

    python bench/bench_safety.py [--quick]

- judge every execution of a 127-stage table, warm (`verify.safety.judge_safety`: the
  criterion and the load angle over every move length; goal ≤ 25 ms): the bundled
  motors' 10 000-pulse plans (tightened to 75°, as `stepramp plan` writes them) and a
  random uneven LE=1 table over the NEMA17's speed range; the executions and the RK4
  steps the compiled model took, against the plain-Python oracle (tests/support/rotor_oracle.py)
  integrating the same executions each from rest (a sample of them, timed and scaled to
  all), which also checks the worst angles agree on that sample;
- 1 000 Monte Carlo samples of a tolerance box (`profiles.ppmc312.tolerance_box.sample_peaks` on
  examples/motor-nema17-tolerances.json, on the moves its corners are worst at; goal
  ≤ 1 s), the whole box verdict (`judge_safety`: corners over every move, then the
  samples), and the oracle on a few samples, scaled;
- the cold first call: a fresh process with an empty numba cache folder compiles the
  kernels (the planner's DP layers and stage counts, the move assembly and the rotor),
  a second one loads them from that cache;
- `stepramp check` without `--motor`: cold start (goal ≤ 0.3 s) against `python -c pass`,
  and whether numba gets imported (it must not).
Single-thread work is timed in process CPU time as well as wall time; the judge runs
on threads (2 cores), so its goal is read on wall time.
"""

from __future__ import annotations

import argparse
import ast
import json
import math
import os
import random
import statistics
import subprocess
import sys
import tempfile
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parent.parent
sys.path.insert(0, str(ROOT))

import numpy as np  # noqa: E402
from benchlib import Results, forget, timed, verdict  # noqa: E402

from profiles.errors import StepRampError  # noqa: E402
from profiles.motor import Motor, bundled_motor_paths, load_motor  # noqa: E402
from profiles.motor.tolerance import samples as box_samples  # noqa: E402
from profiles.ppmc312.load_angle import (  # noqa: E402
    angles,
    directions,
    samples,
    worst_load_angle,
)
from profiles.ppmc312.planner import choose_clock, plan_free_curve  # noqa: E402
from profiles.ppmc312.table import FreeCurveTable  # noqa: E402
from profiles.ppmc312.tolerance_box import sample_peaks  # noqa: E402
from tests.support.oracle_moves import kernel_step_counts, whole_move  # noqa: E402
from verify.safety import judge_safety  # noqa: E402

AIM_DEG = 75.0
JUDGE_GOAL_S = 0.025
SAMPLES_GOAL_S = 1.0
CHECK_GOAL_S = 0.3
TOLERANCED = ROOT / "examples" / "motor-nema17-tolerances.json"
EXAMPLE_TABLE = ROOT / "examples" / "free-curve-nema17.json"


def bundled() -> list[tuple[str, Motor]]:
    return [(p.stem.removeprefix("motor-"), load_motor(p)) for p in bundled_motor_paths()]


def random_le1(motor: Motor, rng: random.Random, most: int, stages: int = 127
               ) -> FreeCurveTable:
    """127 random rates between the motor's top and start speeds, uneven accel and decel
    counts of 2..`most` pulses (LE=1): many move families, each sampled along its
    partial stages."""
    clock = choose_clock(motor)
    fast = math.ceil(clock.hz / motor.top_pps)
    slow = math.floor(clock.hz / motor.start_pps)
    rates = sorted(rng.sample(range(fast, slow), stages))
    acc = tuple(rng.randint(2, most) for _ in rates)
    dec = tuple(rng.randint(2, most) for _ in rates)
    return FreeCurveTable(clock, tuple(rates), acc, dec)


def kernel_steps(table: FreeCurveTable, motor: Motor) -> int:
    """RK4 steps the compiled model takes for every execution of `table` (a counting
    pass, not timed; the verdict forgotten first, so the kernel runs)."""
    forget()
    with kernel_step_counts() as seen:
        worst_load_angle(table, motor)
    return int(sum(int(u.sum()) for u in seen))


def oracle_moves(table: FreeCurveTable, motor: Motor, lengths: list[int]
                 ) -> tuple[float, int, list[float]]:
    """The oracle on whole moves, from rest until settled, every direction judged: (CPU
    s, RK4 steps, worst angle of each move)."""
    c0 = time.process_time()
    steps, worst = 0, []
    for n in lengths:
        deg = 0.0
        for d in directions(motor):
            angle, used = whole_move(table, motor, n, d)
            steps += used
            deg = max(deg, angle)
        worst.append(deg)
    return time.process_time() - c0, steps, worst


def judge_one(label: str, table: FreeCurveTable, motor: Motor, repeats: int,
              sample: int) -> dict[str, object]:
    """judge_safety's warm time on one table, its executions and RK4 steps, and the
    oracle on a sample of the same executions (CPU, scaled to all of them)."""
    crit_wall, _, _ = timed(lambda: judge_safety(table, motor, load_angle=False), repeats)
    out: dict[str, object] = {"label": label, "stages": len(table.rates),
                              "LE": int(table.separate), "criterion_wall_s": crit_wall}
    try:
        judge_safety(table, motor)  # warm: compiled, cached arrays
    except StepRampError as e:  # the verdict's step budget: it refuses, saying why
        wall, cpu, _ = timed(lambda: refused(table, motor), 1)
        return {**out, "refused": str(e), "wall_s": wall, "cpu_s": cpu,
                "move_lengths": len(samples(table, [motor])[0])}
    wall, cpu, v = timed(lambda: judge_safety(table, motor), repeats)  # each a first
    found = angles(table, [motor])
    per_move = found.deg.max(axis=0)
    lengths = [int(n) for n in found.lengths]
    # the oracle on a sample: evenly spread over the judged moves, and the worst one
    pick = sorted(set(np.linspace(0, len(lengths) - 1, min(sample, len(lengths))).astype(int))
                  | {int(np.argmax(per_move))})
    o_cpu, o_steps, o_worst = oracle_moves(table, motor, [lengths[i] for i in pick])
    scale = len(lengths) / len(pick)
    la = v.load_angle
    return {**out, "executions": la.executions, "move_lengths": len(lengths),
            "rk4_steps": kernel_steps(table, motor), "wall_s": wall, "cpu_s": cpu,
            "worst_deg": la.worst_deg, "safe": v.safe,
            "oracle_sampled": len(pick), "oracle_cpu_s_scaled": o_cpu * scale,
            "oracle_rk4_steps_scaled": o_steps * scale,
            "oracle_vs_kernel_max_diff_deg": max(
                abs(o - float(per_move[i])) for o, i in zip(o_worst, pick, strict=True)),
            "speedup_vs_oracle": o_cpu * scale / cpu}


def refused(table: FreeCurveTable, motor: Motor) -> None:
    try:
        judge_safety(table, motor)
    except StepRampError:
        return
    raise AssertionError("refused once, judged the next time")


def judge_row(r: dict[str, object]) -> list[str]:
    head = [str(r["label"]), f"{r['stages']} (LE={r['LE']})"]
    if "refused" in r:
        return [*head, f"{r['move_lengths']} move lengths", "> 8 M for one rotor",
                f"refused after {r['wall_s']:.1f} s", f"{r['criterion_wall_s'] * 1e3:.1f} ms",
                "—", "—", f"≤ 25 ms: {verdict(False)}"]
    return [*head, f"{r['executions']}", f"{r['rk4_steps'] / 1e6:.2f} M",
            f"{r['wall_s'] * 1e3:.1f} ms (CPU {r['cpu_s'] * 1e3:.1f})",
            f"{r['criterion_wall_s'] * 1e3:.1f} ms",
            f"{r['oracle_cpu_s_scaled']:.1f} s ({r['oracle_sampled']} of "
            f"{r['move_lengths']} moves timed)", f"{r['speedup_vs_oracle']:.0f}×",
            f"≤ 25 ms: {verdict(r['wall_s'] <= JUDGE_GOAL_S)}"]


def judge_time(res: Results, quick: bool) -> None:
    motors = bundled()
    cases = [(f"{name}, planned for 10 000 pulses",
              plan_free_curve(m, pulses=10_000, load_angle_deg=AIM_DEG).table, m)
             for name, m in motors]
    nema17 = motors[0][1]
    for most in (40, 400):
        cases.append((f"random uneven LE=1, counts 2–{most} (NEMA17's speed range)",
                      random_le1(nema17, random.Random(7), most), nema17))
    out = [judge_one(label, table, motor, 3 if quick else 9, 8 if quick else 30)
           for label, table, motor in cases]
    res.values["judge"] = out
    judged = [r for r in out if "refused" not in r]
    res.values["judge_worst_wall_s"] = max(r["wall_s"] for r in out)  # type: ignore[type-var]
    res.section("judge", ["table", "stages", "executions judged", "RK4 steps",
                          "judge_safety, warm (median)", "criterion alone",
                          "the oracle, same executions (CPU, scaled)", "oracle / judge CPU",
                          "goal"], [judge_row(r) for r in out],
                note="The oracle integrates each judged move whole in plain Python; on the "
                     "sampled moves its worst angles and the compiled model's agree within "
                     f"{max(r['oracle_vs_kernel_max_diff_deg'] for r in judged):.3f}°.")


def monte_carlo(res: Results, quick: bool) -> None:
    motor = load_motor(TOLERANCED)
    table = plan_free_curve(motor, pulses=3200, load_angle_deg=AIM_DEG).table
    box = judge_safety(table, motor).box
    lengths = list(box.sampled_pulses)
    n = 1000
    sample_peaks(table, motor, lengths, n, seed=0)  # warm
    wall, cpu, _ = timed(lambda: sample_peaks(table, motor, lengths, n, seed=0), 3 if quick else 7)
    box_wall, box_cpu, _ = timed(lambda: judge_safety(table, motor), 3)
    few = box_samples(motor, 4 if quick else 10, seed=0)
    o_cpu = sum(oracle_moves(table, s.motor, lengths)[0] for s in few) * n / len(few)
    res.values["monte_carlo"] = {"motor": TOLERANCED.name, "table_pulses": 3200,
                                 "samples": n, "moves": lengths, "wall_s": wall, "cpu_s": cpu,
                                 "box_verdict_wall_s": box_wall, "box_verdict_cpu_s": box_cpu,
                                 "corners": box.corners, "oracle_cpu_s_scaled": o_cpu,
                                 "oracle_samples": len(few)}
    res.section("monte_carlo", ["what", "measured", "goal"], [
        [f"1 000 Monte Carlo samples × {len(lengths)} moves ({', '.join(map(str, lengths))} "
         f"pulses), `sample_peaks`, warm", f"{wall * 1e3:.0f} ms (CPU {cpu * 1e3:.0f})",
         f"≤ 1 s: {verdict(wall <= SAMPLES_GOAL_S)}"],
        [f"the whole box verdict (`judge_safety`: {box.corners} corners over every move, "
         "then the samples)", f"{box_wall * 1e3:.0f} ms (CPU {box_cpu * 1e3:.0f})", "—"],
        [f"the oracle on the same samples' moves (CPU, {len(few)} samples scaled to 1 000)",
         f"{o_cpu:.1f} s ({o_cpu / cpu:.0f}× the compiled model's CPU)", "—"]],
        note=f"{TOLERANCED.relative_to(ROOT)}, its table planned for 3 200 pulses.")


COLD = """
import json, sys, time
t0 = time.perf_counter()
from profiles.motor import load_motor
from profiles.ppmc312.planner import plan_free_curve
from verify.safety import judge_safety
m = load_motor("nema17-1600")
t = [time.perf_counter()]
for pulses in (10_000, 10_001):  # not the same plan and verdict: they are remembered
    plan = plan_free_curve(m, pulses=pulses)
    t.append(time.perf_counter())
    judge_safety(plan.table, m)
    t.append(time.perf_counter())
print(json.dumps({"imports_s": t[0] - t0, "plan_s": [t[1] - t[0], t[3] - t[2]],
                  "judge_s": [t[2] - t[1], t[4] - t[3]],
                  "numba": "numba" in sys.modules}))
"""


def cold_call(res: Results) -> None:
    runs = {}
    with tempfile.TemporaryDirectory() as cache:
        env = {**os.environ, "NUMBA_CACHE_DIR": cache, "PYTHONPATH": str(ROOT)}
        for label in ("compile", "cache load"):
            out = subprocess.run([sys.executable, "-c", COLD], capture_output=True, text=True,
                                 cwd=ROOT, env=env, check=True)
            runs[label] = json.loads(out.stdout)
    rows = []
    for label, r in runs.items():
        first = r["plan_s"][0] + r["judge_s"][0]
        warm = r["plan_s"][1] + r["judge_s"][1]
        rows.append([f"first plan + judge in a fresh process ({label})",
                     f"{first:.2f} s (plan {r['plan_s'][0]:.2f}, judge {r['judge_s'][0]:.2f})",
                     f"{warm * 1e3:.0f} ms", f"{first - warm:.2f} s"])
    res.values["cold"] = runs
    res.section("cold", ["what (NEMA17, 10 000 pulses, criterion-only plan)", "first call",
                         "a second plan + judge (10 001 pulses)", "paid once"], rows,
                note="A fresh numba cache folder: the first process compiles the planner's, "
                     "the move assembly's and the rotor's kernels and writes them; the second "
                     "loads them.")


HEAVY = ("numpy", "numba", "toppra", "casadi", "matplotlib", "ruckig", "scipy", "jsonschema")
PROBE = ("import sys; from verify.cli import main; rc = main(['check', sys.argv[1]]); "
         f"print(sorted(m for m in {HEAVY!r} if m in sys.modules), file=sys.stderr); "
         "sys.exit(rc)")
# As installed: pip compiles the bytecode once; this environment may forbid writing it
INSTALLED = {k: v for k, v in os.environ.items() if k != "PYTHONDONTWRITEBYTECODE"}


def cold_start(cmd: list[str], repeats: int = 9) -> tuple[float, float]:
    """Median wall and CPU (user + system) seconds of a fresh process running `cmd`."""
    subprocess.run(cmd, check=False, capture_output=True, cwd=ROOT, env=INSTALLED)  # .pyc
    walls, cpus = [], []
    for _ in range(repeats):
        t0 = time.perf_counter()
        proc = subprocess.Popen(cmd, cwd=ROOT, env=INSTALLED, stdout=subprocess.DEVNULL,
                                stderr=subprocess.DEVNULL)
        _, _, usage = os.wait4(proc.pid, 0)
        walls.append(time.perf_counter() - t0)
        cpus.append(usage.ru_utime + usage.ru_stime)
    return statistics.median(walls), statistics.median(cpus)


def check_start(res: Results) -> None:
    bare, bare_cpu = cold_start([sys.executable, "-c", "pass"])
    check, check_cpu = cold_start([sys.executable, "-m", "verify.cli", "check",
                                   str(EXAMPLE_TABLE)])
    probe = subprocess.run([sys.executable, "-c", PROBE, str(EXAMPLE_TABLE)], cwd=ROOT,
                           capture_output=True, text=True, check=True)
    heavy = ast.literal_eval(probe.stderr.strip().splitlines()[-1])
    numba = "numba" in heavy
    res.values["check_cold_start"] = {"check_wall_s": check, "check_cpu_s": check_cpu,
                                      "python_pass_wall_s": bare, "python_pass_cpu_s": bare_cpu,
                                      "imports_numba": numba, "heavy_imported": heavy}
    res.section("check", ["what", "measured", "goal"], [
        ["cold start of `stepramp check` on a table without `--motor` (median of 9 fresh "
         "processes; CPU time, wall time in brackets)",
         f"{check_cpu:.3f} s ({check:.3f} s); {check_cpu / bare_cpu:.1f}× `python -c pass` "
         f"({bare_cpu:.3f} s)", f"≤ 0.3 s: {verdict(check_cpu <= CHECK_GOAL_S)}"],
        ["numba imported by `stepramp check` without `--motor`", "yes" if numba else "no",
         f"never: {verdict(not numba)}"],
        [f"of {', '.join(HEAVY)}: imported by it", ", ".join(heavy) or "none", "—"]])


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--quick", action="store_true", help="fewer repeats and oracle samples")
    quick = ap.parse_args().quick
    res = Results("safety")
    check_start(res)
    cold_call(res)
    judge_time(res, quick)
    monte_carlo(res, quick)
    res.write()


if __name__ == "__main__":
    main()
