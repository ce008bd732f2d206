"""Mutation testing with cosmic-ray, one session per module.

tools/mutation.toml maps each module of profiles/ and verify/ to the tests that judge it
(or excludes it, with the reason), gives a module's test runs their environment (the
load-angle kernels with NUMBA_DISABLE_JIT=1) and lists the equivalent mutants by id, each
with the reason it cannot change behaviour. For each module this

1. writes a cosmic-ray configuration: the module, the test command (pytest on the
   module's tests, -x, no slow tests, hypothesis's `mutation` profile), the timeout;
2. runs `cosmic-ray init` and cosmic-ray's operators filter (`cr-filter-operators`,
   [run] exclude-operators), then filters of its own that mark work items skipped: a
   random sample (`--sample N`: a fixed order seeded by the module's name, so a sample
   is reproducible and a larger one extends it; the rest "not in the sample"), mutants
   inside annotations (never evaluated: no mutant at all, not counted) and the
   equivalent mutants ("equivalent: <why>");
3. checks the unmutated module passes its tests (their time sets the timeout) and runs
   `cosmic-ray exec` (one mutant at a time).

cosmic-ray writes each mutant into the module's file, so all of it runs in a copy of the
checkout, .mutation/src; the sessions (.mutation/<module>.sqlite, `cr-report` reads
them) and their configurations live beside it, git-ignored. `report` turns the sessions
into reports/mutation.json; `python bench/readme.py` writes the README's block from it.

    python tools/mutation.py run [MODULE …] [--sample N] [--again]
    python tools/mutation.py report
    python tools/mutation.py ids MODULE    # each mutant's id and verdict (survivors first)
(MODULE: a dotted name such as profiles.motor.rotor; default every mapped module.)
"""

from __future__ import annotations

import argparse
import ast
import difflib
import hashlib
import json
import os
import random
import re
import shlex
import shutil
import sqlite3
import subprocess
import sys
import time
import tomllib
from datetime import UTC, datetime
from pathlib import Path
from typing import Any

import cosmic_ray.plugins
from cosmic_ray.ast import ast_nodes, get_ast
from cosmic_ray.ast.ast_query import ASTQuery
from cosmic_ray.mutating import mutate_code
from cosmic_ray.work_db import WorkDB, use_db
from cosmic_ray.work_item import MutationSpec, TestOutcome, WorkerOutcome, WorkItem, WorkResult

ROOT = Path(__file__).resolve().parents[1]
CONFIG = ROOT / "tools" / "mutation.toml"
WORK = ROOT / ".mutation"
REPORT = ROOT / "reports" / "mutation.json"
NOT_SAMPLED = "not in the sample"
FILTERED = "Filtered operator"  # cosmic-ray's operators filter says so
EQUIVALENT = "equivalent: "
ANNOTATION = "in an annotation (never evaluated)"
BIN = Path(sys.executable).parent  # cosmic-ray's commands, installed beside python
# the load-angle model: its modules each get a row of the README's block
LOAD_ANGLE = ("profiles.motor.rotor", "profiles.motor.rotor_kernel", "profiles.motor.batch_angle",
              "profiles.ppmc312.load_angle")


def load_config(path: Path = CONFIG) -> dict[str, Any]:
    return tomllib.loads(path.read_text(encoding="utf-8"))


def module_path(name: str, root: Path = ROOT) -> Path:
    base = root / name.replace(".", "/")
    return base / "__init__.py" if base.is_dir() else base.with_suffix(".py")


def equivalents(config: dict[str, Any]) -> dict[tuple[str, str], str]:
    """(module, mutant id) → why it cannot change behaviour."""
    return {(m, i): why for m, ids in config.get("equivalent", {}).items()
            for i, why in ids.items()}


def code_id(definition: str | None, source: str, mutated: str) -> str:
    """A mutant by its code: the enclosing function or class, then the changed line(s)
    before → after (never a line number: moving code keeps the id)."""
    old, new = source.splitlines(), mutated.splitlines()
    before: list[str] = []
    after: list[str] = []
    for tag, i1, i2, j1, j2 in difflib.SequenceMatcher(None, old, new,
                                                       autojunk=False).get_opcodes():
        if tag != "equal":
            before += old[i1:i2]
            after += new[j1:j2]
    return (f"{definition or '<module>'}: "
            f"{' / '.join(s.strip() for s in before)} → {' / '.join(s.strip() for s in after)}")


