"""The README's "Use in CI" snippets, exercised: the pre-commit hook and the GitHub Actions job.

The snippets are parsed out of README.md itself (the fenced ```yaml blocks under
`## Use in CI`), so the README and this test cannot drift apart.

- pre-commit (slow: pre-commit builds the hook's environment by pip-installing
  this repository at its HEAD commit): a temporary git repository with a good and
  a bad table; the README's config, pointed at this repository, fails naming the
  bad table and its chip code, and passes once the bad table is gone. The
  README's `files:` override is run the same way.
- GitHub Actions: the job's `stepramp check` step, run by bash exactly as
  written (with `stepramp` standing for `python -m verify.cli` from this
  checkout) in a directory holding the tables: exit 1 and a JUnit <failure> for
  the bad table, exit 0 without it.
"""

from __future__ import annotations

import os
import re
import shutil
import subprocess
import sys
import tempfile
import xml.etree.ElementTree as ET
from collections.abc import Iterator
from pathlib import Path
from typing import Any

import pytest
import yaml

from tests.support.paths import ROOT
from tests.support.subprocess_env import checkout_env

README = ROOT / "README.md"


GOOD = ROOT / "examples" / "free-curve-nema17.json"


BAD = ROOT / "examples" / "free-curve-bad.json"


HOOK_ID = "stepramp-check"


PRE_COMMIT_TIMEOUT_S = 1200  # the first run pip-installs numpy, toppra, casadi, …


def ci_section() -> str:
    text = README.read_text(encoding="utf-8")
    match = re.search(r"^## Use in CI\n(.*?)(?=^## |\Z)", text, re.S | re.M)
    assert match, "README.md has no '## Use in CI' section"
    return match.group(1)


def yaml_blocks() -> list[str]:
    return re.findall(r"^```ya?ml\n(.*?)^```", ci_section(), re.S | re.M)


def pre_commit_configs() -> list[dict[str, Any]]:
    """The README's .pre-commit-config.yaml snippets, in order (the first is the plain one)."""
    out = [yaml.safe_load(b) for b in yaml_blocks()]
    return [c for c in out if isinstance(c, dict) and "repos" in c]


def workflow_text() -> str:
    found = [b for b in yaml_blocks() if "jobs" in (yaml.safe_load(b) or {})]
    assert len(found) == 1, f"expected one GitHub Actions job in README, found {len(found)}"
    return found[0]


def check_scripts(workflow: dict[str, Any]) -> list[str]:
    """The `run:` scripts of the steps that call `stepramp check`, in job order."""
    out = []
    for job in workflow["jobs"].values():
        for step in job["steps"]:
            run = step.get("run", "")
            if re.search(r"\bstepramp check\b", run):
                out.append(run)
    return out


def test_readme_section_has_both_snippets() -> None:
    configs = pre_commit_configs()
    assert configs, "no .pre-commit-config.yaml snippet under '## Use in CI'"
    for config in configs:
        [repo] = config["repos"]
        assert repo["repo"] == "https://github.com/stepramp/stepramp"
        assert isinstance(repo["rev"], str) and repo["rev"]
        assert [h["id"] for h in repo["hooks"]] == [HOOK_ID]
    assert check_scripts(yaml.safe_load(workflow_text())), "no step runs `stepramp check`"


def test_hook_definition() -> None:
    hooks = yaml.safe_load((ROOT / ".pre-commit-hooks.yaml").read_text(encoding="utf-8"))
    [hook] = [h for h in hooks if h["id"] == HOOK_ID]
    assert hook["language"] == "python"
    assert hook["entry"] == "stepramp check"
    pyproject = (ROOT / "pyproject.toml").read_text(encoding="utf-8")
    assert re.search(r'^stepramp = "verify\.cli:main"$', pyproject, re.M), \
        "the hook's entry needs the `stepramp` console script"
    files = re.compile(hook["files"])
    for selected in ("good.table.json", "fw/ramps/x.table.json", "out/x.upload.hex",
                     "x.upload.bin", "x.upload.ihex", "x.upload.json", "x.upload.h",
                     "x.upload.bus"):
        assert files.search(selected), selected
    for ignored in ("package.json", "x.table.json.bak", "x.upload.c", ".table.json",
                    "motor-nema17.json", "x.upload.hex.orig"):
        assert not files.search(ignored), ignored


def test_override_example_selects_its_files() -> None:
    overrides = [c["repos"][0]["hooks"][0] for c in pre_commit_configs()
                 if "files" in c["repos"][0]["hooks"][0]]
    assert overrides, "README shows no `files:` override"
    for hook in overrides:
        files = re.compile(hook["files"])
        assert files.search("ramps/x-axis.json")
        assert not files.search("motors/x-axis.json")


