"""Synchronised multi-axis moves: planning from an axes file, the report and output files,
ruckig's time- and phase-synchronised durations, the figures, and the joint timeline.

Definitions (docs/manual-notes.md, "Synchronised axes"):
- every axis starts at t = 0 (one trigger) and its pulses land at its chip's exact
  instants (`Execution.pulse_times_s`); `duration_s` is `simulate`'s;
- finish spread = latest minus earliest `duration_s`;
- line deviation = the largest distance, in pulses (each axis's pulse one unit: the
  longest axis's pulse when they have the same pitch), between the joint path as the
  chips emit it and the straight line from start to end, over every instant any axis
  pulses (`profiles.ppmc312.sync.line_deviation_times`).
"""

from __future__ import annotations

import json
import math
from collections.abc import Sequence
from dataclasses import dataclass
from typing import Any

import numpy as np

from profiles.alink import sync as alink_sync
from profiles.axes import AxesFile
from profiles.errors import FormatError
from profiles.motor import Motor
from profiles.ppmc312 import sync as ppmc_sync
from profiles.ppmc312.execution import Execution
from profiles.ppmc312.sync import line_deviation_times, spread_tolerance_s
from profiles.pulses import PulseTrain

Plan = ppmc_sync.SyncPlan | alink_sync.AlinkSyncPlan
AxisPlan = ppmc_sync.AxisMove | alink_sync.AlinkAxisMove


def plan_axes_list(plan: Plan) -> list[AxisPlan]:
    """The plan's axes, typed for either device."""
    return list(plan.axes)


def _triples(axes: AxesFile) -> list[tuple[str, Motor, int]]:
    out = []
    for a in axes.axes:
        if a.motor is None:
            raise FormatError(f"axis {a.name}: sync plans from motors; it gives a table "
                              "(use `stepramp simulate --axes` for a set of tables)")
        out.append((a.name, a.motor, a.pulses))
    return out


def plan_axes(axes: AxesFile) -> Plan:
    """The synchronised plan for an axes file (its device and mode)."""
    triples = _triples(axes)
    if axes.device == "alink":
        return alink_sync.plan_sync(triples, axes.mode)
    return ppmc_sync.plan_sync(triples, axes.mode)


def pulse_times(plan: Plan) -> list[np.ndarray]:
    """Each axis's pulse instants [s] (the chip's exact ones; the A-Link's modelled)."""
    if isinstance(plan, alink_sync.AlinkSyncPlan):
        return [a.pulse_times_s() for a in plan.axes]
    return [a.execution.pulse_times_s() for a in plan.axes]


def pulse_trains(plan: Plan) -> list[PulseTrain]:
    """Each axis's pulse instants as pieces (`profiles.pulses`): any number of pulses in
    bounded memory, for the line deviation and the figure."""
    if isinstance(plan, alink_sync.AlinkSyncPlan):
        return [alink_sync.pulse_train(a.settings, abs(a.pulses)) for a in plan.axes]
    return [ppmc_sync.pulse_train(a.execution) for a in plan.axes]


def durations(plan: Plan) -> list[float]:
    return [a.duration_s for a in plan_axes_list(plan)]


# --------------------------------------------------------------------------- ruckig
@dataclass(frozen=True)
class RuckigSync:
    """ruckig's synchronised durations for the same per-axis limits, bracketing the
    torque curve (constant limits: the least capability over each axis's speeds is a
    feasible bound, the largest an infeasible one) — see verify.references.ruckig_ref."""

    time_feasible_s: float
    phase_feasible_s: float
    time_optimistic_s: float
    phase_optimistic_s: float
    v_max_pps: tuple[float, ...]
    trajectories: dict[str, tuple[np.ndarray, np.ndarray, np.ndarray]]  # t, x[axes], v[axes]

    def to_json(self) -> dict[str, Any]:
        return {"time_synchronised_s": self.time_feasible_s,
                "phase_synchronised_s": self.phase_feasible_s,
                "time_synchronised_optimistic_s": self.time_optimistic_s,
                "phase_synchronised_optimistic_s": self.phase_optimistic_s,
                "v_max_pps": list(self.v_max_pps)}


