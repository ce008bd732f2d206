"""Issue 32 item 11, hostile input round three: one test each (the repeated JSON key is in
tests/contract/test_other_editors.py, motor new near zero in
tests/profiles/motor/test_plausible.py).

- a read-only install and an unwritable HOME: numba's cache finds a folder (or is off),
  said once, instead of an internal error at import;
- `plan --from ruckig --pulses 100000` on a good motor plans;
- `sweep --scheduler` at a server that is not Dask, and at a closed port: one line at once;
- `sync --plot` with 16 axes draws without matplotlib's warnings;
- `design` (and every command) with an incomplete motor file names the file;
- a killed run's hidden temp file is cleared by the next run.

Every address is 127.0.0.1."""

from __future__ import annotations

import dataclasses
import json
import os
import shutil
import socket
import subprocess
import sys
import threading
import time
import warnings
from collections.abc import Iterator
from pathlib import Path

import numpy as np
import pytest

from profiles import compiling
from profiles.errors import ClusterError
from profiles.motor import load_motor
from tests.support.cli import run
from tests.support.paths import ROOT

NEMA17 = ROOT / "profiles" / "data" / "motor-nema17-1600.json"


# --- numba's cache without a writable folder ------------------------------------------------
def read_only_copy(tmp_path: Path) -> dict[str, str]:
    """The package copied where no cache folder can be made (each __pycache__ is a file,
    HOME and the cache folders lie under a file; chmod too, for a non-root run), and the
    environment of a process that imports it."""
    copy = tmp_path / "install"
    for package in ("profiles", "verify"):
        shutil.copytree(ROOT / package, copy / package,
                        ignore=shutil.ignore_patterns("__pycache__"))
    for folder in [p for p in copy.rglob("*") if p.is_dir()] + [copy]:
        (folder / "__pycache__").write_bytes(b"")
    blocker = tmp_path / "not-a-folder"
    blocker.write_bytes(b"")
    for path in sorted(copy.rglob("*"), reverse=True):
        path.chmod(0o555 if path.is_dir() else 0o444)
    env = {k: v for k, v in os.environ.items() if not k.startswith(("NUMBA_", "PYTHON"))}
    env.update(PYTHONPATH=str(copy), HOME=str(blocker / "home"),
               XDG_CACHE_HOME=str(blocker / "cache"), PYTHONDONTWRITEBYTECODE="1",
               NUMBA_CACHE_DIR=str(blocker / "numba"), TMPDIR=str(tmp_path / "tmp"))
    (tmp_path / "tmp").mkdir()
    return env


def test_a_read_only_install_finds_a_cache_folder(tmp_path: Path) -> None:
    """Declaring a kernel failed at import ("no locator available"); now the kernels are
    cached in a private folder under the temporary folder, said once."""
    env = read_only_copy(tmp_path)
    code = ("from profiles.compiling import announce; announce(print)\n"
            "import threading, importlib\n"  # under threads: an ImportError before
            "names = ['profiles.motor.rotor_kernel', 'profiles.motor.assemble_kernel',\n"
            "         'profiles.motor.share_kernel', 'profiles.ppmc312.planner.dp_kernel']\n"
            "ts = [threading.Thread(target=importlib.import_module, args=(n,)) for n in names]\n"
            "[t.start() for t in ts]; [t.join() for t in ts]\n"
            "import profiles.motor.rotor_kernel, profiles.ppmc312.planner.dp_kernel\n"
            "from numba.core import config; print('cache:', config.CACHE_DIR)")
    done = subprocess.run([sys.executable, "-c", code], env=env, cwd=tmp_path,
                          capture_output=True, text=True, timeout=120)
    assert done.returncode == 0 and done.stderr == "", done.stderr
    folder = Path(tempfile_dir(tmp_path)) / f"stepramp-numba-cache-{os.getuid()}"
    assert done.stdout.splitlines() == [
        "numba's cache folders are not writable (the installed package, ~/.cache): the "
        f"kernels are cached in {folder}", f"cache: {folder}"]
    assert folder.is_dir() and folder.stat().st_mode & 0o077 == 0


def tempfile_dir(tmp_path: Path) -> str:
    return str(tmp_path / "tmp")


@pytest.mark.slow  # compiles every kernel once (about half a minute)
def test_plan_in_a_read_only_install(tmp_path: Path) -> None:
    env = read_only_copy(tmp_path)
    done = subprocess.run([sys.executable, "-m", "verify.cli", "plan", "--motor",
                           "nema17-1600", "--moves", "-", "-o",
                           str(tmp_path / "t.json")], input="pulses,weight\n2000,1\n",
                          env=env, cwd=tmp_path, capture_output=True, text=True, timeout=600)
    assert done.returncode == 0, done.stderr
    lines = done.stderr.splitlines()
    assert lines[0].startswith("stepramp plan: numba's cache folders are not writable")
    assert sum("cache folders" in line for line in lines) == 1  # said once