def test_workflow_file_is_the_readme_job() -> None:
    path = ROOT / "docs" / "ci" / "github-actions.yml"
    assert path.read_text(encoding="utf-8") == workflow_text(), \
        f"{path.relative_to(ROOT)} differs from the README's job; copy one into the other"


def test_workflow_publishes_the_report_it_writes() -> None:
    workflow = yaml.safe_load(workflow_text())
    [script] = check_scripts(workflow)
    match = re.search(r"--format junit -o (\S+)", script)
    assert match, "the check step does not write a JUnit report"
    report = match.group(1)
    steps = [s for job in workflow["jobs"].values() for s in job["steps"]]
    install = [s for s in steps if "pip install" in s.get("run", "")]
    assert install and "stepramp" in install[0]["run"]
    publishers = [s for s in steps if report in str(s.get("with", {}))]
    assert publishers, f"no step publishes {report}"
    for step in publishers:
        # A failing check (exit 1/2) must not skip the report.
        assert "cancelled()" in step.get("if", "") or "always()" in step.get("if", "")


def _tables(root: Path, with_bad: bool) -> None:
    (root / "tables").mkdir(exist_ok=True)
    shutil.copy(GOOD, root / "tables" / "good.table.json")
    if with_bad:
        shutil.copy(BAD, root / "bad.table.json")


def _run_check_step(script: str, cwd: Path) -> subprocess.CompletedProcess[str]:
    # `shell: bash` on GitHub runs `bash --noprofile --norc -eo pipefail {0}`.
    stepramp = f'stepramp() {{ "{sys.executable}" -m verify.cli "$@"; }}\n'
    return subprocess.run(["bash", "--noprofile", "--norc", "-eo", "pipefail", "-c",
                           stepramp + script], cwd=cwd, env=checkout_env(), capture_output=True,
                          text=True, timeout=120)


@pytest.mark.slow  # the workflow step as a shell script; CI runs it
def test_workflow_check_step(tmp_path: Path) -> None:
    [script] = check_scripts(yaml.safe_load(workflow_text()))
    report = tmp_path / re.search(r"-o (\S+)", script).group(1)  # type: ignore[union-attr]
    _tables(tmp_path, with_bad=True)
    # An upload file in a subfolder: the step's globs must reach it.
    subprocess.run([sys.executable, "-m", "verify.cli", "export", str(GOOD), "--format", "hex",
                    "-o", str(tmp_path / "tables" / "good.upload.hex")],
                   check=True, env=checkout_env(), cwd=tmp_path, timeout=60)

    failing = _run_check_step(script, tmp_path)
    assert failing.returncode == 1, failing.stderr
    suite = ET.parse(report).getroot()
    cases = {c.get("name"): c for c in suite.iter("testcase")}
    assert set(cases) == {"bad.table.json", "tables/good.table.json", "tables/good.upload.hex"}
    failures = cases["bad.table.json"].findall("failure")
    assert {f.get("type") for f in failures} >= {"rate-min", "pulses-min"}
    assert any("(chip 0x18)" in (f.text or "") for f in failures)
    assert not cases["tables/good.table.json"].findall("failure")
    assert not cases["tables/good.upload.hex"].findall("failure")

    (tmp_path / "bad.table.json").unlink()
    report.unlink()
    passing = _run_check_step(script, tmp_path)
    assert passing.returncode == 0, passing.stdout + passing.stderr
    suite = ET.parse(report).getroot()
    assert suite.get("failures") == "0"
    assert len(list(suite.iter("testcase"))) == 2


def test_workflow_check_step_unusable_input_fails(tmp_path: Path) -> None:
    [script] = check_scripts(yaml.safe_load(workflow_text()))
    _tables(tmp_path, with_bad=False)
    (tmp_path / "broken.table.json").write_text("{not json", encoding="utf-8")
    result = _run_check_step(script, tmp_path)
    assert result.returncode == 2
    report = tmp_path / re.search(r"-o (\S+)", script).group(1)  # type: ignore[union-attr]
    errors = [c for c in ET.parse(report).getroot().iter("testcase") if c.find("error") is not None]
    assert [c.get("name") for c in errors] == ["broken.table.json"]


def test_workflow_check_step_without_files_passes(tmp_path: Path) -> None:
    [script] = check_scripts(yaml.safe_load(workflow_text()))
    result = _run_check_step(script, tmp_path)
    assert result.returncode == 0, result.stderr


def _git(args: list[str], cwd: Path) -> str:
    env = {k: v for k, v in os.environ.items() if not k.startswith("GIT_")}
    return subprocess.run(["git", *args], cwd=cwd, env=env, check=True, capture_output=True,
                          text=True, timeout=60).stdout.strip()


