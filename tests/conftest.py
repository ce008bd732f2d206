"""Test-suite settings.

In CI (CI=true) hypothesis is derandomised, so a run is repeatable and a
failure can be reproduced from the same commit; locally it explores freely.
No deadline anywhere: a 2-core machine running two workers is no place to time
single examples (speed goals live in bench/). The quick local suite (`pytest -m
"not slow"`, outside CI) runs each property on 30 examples instead of hypothesis's
100, unless the test sets its own count: a first look, not the verdict (CI and the
mutation runs keep the full count). tools/mutation.py's runs use the `mutation` profile
(derandomised, no database, no shrinking).

The fuzz campaign is the `fuzz` profile (`HYPOTHESIS_PROFILE=fuzz`, or pytest's
`--hypothesis-profile=fuzz`): tests/contract/test_fuzz.py's campaign tests then run
STEPRAMP_FUZZ_EXAMPLES examples a template (default 100) instead of the suite's few, and
write their summary where STEPRAMP_FUZZ_SUMMARY says (the README's fuzz block:
reports/fuzz.json, tests/support/fuzzing.py's SUMMARY_COMMAND).

The motor catalogue is the bundled motors only: the user's own motor folders
(STEPRAMP_MOTORS, the XDG config folder) would make a test depend on the machine.
"""

from __future__ import annotations

import os
import signal
import tempfile
from collections.abc import Iterator

import pytest
from hypothesis import HealthCheck, Phase, settings

settings.register_profile("ci", derandomize=True, deadline=None, print_blob=True)
settings.register_profile("dev", deadline=None)
settings.register_profile("quick", deadline=None, max_examples=30)
settings.register_profile("fuzz", deadline=None, print_blob=True,
                          max_examples=int(os.environ.get("STEPRAMP_FUZZ_EXAMPLES", "100")),
                          suppress_health_check=list(HealthCheck))
# tools/mutation.py's runs: a mutant needs only *a* failing example, and shrinking one can
# take longer than every other test together
settings.register_profile("mutation", derandomize=True, deadline=None, database=None,
                          phases=(Phase.explicit, Phase.reuse, Phase.generate))
settings.load_profile(os.environ.get("HYPOTHESIS_PROFILE")
                      or ("ci" if os.environ.get("CI") else "dev"))

# A fresh machine's first kernel compilation is said on stderr (profiles.compiling); which
# test happens to compile first would decide whose stderr carries it. Tests of the CLI's
# stderr see it off (its own test turns it on).
os.environ["STEPRAMP_COMPILE_NOTICE"] = "0"


def pytest_configure(config: pytest.Config) -> None:
    if os.environ.get("HYPOTHESIS_PROFILE") or config.getoption("hypothesis_profile", None):
        return  # a profile asked for by name (the fuzz campaign) stays
    if not os.environ.get("CI") and config.getoption("markexpr", "") == "not slow":
        settings.load_profile("quick")


@pytest.fixture(autouse=True, scope="session")
def _bundled_motors_only() -> Iterator[None]:
    saved = {k: os.environ.get(k) for k in ("STEPRAMP_MOTORS", "XDG_CONFIG_HOME")}
    with tempfile.TemporaryDirectory(prefix="stepramp-config-") as config:
        os.environ.pop("STEPRAMP_MOTORS", None)
        os.environ["XDG_CONFIG_HOME"] = config
        try:
            yield
        finally:
            for key, value in saved.items():
                if value is None:
                    os.environ.pop(key, None)
                else:
                    os.environ[key] = value


# The session fails when it leaves a new or changed file in the checkout
# (tests/support/repo_clean.py); pytester runs that plugin's own tests
# (tests/repo/test_repo_clean.py: a test module below the top cannot load a plugin).
# The serial link's fixtures (skewed, pty_chip, link) serve the link's tests and the
# `stepramp link` command's (tests/support/serial_link.py).
pytest_plugins = ["tests.support.repo_clean", "tests.support.serial_link", "pytester"]


@pytest.fixture
def terminal_sigint() -> Iterator[None]:
    """SIGINT at Python's default while the test starts its children, as a terminal's
    foreground job has it. pytest-xdist's workers ignore SIGINT, and a child inherits an
    ignored signal: Python then installs no KeyboardInterrupt handler, and a Ctrl-C the
    test sends the child does nothing (the child ran to the end and exited 0)."""
    previous = signal.signal(signal.SIGINT, signal.default_int_handler)
    try:
        yield
    finally:
        signal.signal(signal.SIGINT, previous)