def test_no_writable_folder_at_all_turns_the_cache_off(monkeypatch: pytest.MonkeyPatch,
                                                       tmp_path: Path) -> None:
    from numba.core import config
    from numba.core.dispatcher import Dispatcher

    # restored after the test, whatever choose_cache sets
    monkeypatch.setattr(Dispatcher, "enable_caching", Dispatcher.enable_caching)
    monkeypatch.setattr(config, "CACHE_DIR", getattr(config, "CACHE_DIR", ""), raising=False)
    monkeypatch.setattr(compiling, "numba_finds_a_cache", lambda: False)
    monkeypatch.setattr(compiling, "fallback_folder", lambda: None)
    assert compiling.choose_cache() == ("no writable folder for numba's cache: the kernels "
                                        "are compiled in every run (about half a minute)")
    assert Dispatcher.enable_caching is compiling.no_cache


def test_a_shared_fallback_folder_others_can_write_is_not_used(
        monkeypatch: pytest.MonkeyPatch, tmp_path: Path) -> None:
    """numba's cache holds code: a folder another user could write into is not loaded."""
    import tempfile

    monkeypatch.setattr(tempfile, "gettempdir", lambda: str(tmp_path))
    shared = tmp_path / f"stepramp-numba-cache-{os.getuid()}"
    shared.mkdir()
    shared.chmod(0o777)
    chosen = compiling.fallback_folder()
    assert chosen is not None and Path(chosen) != shared and Path(chosen).parent == tmp_path
    shared.chmod(0o700)
    assert compiling.fallback_folder() == str(shared)


# --- plan --from ruckig on a good motor -------------------------------------------------------
def test_following_ruckig_on_a_long_move_plans(capsys: pytest.CaptureFixture[str],
                                              tmp_path: Path) -> None:
    """The stand-in motor took the decel side's torque where friction already brakes, so
    it could not accelerate: "the motor cannot accelerate from rest", blamed on the
    user's motor."""
    from profiles.ppmc312.planner.reference_plan import reference_motor
    from verify import references

    motor = load_motor(NEMA17)
    ref = references.ruckig_reference(motor, 100_000)
    follower = reference_motor(motor, ref.v_pps, ref.x_pulses)
    speeds = follower.curve_speed_pps
    assert follower.a_acc_pps2(0.0) > 0
    assert np.all(follower.curve_torque_nm <= motor.torque_nm(speeds) + 1e-12)
    code, out, err = run(capsys, "plan", "--motor", NEMA17, "--from", "ruckig", "--pulses",
                         "100000", "-o", tmp_path / "t.json")
    assert code == 0 and err == "" and "the ruckig reference" in out


# --- sweep --scheduler at what is not a Dask scheduler ----------------------------------------
@pytest.fixture
def banner_server() -> Iterator[str]:
    """A TCP server on 127.0.0.1 that greets every connection as an SSH server does."""
    server = socket.create_server(("127.0.0.1", 0))
    server.settimeout(0.05)
    stop = threading.Event()

    def serve() -> None:
        while not stop.is_set():
            try:
                conn = server.accept()[0]
            except TimeoutError:
                continue
            with conn:
                conn.sendall(b"SSH-2.0-OpenSSH_9.6\r\n")
                time.sleep(0.2)

    thread = threading.Thread(target=serve, daemon=True)
    thread.start()
    try:
        yield f"tcp://127.0.0.1:{server.getsockname()[1]}"
    finally:
        stop.set()
        thread.join()
        server.close()


def closed_port() -> int:
    s = socket.create_server(("127.0.0.1", 0))
    port = int(s.getsockname()[1])
    s.close()
    return port


def test_a_server_that_is_not_dask(banner_server: str, tmp_path: Path,
                                   capsys: pytest.CaptureFixture[str]) -> None:
    """Before: "MemoryError: Unable to allocate 3.07 EiB" (the banner read as a length)."""
    out = tmp_path / "r.csv"
    code, _, err = run(capsys, "sweep", "--motors", NEMA17, "--pulses", "3000", "--scheduler",
                       banner_server, "-o", out)
    assert code == 2 and not out.exists()
    assert err == (f"stepramp sweep: the server at {banner_server} is not a Dask scheduler (its "
                   "first bytes: b'SSH-2.0-'; a scheduler's handshake starts with its length)\n")


