"""The first compilation of our kernels is said, once, and a cached load is not
(profiles.compiling): half a minute of silence on a machine's first plan reads as a hang."""

from __future__ import annotations

import json
import os
import subprocess
import sys
from pathlib import Path
from typing import Any

import numba as nb
import pytest

from profiles import compiling
from tests.support.paths import ROOT


def _kernel(module: str) -> Any:
    """A fresh (never compiled, uncached) kernel whose function lives in `module`."""
    scope: dict[str, Any] = {"__name__": module}
    exec("def twice(x):\n    return 2 * x\n", scope)
    return nb.njit(scope["twice"])


@pytest.fixture
def said(monkeypatch: pytest.MonkeyPatch) -> list[str]:
    lines: list[str] = []
    monkeypatch.setattr(compiling, "_said", False)
    monkeypatch.delenv(compiling.QUIET_ENV, raising=False)
    compiling.watch()
    compiling.announce(lines.append)
    yield lines
    compiling.announce(None)


def test_our_first_compilation_is_said_once(said: list[str]) -> None:
    assert _kernel("profiles.fake_kernel")(3) == 6
    assert said == [compiling.NOTICE]
    assert _kernel("verify.fake_kernel")(4) == 8  # later compilations: already said
    assert said == [compiling.NOTICE]


def test_other_modules_kernels_and_silent_front_ends_say_nothing(        said: list[str]) -> None:
    assert _kernel("someone_else.kernel")(1) == 2
    assert said == []
    compiling.announce(None)  # a library caller that asked for nothing
    assert _kernel("profiles.fake_kernel")(1) == 2
    assert said == []


def test_nothing_is_said_before_a_front_end_asks() -> None:
    """A library caller (a notebook, a script) that never calls `announce` hears nothing,
    and the line is still to come for a front end that does (the suite runs with the
    command's notice off, and the tests that say it put `_said` back)."""
    assert compiling._say is None and compiling._said is False


def test_a_fresh_process_says_it_once() -> None:
    """In a new interpreter (nothing said yet, nobody listening yet): one line for two
    compilations."""
    script = (
        "import numba\n"
        "from profiles import compiling\n"
        "compiling.watch()\n"
        "compiling.announce(print)\n"
        "for n in (1, 2):\n"
        "    scope = {'__name__': 'profiles.fresh'}\n"
        "    exec('def f(x):\\n    return x + 1\\n', scope)\n"
        "    assert numba.njit(scope['f'])(n) == n + 1\n")
    run = subprocess.run([sys.executable, "-c", script], capture_output=True, text=True,
                         timeout=300, cwd=ROOT,
                         env={**os.environ, compiling.QUIET_ENV: "1"})
    assert run.returncode == 0, run.stderr
    assert run.stdout.splitlines() == [compiling.NOTICE]


@pytest.mark.parametrize(("setting", "says"), [(None, True), ("1", True), ("0", False)])
def test_the_command_says_it_unless_told_not_to(setting: str | None, says: bool,
                                                monkeypatch: pytest.MonkeyPatch) -> None:
    """`stepramp` hands its one-line `say` over; STEPRAMP_COMPILE_NOTICE=0 silences it."""
    from verify.cli import main

    monkeypatch.setattr(compiling, "_say", None)
    if setting is None:
        monkeypatch.delenv("STEPRAMP_COMPILE_NOTICE", raising=False)
    else:
        monkeypatch.setenv("STEPRAMP_COMPILE_NOTICE", setting)
    assert main(["motor", "list"]) == 0
    assert (compiling._say is not None) is says


@pytest.mark.slow
def test_a_machines_first_plan_says_it_compiles_and_the_next_does_not(
        tmp_path: Path) -> None:
    """A fresh numba cache: the first `stepramp plan` says so in one line on stderr
    (about half a minute), the second loads the cache and says nothing."""
    env = {**os.environ, "NUMBA_CACHE_DIR": str(tmp_path / "cache"),
           "STEPRAMP_COMPILE_NOTICE": "1"}
    cmd = [sys.executable, "-m", "verify.cli", "plan", "--motor", "nema17-1600",
           "--pulses", "300", "-o", str(tmp_path / "t.json")]
    first = subprocess.run(cmd, env=env, capture_output=True, text=True, timeout=600)
    assert first.returncode == 0, first.stderr
    assert first.stderr.splitlines() == [f"stepramp plan: {compiling.NOTICE}"]
    again = subprocess.run(cmd, env=env, capture_output=True, text=True, timeout=600)
    assert again.returncode == 0 and again.stderr == ""


