"""What the A-Link ALUM's one safety verdict costs, warm, against a reference in the same run.

    python bench/bench_alink.py [--quick]

- the whole verdict on a settings file (`verify.safety.judge_safety` on the unit's ramp,
  what `stepramp check SETTINGS --motor M` runs): the criterion, every move length, and
  every command family — decel stops (STOP 31) from every pulse of the ramp, immediate
  stops (STOP 28, EL, STP), CHANGE_SPD under both readings, LIMIT, and the homing legs
  (OL/OH from `stepramp alink homing`'s planner) — for the bundled motors and a datasheet
  motor (made in this run by `stepramp motor new`, as bench_plantime.py's), on the
  settings `stepramp alink settings --motor M` writes, linear and S-curve (each about 250
  stages). Warm: the kernels compiled (or loaded from their cache), every remembered
  verdict forgotten before each call (`benchlib.forget`). Goals: ≤ 50 ms linear, ≤ 100 ms
  S-curve, on wall time (the kernel runs on threads, 2 cores);
- the reference, in the same run: a 1-DOF toppra solve of a 10 000-pulse move for the
  same motor (bench_plantime.py's reference, its 6 linearisations): the verdict's time as
  a ratio to it is what to compare between runs on a shared machine.
"""

from __future__ import annotations

import argparse
import os
import statistics
import sys
import tempfile
from pathlib import Path
from typing import Any

ROOT = Path(__file__).resolve().parent.parent
sys.path.insert(0, str(ROOT))

from bench_plantime import bench_motors, run_cli, toppra_solve_s  # noqa: E402
from benchlib import Results, count, timed, verdict  # noqa: E402

from profiles.alink.formats import parse, settings_of  # noqa: E402
from profiles.alink.planner.homing import plan_homing  # noqa: E402
from profiles.alink.ramp import AlinkRamp, ramp_of  # noqa: E402
from profiles.motor import Motor, load_motor  # noqa: E402
from profiles.motor.catalogue import resolve  # noqa: E402
from verify.safety import SafetyVerdict, judge_safety  # noqa: E402

GOAL_S = {"linear": 0.050, "s_curve": 0.100}
SHAPES = ("linear", "s_curve")


def settings_ramp(motor_arg: str, shape: str, folder: str) -> AlinkRamp:
    """The ramp of the settings `stepramp alink settings --motor` writes (tightened to the
    75° aim) in `shape`."""
    path = os.path.join(folder, f"{Path(motor_arg).stem}-{shape}.json")
    run_cli("alink", "settings", "--motor", motor_arg, "--format", "json", "-o", path,
            *(("--s-curve",) if shape == "s_curve" else ()))
    settings = settings_of(parse(Path(path).read_bytes(), path).items)
    assert settings is not None, path
    return ramp_of(settings)


def executions(v: SafetyVerdict) -> int:
    """Every execution the verdict judged: the moves' and each command family's."""
    moves = v.load_angle.executions if v.load_angle is not None else 0
    return moves + sum(int(c.to_json()["executions"]) for _, c in v.commands)


def one(name: str, motor: Motor, ramp: AlinkRamp, toppra_s: float, repeats: int
        ) -> dict[str, Any]:
    homing = plan_homing(motor).table
    judge = lambda: judge_safety(ramp, motor, homing=homing)  # noqa: E731
    judge()  # the kernels compiled or loaded, outside the timing
    wall, cpu, v = timed(judge, repeats)
    return {"motor": name, "shape": ramp.shape, "stages": len(ramp.pulses),
            "ramp_pulses": ramp.ramp_pulses, "steps": ramp.steps,
            "families": [n for n, _ in v.commands], "executions": executions(v),
            "verdict_s": wall, "verdict_cpu_s": cpu, "toppra_s": toppra_s,
            "ratio": wall / toppra_s, "goal_s": GOAL_S[ramp.shape],
            "met": wall <= GOAL_S[ramp.shape], "safe": v.safe, "within_aim": v.within_aim}


def verdicts(res: Results, quick: bool, folder: str) -> None:
    repeats = 3 if quick else 9
    rows_v: list[dict[str, Any]] = []
    for name, arg in bench_motors(folder):
        motor = load_motor(resolve(arg))
        toppra_s = statistics.median(toppra_solve_s(motor, 6) for _ in range(3))
        for shape in SHAPES:
            rows_v.append(one(name, motor, settings_ramp(arg, shape, folder), toppra_s,
                              repeats))
            r = rows_v[-1]
            print(f"{name} {shape}: {r['verdict_s'] * 1e3:.1f} ms "
                  f"({r['ratio']:.2f}× toppra {toppra_s * 1e3:.0f} ms)", flush=True)
    res.values["verdicts"] = rows_v
    rows = [[r["motor"], "S-curve" if r["shape"] == "s_curve" else "linear",
             f"{r['stages']} ({count(r['steps'])} steps, {count(r['ramp_pulses'])} pulses)",
             count(r["executions"]),
             f"{r['verdict_s'] * 1e3:.1f} ms (CPU {r['verdict_cpu_s'] * 1e3:.1f})",
             f"{r['toppra_s'] * 1e3:.0f} ms", f"{r['ratio']:.2f}",
             f"≤ {r['goal_s'] * 1e3:.0f} ms: {verdict(r['met'])}"] for r in rows_v]
    res.section("verdict", ["motor", "ramp", "stages", "executions judged",
                            "the whole verdict, warm (median)", "toppra solve, same motor",
                            "verdict / toppra", "goal"], rows,
                "Every command family judged (decel stops, immediate stops, CHANGE_SPD in "
                "linear, LIMIT, the homing legs) on the settings `stepramp alink settings "
                "--motor M` writes; 17hs19: made in the run by `stepramp motor new` (its "
                "tolerance box: every corner). At 67140f2, before the changes it came with, the "
                "same verdicts took 0.30–0.46 s CPU (linear) and 1.5–3.4 s CPU (S-curve), "
                "measured beside this tree on the same settings (their JSON equal to 1e-6): "
                "3–8× the CPU they took at 3c8a3fe (102–118 ms linear, 240–406 ms S-curve, "
                "load 7–8); since then the stop families are sampled along the ramp and "
                "refined (docs/manual-notes.md, \"A-Link ALUM: stops sampled along the "
                "ramp\"): fewer stops judged, the same verdicts.")


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--quick", action="store_true", help="fewer repeats")
    args = ap.parse_args()
    res = Results("alink")
    with tempfile.TemporaryDirectory() as folder:
        verdicts(res, args.quick, folder)
    res.write()


if __name__ == "__main__":
    main()
