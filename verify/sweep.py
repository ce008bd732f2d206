"""Sweeps: plan and verify a catalogue of motors × move lengths (× tolerance samples).

One job per (motor, move length): plan the robust table (profiles.ppmc312.planner:
over the motor's tolerance box when it has one, tightened to the load-angle
target), then judge it as `stepramp check --motor` does (the criterion at the
box's worst case, the load angle at every corner and over `samples` seeded Monte
Carlo samples; a motor without tolerances: on every execution). Jobs are
independent and take their motor as JSON, so they run in-process, on local
processes or on a Dask cluster, with the same rows in the same order (each row is
put back at its job's place, whatever finishes first).

Where jobs run (`run_sweep`):
- local processes come from a forkserver, never forked from this process: it may run
  threads (the load-angle model's, tqdm's monitor, a Dask client's loop) and a fork
  copies their locks mid-use. The forkserver first imports `verify.sweep_worker`,
  which runs one small job, so every worker forked from it starts with the planner
  imported and the compiled load-angle kernels loaded. Workers ignore SIGINT: Ctrl-C
  is this process's, which ends them at once.
- on a Dask cluster this process is an asynchronous client and every wait is bounded
  by `timeout_s`: connecting, and each stretch without a finished job, after which
  the scheduler must answer (within `timeout_s`) and have workers, else the sweep
  stops with a one-line `ClusterError`. A worker lost mid-sweep is the scheduler's to
  recover: it runs that worker's jobs again elsewhere. Ctrl-C (or any error) cancels
  the jobs still on the cluster.
"""

from __future__ import annotations

import asyncio
import contextlib
import csv
import io
import re
import signal
import socket
import struct
import time
from collections.abc import Iterator, Sequence
from concurrent.futures import Executor, Future, ProcessPoolExecutor, as_completed
from dataclasses import dataclass
from typing import Any

from profiles.errors import (
    ClusterError,
    FormatError,
    StepRampError,
    require_int,
    require_number,
)
from profiles.progress import Progress, report

COLUMNS = ("motor", "pulses", "move_time_s", "worst_load_angle_deg", "safe", "failed",
           "margin_deg", "worst_pulses", "stages", "LE", "clock", "top_pps", "binds",
           "solve_s", "judge_s", "corners", "samples", "sample_failures",
           "stall_probability_upper", "error", "safety",
           # real units (profiles/motor/travel.py): rev and rpm always, mm and mm/s where
           # the motor file states its travel_mm_per_rev (else empty)
           "move_rev", "top_rpm", "travel_mm_per_rev", "move_mm", "top_mm_s")


@dataclass(frozen=True)
class Job:
    motor: str                  # the name in the results (the file's name or stem)
    motor_json: dict[str, Any]
    pulses: int
    samples: int
    seed: int
    load_angle_deg: float | None
    cruise_reserve: str = "2x,10%"   # the torque reserve at the top speed (`plan`'s option)


def run_job(job: Job) -> dict[str, Any]:
    """One row: the plan and both verdicts for one motor and move length. A request no
    table can meet is a row with `error` set and `safe` False, not an exception."""
    from profiles.motor import Motor
    from profiles.motor.reserve import parse_cruise_reserve
    from profiles.ppmc312.planner import plan_free_curve

    row: dict[str, Any] = dict.fromkeys(COLUMNS)
    row.update(motor=job.motor, pulses=job.pulses, safe=False, error="")
    try:
        motor = Motor.from_json(job.motor_json)
        row.update(real_units(motor, job.pulses))
        # planned to the reserve's top speed, judged on the motor as it is
        plan = plan_free_curve(parse_cruise_reserve(job.cruise_reserve).applied(motor),
                               pulses=job.pulses, load_angle_deg=job.load_angle_deg)
    except StepRampError as e:
        row["error"] = str(e)
        return row
    table = plan.table
    row.update(move_time_s=plan.duration_s, stages=len(table.rates), LE=int(table.separate),
               clock=table.clock.name, top_pps=table.clock.hz / table.rates[0],
               binds=plan.binds, solve_s=plan.solve_s)
    row.update(real_units(motor, job.pulses, row["top_pps"]))
    t0 = time.perf_counter()
    row.update(judge(table, motor, job.samples, job.seed,
                     None if job.load_angle_deg is None else min(job.load_angle_deg, 90.0)))
    row["judge_s"] = time.perf_counter() - t0
    return row