def ruckig_sync(motors: Sequence[Motor], pulses: Sequence[int], *, samples: int = 801
                ) -> RuckigSync:
    """Ruckig(n_dofs) with Synchronization.Time and .Phase, normalised units (each axis's
    position / its pulses, time / the longest axis's t_ref): see REFERENCES.md.

    Per axis: v0 = min(start, jump) (phase: the boundary speeds are made proportional,
    each at most its own, and every limit in the line's normalised coordinate is the least
    of the axes', or ruckig falls back to time synchronisation); the feasible
    bound takes each axis's speed cap that makes its own move fastest (as
    `ruckig_reference` does) and min a_acc / min a_dec over [v0, cap]; the optimistic
    one v_lim and the largest a_acc / a_dec over [0, v_lim]; jerk: max_jerk_pps3 or none.
    """
    from ruckig import InputParameter, Result, Ruckig, Synchronization, Trajectory

    from profiles.errors import ReferenceSolveError
    from verify.references._common import move_limits
    from verify.references.ruckig_ref import _max_over, _v_max_candidates

    n = len(motors)
    dist = [float(abs(p)) for p in pulses]
    lims = [move_limits(m, d) for m, d in zip(motors, dist, strict=True)]
    t_ref = max(lim.t_ref_s for lim in lims)

    def solve(v0: list[float], vmax: list[float], acc: list[float], dec: list[float],
              sync: Any) -> Any:
        inp = InputParameter(n)
        inp.current_position = [0.0] * n
        inp.target_position = [1.0] * n
        # phase: ruckig checks collinearity to machine epsilon, so proportional boundary
        # speeds must be the very same normalised float on every axis
        vn = [v0[i] * t_ref / dist[i] for i in range(n)]
        if sync == Synchronization.Phase:
            vn = [min(vn)] * n
        inp.current_velocity = vn
        inp.target_velocity = list(inp.current_velocity)
        inp.current_acceleration = [0.0] * n
        inp.target_acceleration = [0.0] * n
        vm = [vmax[i] * t_ref / dist[i] for i in range(n)]
        am = [acc[i] * t_ref**2 / dist[i] for i in range(n)]
        dm = [dec[i] * t_ref**2 / dist[i] for i in range(n)]
        jm = [math.inf if m.max_jerk_pps3 is None else m.max_jerk_pps3 * t_ref**3 / dist[i]
              for i, m in enumerate(motors)]
        if sync == Synchronization.Phase:
            # On the line every axis runs the same normalised profile, so each limit is the
            # least of the axes'. (Given per-axis limits, ruckig only scales the limiting
            # axis's profile and falls back to time synchronisation when that breaks another
            # axis's limit: no straight line at all.)
            vm, am, dm, jm = ([min(x)] * n for x in (vm, am, dm, jm))
        inp.max_velocity = vm
        inp.max_acceleration = am
        inp.min_acceleration = [-x for x in dm]
        inp.max_jerk = jm
        inp.synchronization = sync
        traj = Trajectory(n)
        try:
            result = Ruckig(n).calculate(inp, traj)
        except RuntimeError as exc:
            raise ReferenceSolveError(f"ruckig: {str(exc).splitlines()[0]}") from exc
        if result != Result.Working:
            raise ReferenceSolveError(f"ruckig: calculation failed ({result})")
        return traj

    v0 = [lim.v0_pps for lim in lims]
    caps = []
    for i, (m, lim) in enumerate(zip(motors, lims, strict=True)):
        def own(v: float, i: int = i, m: Motor = m) -> float:
            a = float(m.min_a_acc_pps2(v0[i], v))
            if a <= 0:
                return math.inf
            d = float(m.min_a_dec_pps2(v0[i], v))
            one = RuckigSync1(dist[i], v0[i], v, a, d, m.max_jerk_pps3)
            return one.duration()
        caps.append(min(_v_max_candidates(m, v0[i], lim.v_lim_pps), key=own))
    feas_acc = [float(m.min_a_acc_pps2(v0[i], caps[i])) for i, m in enumerate(motors)]
    feas_dec = [float(m.min_a_dec_pps2(v0[i], caps[i])) for i, m in enumerate(motors)]
    opt_acc = [_max_over(m, m.a_acc_pps2, 0.0, lims[i].v_lim_pps) for i, m in enumerate(motors)]
    opt_dec = [_max_over(m, m.a_dec_pps2, 0.0, lims[i].v_lim_pps) for i, m in enumerate(motors)]
    v_lim = [lim.v_lim_pps for lim in lims]
    share = min(v0[i] / dist[i] for i in range(n))
    v0_phase = [share * dist[i] for i in range(n)]
    out: dict[str, float] = {}
    trajs: dict[str, tuple[np.ndarray, np.ndarray, np.ndarray]] = {}
    for name, sync, start in (("time", Synchronization.Time, v0),
                              ("phase", Synchronization.Phase, v0_phase)):
        traj = solve(start, caps, feas_acc, feas_dec, sync)
        out[f"{name}_feasible"] = float(traj.duration) * t_ref
        t_n = np.linspace(0.0, float(traj.duration), samples)
        pv = [traj.at_time(float(t)) for t in t_n]
        x = np.array([[p[0][i] * dist[i] for i in range(n)] for p in pv])
        v = np.array([[p[1][i] * dist[i] / t_ref for i in range(n)] for p in pv])
        trajs[name] = (t_n * t_ref, x, v)
        out[f"{name}_optimistic"] = float(solve(start, v_lim, opt_acc, opt_dec,
                                                sync).duration) * t_ref
    return RuckigSync(out["time_feasible"], out["phase_feasible"], out["time_optimistic"],
                      out["phase_optimistic"], tuple(caps), trajs)