def _pre_commit(cwd: Path, home: Path) -> subprocess.CompletedProcess[str]:
    env = {k: v for k, v in os.environ.items() if not k.startswith("GIT_")}
    env.pop("PYTHONPATH", None)  # the hook must run from its own installed environment
    # A hook environment is ~0.5 GB per stepramp commit: keep it out of ~/.cache.
    env["PRE_COMMIT_HOME"] = str(home)
    return subprocess.run([sys.executable, "-m", "pre_commit", "run", "--all-files",
                           "--color", "never"], cwd=cwd, env=env, capture_output=True, text=True,
                          timeout=PRE_COMMIT_TIMEOUT_S)


def _local_config(config: dict[str, Any], rev: str) -> str:
    """The README's config with `repo:` this checkout and `rev:` its HEAD commit."""
    config = yaml.safe_load(yaml.safe_dump(config))
    config["repos"][0]["repo"] = str(ROOT)
    config["repos"][0]["rev"] = rev
    return yaml.safe_dump(config, sort_keys=False)


@pytest.fixture(scope="module")
def pre_commit_home() -> Iterator[Path]:
    """pre-commit's cache, shared by this module's tests and removed after them."""
    with tempfile.TemporaryDirectory(prefix="stepramp-pre-commit-") as home:
        yield Path(home)


@pytest.fixture
def firmware_repo(tmp_path: Path) -> Path:
    if shutil.which("git") is None or not (ROOT / ".git").exists():
        pytest.skip("needs git and this repository's git checkout")
    _git(["init", "-q"], tmp_path)
    return tmp_path


@pytest.mark.slow
def test_pre_commit_hook(firmware_repo: Path, pre_commit_home: Path) -> None:
    rev = _git(["rev-parse", "HEAD"], ROOT)
    config = pre_commit_configs()[0]
    assert "files" not in config["repos"][0]["hooks"][0], "the first snippet is the plain one"
    (firmware_repo / ".pre-commit-config.yaml").write_text(_local_config(config, rev))
    shutil.copy(GOOD, firmware_repo / "good.table.json")
    shutil.copy(BAD, firmware_repo / "bad.table.json")
    (firmware_repo / "notes.json").write_text('{"not": "a table"}\n')  # outside the pattern
    _git(["add", "-A"], firmware_repo)

    failing = _pre_commit(firmware_repo, pre_commit_home)
    out = failing.stdout + failing.stderr
    assert failing.returncode == 1, out
    assert f"- hook id: {HOOK_ID}" in out and "- exit code: 1" in out
    assert "bad.table.json: error [rate-min] stage 0 (chip 0x18)" in out
    assert "bad.table.json: error [pulses-min] stage 3 (chip 0x19)" in out
    assert "good.table.json:" not in out and "notes.json" not in out
    assert "2 files checked: 1 ok, 1 failed" in out

    _git(["rm", "-q", "-f", "bad.table.json"], firmware_repo)
    passing = _pre_commit(firmware_repo, pre_commit_home)
    out = passing.stdout + passing.stderr
    assert passing.returncode == 0, out
    assert re.search(r"stepramp check .*Passed", out)


@pytest.mark.slow
def test_pre_commit_files_override(firmware_repo: Path, pre_commit_home: Path) -> None:
    rev = _git(["rev-parse", "HEAD"], ROOT)
    [config] = [c for c in pre_commit_configs() if "files" in c["repos"][0]["hooks"][0]]
    hook = config["repos"][0]["hooks"][0]
    (firmware_repo / ".pre-commit-config.yaml").write_text(_local_config(config, rev))
    motor_arg = hook["args"][hook["args"].index("--motor") + 1]
    (firmware_repo / motor_arg).parent.mkdir(parents=True)
    shutil.copy(ROOT / "profiles" / "data" / "motor-nema17-1600.json", firmware_repo / motor_arg)
    (firmware_repo / "ramps").mkdir()
    shutil.copy(GOOD, firmware_repo / "ramps" / "x.json")
    shutil.copy(BAD, firmware_repo / "ramps" / "y.json")
    shutil.copy(BAD, firmware_repo / "elsewhere.table.json")  # not selected by the override
    _git(["add", "-A"], firmware_repo)

    failing = _pre_commit(firmware_repo, pre_commit_home)
    out = failing.stdout + failing.stderr
    assert failing.returncode == 1, out
    assert "ramps/y.json: error [rate-min] stage 0 (chip 0x18)" in out
    assert "elsewhere.table.json" not in out
    assert "2 files checked: 1 ok, 1 failed" in out

    _git(["rm", "-q", "-f", "ramps/y.json"], firmware_repo)
    passing = _pre_commit(firmware_repo, pre_commit_home)
    assert passing.returncode == 0, passing.stdout + passing.stderr
