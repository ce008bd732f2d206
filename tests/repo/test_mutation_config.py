"""tools/mutation.toml against the code, and tools/mutation.py's filters: every module
of profiles/ and verify/ is mapped to tests or excluded with a reason, every test it names
exists, every mutant it calls equivalent still exists (ids are code, so a stale one is
found here, not kept silently) and is marked skipped with its reason; a mutant in an
annotation is none; a sample is fixed and a larger one extends it. The report's rows (the
README's block) are its modules'."""

from __future__ import annotations

import json
import re
import subprocess
from pathlib import Path
from types import ModuleType

from cosmic_ray.commands import init
from cosmic_ray.work_db import WorkDB, use_db
from cosmic_ray.work_item import TestOutcome as Outcome
from cosmic_ray.work_item import WorkerOutcome, WorkResult

from tests.support.paths import ROOT, load_script


def load_tool() -> ModuleType:
    return load_script(ROOT / "tools" / "mutation.py", "stepramp_mutation")


tool = load_tool()
CONFIG = tool.load_config()


def package_modules() -> set[str]:
    names = set()
    for path in [*ROOT.glob("profiles/**/*.py"), *ROOT.glob("verify/**/*.py")]:
        name = ".".join(path.relative_to(ROOT).with_suffix("").parts)
        names.add(name.removesuffix(".__init__"))
    return names


def test_every_module_is_mapped_or_excluded_with_a_reason() -> None:
    mapped, left_out = set(CONFIG["modules"]), CONFIG["excluded"]
    assert not mapped & set(left_out)
    assert mapped | set(left_out) == package_modules()
    assert all(why.strip() for why in left_out.values())


def test_every_mapped_test_exists() -> None:
    for name, tests in CONFIG["modules"].items():
        files = [t.split("::")[0] for t in tests if t.startswith("tests/")]
        assert files, name
        for f in files:
            assert (ROOT / f).is_file(), (name, f)


def test_the_load_angle_kernels_run_as_plain_python() -> None:
    assert set(CONFIG["env"]) <= set(CONFIG["modules"])
    assert CONFIG["env"]["profiles.motor.rotor_kernel"] == {"NUMBA_DISABLE_JIT": "1"}
    assert set(tool.LOAD_ANGLE) <= set(CONFIG["modules"])


def test_every_equivalent_mutant_exists_and_says_why() -> None:
    assert set(CONFIG["equivalent"]) <= set(CONFIG["modules"])
    for name, listed in CONFIG["equivalent"].items():
        source = tool.module_path(name).read_text(encoding="utf-8")
        firsts = {mid.split(": ", 1)[1].split(" → ")[0].split(" / ")[0] for mid in listed}
        lines = {i for i, line in enumerate(source.splitlines(), 1) if line.strip() in firsts}
        ids = tool.mutant_ids_at(source, lines)
        for mid, why in listed.items():
            assert mid in ids, f"{name}: no mutant {mid!r} (stale: the code changed)"
            assert len(why) > 20, (name, mid)


SOURCE = ("def f(a, b):\n"
          "    if a < b:\n"
          "        return a + 1\n"
          "    return b\n")


def session(folder: Path, source: str = SOURCE) -> tuple[Path, Path]:
    """A cosmic-ray session of a module `m` holding `source`, in `folder`."""
    folder.mkdir(exist_ok=True)
    module = folder / "m.py"
    module.write_text(source, encoding="utf-8")
    db_path = folder / "m.sqlite"
    with use_db(str(db_path)) as db:
        init([module], db, {})
    return module, db_path


def ids_by_job(db: WorkDB, source: str) -> dict[str, str]:
    return {w.job_id: tool.mutant_id(source, w.mutations[0]) for w in db.work_items}


def test_ids_are_the_code_not_its_line(tmp_path: Path) -> None:
    _, db_path = session(tmp_path)
    moved = "import os\n\n\n" + SOURCE
    _, moved_db = session(tmp_path / "moved", moved)
    with use_db(str(db_path)) as db, use_db(str(moved_db)) as other:
        before, after = ids_by_job(db, SOURCE), ids_by_job(other, moved)
    assert "f: if a < b: → if a <= b:" in before.values()
    assert "f: return a + 1 → return a - 1" in before.values()
    assert set(before.values()) == set(after.values())