@dataclass(frozen=True)
class RuckigSync1:
    """One axis's own ruckig move (normalised), to choose its speed cap."""

    pulses: float
    v0: float
    vmax: float
    acc: float
    dec: float
    jerk: float | None

    def duration(self) -> float:
        from ruckig import InputParameter, Result, Ruckig, Trajectory

        t_ref = math.sqrt(self.pulses / self.acc)
        inp = InputParameter(1)
        inp.current_position, inp.target_position = [0.0], [1.0]
        inp.current_velocity = [self.v0 * t_ref / self.pulses]
        inp.target_velocity = list(inp.current_velocity)
        inp.current_acceleration, inp.target_acceleration = [0.0], [0.0]
        inp.max_velocity = [self.vmax * t_ref / self.pulses]
        inp.max_acceleration = [self.acc * t_ref**2 / self.pulses]
        inp.min_acceleration = [-self.dec * t_ref**2 / self.pulses]
        inp.max_jerk = [math.inf if self.jerk is None else self.jerk * t_ref**3 / self.pulses]
        traj = Trajectory(1)
        try:
            ok = Ruckig(1).calculate(inp, traj) == Result.Working
        except RuntimeError:
            ok = False
        return float(traj.duration) * t_ref if ok else math.inf


# --------------------------------------------------------------------------- report
def sync_report(plan: Plan, *, device: str, ruckig: RuckigSync | None = None,
                commands: Sequence[bytes | list[tuple[int, int, int]]] | None = None
                ) -> dict[str, Any]:
    """report.json: per axis its duration (as simulate computes it), the finish spread and
    its tolerance, the line deviation, ruckig's synchronised durations beside ours, and
    each PPMC-312 table's safety verdict over every move length (verify.safety, over the
    motor's tolerance box when it has one)."""
    from verify.safety import judge_safety

    times = pulse_trains(plan)
    dev, _, _ = line_deviation_times(times)
    d = durations(plan)
    axes = []
    for i, a in enumerate(plan_axes_list(plan)):
        item: dict[str, Any] = {"name": a.name, "pulses": a.pulses, "duration_s": d[i],
                                "fastest_s": a.fastest_s, "how": a.how}
        if isinstance(a, ppmc_sync.AxisMove):
            item.update(clock=a.table.clock.name, stages=len(a.table.rates),
                        top_pps=a.table.clock.hz / a.table.rates[0],
                        separate_decel=a.table.separate, shape=a.execution.shape,
                        first_pulse_latency_s=a.execution.first_pulse_latency_s,
                        safety=judge_safety(a.table, a.motor).to_json())
        else:
            s = a.settings
            item.update(start_pps=s.start_pps, high_pps=s.high_pps, up_time_para=s.accel_para,
                        multiplier=s.multiplier,
                        stall_safe=alink_sync.is_stall_safe(s, a.motor))
        if commands is not None:
            c = commands[i]
            item["move_command"] = (" ".join(f"{b:02X}" for b in c) if isinstance(c, bytes)
                                    else [" ".join(f"{w:04X}" for w in ws) for ws in c])
        axes.append(item)
    spread = max(d) - min(d)
    out: dict[str, Any] = {
        "format": "stepramp.sync-report/1", "device": device, "mode": plan.mode,
        "duration_s": max(d), "unsynchronised_s": plan.unsynchronised_s,
        "finish_spread_s": spread, "finish_spread_tolerance_s": spread_tolerance_s(max(d)),
        "max_line_deviation_pulses": dev, "info": plan.info, "axes": axes}
    if ruckig is not None:
        out["ruckig"] = ruckig.to_json()
    return out