def test_a_refused_connection_is_said_at_once(tmp_path: Path,
                                              capsys: pytest.CaptureFixture[str]) -> None:
    """Before: the whole 10 s, then TimeoutError."""
    address = f"tcp://127.0.0.1:{closed_port()}"
    start = time.monotonic()
    code, _, err = run(capsys, "sweep", "--motors", NEMA17, "--pulses", "3000", "--scheduler",
                       address, "-o", tmp_path / "r.csv")
    assert code == 2 and time.monotonic() - start < 3
    assert err == (f"stepramp sweep: no Dask scheduler at {address}: connection refused "
                   "(nothing listens on that port)\n")


def test_a_dask_scheduler_passes_the_probe() -> None:
    import distributed

    from verify.sweep import probe_scheduler

    with distributed.LocalCluster(n_workers=0, processes=False, protocol="tcp://",
                                  host="127.0.0.1", dashboard_address=None) as cluster:
        probe_scheduler(cluster.scheduler_address, 5.0)
    with pytest.raises(ClusterError, match="connection refused"):
        probe_scheduler(f"127.0.0.1:{closed_port()}", 5.0)


# --- sync --plot with 16 axes ----------------------------------------------------------------
@pytest.mark.slow  # a 16-axis figure takes 2–3 s to lay out
def test_sync_figure_of_16_axes_draws_without_warnings(tmp_path: Path) -> None:
    """Before: "constrained_layout not applied because axes sizes collapsed to zero",
    twice (a legend entry per line: 30 and 49 of them)."""
    from verify import sync
    from verify.devices import load_axes
    from verify.plot import figure_bytes

    plan = sync.plan_axes(load_axes(ROOT / "examples" / "axes-xy.json"))
    axes = tuple(dataclasses.replace(plan.axes[i % 2], name=f"axis{i}") for i in range(16))
    plan = dataclasses.replace(plan, axes=axes)
    ruckig = sync.ruckig_sync([a.motor for a in axes], [a.pulses for a in axes])
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        fig = sync.sync_figure(plan, ruckig)
        legends = [len(ax.get_legend().get_texts()) for ax in fig.axes]
        assert figure_bytes(fig, tmp_path / "s.png").startswith(b"\x89PNG")
    # 15 paths + the straight lines; one deviation envelope whatever the number of axes
    # (least to largest, its largest, the worst instant); 16 speeds + 2 ruckig + 0
    assert legends == [16, 3, 19]


# --- an incomplete motor file is named ---------------------------------------------------------
@pytest.mark.parametrize("command", [["design", "--no-browser", "--motor"],
                                     ["plan", "--pulses", "1000", "--motor"]])
def test_an_incomplete_motor_file_is_named(command: list[str], tmp_path: Path,
                                           capsys: pytest.CaptureFixture[str]) -> None:
    obj = json.loads(NEMA17.read_text())
    del obj["inertia_kgm2"]
    motor = tmp_path / "m.json"
    motor.write_text(json.dumps(obj))
    code, _, err = run(capsys, *command, motor)
    assert code == 2 and err == (f"stepramp {command[0]}: {motor}: missing key(s) in motor "
                                 "file: inertia_kgm2\n")


# --- a killed run's temp file ---------------------------------------------------------------------
def test_a_killed_runs_temp_file_is_cleared(tmp_path: Path,
                                            capsys: pytest.CaptureFixture[str]) -> None:
    from verify.output import STALE_S, host_tag

    dead = subprocess.run([sys.executable, "-c", "import os; print(os.getpid())"],
                          capture_output=True, text=True, check=True).stdout.strip()
    host = host_tag()
    left = {"dead": tmp_path / f".t.hex.{host}-{dead}-abcd1234.part",
            "running": tmp_path / f".t.hex.{host}-{os.getpid()}-abcd1234.part",
            "other host": tmp_path / f".t.hex.elsewhere-{dead}-abcd1234.orig",
            "old, unnamed": tmp_path / ".t.hex.k2j4h5g6.part",
            "another file's": tmp_path / f".u.hex.{host}-{dead}-abcd1234.part"}
    for path in left.values():
        path.write_text("half a file")
    day_old = time.time() - STALE_S - 60
    os.utime(left["old, unnamed"], (day_old, day_old))
    code, _, _ = run(capsys, "export", ROOT / "examples" / "free-curve-nema17.json", "-o",
                     tmp_path / "t.hex")
    assert code == 0
    kept = {k for k, p in left.items() if p.exists()}
    assert kept == {"running", "other host", "another file's"}
    assert sorted(p.name for p in tmp_path.iterdir() if p.name.startswith(".t.hex")) == sorted(
        left[k].name for k in ("running", "other host"))