def mutant_id(source: str, spec: MutationSpec) -> str:
    """The id of a session's mutant."""
    operator = cosmic_ray.plugins.get_operator(spec.operator_name)(**spec.operator_args)
    mutated = mutate_code(source, operator, spec.occurrence)
    if mutated is None:
        return f"{spec.definition_name or '<module>'}: ({spec.operator_name}: no mutant)"
    return code_id(spec.definition_name, source, mutated)


def spans(node: Any, lines: set[int]) -> bool:
    return any(node.start_pos[0] <= line <= node.end_pos[0] for line in lines)


def mutant_ids_at(source: str, lines: set[int]) -> set[str]:
    """The ids of the module's mutants (every cosmic-ray operator) changing `lines`, as a
    session makes them, without enumerating the whole module's: each top-level statement
    holding one of them on its own, at its place (after as many empty lines)."""
    return {i for top in get_ast(source).children if spans(top, lines)
            for i in _ids_in("\n" * (top.start_pos[0] - 1) + top.get_code(include_prefix=False),
                             lines)}


def _ids_in(source: str, lines: set[int]) -> set[str]:
    near = [n for n in ast_nodes(get_ast(source)) if spans(n, lines)]
    ids = set()
    for name in cosmic_ray.plugins.operator_names():
        kind = cosmic_ray.plugins.get_operator(name)
        if kind.arguments():
            continue
        for node in near:
            for index, (start, _) in enumerate(kind().mutation_positions(node)):
                if start[0] not in lines:
                    continue
                tree = get_ast(source)  # a fresh tree for each mutant
                twin = next(n for n in ast_nodes(tree) if (n.type, n.start_pos, n.end_pos)
                            == (node.type, node.start_pos, node.end_pos))
                definition = ASTQuery(twin).get_definition_name()
                siblings = twin.parent.children
                siblings[siblings.index(twin)] = kind().mutate(twin, index)
                ids.add(code_id(definition, source, tree.get_code()))
    return ids


def digest(source: str) -> str:
    return hashlib.sha256(source.encode()).hexdigest()[:16]


def annotation_spans(source: str) -> list[tuple[tuple[int, int], tuple[int, int]]]:
    """Where the module's annotations are, when it never evaluates them."""
    if "from __future__ import annotations" not in source:
        return []
    spans = []
    for node in ast.walk(ast.parse(source)):
        found = [node.returns] if isinstance(node, ast.FunctionDef | ast.AsyncFunctionDef) else []
        found += [node.annotation] if isinstance(node, ast.arg | ast.AnnAssign) else []
        spans += [((a.lineno, a.col_offset), (a.end_lineno or 0, a.end_col_offset or 0))
                  for a in found if a is not None]
    return spans


def annotation_filter(db: WorkDB, source: str) -> None:
    """A mutant inside an annotation is none (`from __future__ import annotations`: never
    evaluated): skipped, and not counted, like an excluded operator's."""
    spans, done = annotation_spans(source), dict(db.results)
    hits = [w.job_id for w in db.work_items
            if any(a <= w.mutations[0].start_pos < b for a, b in spans)
            and (w.job_id not in done or done[w.job_id].output != FILTERED)]
    db.set_multiple_results(hits, WorkResult(WorkerOutcome.SKIPPED, output=ANNOTATION))


def forget(session: Path, job_ids: list[str]) -> None:
    """Drop results, so `cosmic-ray exec` runs those work items again."""
    with sqlite3.connect(session) as db:
        db.executemany("DELETE FROM work_results WHERE job_id = ?", [(j,) for j in job_ids])


def sample_filter(db: WorkDB, session: Path, name: str, n: int, excluded: list[str]
                  ) -> None:
    """Mark every mutant but the first `n` of a fixed random order skipped (0: none):
    the order of the mutants of the operators not `excluded`, seeded by the module's
    name (a larger `n` extends a sample; a smaller one drops the rest)."""
    done = dict(db.results)
    pattern = re.compile("|".join(f"(?:{e})" for e in excluded) or "(?!)")
    items = sorted((w for w in db.work_items if not pattern.match(w.mutations[0].operator_name)),
                   key=lambda w: (w.mutations[0].start_pos, w.mutations[0].operator_name,
                                  w.mutations[0].occurrence))
    random.Random(name).shuffle(items)
    keep = items[:n] if n else items
    forget(session, [w.job_id for w in keep
                     if w.job_id in done and done[w.job_id].output == NOT_SAMPLED])
    rest = [w.job_id for w in items[len(keep):] if w.job_id not in done
            or done[w.job_id].output not in (NOT_SAMPLED, ANNOTATION, FILTERED)]
    db.set_multiple_results(rest, WorkResult(WorkerOutcome.SKIPPED, output=NOT_SAMPLED))


