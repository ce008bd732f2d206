"""`stepramp sweep` (verify/cli/sweep.py): files, figure and refusals."""

from __future__ import annotations

import csv
import json
import socket
import threading
from collections.abc import Iterator
from pathlib import Path
from typing import Any

import pytest

from profiles.motor import load_motor
from tests.support.paths import ROOT
from verify import cli

NEMA17 = ROOT / "profiles" / "data" / "motor-nema17-1600.json"


@pytest.mark.slow  # end-to-end; CI runs it
def test_sweep_cli_csv_parquet_plot(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    out = tmp_path / "r.csv"
    fig = tmp_path / "r.png"
    args = ["sweep", "--motors", str(NEMA17), "--pulses", "3000", "--load-angle", "90"]
    assert cli.main([*args, "--plot", str(fig), "-o", str(out)]) == 0
    rows = list(csv.DictReader(out.open()))
    assert len(rows) == 1 and rows[0]["motor"] == "motor-nema17-1600"
    assert rows[0]["safe"] == "True" and float(rows[0]["worst_load_angle_deg"]) < 90
    assert fig.stat().st_size > 1000
    assert "1 safe, 0 not safe" in capsys.readouterr().err
    import pyarrow.parquet as pq
    pout = tmp_path / "r.parquet"
    assert cli.main([*args, "-o", str(pout)]) == 0
    table = pq.read_table(pout).to_pylist()
    assert table[0]["pulses"] == 3000
    assert table[0]["move_time_s"] == pytest.approx(float(rows[0]["move_time_s"]), rel=1e-15)


def test_sweep_cli_refusals(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    out = tmp_path / "r.csv"
    # a motor whose tolerance box cannot start is a row with its reason, and exit 1
    weak = tmp_path / "weak.json"
    weak.write_text(json.dumps(dict(json.loads(NEMA17.read_text()),
                                    tolerances={"friction_torque_nm": [0.0, 0.5]})))
    assert cli.main(["sweep", "--motors", str(weak), "--pulses", "3000", "-o", str(out)]) == 1
    row = next(csv.DictReader(out.open()))
    assert row["safe"] == "False" and "cannot start" in row["error"]
    capsys.readouterr()
    bad = tmp_path / "bad.csv"
    assert cli.main(["sweep", "--motors", str(NEMA17), "--pulses", "3000", "--workers", "2",
                     "--scheduler", "tcp://127.0.0.1:1", "-o", str(bad)]) == 2
    assert "one or the other" in capsys.readouterr().err and not bad.exists()
    assert load_motor(NEMA17)  # the bundled file was not touched


@pytest.mark.parametrize("address, says", [
    ("garbage", "'garbage': not a Dask scheduler address"),
    ("", "'': not a Dask scheduler address"),
    ("udp://10.0.0.5:8786", "not a Dask scheduler address"),
    ("http://10.0.0.5:8787", "http:// is the dashboard's"),
    ("tcp://10.0.0.5", "not a Dask scheduler address"),
    ("tcp://10.0.0.5:0", "--scheduler port: 0 is outside the allowed range 1..65535"),
    ("tcp://" + "h" * 100_000 + ":1", "… (100008 characters)"),
])
def test_a_malformed_scheduler_address_is_refused_at_once(
        tmp_path: Path, capsys: pytest.CaptureFixture[str], monkeypatch: pytest.MonkeyPatch,
        address: str, says: str) -> None:
    import distributed

    def no_client(*args: object, **kwargs: object) -> None:
        raise AssertionError("a malformed address never reaches Dask")

    monkeypatch.setattr(distributed, "Client", no_client)
    out = tmp_path / "r.csv"
    code = cli.main(["sweep", "--motors", str(NEMA17), "--pulses", "3000", "--scheduler",
                     address, "-o", str(out)])
    err = capsys.readouterr().err
    assert code == 2 and says in err and err.startswith("stepramp sweep: --scheduler ")
    assert len(err.splitlines()) == 1 and len(err) < 300 and not out.exists()


@pytest.fixture
def silent_scheduler() -> Iterator[tuple[str, list[socket.socket]]]:
    """A listener that accepts connections and never says a word."""
    server = socket.create_server(("127.0.0.1", 0))
    server.settimeout(0.05)
    accepted: list[socket.socket] = []
    stop = threading.Event()

    def serve() -> None:
        while not stop.is_set():
            try:
                accepted.append(server.accept()[0])
            except TimeoutError:
                pass

    thread = threading.Thread(target=serve, daemon=True)
    thread.start()
    try:
        yield f"tcp://127.0.0.1:{server.getsockname()[1]}", accepted
    finally:
        stop.set()
        thread.join()
        for conn in accepted:
            conn.close()
        server.close()


def test_a_scheduler_that_never_answers_times_out(
        tmp_path: Path, capsys: pytest.CaptureFixture[str],
        silent_scheduler: tuple[str, list[socket.socket]]) -> None:
    address, accepted = silent_scheduler
    out = tmp_path / "r.csv"
    code = cli.main(["sweep", "--motors", str(NEMA17), "--pulses", "3000", "--scheduler",
                     address, "--timeout", "0.5", "-o", str(out)])
    err = capsys.readouterr().err
    assert code == 2 and accepted  # it connected, then waited 0.5 s for an answer
    assert err.startswith(f"stepramp sweep: no Dask scheduler answered at {address} within "
                          "0.5 s") and len(err.splitlines()) == 1
    assert not out.exists()


@pytest.mark.parametrize("options, says", [
    (["--load-angle", "nan"], "--load-angle: nan is outside the allowed range 1.0..90.0"),
    (["--load-angle", "inf"], "--load-angle: inf is outside the allowed range 1.0..90.0"),
    (["--load-angle", "-1"], "--load-angle: -1.0 is outside the allowed range 1.0..90.0"),
    (["--workers", "0"], "--workers: 0 is outside the allowed range 1..256"),
    (["--scheduler", "h:1", "--timeout", "nan"], "--timeout: nan is outside the allowed "
                                                 "range above 0.0 up to 3600.0"),
    (["--scheduler", "h:1", "--timeout", "-1"], "--timeout: -1.0 is outside"),
    (["--scheduler", "h:1", "--timeout", "inf"], "--timeout: inf is outside"),
    (["--timeout", "5"], "--timeout bounds the waits on a Dask scheduler"),
    (["--samples", "-1"], "argument --samples: '-1' is negative"),
])
def test_sweep_numbers_are_checked_first(tmp_path: Path, capsys: pytest.CaptureFixture[str],
                                         options: list[str], says: str) -> None:
    out = tmp_path / "r.csv"
    code = cli.main(["sweep", "--motors", str(NEMA17), "--pulses", "3000", *options,
                     "-o", str(out)])
    err = capsys.readouterr().err
    assert code == 2 and says in err and len(err.splitlines()) == 1 and not out.exists()


def test_sweep_plot_x_mm_needs_every_motor_s_travel(tmp_path: Any,
                                                    capsys: pytest.CaptureFixture[str]) -> None:
    from verify import cli

    code = cli.main(["sweep", "--motors", "nema17-1600", "--pulses", "400", "--samples", "0",
                     "--plot-x", "mm", "--plot", str(tmp_path / "s.png"),
                     "-o", str(tmp_path / "s.csv")])
    assert code == 2
    err = capsys.readouterr().err
    assert "--plot-x mm: nema17-1600 states no travel_mm_per_rev" in err
    assert not (tmp_path / "s.csv").exists()
