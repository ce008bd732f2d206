"""tools/mutation.toml against the code: every module of profiles/ and verify/ is mapped
to tests or excluded with a reason, every test it names exists, and every mutant it
calls equivalent still exists (ids are code, so a stale one is found here, not kept
silently). And the mutants' ids are code: lines moving leave them unchanged."""

from __future__ import annotations

import os
import re
import subprocess
import sys
from pathlib import Path

from tests.support.paths import ROOT

sys.path.insert(0, str(ROOT / "tools"))

import mutants
from mutation_config import equivalents, excluded, load_config, module_path, modules

CONFIG = load_config()


def package_modules() -> set[str]:
    names = set()
    for path in [*ROOT.glob("profiles/**/*.py"), *ROOT.glob("verify/**/*.py")]:
        name = ".".join(path.relative_to(ROOT).with_suffix("").parts)
        names.add(name.removesuffix(".__init__"))
    return names


def test_every_module_is_mapped_or_excluded_with_a_reason() -> None:
    mapped = {m.name for m in modules(CONFIG)}
    left_out = excluded(CONFIG)
    assert not mapped & set(left_out)
    assert mapped | set(left_out) == package_modules()
    assert all(why.strip() for why in left_out.values())


def test_every_mapped_test_exists() -> None:
    for m in modules(CONFIG):
        files = [t.split("::")[0] for t in m.tests if t.startswith("tests/")]
        assert files, m.name
        for f in files:
            assert (ROOT / f).is_file(), (m.name, f)


def test_every_equivalent_mutant_exists_and_says_why() -> None:
    ids: dict[str, set[str]] = {}
    for (name, mid), why in equivalents(CONFIG).items():
        if name not in ids:
            ids[name] = {s.id for s in mutants.sites(module_path(name).read_text())}
        assert mid in ids[name], f"{name}: no mutant {mid!r} (stale: the code changed)"
        assert len(why) > 20, (name, mid)


def test_ids_are_the_code_not_its_line() -> None:
    source = (ROOT / "profiles" / "motor" / "rotor.py").read_text()
    moved = source.replace("\nimport bisect\n", "\nimport bisect\n\n\ndef _new(x):\n"
                                                "    return x[-1] + 1 if x else max(x)\n", 1)
    before = [s.id for s in mutants.sites(source)]
    after = {s.id for s in mutants.sites(moved)}
    assert len(before) == len(set(before))
    assert set(before) <= after and len(after) > len(before)


def test_each_operator_makes_the_mutant_its_id_says() -> None:
    source = ("def f(a, fr, u, xs):\n"
              "    if not xs:\n"
              "        print(a)\n"
              "    return max(a + fr, xs[-1] * 2) if u > 0 and True else None\n")
    sites = mutants.sites(source)
    ret = "return max(a + fr, xs[-1] * 2) if u > 0 and True else None"
    expected = {
        "f: not xs → xs", "f: print(a) → None",
        f"f: {ret} → return max(a - fr, xs[-1] * 2) if u > 0 and True else None",
        f"f: {ret} → return max(a + fr, xs[+1] * 2) if u > 0 and True else None",
        f"f: {ret} → return max(a + fr, xs[-2] * 2) if u > 0 and True else None",
        f"f: {ret} → return max(a + fr, xs[-1] / 2) if u > 0 and True else None",
        f"f: {ret} → return min(a + fr, xs[-1] * 2) if u > 0 and True else None",
        f"f: {ret} → return max(a + fr, xs[-1] * 2) if u >= 0 and True else None",
        f"f: {ret} → return max(a + fr, xs[-1] * 2) if u > 1 and True else None",
        f"f: {ret} → return max(a + fr, xs[-1] * 2) if u > 0 or True else None",
        f"f: {ret} → return max(a + fr, xs[-1] * 2) if u > 0 and False else None",
    }
    assert expected <= {site.id for site in sites} and len(sites) == 15
    plain = mutants.mutant(source, -1)  # no site: the source unparsed
    for site in sites:
        changed = mutants.mutant(source, site.index)
        assert changed != plain
        assert site.after in changed or site.after == "None"
    catalogue = (ROOT / "profiles" / "motor" / "catalogue.py").read_text()
    for site in mutants.sites(catalogue):  # every mutant of a real module compiles
        compile(mutants.mutant(catalogue, site.index), "catalogue", "exec")