def real_units(motor: Any, pulses: int, top_pps: float | None = None) -> dict[str, Any]:
    """A row's real-unit columns: the move in rev and mm, the top speed in rpm and mm/s
    (mm only with the motor file's travel_mm_per_rev; the speeds once planned)."""
    from profiles.motor.travel import AxisUnits, axis_units

    rev, u = AxisUnits(int(motor.steps_per_rev)), axis_units(motor)
    out: dict[str, Any] = {"move_rev": rev.distance(pulses),
                           "travel_mm_per_rev": u.mm_per_rev,
                           "move_mm": u.distance(pulses) if u.linear else None}
    if top_pps is not None:
        out.update(top_rpm=rev.speed(top_pps), top_mm_s=u.speed(top_pps) if u.linear else None)
    return out


def judge(table: Any, motor: Any, samples: int, seed: int,
          aim_deg: float | None = None) -> dict[str, Any]:
    """The safety verdict (verify.safety) as a row's columns; `safety` holds its whole
    JSON object, as `check --motor --format json` shows it."""
    import json

    from profiles.motor.angles import AIM_DEG
    from verify.safety import judge_safety

    verdict = judge_safety(table, motor, samples=samples, seed=seed,
                           aim_deg=AIM_DEG if aim_deg is None else aim_deg)
    j = verdict.to_json()
    box = j["tolerance_box"]
    return {"worst_load_angle_deg": j["worst_load_angle_deg"], "safe": verdict.safe,
            "failed": ";".join(verdict.failed), "margin_deg": j["margin_deg"],
            "worst_pulses": j["worst_pulses"], "corners": box["corners"] if box else 1,
            "samples": box["samples"] if box else 0,
            "sample_failures": box["sample_failures"] if box else 0,
            "stall_probability_upper": box["stall_probability_upper"] if box and samples
            else None, "safety": json.dumps(j, sort_keys=True)}


def jobs_of(motors: Sequence[tuple[str, dict[str, Any]]], pulses: Sequence[int], *,
            samples: int, seed: int = 0, load_angle_deg: float | None = 75.0,
            cruise_reserve: str = "2x,10%") -> list[Job]:
    """One job per motor and move length, motors outermost. The load-angle target and
    the cruise reserve are checked here, once: past their range every job would fail
    alike."""
    from profiles.motor.reserve import parse_cruise_reserve

    check_options(load_angle_deg=load_angle_deg)
    parse_cruise_reserve(cruise_reserve)
    return [Job(name, obj, int(n), samples, seed, load_angle_deg, cruise_reserve)
            for name, obj in motors for n in pulses]


DEFAULT_TIMEOUT_S = 10.0   # a scheduler on the network answers in milliseconds
TIMEOUT_MAX_S = 3600.0
WORKERS_MAX = 256
WARM_MODULE = "verify.sweep_worker"  # what the local workers' forkserver imports first


def run_sweep(jobs: Sequence[Job], *, workers: int = 1, scheduler: str | None = None,
              timeout_s: float = DEFAULT_TIMEOUT_S,
              progress: Progress | None = None) -> list[dict[str, Any]]:
    """Every job's row, in job order: in this process (workers 1, no scheduler), on
    `workers` local processes, or on the Dask cluster at `scheduler`, waiting at most
    `timeout_s` for it to answer (see the module's docstring)."""
    check_options(workers=workers, timeout_s=timeout_s)
    if scheduler is not None:
        scheduler_address(scheduler)
    report(progress, 0, len(jobs))
    if scheduler is not None:
        return _on_cluster(jobs, scheduler, float(timeout_s), progress)
    if workers == 1 or len(jobs) < 2:
        rows = []
        for i, job in enumerate(jobs, start=1):
            rows.append(run_job(job))
            report(progress, i, len(jobs))
        return rows
    return _on_processes(jobs, workers, progress)


