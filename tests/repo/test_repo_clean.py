"""The session check of tests/support/repo_clean.py: a run that leaves a file in the checkout
fails and names it; one that writes only under tmp_path passes. Each case is a pytest
session of its own in a fresh git repository."""

from __future__ import annotations

import shutil
import subprocess

import pytest

from tests.support.paths import ROOT


def _session(pytester: pytest.Pytester, body: str) -> pytest.RunResult:
    subprocess.run(["git", "init", "-q"], cwd=pytester.path, check=True)
    shutil.copy(ROOT / "tests" / "support" / "repo_clean.py", pytester.path / "repo_clean.py")
    pytester.makeconftest('pytest_plugins = ["repo_clean"]\n')
    (pytester.path / ".gitignore").write_text("runpytest-*/\n")  # pytester's basetemp
    pytester.makepyfile(test_it=body)
    subprocess.run(["git", "add", "-A"], cwd=pytester.path, check=True)
    subprocess.run(["git", "-c", "user.name=t", "-c", "user.email=t@t", "commit", "-qm", "t"],
                   cwd=pytester.path, check=True)
    return pytester.runpytest_inprocess("-p", "no:cacheprovider", "-o", "addopts=")


def test_a_file_left_in_the_checkout_fails_the_session(pytester: pytest.Pytester) -> None:
    result = _session(pytester, """
from pathlib import Path

def test_writes_beside_the_sources():
    Path("left-behind.txt").write_text("x")
""")
    assert result.ret == pytest.ExitCode.TESTS_FAILED
    result.stdout.fnmatch_lines(["*the test session wrote into the repository:*",
                                 "*?? left-behind.txt*"])


def test_files_under_tmp_path_pass(pytester: pytest.Pytester) -> None:
    result = _session(pytester, """
def test_writes_in_tmp(tmp_path):
    (tmp_path / "out.txt").write_text("x")
""")
    assert result.ret == pytest.ExitCode.OK


@pytest.mark.slow
def test_the_fuzz_campaign_writes_nothing_into_the_checkout() -> None:
    """The fuzz campaign (tests/contract/test_fuzz.py under the `fuzz` profile, one example
    a light template, every command) run from the repository root: every case's files go
    to its temporary folder."""
    import os
    import sys

    from tests.support.repo_clean import porcelain

    root = ROOT
    before = porcelain(root)
    if before is None:
        pytest.skip("not a git checkout")
    env = {**os.environ, "HYPOTHESIS_PROFILE": "fuzz", "STEPRAMP_FUZZ_EXAMPLES": "1"}
    env.pop("STEPRAMP_FUZZ_SUMMARY", None)
    r = subprocess.run([sys.executable, "-m", "pytest", "-q", "-p", "no:cacheprovider",
                        "tests/contract/test_fuzz.py", "-k",
                        "command_lines and not sync and not sweep and not plan"],
                       cwd=root, env=env, capture_output=True, text=True, timeout=900)
    assert r.returncode == 0, r.stdout[-2000:]
    assert "passed" in r.stdout
    assert porcelain(root) == before
