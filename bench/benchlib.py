"""What every bench shares: its results file, the machine it ran on, timers, goal rows.

Each bench writes `bench/results/<name>.json` (the format every bench and tool keeps):

    {"name", "command", "measured_at", "machine": {"cpus", "python", "load_avg_before",
     "load_avg_after", "note"}, "values": {raw numbers}, "sections": {id: {"columns",
     "rows", "note"}}}

`values` holds what was measured (tests and the README generator compute from it),
`sections` the ready-to-print tables derived from `values` by the same script;
`python bench/readme.py` puts sections into the README between
`<!-- bench:<name>:<section> -->` and `<!-- /bench -->`. Files are written whole or
not at all (a bench that stops half-way leaves the last complete results in place).
"""

from __future__ import annotations

import datetime as dt
import json
import math
import os
import platform
import statistics
import sys
import tempfile
import time
from collections.abc import Callable, Sequence
from pathlib import Path
from typing import Any

ROOT = Path(__file__).resolve().parent.parent
RESULTS = ROOT / "bench" / "results"
NOTE = "2-core VM shared with other sessions: load averages before and after the run"


class Results:
    """One bench run's results: values and sections, written by `write`."""

    def __init__(self, name: str, note: str = NOTE, folder: str = "bench") -> None:
        self.name = name
        self.note = note
        self.command = " ".join(["python", f"{folder}/{Path(sys.argv[0]).name}", *sys.argv[1:]])
        self.load_before = os.getloadavg()[0]
        self.values: dict[str, Any] = {}
        self.sections: dict[str, dict[str, Any]] = {}

    def section(self, section_id: str, columns: Sequence[str], rows: Sequence[Sequence[Any]],
                note: str | None = None, *, echo: bool = True) -> None:
        """A table for the README (every cell a string); printed too unless `echo` is
        False."""
        cells = [[str(c) for c in row] for row in rows]
        for row in cells:
            if len(row) != len(columns):
                raise ValueError(f"section {section_id}: row {row} has {len(row)} cells, "
                                 f"{len(columns)} columns")
        self.sections[section_id] = {"columns": list(columns), "rows": cells}
        if note:
            self.sections[section_id]["note"] = note
        if echo:
            print(f"\n[{self.name}:{section_id}]")
            print(markdown_table(list(columns), cells) + (f"\n{note}" if note else ""),
                  flush=True)

    def document(self) -> dict[str, Any]:
        return {"name": self.name, "command": self.command,
                "measured_at": dt.datetime.now(dt.UTC).isoformat(timespec="seconds"),
                "machine": {"cpus": os.cpu_count(), "python": platform.python_version(),
                            "load_avg_before": round(self.load_before, 2),
                            "load_avg_after": round(os.getloadavg()[0], 2), "note": self.note},
                "values": finite(self.values), "sections": self.sections}

    def write(self, folder: Path = RESULTS) -> Path:
        """bench/results/<name>.json, whole or not at all."""
        folder.mkdir(parents=True, exist_ok=True)
        path = folder / f"{self.name}.json"
        text = json.dumps(self.document(), indent=1, ensure_ascii=False, allow_nan=False)
        fd, tmp = tempfile.mkstemp(dir=folder, prefix=f".{self.name}.", suffix=".tmp")
        with os.fdopen(fd, "w", encoding="utf-8") as f:
            f.write(text + "\n")
        os.replace(tmp, path)
        print(f"\nwrote {path.relative_to(ROOT) if path.is_relative_to(ROOT) else path}")
        return path


def finite(value: Any) -> Any:
    """`value` with every non-finite float as None (JSON has no NaN or infinity) and every
    float rounded to 6 significant digits (the results are measurements, not bits)."""
    if isinstance(value, dict):
        return {str(k): finite(v) for k, v in value.items()}
    if isinstance(value, list | tuple):
        return [finite(v) for v in value]
    if hasattr(value, "item") and not isinstance(value, list | dict):  # numpy scalars
        value = value.item()
    if isinstance(value, float):
        return float(f"{value:.6g}") if math.isfinite(value) else None
    return value


def markdown_table(columns: Sequence[str], rows: Sequence[Sequence[str]]) -> str:
    """A GitHub table; a `|` inside a cell is escaped."""
    def line(cells: Sequence[str]) -> str:
        return "| " + " | ".join(c.replace("|", "\\|") for c in cells) + " |"

    return "\n".join([line(columns), "|" + "---|" * len(columns), *(line(r) for r in rows)])


def forget() -> None:
    """Forget what the library remembers between calls (each table's move model, the
    verdicts judged, moves', decel stops' and the A-Link ramps', the plans planned), so a
    repeated call costs what a first one does."""
    from profiles.ppmc312.load_angle import forget_verdicts
    from profiles.ppmc312.move_batch import forget_tables
    from profiles.ppmc312.planner.free_curve import forget_plans
    from profiles.ppmc312.stops import forget_stop_verdicts
    from verify.alink_safety import forget_ramp_verdicts

    forget_ramp_verdicts()
    forget_tables()
    forget_verdicts()
    forget_stop_verdicts()
    forget_plans()


def timed(fn: Callable[[], Any], repeats: int) -> tuple[float, float, Any]:
    """(median wall s, median process CPU s, last result) over `repeats` calls, each as
    if it were the first (`forget`)."""
    walls, cpus, out = [], [], None
    for _ in range(repeats):
        forget()
        w0, c0 = time.perf_counter(), time.process_time()
        out = fn()
        cpus.append(time.process_time() - c0)
        walls.append(time.perf_counter() - w0)
    return statistics.median(walls), statistics.median(cpus), out


def gmean(xs: Sequence[float]) -> float:
    return math.exp(sum(math.log(x) for x in xs) / len(xs))


def verdict(ok: bool) -> str:
    return "met" if ok else "**missed**"


def count(x: float) -> str:
    """A large number with thin groups: 40 900."""
    return f"{x:,.0f}".replace(",", " ")


# As installed: pip compiles the bytecode once; this environment may forbid writing it
INSTALLED = {k: v for k, v in os.environ.items() if k != "PYTHONDONTWRITEBYTECODE"}


def fresh_processes(cmd: Sequence[str], repeats: int, env: dict[str, str] | None = None,
                    warm: bool = True) -> tuple[float, float]:
    """Median wall and CPU (user + system) seconds of `repeats` fresh processes running
    `cmd` in the repository (after one untimed run that writes the bytecode and the
    compiled kernels' cache, unless not `warm`); each must exit 0 or 1."""
    import subprocess

    env = INSTALLED if env is None else env
    if warm:
        subprocess.run(list(cmd), check=False, capture_output=True, cwd=ROOT, env=env)
    walls, cpus = [], []
    for _ in range(repeats):
        t0 = time.perf_counter()
        proc = subprocess.Popen(list(cmd), cwd=ROOT, env=env, stdout=subprocess.DEVNULL,
                                stderr=subprocess.DEVNULL)
        _, status, usage = os.wait4(proc.pid, 0)
        walls.append(time.perf_counter() - t0)
        cpus.append(usage.ru_utime + usage.ru_stime)
        if os.waitstatus_to_exitcode(status) not in (0, 1):
            raise SystemExit(f"{' '.join(cmd)}: exit {os.waitstatus_to_exitcode(status)}")
    return statistics.median(walls), statistics.median(cpus)