def check_options(*, workers: int = 1, timeout_s: float = DEFAULT_TIMEOUT_S,
                  load_angle_deg: float | None = None) -> None:
    """The numbers a sweep takes, each in its range (FieldRangeError naming it): NaN, ±inf
    and negatives never pass."""
    require_int("workers", workers, 1, WORKERS_MAX)
    require_number("timeout [s]", timeout_s, 0.0, TIMEOUT_MAX_S, lo_open=True)
    if load_angle_deg is not None:
        from profiles.motor.rotor import PEAK_DEG

        require_number("load angle target [°]", load_angle_deg, 1.0, PEAK_DEG)


# --- local processes ---------------------------------------------------------------------------
def _on_processes(jobs: Sequence[Job], workers: int,
                  progress: Progress | None) -> list[dict[str, Any]]:
    import multiprocessing
    from concurrent.futures.process import BrokenProcessPool

    context = multiprocessing.get_context("forkserver")
    # takes effect when the forkserver starts (once per process): see the module docstring
    context.set_forkserver_preload([WARM_MODULE])
    pool = ProcessPoolExecutor(min(workers, len(jobs)), mp_context=context,
                               initializer=_ignore_sigint)
    try:
        return _collect(pool, jobs, progress)
    except BrokenProcessPool:
        raise ClusterError("a local worker process died (killed, or out of memory?): the "
                           "sweep stopped") from None
    except BaseException:  # Ctrl-C: end the workers now, not after their current jobs
        _end_workers(pool)
        raise
    finally:
        pool.shutdown(wait=True, cancel_futures=True)


def _ignore_sigint() -> None:
    # A terminal's Ctrl-C reaches the whole process group: the parent handles it (it ends
    # the workers); a worker interrupted on its own would print a traceback and go on.
    signal.signal(signal.SIGINT, signal.SIG_IGN)


def _end_workers(pool: ProcessPoolExecutor) -> None:
    end = getattr(pool, "terminate_workers", None)  # Python ≥ 3.14
    if end is not None:
        end()
        return
    for process in list((getattr(pool, "_processes", None) or {}).values()):
        process.terminate()


def _collect(executor: Executor, jobs: Sequence[Job],
             progress: Progress | None) -> list[dict[str, Any]]:
    futures: dict[Future[dict[str, Any]], int] = {executor.submit(run_job, job): i
                                                  for i, job in enumerate(jobs)}
    rows: list[dict[str, Any] | None] = [None] * len(jobs)
    for done, future in enumerate(as_completed(futures), start=1):
        rows[futures[future]] = future.result()
        report(progress, done, len(jobs))
    return [r for r in rows if r is not None]


# --- a Dask cluster ----------------------------------------------------------------------------
SCHEDULER_SCHEMES = ("tcp", "tls", "ws", "wss", "ucx")
_HOST_PORT = re.compile(r"(\[[0-9A-Fa-f:.]+\]|[A-Za-z0-9](?:[A-Za-z0-9.-]{0,251}[A-Za-z0-9])?)"
                        r":([0-9]{1,5})")
ECHO_CHARS = 60


def scheduler_address(text: str, name: str = "scheduler") -> str:
    """`text` if a Dask client can connect to it: SCHEME://HOST:PORT (tcp, tls, ws, wss,
    ucx), HOST:PORT (tcp), or inproc://… (a cluster in this process); else a one-line
    FormatError naming `name`, at once rather than after a connect timeout."""
    scheme, sep, rest = text.partition("://")
    if not sep:
        scheme, rest = "tcp", text
    if scheme == "inproc" and rest.isprintable() and rest.strip() == rest != "":
        return text
    found = _HOST_PORT.fullmatch(rest) if scheme in SCHEDULER_SCHEMES else None
    if found is None:
        hint = ("; http:// is the dashboard's, the scheduler listens on tcp:// (port 8786 by "
                "default)") if scheme in ("http", "https") else ""
        raise FormatError(f"{name} {_echo(text)}: not a Dask scheduler address: give "
                          f"tcp://HOST:PORT (or tls://, ws://, wss://, ucx://){hint}")
    require_int(f"{name} port", int(found[2]), 1, 65535)
    return text