def equivalent_filter(db: WorkDB, session: Path, name: str, source: str,
                      known: dict[tuple[str, str], str]) -> None:
    """Mark the listed equivalent mutants skipped with their reason (pending or survived
    ones), and run again one no longer listed."""
    done = dict(db.results)
    dropped = []
    for item in db.work_items:
        result = done.get(item.job_id)
        marked = result is not None and (result.output or "").startswith(EQUIVALENT)
        if result is not None and not marked and result.test_outcome != TestOutcome.SURVIVED:
            continue
        why = known.get((name, mutant_id(source, item.mutations[0])))
        if why is not None:
            db.set_result(item.job_id, WorkResult(WorkerOutcome.SKIPPED,
                                                  output=EQUIVALENT + why))
        elif marked:
            dropped.append(item.job_id)
    forget(session, dropped)


def test_command(tests: list[str]) -> list[str]:
    # no:tests.support.repo_clean: the suite's check that a session leaves the checkout
    # unchanged fails whenever cosmic-ray has a mutant in place
    return [sys.executable, "-m", "pytest", "-x", "-q", "-m", "not slow", "--no-header",
            "-p", "no:cacheprovider", "-p", "no:tests.support.repo_clean", "-o", "addopts=",
            *tests]


def copy_checkout(dest: Path) -> None:
    """The checkout's files (tracked, and new ones git does not ignore) into `dest`, their
    times kept (numba's cache of an unchanged module stays valid)."""
    listed = subprocess.run(["git", "ls-files", "-z", "--cached", "--others",
                             "--exclude-standard"], cwd=ROOT, capture_output=True,
                            check=True).stdout.decode().split("\0")
    shutil.rmtree(dest, ignore_errors=True)
    for rel in filter(None, listed):
        src = ROOT / rel
        if src.is_file() and not src.is_symlink():
            (dest / rel).parent.mkdir(parents=True, exist_ok=True)
            shutil.copy2(src, dest / rel)


def session_config(name: str, tests: list[str], timeout: float, run: dict[str, Any]) -> str:
    path = module_path(name, Path(".")).as_posix()
    excluded = ", ".join(json.dumps(e) for e in run.get("exclude-operators", []))
    return (f"# generated by tools/mutation.py for {name}\n[cosmic-ray]\n"
            f"module-path = {json.dumps(path)}\ntimeout = {timeout:.0f}.0\n"
            f"excluded-modules = []\n"
            f"test-command = {json.dumps(shlex.join(test_command(tests)))}\n\n"
            f"[cosmic-ray.distributor]\nname = \"local\"\n\n"
            f"[cosmic-ray.filters.operators-filter]\nexclude-operators = [{excluded}]\n")


def prepare(name: str, config: dict[str, Any], sample: int, again: bool,
            env: dict[str, str]) -> int:
    """The module's session set up (anew when its source changed) and filtered; how many
    mutants are left to run."""
    src, session, cfg = WORK / "src", WORK / f"{name}.sqlite", WORK / f"{name}.toml"
    source = module_path(name, src).read_text(encoding="utf-8")
    state_path = WORK / f"{name}.json"
    state = json.loads(state_path.read_text()) if state_path.exists() else {}
    if state.get("sha") != digest(source) or not session.exists():
        state_path.unlink(missing_ok=True)
        cfg.write_text(session_config(name, config["modules"][name], 0.0, config["run"]),
                       encoding="utf-8")
        for argv in (["cosmic-ray", "init", "--force", str(cfg), str(session)],
                     ["cr-filter-operators", str(session), str(cfg)]):
            subprocess.run([str(BIN / argv[0]), *argv[1:]], cwd=src, env=env, check=True)
    with use_db(str(session)) as db:
        if again:
            forget(session, [j for j, r in db.results if r.test_outcome == TestOutcome.SURVIVED])
        sample_filter(db, session, name, sample, config["run"].get("exclude-operators", []))
        annotation_filter(db, source)
        equivalent_filter(db, session, name, source, equivalents(config))
        return len(db.pending_work_items)