# --------------------------------------------------------------------------- files
# Every device file sync writes goes through its device's format table and carries its
# check: uploads, move commands and command words a CRC-32, Intel HEX its record
# checksums; axes.h holds each axis's symbols (prefixed with its name) with their own
# CRC-32 (`profiles.ppmc312.formats.parse_c_set`, `profiles.alink.formats.parse_c_set`
# read them back verified). The table, axes and report JSON are documents, not bytes a
# device takes: they carry no check.
SYNC_HEADER_NAME = "stepramp_sync"  # axes.h's include guard STEPRAMP_SYNC_H
MOVE_SUFFIX = "_move"              # a PPMC-312 axis's move command in axes.h: NAME_move_…
# the files of each axis (NAME.suffix) and the shared ones, by device; report.json too
AXIS_FILES = {"ppmc312": (".table.json", ".upload.hex", ".upload.ihex", ".move.hex"),
              "alink": (".settings.json", ".commands.hex")}
SHARED_FILES = {"ppmc312": ("axes.h", "axes.json"), "alink": ("axes.h",)}
REPORT_FILE = "report.json"


def output_names(names: Sequence[str], device: str) -> list[str]:
    """The names of every file sync writes into its folder for axes `names`."""
    return ([n + suffix for n in names for suffix in AXIS_FILES[device]]
            + [*SHARED_FILES[device], REPORT_FILE])


def check_axis_names(names: Sequence[str], device: str) -> None:
    """Refuse axis names that cannot prefix the symbols of axes.h, before any planning:
    a C identifier that is no keyword, and (PPMC-312) no axis named like another's move
    command (x and x_move would both declare X_MOVE_…; compared ignoring case, as the
    macros are upper case)."""
    from profiles.formats import c_name

    taken = {n.lower() for n in names}
    for n in names:
        c_name(n, "axis name")
        if device != "alink" and (n + MOVE_SUFFIX).lower() in taken:
            raise FormatError(f"axis {n}{MOVE_SUFFIX}: the C symbols of axis {n}'s move "
                              f"command are named {n}{MOVE_SUFFIX}_…; rename one of the axes")


def ppmc_files(plan: ppmc_sync.SyncPlan, *, trigger: int = ppmc_sync.TRIGGER_EVENT1,
               command: str | None = None) -> dict[str, bytes]:
    """Every output file of a PPMC-312 plan, by name: NAME.table.json, NAME.upload.hex and
    NAME.upload.ihex (the upload, CRC-32 / record checksums), NAME.move.hex (the move
    command, trigger bits set, CRC-32), axes.h (every axis's blocks as NAME_… and move
    command as NAME_move_…, each with its CRC-32) and axes.json (the tables as an axes
    file, for `stepramp simulate --axes`). `command` is the command line, for axes.h's
    provenance."""
    from profiles.formats import Provenance, RenderOptions
    from profiles.ppmc312 import encode_table
    from profiles.ppmc312.formats import FORMATS, render_c_set
    from profiles.ppmc312.table import dump_table

    check_axis_names([a.name for a in plan.axes], "ppmc312")
    files: dict[str, bytes] = {}
    uploads: list[tuple[str, Sequence[bytes], str]] = []
    for a in plan.axes:
        blocks = encode_table(a.table)
        move = ppmc_sync.move_command(a, trigger)
        table, hex_file, ihex_file, move_file = (a.name + s for s in AXIS_FILES["ppmc312"])
        files[table] = dump_table(a.table).encode()
        files[hex_file] = FORMATS.render(blocks, "text")
        files[ihex_file] = FORMATS.render(blocks, "ihex")
        files[move_file] = FORMATS.render([move], "text")
        uploads += [(a.name, blocks, f"axis {a.name}: {a.pulses} pulses, "
                                     f"{a.duration_s * 1e3:.6g} ms: its table upload"),
                    (a.name + MOVE_SUFFIX, [move], f"axis {a.name}: its move command (82), "
                                                   "held until the trigger")]
    header, axes_file = SHARED_FILES["ppmc312"]
    files[header] = render_c_set(uploads, RenderOptions(name=SYNC_HEADER_NAME, provenance=(
        Provenance(command, (f"One synchronised move ({plan.mode} mode). Per axis: write its "
                            "blocks in order, then its move command; every chip starts when "
                            "event input 1 goes low (TRG 01).",)))))
    # the same move as a set of tables: `stepramp simulate --axes DIR/axes.json`
    files[axes_file] = (json.dumps(
        {"format": "stepramp.axes/1", "mode": plan.mode, "device": "ppmc312",
         "axes": [{"name": a.name, "table": a.name + AXIS_FILES["ppmc312"][0],
                   "pulses": a.pulses}
                  for a in plan.axes]}, indent=1) + "\n").encode()
    return files


