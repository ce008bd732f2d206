"""One module's mutants, each in a forked child that imports it in place of the module.

The worker imports the heavy libraries once (numpy, numba, scipy, hypothesis, pytest),
never the project's modules: each child imports them fresh, the mutant among them.
Numba's on-disk cache is sent to a temporary folder for the run (a mutated kernel must
never find, nor leave, a compiled copy beside the sources).
"""

from __future__ import annotations

import ast
import json
import os
import random
import shutil
import signal
import sys
import tempfile
import time
from pathlib import Path
from typing import Any

import mutants
from mutant_finder import install
from mutation_config import ROOT, Module, log_path, read_log, source_hash

BASELINE_LIMIT_S = 900.0
MIN_TIMEOUT_S = 120.0
# a mutant may take 6× the unmutated run before it counts as a hang: the machine is shared,
# and a survivor runs every test (a tight limit would count slow survivors as killed)
TIMEOUT_FACTOR = 6.0


class _FastFirst:
    """The quickest tests first (by their time in the unmutated run, which records it;
    with -x most mutants then die in a cheap test); hypothesis derandomised, no
    database, and no shrinking: a mutant needs only *a* failing example, and shrinking
    one can take longer than every other test together. The profile is registered after
    the suite's conftest loaded its own."""

    def __init__(self, durations: dict[str, float], record: Path | None) -> None:
        self.durations, self.record = durations, record
        self.seen: dict[str, float] = {}

    def pytest_configure(self, config: object) -> None:
        from hypothesis import Phase, settings

        settings.register_profile("mutation", settings.default, derandomize=True,
                                  database=None, deadline=None,
                                  phases=(Phase.explicit, Phase.reuse, Phase.generate))
        settings.load_profile("mutation")

    def pytest_collection_modifyitems(self, items: list[Any]) -> None:
        def key(item: Any) -> tuple[float, bool]:
            hyp = bool(getattr(getattr(item, "obj", None), "is_hypothesis_test", False))
            return (self.durations.get(item.nodeid, 1e9 if hyp else 1e6), hyp)
        items.sort(key=key)

    def pytest_runtest_logreport(self, report: Any) -> None:
        self.seen[report.nodeid] = self.seen.get(report.nodeid, 0.0) + report.duration

    def pytest_sessionfinish(self) -> None:
        if self.record is not None:
            self.record.write_text(json.dumps(self.seen))


def _run_child(name: str, path: Path, source: str, tests: list[str], plugin: _FastFirst,
               own_cache: str | None, scratch: Path) -> int:
    import pytest

    if own_cache is not None:
        # numba keys its on-disk cache by the module's file, which a mutant shares with
        # the source: every mutant of a compiled module would load the first one's code
        from numba.core import config

        os.environ["NUMBA_CACHE_DIR"] = own_cache
        config.reload_config()
    # the mutant here and in every Python process a test starts (a CLI subprocess)
    install(name, path, source, scratch / "mutant.py")
    devnull = os.open(os.devnull, os.O_WRONLY)
    os.dup2(devnull, 1)
    os.dup2(devnull, 2)
    # no:tests.support.repo_clean: the suite's check that a session leaves the checkout
    # unchanged would fail a mutant's run whenever the checkout changes meanwhile (a log,
    # an edit)
    return int(pytest.main(["-x", "-q", "-m", "not slow", "-p", "no:cacheprovider",
                            "-p", "no:tests.support.repo_clean",
                            "--no-header", "-o", "addopts=", *tests], plugins=[plugin]))


def run_one(name: str, path: Path, source: str, tests: list[str], timeout_s: float,
            plugin: _FastFirst | None = None) -> str:
    """'killed', 'survived' or 'timeout' for one source of the module. A module with
    cached compiled functions gets a numba cache of its own for each source."""
    own_cache = (tempfile.mkdtemp(prefix="stepramp-mutant-numba-")
                 if "cache=True" in source else None)
    scratch = Path(tempfile.mkdtemp(prefix="stepramp-mutant-"))
    pid = os.fork()
    if pid == 0:  # child
        code = 3
        try:
            os.setpgid(0, 0)  # with the processes its tests start: a timeout kills them all
            code = _run_child(name, path, source, tests, plugin or _FastFirst({}, None),
                              own_cache, scratch)
        finally:
            os._exit(code)
    deadline = time.monotonic() + timeout_s
    try:
        while True:
            done, status = os.waitpid(pid, os.WNOHANG)
            if done:
                return "survived" if os.waitstatus_to_exitcode(status) == 0 else "killed"
            if time.monotonic() > deadline:
                os.killpg(pid, signal.SIGKILL)
                os.waitpid(pid, 0)
                return "timeout"
            time.sleep(0.02)
    finally:
        shutil.rmtree(scratch, ignore_errors=True)
        if own_cache is not None:
            shutil.rmtree(own_cache, ignore_errors=True)