def test_the_notebook_designer_says_it_in_the_cell(said: list[str],
                                                    capsys: pytest.CaptureFixture[str]) -> None:
    """A designer built in a notebook hands over a `say` that prints into the cell's
    output, where its first compilation would otherwise be half a minute of a busy cell."""
    from profiles.motor import bundled_motor_paths, load_motor
    from verify.designer import designer

    designer(load_motor(bundled_motor_paths()[0]), pulses=2_000)
    assert _kernel("profiles.fake_kernel")(5) == 10
    assert capsys.readouterr().out.splitlines() == [f"stepramp designer: {compiling.NOTICE}"]


LEAN_PROBE = """
import json, sys, threading
from profiles import compiling
gate = threading.Event()
other = threading.Thread(target=gate.wait)
other.start()
busy = compiling.lean_registries()  # another thread could be importing scipy meanwhile
gate.set()
other.join()
done = compiling.lean_registries()
left = [m for m in compiling.LEAN_WITHOUT if m in sys.modules]
import numba.np.arraymath
blas = numba.np.arraymath._HAVE_BLAS
import scipy.linalg, cffi  # available again to whatever wants them
from numba.core import entrypoints
print(json.dumps([busy, done, left, blas, compiling.lean_registries(),
                  entrypoints._already_initialized]))
"""


def test_lean_registries_only_alone_and_only_once() -> None:
    """numba's registry modules are imported without scipy.linalg and cffi (and numba's
    extensions not looked for) only in a process with one thread, and both stay
    importable afterwards; a second call (numba's modules loaded) does nothing."""
    run = subprocess.run([sys.executable, "-c", LEAN_PROBE], capture_output=True, text=True,
                         timeout=300, cwd=ROOT)
    assert run.returncode == 0, run.stderr
    assert json.loads(run.stdout) == [False, True, [], False, False, True]


CHECK_PROBE = """
import sys
from verify.cli import main
sys.argv = ["stepramp", *sys.argv[1:]]
code = main()  # as the `stepramp` process: lean
print([m for m in ("scipy.linalg", "cffi") if m in sys.modules], file=sys.stderr)
print([m for m in REGISTRIES if m in sys.modules], file=sys.stderr)
sys.exit(code)
"""
# modules only numba's registry refresh imports (not numba's import, not our kernels)
REGISTRIES = ("numba.np.polynomial.polynomial_core", "numba.typed.typeddict",
              "numba.np.random.generator_core")


def test_the_command_judges_alike_without_scipy_linalg_and_cffi(
        capsys: pytest.CaptureFixture[str]) -> None:
    """`stepramp check --motor` in its own process (numba's registries lean: neither
    scipy.linalg nor cffi imported, and the cached kernels loaded without the registries'
    refresh) gives the verdict this process gives (the reference, numba loaded as a
    library caller's, the registries refreshed)."""
    from verify.cli import main

    root = ROOT
    args = ["check", str(root / "examples" / "free-curve-nema17.json"), "--motor",
            "nema17-1600", "--format", "json"]
    probe = f"REGISTRIES = {REGISTRIES!r}\n{CHECK_PROBE}"
    run = subprocess.run([sys.executable, "-c", probe, *args], capture_output=True,
                         text=True, timeout=300, cwd=root)
    assert run.returncode in (0, 1), run.stderr
    assert run.stderr.strip().splitlines()[-2:] == ["[]", "[]"]
    capsys.readouterr()
    code = main(args)
    assert (code, json.loads(capsys.readouterr().out)) == (run.returncode,
                                                           json.loads(run.stdout))