def alink_command_lists(plan: alink_sync.AlinkSyncPlan, *, slave_address: int | None = None
                        ) -> list[list[Any]]:
    """Per axis: its settings, MODE_SIG with STA (start with the unit's other axis on the
    simultaneous-start input), and the relative move — `Command`s with pair codes."""
    from profiles import alink

    out = []
    for axis, a in enumerate(plan.axes):
        writer = alink.CommandWriter(address=None if slave_address is None else
                                     alink.command_address(slave_address, axis))
        cmds = alink.settings_commands(a.settings, writer=writer)
        cmds.append(writer.put(alink.Cmd.MODE_SIG, 0, alink_sync.MODE_SIG_STA))
        cmds.append(writer.put(alink.Cmd.MOVE_R, alink.FUNC_MOVE, a.pulses))
        out.append(cmds)
    return out


def alink_commands(plan: alink_sync.AlinkSyncPlan, *, slave_address: int | None = None
                   ) -> list[list[tuple[int, int, int]]]:
    """`alink_command_lists` as each command's words."""
    return [[c.words for c in cmds]
            for cmds in alink_command_lists(plan, slave_address=slave_address)]


def alink_files(plan: alink_sync.AlinkSyncPlan, *, command: str | None = None
                ) -> dict[str, bytes]:
    """Every output file of an A-Link plan, by name: NAME.settings.json (the settings
    document of the axis's settings commands, with its pulses and duration, CRC-32),
    NAME.commands.hex (every command: settings, MODE_SIG with STA, MOVE_R; CRC-32) and
    axes.h (each axis's words as NAME_words with its CRC-32); `stepramp alink read`
    reads each back verified."""
    from profiles.alink.formats import FORMATS, render_c_set
    from profiles.formats import Provenance, RenderOptions

    check_axis_names([a.name for a in plan.axes], "alink")
    files: dict[str, bytes] = {}
    sets: list[tuple[str, Sequence[Any], str]] = []
    for a, cmds in zip(plan.axes, alink_command_lists(plan), strict=True):
        settings = cmds[:-2]  # MODE_SIG and MOVE_R are the move, not the settings
        settings_file, commands_file = (a.name + s for s in AXIS_FILES["alink"])
        files[settings_file] = FORMATS.render(settings, "json", RenderOptions(
            header={"pulses": a.pulses, "duration_s": a.duration_s}))
        files[commands_file] = FORMATS.render(cmds, "hex")
        sets.append((a.name, cmds, f"axis {a.name}: {a.pulses} pulses, "
                                   f"{a.duration_s * 1e3:.6g} ms: settings, MODE_SIG (STA), "
                                   "MOVE_R"))
    files[SHARED_FILES["alink"][0]] = render_c_set(sets, RenderOptions(
        name=SYNC_HEADER_NAME,
        provenance=Provenance(command, (f"One synchronised move ({plan.mode} mode).",))))
    return files