def run_module(name: str, config: dict[str, Any], sample: int, again: bool) -> bool:
    """One module's session: set up (or resumed), filtered, executed. False when the
    unmutated module fails its tests."""
    src, tests, state_path = WORK / "src", config["modules"][name], WORK / f"{name}.json"
    env = {**os.environ, "CI": "true", "HYPOTHESIS_PROFILE": "mutation", "MPLBACKEND": "Agg",
           "NUMBA_CACHE_DIR": str(WORK / "numba"), **config.get("env", {}).get(name, {})}
    load = round(os.getloadavg()[0], 2)
    pending = prepare(name, config, sample, again, env)
    state = json.loads(state_path.read_text()) if state_path.exists() else {}
    state.update(sha=digest(module_path(name, src).read_text(encoding="utf-8")),
                 sample=sample)
    if pending:
        t0 = time.monotonic()
        base = subprocess.run(test_command(tests), cwd=src, env=env, capture_output=True,
                              text=True)
        base_s = time.monotonic() - t0
        if base.returncode != 0:
            print(f"{name}: the tests fail on the unmutated module:\n{base.stdout[-3000:]}",
                  file=sys.stderr)
            return False
        print(f"{name}: {pending} mutants to run, baseline {base_s:.0f} s", file=sys.stderr,
              flush=True)
        timeout = max(float(config["run"]["timeout-min"]),
                      float(config["run"]["timeout-factor"]) * base_s)
        cfg = WORK / f"{name}.toml"
        cfg.write_text(session_config(name, tests, timeout, config["run"]), encoding="utf-8")
        subprocess.run([str(BIN / "cosmic-ray"), "exec", str(cfg), str(WORK / f"{name}.sqlite")],
                       cwd=src, env=env, check=True)
        state.setdefault("load_avg_before", load)
        state.update(baseline_s=round(base_s, 1),
                     at=datetime.now(UTC).isoformat(timespec="seconds"),
                     seconds=round(state.get("seconds", 0.0) + time.monotonic() - t0, 1))
    state_path.write_text(json.dumps(state), encoding="utf-8")
    return True


def verdict(result: WorkResult | None) -> str:
    if result is None:
        return "not run"
    if result.worker_outcome == WorkerOutcome.SKIPPED:
        out = result.output or ""
        return ("equivalent" if out.startswith(EQUIVALENT)
                else "filtered" if out in (FILTERED, ANNOTATION) else "not run")
    if result.worker_outcome != WorkerOutcome.NORMAL:
        return "error"
    if result.test_outcome == TestOutcome.KILLED:
        return "timeout" if result.output == "timeout" else "killed"
    return "survived" if result.test_outcome == TestOutcome.SURVIVED else "error"


def judged(name: str) -> list[tuple[WorkItem, str]]:
    with use_db(str(WORK / f"{name}.sqlite"), WorkDB.Mode.open) as db:
        results = dict(db.results)
        return [(w, verdict(results.get(w.job_id))) for w in db.work_items]


def module_summary(name: str, config: dict[str, Any]) -> dict[str, Any]:
    """A module's counts, survivors and equivalent mutants from its session."""
    items = judged(name)
    source = module_path(name).read_text(encoding="utf-8")
    state = json.loads((WORK / f"{name}.json").read_text())
    count = {v: sum(1 for _, x in items if x == v) for v in
             ("killed", "timeout", "survived", "equivalent", "error", "not run", "filtered")}
    caught, survived = count["killed"] + count["timeout"], count["survived"]
    known = equivalents(config)
    ids = {w.job_id: mutant_id(source, w.mutations[0]) for w, v in items
           if v in ("survived", "equivalent")}
    return {"mutants": len(items) - count.pop("filtered"), **count,
            "score": round(caught / (caught + survived), 4) if caught + survived else None,
            "sample": state.get("sample", 0), "seconds": state.get("seconds", 0.0),
            "current": state["sha"] == digest(source),
            "survivors": sorted(({"id": ids[w.job_id], "line": w.mutations[0].start_pos[0]}
                                 for w, v in items if v == "survived"), key=str),
            "equivalent_mutants": sorted(({"id": ids[w.job_id], "why": known.get(
                (name, ids[w.job_id]), "(no longer listed)")} for w, v in items
                if v == "equivalent"), key=str)}