def _echo(text: str) -> str:
    """An input as a message shows it: quoted, and cut when long."""
    if len(text) <= ECHO_CHARS:
        return repr(text)
    return f"{text[:ECHO_CHARS]!r}… ({len(text)} characters)"


def _on_cluster(jobs: Sequence[Job], address: str, timeout_s: float,
                progress: Progress | None) -> list[dict[str, Any]]:
    try:
        import distributed  # noqa: F401
    except ImportError:
        raise FormatError("--scheduler needs Dask: pip install 'stepramp[cluster]'") from None
    probe_scheduler(address, timeout_s)
    work = _cluster_rows(jobs, address, timeout_s, progress)
    with _quiet("distributed"):
        try:
            asyncio.get_running_loop()
        except RuntimeError:  # the usual case: no event loop runs in this thread
            return asyncio.run(work)
        from concurrent.futures import ThreadPoolExecutor

        with ThreadPoolExecutor(1) as thread:  # called from a running loop (a notebook)
            return thread.submit(asyncio.run, work).result()


# A Dask handshake is some hundred bytes; a text banner read as its length is petabytes
# (Dask allocated it: "MemoryError: Unable to allocate 3.07 EiB").
HANDSHAKE_MAX_BYTES = 1 << 26


def probe_scheduler(address: str, timeout_s: float) -> None:
    """Before Dask connects to a tcp:// address: is something there, and does it speak
    first as a Dask scheduler does? On accepting, a scheduler sends its handshake, whose
    first 8 bytes are the message's length (distributed.comm.tcp). A refused connection
    is said at once (Dask retries until its timeout, then says TimeoutError), and a
    server that is not Dask in one line (Dask read its first bytes as a length and
    tried to allocate it). Other schemes (tls, ws, ucx, inproc) are left to Dask."""
    scheme, sep, rest = address.partition("://")
    found = _HOST_PORT.fullmatch(rest if sep else address)
    if (sep and scheme != "tcp") or found is None:
        return
    host, port = found[1].strip("[]"), int(found[2])
    deadline = time.monotonic() + timeout_s
    try:
        sock = socket.create_connection((host, port), timeout=timeout_s)
    except ConnectionRefusedError:
        raise ClusterError(f"no Dask scheduler at {address}: connection refused (nothing "
                           "listens on that port)") from None
    except TimeoutError:
        raise ClusterError(f"no Dask scheduler answered at {address} within {timeout_s:g} s "
                           "(no connection)") from None
    except OSError as e:
        raise ClusterError(f"no Dask scheduler at {address}: {e.strerror or _why(e)}") from None
    with sock:
        head = _first_bytes(sock, 8, deadline)
    if head is None:
        raise ClusterError(f"no Dask scheduler answered at {address} within {timeout_s:g} s "
                           "(the server accepted the connection and sent nothing: not a "
                           "Dask scheduler?)")
    size = struct.unpack("Q", head)[0] if len(head) == 8 else 0
    if not 0 < size <= HANDSHAKE_MAX_BYTES:
        raise ClusterError(f"the server at {address} is not a Dask scheduler (its first bytes: "
                           f"{head!r}; a scheduler's handshake starts with its length)")


def _first_bytes(sock: socket.socket, n: int, deadline: float) -> bytes | None:
    """Up to `n` bytes a peer sends first (fewer: it closed); None when it sends
    nothing before `deadline`."""
    head = b""
    try:
        while len(head) < n:
            sock.settimeout(max(deadline - time.monotonic(), 1e-3))
            chunk = sock.recv(n - len(head))
            if not chunk:
                break
            head += chunk
    except TimeoutError:
        return head or None
    except OSError:  # reset by the peer: what it sent is all there is
        pass
    return head