# --------------------------------------------------------------------------- timeline
def joint_timeline(names: Sequence[str], executions: Sequence[Execution]) -> str:
    """Every segment boundary of every axis in time order: what each axis runs from then."""
    events = []
    for name, e in zip(names, executions, strict=True):
        hz = e.clock.hz
        for s in e.segments:
            events.append((s.start_tick / hz, name, f"{s.phase} {hz / s.rate:.6g} pps "
                           f"(rate {s.rate}) × {s.pulses}"))
        events.append((e.duration_s, name, f"done: {e.pulses} pulses"))
    events.sort(key=lambda ev: (ev[0], names.index(ev[1])))
    width = max(len(n) for n in names)
    lines = [f"{t * 1e3:12.6f} ms  {name:<{width}}  {what}" for t, name, what in events]
    dev = line_deviation_times([ppmc_sync.pulse_train(e) for e in executions])[0]
    d = [e.duration_s for e in executions]
    lines.append(f"finish spread {(max(d) - min(d)) * 1e6:.3f} µs, line deviation "
                 f"{dev:.4g} pulses")
    return "\n".join(lines) + "\n"


# --------------------------------------------------------------------------- figure
FIGURE_SPEED_POINTS = 400  # an A-Link axis's speed: between this many of its pulses


def sync_figure(plan: Plan, ruckig: RuckigSync | None = None) -> Any:
    """Joint path against the line, deviation over time, each axis's speed against time
    (with ruckig's time- and phase-synchronised speeds when given). Positions and speeds
    are signed (a CCW axis runs negative), every line has a legend entry."""
    from verify.plot import _plt

    plt = _plt()
    trains = pulse_trains(plan)
    dev, t, d = line_deviation_times(trains)  # every instant, or a bounded trace
    fig, (ax_p, ax_d, ax_v) = plt.subplots(3, 1, figsize=(8.0, 10.0), constrained_layout=True,
                                           gridspec_kw={"height_ratios": [4, 2, 3]})
    axes = plan_axes_list(plan)
    sign = [1 if a.pulses >= 0 else -1 for a in axes]
    lead = int(np.argmax([tr.count for tr in trains]))
    names = [a.name for a in axes]
    x = [s * tr.emitted(t) for s, tr in zip(sign, trains, strict=True)]
    for i, name in enumerate(names):
        if i == lead and len(names) > 1:
            continue
        line = ax_p.step(x[lead], x[i], where="post", lw=1.2, label=f"{name} (executed)")[0]
        ax_p.plot([0, axes[lead].pulses], [0, axes[i].pulses], ls="--", lw=0.8,
                  color=line.get_color(), alpha=0.7, label=f"{name}: the straight line")
    ax_p.set(xlabel=f"{names[lead]} [pulses]", ylabel="other axes [pulses]",
             title=f"{plan.mode} mode: joint path against the straight line\n"
                   f"(max deviation {dev:.3g} pulses)")
    ax_p.legend(fontsize=8)
    ax_d.step(t * 1e3, d, where="post", color="tab:red", lw=1.0,
              label="distance of the joint path to the line")
    ax_d.set(xlabel="time [ms]", ylabel="distance to\nthe line [pulses]")
    ax_d.legend(fontsize=8, loc="upper right")
    for i, a in enumerate(axes):
        label = f"{a.name} ({a.duration_s * 1e3:.2f} ms)"
        if isinstance(a, ppmc_sync.AxisMove):
            te, _, v = a.execution.edges()
            ax_v.step(te * 1e3, sign[i] * v, where="post", lw=1.4, color=f"C{i}", label=label)
        else:  # the modelled speed between pulses spread evenly over the move
            k = np.unique(np.linspace(1, trains[i].count, FIGURE_SPEED_POINTS).astype(np.int64))
            tk = trains[i].time_of(k)
            ax_v.plot(tk[1:] * 1e3, sign[i] * np.diff(k) / np.diff(tk) if len(k) > 1 else [],
                      lw=1.4, color=f"C{i}", label=label)
    if ruckig is not None:
        for key, ls, dur in (("time", "--", ruckig.time_feasible_s),
                             ("phase", ":", ruckig.phase_feasible_s)):
            tr, _, vr = ruckig.trajectories[key]
            for i, name in enumerate(names):
                ax_v.plot(tr * 1e3, sign[i] * vr[:, i], ls=ls, lw=1.0, color=f"C{i}",
                          label=f"ruckig {key}-sync {name} ({dur * 1e3:.2f} ms)")
    ax_v.axhline(0.0, color="0.3", lw=0.6, label="standstill")
    ax_v.set(xlabel="time [ms]", ylabel="speed [pps]\n(negative: CCW)")
    ax_v.legend(fontsize=7, ncols=2, loc="best")
    for ax in (ax_p, ax_d, ax_v):
        ax.grid(alpha=0.3)
    return fig

