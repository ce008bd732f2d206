"""The suite writes only under temporary folders: `git status --porcelain` (untracked
files listed one by one) is taken when the session starts and again when it ends, and a
file that appears or changes in between fails the run, naming it. Checked once, in the
process that runs the session (xdist's controller, not its workers); skipped outside a
git checkout."""

from __future__ import annotations

import subprocess
from pathlib import Path

import pytest

_KEY = pytest.StashKey[set[str] | None]()


def porcelain(root: Path) -> set[str] | None:
    """The lines of `git status --porcelain --untracked-files=all`; None: no checkout."""
    try:
        r = subprocess.run(["git", "status", "--porcelain", "--untracked-files=all"],
                           cwd=root, capture_output=True, text=True, timeout=60)
    except (OSError, subprocess.TimeoutExpired):
        return None
    return set(r.stdout.splitlines()) if r.returncode == 0 else None


def _controller(session: pytest.Session) -> bool:
    return not hasattr(session.config, "workerinput")


def pytest_sessionstart(session: pytest.Session) -> None:
    if _controller(session):
        session.stash[_KEY] = porcelain(session.config.rootpath)


def pytest_sessionfinish(session: pytest.Session, exitstatus: int) -> None:
    before = session.stash.get(_KEY, None)
    if not _controller(session) or before is None:
        return
    after = porcelain(session.config.rootpath)
    new = sorted((after or set()) - before)
    if new:
        reporter = session.config.pluginmanager.get_plugin("terminalreporter")
        lines = "\n".join(f"  {line}" for line in new)
        message = f"the test session wrote into the repository:\n{lines}"
        if reporter is not None:
            reporter.write_line(message, red=True)
        session.exitstatus = pytest.ExitCode.TESTS_FAILED