@contextlib.contextmanager
def _quiet(package: str) -> Iterator[None]:
    """A package's log lines off (its loggers may set their own levels): the sweep says
    what went wrong in its one line."""
    import logging

    names = [n for n in list(logging.root.manager.loggerDict)
             if n == package or n.startswith(package + ".")]
    loggers = [logging.getLogger(n) for n in names]
    levels = [log.level for log in loggers]
    for log in loggers:
        log.setLevel(logging.CRITICAL)
    try:
        yield
    finally:
        for log, level in zip(loggers, levels, strict=True):
            log.setLevel(level)


async def _cluster_rows(jobs: Sequence[Job], address: str, timeout_s: float,
                        progress: Progress | None) -> list[dict[str, Any]]:
    from distributed import Client

    client = Client(address, asynchronous=True, timeout=timeout_s, set_as_default=False)
    waiting: dict[asyncio.Future[Any], int] = {}
    try:
        try:
            await asyncio.wait_for(client, timeout_s)
        except Exception as e:  # connecting is I/O: whatever fails, no scheduler answered
            raise ClusterError(f"no Dask scheduler answered at {address} within "
                               f"{timeout_s:g} s ({_why(e)})") from None
        futures = client.map(run_job, list(jobs), pure=False)
        waiting = {asyncio.ensure_future(_result(f)): i for i, f in enumerate(futures)}
        rows: list[dict[str, Any] | None] = [None] * len(jobs)
        pending = set(waiting)
        while pending:
            done, pending = await asyncio.wait(pending, timeout=timeout_s,
                                               return_when=asyncio.FIRST_COMPLETED)
            if not done:
                await _check_cluster(client, address, timeout_s)
            for task in done:
                rows[waiting[task]] = _row_of(task, jobs[waiting[task]])
            report(progress, len(jobs) - len(pending), len(jobs))
        return [r for r in rows if r is not None]
    finally:
        for task in waiting:
            task.cancel()
        with contextlib.suppress(Exception):
            await asyncio.wait_for(client.close(), timeout_s)


async def _result(future: Any) -> dict[str, Any]:
    row: dict[str, Any] = await future.result()  # an asynchronous client's future
    return row


async def _check_cluster(client: Any, address: str, timeout_s: float) -> None:
    """After `timeout_s` without a finished job: the scheduler answers, with workers."""
    try:
        info = await asyncio.wait_for(client.scheduler.identity(), timeout_s)
    except Exception as e:
        raise ClusterError(f"the Dask scheduler at {address} stopped answering (no reply "
                           f"within {timeout_s:g} s: {_why(e)})") from None
    if not info.get("n_workers", len(info.get("workers", ()))):
        raise ClusterError(f"the Dask cluster at {address} has no workers: no job finished "
                           f"in {timeout_s:g} s")


def _row_of(task: asyncio.Future[Any], job: Job) -> dict[str, Any]:
    name = f"the job {job.motor} × {job.pulses} pulses"
    if task.cancelled():  # the future was cancelled on the cluster (not by us: we wait)
        raise ClusterError(f"{name} was cancelled on the Dask cluster")
    error = task.exception()
    if error is not None:
        raise ClusterError(f"{name} failed on the Dask cluster: {_why(error)}")
    row: dict[str, Any] = task.result()
    return row


def _why(e: BaseException) -> str:
    """An exception in a few words: its class and its first line, cut."""
    text = str(e).strip()
    first = text.splitlines()[0] if text else ""
    if len(first) > 2 * ECHO_CHARS:
        first = first[:2 * ECHO_CHARS] + "…"
    return type(e).__name__ + (f": {first}" if first else "")


