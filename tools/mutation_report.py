"""bench/results/mutation.json (the shared results format) and bench/results/mutation.md
from the verdict logs of tools/mutation.py: nothing is run here.

Each module's mutants are those of its current source; a mutant's verdict is its last
logged one for that source. A module with no verdict for its current source is listed
as not run (so is one whose unmutated tests failed).
"""

from __future__ import annotations

import datetime
import json
import os
import platform
from collections import Counter
from typing import Any

import mutants
from mutation_config import (
    ROOT,
    equivalents,
    excluded,
    modules,
    read_log,
    source_hash,
)

RESULTS = ROOT / "bench" / "results"


def module_result(name: str, path: Any, equivalent: dict[tuple[str, str], str]
                  ) -> dict[str, Any]:
    source = path.read_text()
    digest = source_hash(source)
    last: dict[str, str] = {}
    seconds = 0.0
    for e in read_log(name):
        if e["sha"] == digest:
            last[str(e["id"])] = str(e["verdict"])
            seconds += float(e.get("s", 0.0))  # type: ignore[arg-type]
    sites = mutants.sites(source)
    if last.get("<baseline>", "survived") != "survived":  # the tests failed unmutated
        return {"mutants": len(sites), "run": 0, "baseline": last["<baseline>"]}
    counts: Counter[str] = Counter()
    survivors: list[dict[str, Any]] = []
    for s in sites:
        verdict = last.get(s.id, "not run")
        if verdict == "survived" and (name, s.id) in equivalent:
            verdict = "equivalent"
        counts[verdict] += 1
        if verdict == "survived":
            survivors.append({"id": s.id, "line": s.line})
    run = len(sites) - counts["not run"]
    scored = run - counts["equivalent"]
    killed = counts["killed"] + counts["timeout"]
    return {"mutants": len(sites), "run": run, "killed": counts["killed"],
            "timeout": counts["timeout"], "equivalent": counts["equivalent"],
            "survived": counts["survived"], "not_run": counts["not run"],
            "score": round(killed / scored, 4) if scored else None,
            "seconds": round(seconds), "survivors": survivors}


def _row(name: str, r: dict[str, Any]) -> list[str]:
    if r["mutants"] == 0:
        return [name, "0", "", "", "", "", "no mutants"]
    if "baseline" in r:
        return [name, str(r["mutants"]), "", "", "", "", "not run: its tests fail unmutated"]
    if r.get("run", 0) == 0:
        return [name, str(r["mutants"]), "", "", "", "", "not run"]
    score = "" if r["score"] is None else f"{100 * r['score']:.1f} %"
    partial = f" ({r['not_run']} not run)" if r["not_run"] else ""
    return [name, f"{r['mutants']}{partial}", str(r["killed"]), str(r["timeout"]),
            str(r["equivalent"]), str(r["survived"]), score]


def _totals(results: dict[str, dict[str, Any]]) -> dict[str, Any]:
    keys = ("mutants", "run", "killed", "timeout", "equivalent", "survived", "seconds")
    total: dict[str, Any] = {k: sum(int(r.get(k, 0)) for r in results.values()) for k in keys}
    scored = total["run"] - total["equivalent"]
    total["score"] = round((total["killed"] + total["timeout"]) / scored, 4) if scored else None
    return total


def write(config: dict[str, Any], command: str) -> None:
    equivalent = equivalents(config)
    results = {m.name: module_result(m.name, m.path, equivalent) for m in modules(config)}
    not_run = [n for n, r in results.items() if r.get("run", 0) == 0 and r["mutants"]]
    partial = [n for n, r in results.items() if r.get("not_run")
               and n not in not_run]
    total = _totals(results)
    doc = {
        "name": "mutation", "command": command,
        "measured_at": datetime.date.today().isoformat(),
        "machine": {"cpus": os.cpu_count(), "python": platform.python_version(),
                    "load_avg_before": round(os.getloadavg()[0], 2),
                    "note": "shared 2-core machine; verdicts logged per mutant in "
                            "bench/results/mutation/*.jsonl"},
        "values": {"modules": results, "total": total, "not_run": not_run,
                   "partial": partial, "excluded": excluded(config),
                   "equivalent_listed": len(equivalent)},
        "sections": {"per-module": {
            "columns": COLUMNS,
            "rows": [_row(n, r) for n, r in results.items()],
            "note": _note(total, not_run, partial, excluded(config))},
            "summary": _summary_section(results, total)},
    }
    (RESULTS / "mutation.json").write_text(json.dumps(doc, indent=1, ensure_ascii=False) + "\n")
    (RESULTS / "mutation.md").write_text(_summary(doc, equivalent))


COLUMNS = ["module", "mutants", "killed", "timeout", "equivalent", "survived", "score"]
# the load-angle model: every safety verdict rests on it (shown module by module)
MODEL = ("profiles.motor.rotor", "profiles.motor.rotor_kernel", "profiles.ppmc312.load_angle")


def _summary_section(results: dict[str, dict[str, Any]], total: dict[str, Any]
                     ) -> dict[str, Any]:
    """The README's table: the load-angle model's modules, the rest together, the total."""
    rest = {n: r for n, r in results.items() if n not in MODEL}
    others = _totals(rest)
    others["not_run"] = others["mutants"] - others["run"]
    rows = [_row(n, results[n]) for n in MODEL if n in results]
    rows.append(_row(f"{len(rest)} other modules", others))
    total = {**total, "not_run": total["mutants"] - total["run"]}
    rows.append(_row("**all**", total))
    return {"columns": COLUMNS, "rows": rows,
            "note": "Score = (killed + timeout) / (run − equivalent); a module with mutants "
                    "not run is scored over those run (a random sample, tools/mutation.py "
                    "--sample). Every module, its survivors and the equivalent mutants with "
                    "their reasons: bench/results/mutation.md."}


def _note(total: dict[str, Any], not_run: list[str], partial: list[str],
          excluded_: dict[str, str]) -> str:
    score = "" if total["score"] is None else f"{100 * total['score']:.1f} %"
    parts = [f"{total['run']} of {total['mutants']} mutants run, score {score} "
             "(killed + timeout) / (run − equivalent), "
             f"{total['seconds'] / 3600:.1f} h of mutant runs on the shared 2-core machine"]
    if not_run:
        parts.append(f"not run: {len(not_run)} module(s)")
    if partial:
        parts.append(f"sampled (each score over the mutants run): {len(partial)} module(s)")
    parts.append(f"excluded: {', '.join(excluded_)}")
    return "; ".join(parts) + "."


def _summary(doc: dict[str, Any], equivalent: dict[tuple[str, str], str]) -> str:
    v = doc["values"]
    sec = doc["sections"]["per-module"]
    lines = ["# Mutation run", "", f"`{doc['command']}` ({doc['measured_at']}). "
             "Written by tools/mutation.py from bench/results/mutation/*.jsonl.", "",
             "| " + " | ".join(sec["columns"]) + " |",
             "|" + "---|" * len(sec["columns"])]
    lines += ["| " + " | ".join(row) + " |" for row in sec["rows"]]
    lines += ["", sec["note"], "", "## Excluded", ""]
    lines += [f"- {name}: {why}" for name, why in v["excluded"].items()]
    lines += ["", "## Survivors", ""]
    for name, r in v["modules"].items():
        for s in r.get("survivors", []):
            lines.append(f"- {name} (line {s['line']}): `{s['id']}`")
    lines += ["", "## Equivalent mutants (tools/mutation.toml)", ""]
    lines += [f"- {name}: `{mid}`: {why}" for (name, mid), why in equivalent.items()]
    return "\n".join(lines) + "\n"