def _prepare() -> None:
    """Heavy imports once, before forking; not the project's modules."""
    os.environ.setdefault("CI", "true")
    os.environ["NUMBA_CACHE_DIR"] = tempfile.mkdtemp(prefix="stepramp-mutation-numba-")
    os.environ.setdefault("MPLBACKEND", "Agg")
    os.chdir(ROOT)
    sys.path.insert(0, str(ROOT))
    import hypothesis  # noqa: F401
    import matplotlib  # noqa: F401
    import numba  # noqa: F401
    import numpy  # noqa: F401
    import pytest  # noqa: F401
    import scipy  # noqa: F401


def _todo(m: Module, digest: str, resume: bool, again: set[str]) -> set[str] | None:
    """The mutant ids to skip (already judged) or, with `again`, the only ones to run
    (those whose last verdict is in it); None: all."""
    last = {str(e["id"]): str(e["verdict"]) for e in read_log(m.name) if e["sha"] == digest}
    if again:
        return {i for i, v in last.items() if v in again}
    return set(last) if resume else None


def sample_order(m: Module, sites: list[mutants.Site]) -> list[mutants.Site]:
    """The module's mutants in a fixed random order (seeded by its name): a sample of N
    is the first N, and a larger one extends it."""
    order = list(sites)
    random.Random(m.name).shuffle(order)
    return order


def worker(m: Module, resume: bool, again: set[str], sample: int = 0) -> int:
    _prepare()
    source = m.path.read_text()
    digest = source_hash(source)
    sites = mutants.sites(source)
    if sample:  # a random sample: its first `sample` mutants, those already judged kept
        sites = sample_order(m, sites)[:sample]
    chosen = _todo(m, digest, resume or bool(sample), again)
    wanted = [s for s in sites if chosen is None
              or (s.id in chosen if again else s.id not in chosen)]
    log = log_path(m.name)
    if not wanted:
        return 0
    t0 = time.monotonic()
    record = Path(os.environ["NUMBA_CACHE_DIR"]) / "durations.json"
    base = run_one(m.name, m.path, ast.unparse(ast.parse(source)), m.tests, BASELINE_LIMIT_S,
                   _FastFirst({}, record))
    base_s = time.monotonic() - t0
    durations = json.loads(record.read_text()) if record.exists() else {}
    if base != "survived":
        print(f"{m.name}: the tests fail on the unmutated module ({base})", file=sys.stderr)
        with log.open("a") as f:
            f.write(json.dumps({"id": "<baseline>", "verdict": base, "sha": digest}) + "\n")
        return 1
    with log.open("a") as f:  # the unmutated run passed (a later failure is logged too)
        f.write(json.dumps({"id": "<baseline>", "verdict": base, "sha": digest,
                            "s": round(base_s, 2), "at": round(time.time())}) + "\n")
    timeout_s = max(MIN_TIMEOUT_S, TIMEOUT_FACTOR * base_s)
    print(f"{m.name}: {len(wanted)} mutants, baseline {base_s:.1f} s", file=sys.stderr,
          flush=True)
    for site in wanted:
        t1 = time.monotonic()
        verdict = run_one(m.name, m.path, mutants.mutant(source, site.index), m.tests,
                          timeout_s, _FastFirst(durations, None))
        entry = {"id": site.id, "verdict": verdict, "sha": digest, "line": site.line,
                 "s": round(time.monotonic() - t1, 2), "at": round(time.time())}
        with log.open("a") as f:
            f.write(json.dumps(entry, ensure_ascii=False) + "\n")
    return 0