def encode_rows(rows: Sequence[dict[str, Any]], path: str) -> bytes | str:
    """The rows as CSV text, or Parquet bytes when `path` ends in .parquet (pyarrow)."""
    if str(path).endswith(".parquet"):
        try:
            import pyarrow as pa
            import pyarrow.parquet as pq
        except ImportError:
            raise FormatError("Parquet output needs pyarrow: pip install 'stepramp[cluster]'") \
                from None
        buf = io.BytesIO()
        pq.write_table(pa.Table.from_pylist([{k: r.get(k) for k in COLUMNS} for r in rows]), buf)
        return buf.getvalue()
    out = io.StringIO()
    writer = csv.DictWriter(out, fieldnames=COLUMNS, lineterminator="\n")
    writer.writeheader()
    for r in rows:
        writer.writerow({k: _cell(r.get(k)) for k in COLUMNS})
    return out.getvalue()


def _cell(v: Any) -> Any:
    if v is None:
        return ""
    if isinstance(v, float):
        return repr(v)
    return v


PLANNED = "from the length a table was planned for (open circle)"


def sweep_figure(rows: Sequence[dict[str, Any]], aim_deg: float | None = None, *,
                 units: dict[str, Any] | None = None) -> Any:
    """Move time against the move length each table was planned for, one line per motor;
    each table's worst load angle (over every move length it can run) at the length where
    it occurs (`worst_pulses`), joined to the length it was planned for; the 90° peak, and
    the aim the tables were tightened to (`aim_deg`, when below the peak). `units`: motor
    name → `profiles.motor.travel.AxisUnits` to draw lengths in (every motor's own: rev or
    mm); None: pulses."""
    from profiles.motor.angles import PEAK_DEG
    from verify.plot import pyplot

    plt = pyplot()
    fig, (ax_t, ax_a) = plt.subplots(2, 1, figsize=(8, 7.5), sharex=True,
                                     constrained_layout=True)
    unit = "pulses" if not units else next(iter(units.values())).distance_unit
    for i, name in enumerate(dict.fromkeys(r["motor"] for r in rows)):
        mine = sorted((r for r in rows if r["motor"] == name and not r["error"]),
                      key=lambda r: r["pulses"])
        if not mine:
            continue
        length = (lambda p: p) if not units else units[name].distance
        n = [length(r["pulses"]) for r in mine]
        ax_t.plot(n, [r["move_time_s"] for r in mine], marker="o", color=f"C{i}", label=name)
        at = [r for r in mine if r.get("worst_pulses") not in (None, "")]
        for r in at:  # from the length planned for to the length where the worst is
            ax_a.plot([length(r["pulses"]), length(r["worst_pulses"])],
                      [r["worst_load_angle_deg"]] * 2, color=f"C{i}", lw=0.8, ls=":",
                      marker="o", mfc="none", markevery=[0], label=PLANNED)
        ax_a.plot([length(r["worst_pulses"]) for r in at],
                  [r["worst_load_angle_deg"] for r in at], ls="none", marker="o",
                  color=f"C{i}", label=f"{name}: each table's worst")
    ax_a.axhline(PEAK_DEG, color="red", lw=1, ls="--", label=f"{PEAK_DEG:g}° peak")
    if aim_deg is not None and aim_deg < PEAK_DEG:
        ax_a.axhline(aim_deg, color="orange", lw=1, ls=":", label=f"{aim_deg:g}° aim")
    ax_t.set(xscale="log", yscale="log", ylabel="move time [s]",
             xlabel=f"move length planned for [{unit}]",
             title="stepramp sweep: robust tables")
    ax_t.xaxis.set_tick_params(labelbottom=True)
    ax_a.set(xscale="log", xlabel=f"move length where the worst load angle occurs [{unit}]",
             ylabel="worst load angle [° electrical]")
    ax_t.legend(fontsize=7)
    handles, labels = ax_a.get_legend_handles_labels()
    once = dict(zip(labels, handles, strict=True))  # the joins: one entry
    ax_a.legend(once.values(), once.keys(), fontsize=7)
    return fig