def row(label: str, mods: list[dict[str, Any]]) -> list[str]:
    total = {k: sum(m[k] for m in mods) for k in
             ("mutants", "not run", "killed", "timeout", "equivalent", "survived")}
    caught = total["killed"] + total["timeout"]
    score = caught / (caught + total["survived"]) if caught + total["survived"] else None
    return [label, f"{total['mutants']} ({total['not run']} not run)",
            *(str(total[k]) for k in ("killed", "timeout", "equivalent", "survived")),
            "—" if score is None else f"{100 * score:.1f} %"]


def report(config: dict[str, Any]) -> dict[str, Any]:
    names = [n for n in config["modules"] if (WORK / f"{n}.json").exists()]
    values = {n: module_summary(n, config) for n in names}
    others = [n for n in names if n not in LOAD_ANGLE]
    rows = [row(n, [values[n]]) for n in LOAD_ANGLE if n in values]
    rows += [row(f"{len(others)} other modules", [values[n] for n in others]),
             row("**all**", list(values.values()))]
    samples = sorted({values[n]["sample"] for n in names})
    note = ("Score = (killed + timeout) / (run − equivalent), over a random sample of each "
            "module's mutants (`--sample N`, seeded by the module's name; cosmic-ray's "
            "operators, less those tools/mutation.toml leaves out and any change inside an "
            "annotation). Every module, its "
            "survivors and the equivalent mutants with their reasons: reports/mutation.json.")
    states = [{"at": datetime.fromtimestamp(p.stat().st_mtime, UTC).isoformat(
        timespec="seconds"), "load_avg_before": None, **json.loads(p.read_text())}
        for p in (WORK / f"{n}.json" for n in names)]
    return {
        "name": "mutation",
        "command": "python tools/mutation.py run " + ", ".join(
            f"--sample {s} ({', '.join(n for n in names if values[n]['sample'] == s)})"
            if len([n for n in names if values[n]["sample"] == s]) <= 3 else
            f"--sample {s} ({len([n for n in names if values[n]['sample'] == s])} modules)"
            for s in samples) + "; python tools/mutation.py report",
        "measured_at": max(s["at"] for s in states),
        "machine": {"cpus": os.cpu_count(), "python": sys.version.split()[0],
                    "load_avg_before": next((s["load_avg_before"] for s in states
                                             if s["load_avg_before"] is not None), None),
                    "note": "2-core machine shared with other sessions; one mutant at a time"},
        "values": {"modules": values},
        "sections": {"summary": {"columns": ["module", "mutants", "killed", "timeout",
                                             "equivalent", "survived", "score"],
                                 "rows": rows, "note": note}},
    }


def show_ids(name: str) -> None:
    source = module_path(name).read_text(encoding="utf-8")
    order = ("survived", "error", "equivalent", "timeout", "killed")
    for w, v in sorted(judged(name), key=lambda p: order.index(p[1]) if p[1] in order else 9):
        if v in order:
            print(f"{v:10} line {w.mutations[0].start_pos[0]:4}  "
                  f"{mutant_id(source, w.mutations[0])}")


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    sub = ap.add_subparsers(dest="command", required=True)
    run = sub.add_parser("run", help="run the modules' sessions (resumed where they stopped)")
    run.add_argument("modules", nargs="*")
    run.add_argument("--sample", type=int, default=0, metavar="N",
                     help="N random mutants per module (0: all)")
    run.add_argument("--again", action="store_true", help="run the survivors again")
    sub.add_parser("report", help="write reports/mutation.json from the sessions")
    sub.add_parser("ids", help="each mutant's id and verdict").add_argument("module")
    args = ap.parse_args()
    config = load_config()
    if args.command == "ids":
        show_ids(args.module)
    elif args.command == "report":
        REPORT.write_text(json.dumps(report(config), indent=1, ensure_ascii=False) + "\n",
                          encoding="utf-8")
    else:
        unknown = set(args.modules) - set(config["modules"])
        if unknown:
            ap.error(f"not in tools/mutation.toml [modules]: {sorted(unknown)}")
        WORK.mkdir(exist_ok=True)
        copy_checkout(WORK / "src")
        failed = [n for n in args.modules or list(config["modules"])
                  if not run_module(n, config, args.sample, args.again)]
        return 1 if failed else 0
    return 0


if __name__ == "__main__":
    sys.exit(main())