def test_a_mutant_replaces_its_module_in_the_processes_its_tests_start(tmp_path: Path) -> None:
    """A test that runs the CLI in a subprocess judges the mutant too (tools/mutant_finder:
    the environment names it, tools/mutant_site/sitecustomize.py installs it there); a
    process started without it imports the module as it is."""
    probe = ("import subprocess, sys\n"
             "child = 'import stepramp_probe; print(stepramp_probe.SAYS)'\n"
             "print(subprocess.run([sys.executable, '-c', child], capture_output=True, "
             "text=True).stdout.strip() or 'no such module')\n")
    # a module only the mutant's source defines stands in for a project module
    setup = ("import sys; sys.path.insert(0, {tools!r})\n"
             "from pathlib import Path\n"
             "import mutant_finder\n"
             "mutant_finder.install('stepramp_probe', Path({path!r}), 'SAYS = \"mutant\"', "
             "Path({file!r}))\n")
    env = {k: v for k, v in os.environ.items() if k not in ("PYTHONPATH", "STEPRAMP_MUTANT")}
    code = setup.format(tools=str(ROOT / "tools"), path=str(tmp_path / "stepramp_probe.py"),
                        file=str(tmp_path / "mutant.py")) + probe
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True,
                         env=env, timeout=60)
    assert out.returncode == 0, out.stderr
    assert out.stdout.strip() == "mutant"
    plain = subprocess.run([sys.executable, "-c", probe], capture_output=True, text=True,
                           env=env, timeout=60)
    assert plain.stdout.strip() == "no such module"


def test_a_mutants_run_turns_off_the_plugin_the_suite_loads() -> None:
    """tools/mutation_run.py blocks the repo-clean plugin by the name tests/conftest.py
    loads it under (a name that blocks nothing would fail every mutant's run whenever
    the checkout changes meanwhile)."""
    source = (ROOT / "tools" / "mutation_run.py").read_text(encoding="utf-8")
    blocked = [name.removeprefix("no:") for name in re.findall(r'"(no:[\w.]+)"', source)]
    conftest = (ROOT / "tests" / "conftest.py").read_text(encoding="utf-8")
    plugins = re.search(r"^pytest_plugins = \[(.*)\]$", conftest, re.M)
    assert plugins is not None
    assert "tests.support.repo_clean" in re.findall(r'"([\w.]+)"', plugins.group(1))
    assert "tests.support.repo_clean" in blocked


def test_mutmut_mutates_both_packages_and_selects_existing_tests() -> None:
    """pyproject.toml's [tool.mutmut] (the maintained tool replacing tools/mutation.py):
    it mutates profiles/ and verify/ whole, its test selection names folders that exist,
    slow tests and the repo-clean check stay out of a mutant's run, and its working copy
    (mutants/) is git-ignored, never committed."""
    import tomllib

    config = tomllib.loads((ROOT / "pyproject.toml").read_text(encoding="utf-8"))
    mutmut = config["tool"]["mutmut"]
    assert sorted(mutmut["source_paths"]) == ["profiles", "verify"]
    for selected in mutmut["pytest_add_cli_args_test_selection"]:
        assert (ROOT / selected).exists(), selected
    args = mutmut["pytest_add_cli_args"]
    assert args[args.index("-m") + 1] == "not slow"
    assert "no:tests.support.repo_clean" in args
    assert any(d.startswith("mutmut") for d in config["project"]["optional-dependencies"]["dev"])
    r = subprocess.run(["git", "check-ignore", "-q", "mutants/profiles/x.py"], cwd=ROOT)
    assert r.returncode == 0, "mutants/ is not git-ignored"