def test_the_equivalents_filter_marks_them_skipped_with_their_reason(tmp_path: Path) -> None:
    _, db_path = session(tmp_path)
    why = "a reason long enough to be one"
    with use_db(str(db_path)) as db:
        ids = ids_by_job(db, SOURCE)
        [job] = [j for j, i in ids.items() if i == "f: if a < b: → if a <= b:"]
        [survivor] = [j for j, i in ids.items() if i == "f: return a + 1 → return a - 1"]
        db.set_result(survivor, WorkResult(WorkerOutcome.NORMAL,
                                           test_outcome=Outcome.SURVIVED))
        known = {("m", "f: if a < b: → if a <= b:"): why,
                 ("m", "f: return a + 1 → return a - 1"): why}
        tool.equivalent_filter(db, db_path, "m", SOURCE, known)
        results = dict(db.results)
        assert {j: r.output for j, r in results.items()} == \
            {job: "equivalent: " + why, survivor: "equivalent: " + why}
        assert all(r.worker_outcome == WorkerOutcome.SKIPPED for r in results.values())
        assert tool.verdict(results[job]) == "equivalent"
        tool.equivalent_filter(db, db_path, "m", SOURCE, {})  # no longer listed: run again
        assert dict(db.results) == {}


def test_a_mutant_in_an_annotation_is_none(tmp_path: Path) -> None:
    """Annotations are never evaluated (`from __future__ import annotations`): a mutant
    there is skipped and not counted; a default value's is kept, and so is every mutant of
    a module that evaluates its annotations."""
    line = "def f(a: int | None, b: int = 1 | 2) -> int | None:"
    body = f"{line}\n    x: int | None = a\n    return x\n"
    default = (4, line.index("1 | 2") + 2)  # the `|` of the default value
    for future in (True, False):
        text = ("from __future__ import annotations\n\n\n" if future else "\n\n\n") + body
        _, db_path = session(tmp_path / str(future), text)
        with use_db(str(db_path)) as db:
            tool.annotation_filter(db, text)
            done = dict(db.results)
            skipped = {w.mutations[0].start_pos for w in db.work_items if w.job_id in done}
            kept = {w.mutations[0].start_pos for w in db.work_items if w.job_id not in done}
            assert {tool.verdict(r) for r in done.values()} <= {"filtered"}
        assert default in kept
        if future:
            assert skipped == {(4, line.index("|")), (4, line.rindex("|"))}
        else:
            assert not skipped


def test_a_sample_is_fixed_and_a_larger_one_extends_it(tmp_path: Path) -> None:
    _, db_path = session(tmp_path)
    _, again = session(tmp_path / "again")

    def sampled(path: Path, n: int) -> set[str]:
        with use_db(str(path)) as db:
            tool.sample_filter(db, path, "m", n, [])
            ids = ids_by_job(db, SOURCE)
            return {ids[w.job_id] for w in db.pending_work_items}

    three = sampled(db_path, 3)
    assert len(three) == 3 and sampled(again, 3) == three
    five = sampled(db_path, 5)
    assert len(five) == 5 and three <= five
    with use_db(str(db_path)) as db:
        assert {r.output for _, r in db.results} == {tool.NOT_SAMPLED}


def test_a_mutants_run_turns_off_the_plugin_the_suite_loads() -> None:
    """A mutant's tests run without the repo-clean check (it would fail every run: the
    mutant is in the copy's file), blocked by the name tests/conftest.py loads it under."""
    command = tool.test_command(["tests/x.py"])
    blocked = [command[i + 1].removeprefix("no:") for i, a in enumerate(command) if a == "-p"]
    conftest = (ROOT / "tests" / "conftest.py").read_text(encoding="utf-8")
    plugins = re.search(r"^pytest_plugins = \[(.*)\]$", conftest, re.M)
    assert plugins is not None
    assert "tests.support.repo_clean" in re.findall(r'"([\w.]+)"', plugins.group(1))
    assert "tests.support.repo_clean" in blocked
    assert command[len(command) - 1 - command[::-1].index("-m") + 1] == "not slow"


def test_cosmic_ray_is_a_dev_dependency_and_the_runs_are_git_ignored() -> None:
    import tomllib

    config = tomllib.loads((ROOT / "pyproject.toml").read_text(encoding="utf-8"))
    assert any(d.startswith("cosmic-ray") for d in
               config["project"]["optional-dependencies"]["dev"])
    r = subprocess.run(["git", "check-ignore", "-q", ".mutation/profiles.axes.sqlite"],
                       cwd=ROOT)
    assert r.returncode == 0, ".mutation/ is not git-ignored"


def test_the_reports_rows_are_its_modules() -> None:
    """reports/mutation.json's summary (the README's block, bench/readme.py) adds up its
    modules' counts."""
    doc = json.loads(tool.REPORT.read_text(encoding="utf-8"))
    modules = doc["values"]["modules"]
    assert set(modules) <= set(CONFIG["modules"])
    rows = doc["sections"]["summary"]["rows"]
    assert rows[-1] == tool.row("**all**", list(modules.values()))
    for r in rows[:-2]:
        assert r == tool.row(r[0], [modules[r[0]]])
    for m in modules.values():
        assert m["survived"] == len(m["survivors"])
        assert m["equivalent"] == len(m["equivalent_mutants"])
        assert all(e["why"] != "(no longer listed)" for e in m["equivalent_mutants"])
