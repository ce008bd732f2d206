"""Generate the notebooks (outputs stripped) and the README figure.

    python notebooks/build.py              # notebooks and docs/img/compare-nema17.png
    python notebooks/build.py notebooks    # the .ipynb only
    python notebooks/build.py figures      # the PNG only
    python notebooks/build.py notebooks --out DIR   # write the notebooks elsewhere

The notebooks are written from the cell sources below with fixed cell ids, so
running this twice gives byte-identical files (tests/test_notebooks.py checks
the committed ones against a fresh build). Edit the sources here, not the
.ipynb files.
"""

from __future__ import annotations

import argparse
import sys
from pathlib import Path
from typing import Any

HERE = Path(__file__).resolve().parent
ROOT = HERE.parent
FIGURE = ROOT / "docs" / "img" / "compare-nema17.png"
FIGURE_PULSES = 10_000

Cell = tuple[str, str]  # ("md" | "code", source)

# --------------------------------------------------------------------------- notebook 1
DESIGN: list[Cell] = [
    ("md", """\
# Designing a free curve

From a motor's pull-out torque curve to the fastest stall-safe PPMC-312
free-curve table for one move, how it compares with the continuous time
optimum, and what the safety factor and the stage budget cost in move time."""),
    ("code", """\
import dataclasses

import matplotlib.pyplot as plt
import numpy as np
from matplotlib.ticker import FuncFormatter

from profiles.motor import bundled_motor_paths, load_motor
from profiles.ppmc312.planner import plan_free_curve
from verify.compare import compare_table
from verify.plot import motor_figure
from verify.references import exact_optimum
from verify.criterion import stall_margins

PULSES = 10_000
for path in bundled_motor_paths():
    print(f"{path.name:32s} {load_motor(path).name}")"""),
    ("md", """\
## The motor

Left: pull-out torque, and the share of it the planner may use (× safety
factor). Right: the acceleration that torque gives against the load inertia,
speeding up (friction works against the motor) and slowing down (friction
helps)."""),
    ("code", """\
motor_path = next(p for p in bundled_motor_paths() if "nema17" in p.name)
motor = load_motor(motor_path)
print(motor.name)
print(f"start {motor.start_pps:g} pps, top {motor.top_pps:g} pps, "
      f"safety factor {motor.safety_factor:g}, inertia {motor.inertia_kgm2:g} kg·m²")
motor_figure(motor)
plt.show()"""),
    ("md", """\
## The optimal table for one move

`plan_free_curve` searches the stall-safe staircase (at most 127 stages) with
the shortest move of `PULSES` pulses, as the chip runs it."""),
    ("code", """\
plan = plan_free_curve(motor, pulses=PULSES)
table = plan.table
print(plan.info)
print(f"clock {table.clock.name}, {len(table.rates)} stages, "
      f"separate decel counts (LE=1): {table.separate}")
print(f"move of {PULSES} pulses: {plan.duration_s * 1e3:.3f} ms")"""),
    ("md", """\
## Against the time-optimal references

The staircase (red steps) against the continuous references: the exact
optimum, toppra and casadi (which should agree with it) and ruckig (constant
acceleration limits, so slower). Top: speed against time; middle: speed
against position; bottom: the stall margin of every stage."""),
    ("code", """\
comparison = compare_table(table, motor, PULSES)
print(comparison.to_text())
comparison.figure()
plt.show()"""),
    ("md", """\
## Stall margin per stage

Margin = the acceleration the motor can give over the stage's speed step
÷ the acceleration the step needs (≥ 1 is stall-safe; `inf`: no speed
change). The fastest and slowest stages, and the tightest one:"""),
    ("code", """\
margins = stall_margins(table, motor)
accel_m, decel_m = margins["accel"], margins["decel"]
rows = []
for i, rate in enumerate(table.rates):
    acc = table.accel_pulses[i] if i < len(table.accel_pulses) else None
    dec = table.decel[i] if i < len(table.decel) else None
    rows.append((i, rate, table.clock.hz / rate, acc, dec,
                 accel_m[i] if i < len(accel_m) else None,
                 decel_m[i] if i < len(decel_m) else None))


def fmt(x, spec):
    return "-" if x is None else format(x, spec)


print(f"{'stage':>5} {'rate':>6} {'speed pps':>10} {'accel n':>8} {'decel n':>8} "
      f"{'accel margin':>13} {'decel margin':>13}")
tightest = min(range(len(rows)),
               key=lambda k: min(x for x in (rows[k][5], rows[k][6], np.inf) if x is not None))
shown = sorted(set(range(6)) | set(range(len(rows) - 4, len(rows))) | {tightest})
last = -1
for k in shown:
    if k != last + 1:
        print(f"{'…':>5}")
    i, rate, speed, acc, dec, am, dm = rows[k]
    mark = "  ← tightest" if k == tightest else ""
    print(f"{i:5d} {rate:6d} {speed:10.1f} {fmt(acc, '8d')} {fmt(dec, '8d')} "
          f"{fmt(am, '13.4f')} {fmt(dm, '13.4f')}{mark}")
    last = k
print(f"\\nsmallest margin {margins['min']:.4f}")
assert margins["min"] >= 1.0, "the planned table breaks the stall-safety criterion\""""),
    ("md", """\
## What the safety factor costs

A smaller safety factor leaves more torque in reserve and gives a slower
move. Each variant is a new `Motor` (`dataclasses.replace`); its table is
checked against that motor, and compared with that motor's exact optimum."""),
    ("code", """\
def study(m, **kwargs):
    p = plan_free_curve(m, pulses=PULSES, **kwargs)
    optimum_s = float(exact_optimum(m, PULSES).duration_s)
    margin = stall_margins(p.table, m)["min"]
    assert margin >= 1.0, f"{kwargs}: stall margin {margin}"
    return p, optimum_s, margin


sf_rows = []
for sf in (0.4, 0.5, 0.6, 0.7):
    p, optimum_s, margin = study(dataclasses.replace(motor, safety_factor=sf))
    sf_rows.append((sf, len(p.table.rates), p.duration_s, optimum_s, margin))

print(f"{'safety':>6} {'stages':>6} {'table ms':>9} {'optimum ms':>11} {'ratio':>6} "
      f"{'margin':>7}")
for sf, n, t, opt, margin in sf_rows:
    print(f"{sf:6.2f} {n:6d} {t * 1e3:9.2f} {opt * 1e3:11.2f} {t / opt:6.3f} {margin:7.3f}")"""),
    ("md", """\
## What the stage budget costs

Fewer stages force coarser speed steps; each step must still be stall-safe,
so the ramp gets longer."""),
    ("code", """\
stage_rows = []
for budget in (8, 16, 32, 64, 127):
    p, optimum_s, margin = study(motor, max_stages=budget)
    assert len(p.table.rates) <= budget
    stage_rows.append((budget, len(p.table.rates), p.duration_s, optimum_s, margin))

print(f"{'budget':>6} {'used':>5} {'table ms':>9} {'ratio':>6} {'margin':>7}")
for budget, used, t, opt, margin in stage_rows:
    print(f"{budget:6d} {used:5d} {t * 1e3:9.2f} {t / opt:6.3f} {margin:7.3f}")"""),
    ("code", """\
fig, (ax_sf, ax_n) = plt.subplots(1, 2, figsize=(10, 3.8), constrained_layout=True)
sfs = [r[0] for r in sf_rows]
ax_sf.plot(sfs, [r[2] * 1e3 for r in sf_rows], "o-", color="tab:red", label="table")
ax_sf.plot(sfs, [r[3] * 1e3 for r in sf_rows], "s--", color="0.4", label="exact optimum")
ax_sf.set(xlabel="safety factor", ylabel="move time [ms]",
          title=f"{PULSES} pulses, 127-stage budget")
budgets = [r[0] for r in stage_rows]
ax_n.plot(budgets, [r[2] * 1e3 for r in stage_rows], "o-", color="tab:red", label="table")
ax_n.axhline(stage_rows[0][3] * 1e3, ls="--", color="0.4", label="exact optimum")
ax_n.set_xscale("log", base=2)
ax_n.set_yscale("log")  # 8 stages cost several times the optimum; 64 vs 127 is close
plain = FuncFormatter(lambda y, _pos: f"{y:g}")
ax_n.yaxis.set_major_formatter(plain)
ax_n.yaxis.set_minor_formatter(plain)
ax_n.set_xticks(budgets, [str(b) for b in budgets])
ax_n.set(xlabel="stage budget (max_stages)", ylabel="move time [ms]",
         title=f"{PULSES} pulses, safety factor {motor.safety_factor:g}")
for ax in (ax_sf, ax_n):
    ax.grid(alpha=0.3)
    ax.legend()
plt.show()"""),
]

# --------------------------------------------------------------------------- notebook 2
LINEAR_VS_FREE: list[Cell] = [
    ("md", """\
# Init tables against the free curve

The PPMC-312 builds its own linear or S-curve staircase from the init
command's few parameters; the free-curve command takes every stage. For each
bundled motor and move length: the best stall-safe linear and S-curve init
tables (`plan_init`) against the optimal free curve (`plan_free_curve`)."""),
    ("code", """\
import html
import math

import matplotlib.pyplot as plt
import numpy as np
from IPython.display import HTML, display

from profiles.ppmc312.init_planner import init_candidates, plan_init
from profiles.motor import bundled_motor_paths, load_motor
from profiles.ppmc312.planner import plan_free_curve

LENGTHS = (300, 2_000, 10_000, 100_000)
SHAPES = ("linear", "s_curve")
motors = [load_motor(p) for p in bundled_motor_paths()]
for m in motors:
    print(m.name)"""),
    ("md", """\
The smallest stall-safe pulse counts for each candidate high speed do not
depend on the move, so `init_candidates` runs once per motor and shape and
`plan_init` only simulates each move over them."""),
    ("code", """\
results = []  # (motor, pulses, free plan, {shape: init plan})
for m in motors:
    candidates = {shape: init_candidates(m, shape) for shape in SHAPES}
    for pulses in LENGTHS:
        free = plan_free_curve(m, pulses=pulses)
        inits = {shape: plan_init(m, shape, pulses, candidates=candidates[shape])
                 for shape in SHAPES}
        results.append((m, pulses, free, inits))
        for shape, ip in inits.items():
            # The free curve is optimal over every staircase, the init ones included.
            assert free.duration_s <= ip.duration_s * (1 + 1e-9), (m.name, pulses, shape)
print(f"{len(results)} cases planned")"""),
    ("code", """\
def cell(value, bold=False):
    text = html.escape(str(value))
    return f"<td style='text-align:right'>{'<b>' + text + '</b>' if bold else text}</td>"


head = ("<tr><th>motor</th><th>pulses</th><th>free curve ms</th><th>linear ms</th>"
        "<th>S-curve ms</th><th>linear / free</th><th>S-curve / free</th>"
        "<th>best init table</th></tr>")
body = []
for m, pulses, free, inits in results:
    lin, s = inits["linear"], inits["s_curve"]
    best = min(inits.values(), key=lambda ip: ip.duration_s)
    body.append(
        f"<tr><td>{html.escape(m.name)}</td>{cell(f'{pulses:,}')}"
        + cell(f"{free.duration_s * 1e3:.2f}", bold=True)
        + cell(f"{lin.duration_s * 1e3:.2f}") + cell(f"{s.duration_s * 1e3:.2f}")
        + cell(f"{lin.duration_s / free.duration_s:.3f}")
        + cell(f"{s.duration_s / free.duration_s:.3f}")
        + f"<td style='font-size:85%'>{html.escape(best.info)}</td></tr>")
display(HTML("<table>" + head + "".join(body) + "</table>"))"""),
    ("md", """\
Move time of the best init table ÷ the free curve's (1 = as fast as the free
curve). Long moves are mostly cruise, so the ramps matter less."""),
    ("code", """\
fig, axes = plt.subplots(1, len(motors), figsize=(4.2 * len(motors), 3.8),
                         constrained_layout=True, sharey=True)
for ax, m in zip(np.atleast_1d(axes), motors, strict=True):
    rows = [r for r in results if r[0] is m]
    xs = [r[1] for r in rows]
    for shape, style, label in (("linear", "o-", "best linear init"),
                                ("s_curve", "s--", "best S-curve init")):
        ax.plot(xs, [r[3][shape].duration_s / r[2].duration_s for r in rows], style,
                label=label)
    ax.axhline(1.0, color="k", lw=1, label="free curve")
    ax.set_xscale("log")
    ax.set_xticks(xs, [f"{x:,}" for x in xs])
    ax.set(xlabel="move [pulses]", title=m.name.split(",")[0])
    ax.grid(alpha=0.3, which="both")
np.atleast_1d(axes)[0].set_ylabel("move time / free-curve time")
np.atleast_1d(axes)[0].legend()
plt.show()"""),
    ("code", """\
for m in motors:
    ratios = [r[3][shape].duration_s / r[2].duration_s
              for r in results if r[0] is m for shape in SHAPES]
    gmean = math.exp(sum(math.log(x) for x in ratios) / len(ratios))
    print(f"{m.name}: init tables take {min(ratios):.2f}–{max(ratios):.2f}× the free curve "
          f"(geometric mean {gmean:.2f}×)")"""),
]

# --------------------------------------------------------------------------- notebook 3
UPLOAD: list[Cell] = [
    ("md", """\
# Upload files for the three devices

One plan, written out as the bytes each device takes, then read back and
decoded to show nothing was lost:

- PPMC-312 free-curve upload: hex, C header and bus register writes;
- PPMC-312 ASCII init frame (the best linear init table, LE=0: the serial
  command has no separate decel counts);
- A-Link ALUM settings command words, with the CRC-32 the words lack;
- MC-200 SPI packet stream following the staircase, with the CRC-32 its packet
  checksum cannot give.

The files go to a temporary folder, removed by the last cell."""),
    ("code", """\
import re
import tempfile
from itertools import pairwise
from pathlib import Path

from profiles.alink import plan_settings, settings_commands, settings_from_commands
from profiles.alink import formats as alink_files
from profiles.ppmc312.init_planner import plan_init
from profiles.mc200 import decode_stream, encode_stream, stream_move
from profiles.mc200 import formats as mc200_files
from profiles.motor import bundled_motor_paths, load_motor
from profiles.ppmc312.planner import plan_free_curve
from profiles.ppmc312 import decode_upload, encode_free_curve
from profiles.ppmc312.ascii import decode_serial_init, encode_serial_init
from profiles.ppmc312.formats import parse, parse_upload, render
from profiles.ppmc312.execution import simulate_move
from verify.references import exact_optimum

PULSES = 10_000
motor = load_motor(next(p for p in bundled_motor_paths() if "nema17" in p.name))
plan = plan_free_curve(motor, pulses=PULSES)
print(motor.name)
print(plan.info)

workdir = tempfile.TemporaryDirectory(prefix="stepramp-upload-")
out = Path(workdir.name)


def show(path, lines=6):
    text = path.read_text().splitlines()
    print(f"--- {path.name} ({path.stat().st_size} bytes, {len(text)} lines)")
    print("\\n".join(text[:lines] + (["…"] if len(text) > lines else [])))"""),
    ("md", """\
## PPMC-312 free-curve upload

The command block then the rate and pulse-count parameter blocks, in three
renderings of the same blocks."""),
    ("code", """\
blocks = encode_free_curve(plan.table)
files = {"hex": out / "free-curve.upload.hex", "c": out / "free-curve.h",
         "bus": out / "free-curve.bus.txt"}
for fmt, path in files.items():
    path.write_bytes(render(blocks, fmt))
    show(path)
print(f"\\n{len(blocks)} blocks, {sum(map(len, blocks))} bytes")"""),
    ("code", """\
# Every file carries a CRC-32 of the blocks (the parallel bus itself has no check):
# parse verifies it and says so.
for fmt, path in files.items():
    print(f"{path.name}: {parse(path.read_bytes()).detail}")

# Hex file: parse the blocks back and decode the table.
parsed = parse_upload(files["hex"].read_bytes())
assert parsed == blocks
decoded = decode_upload(parsed)
assert decoded == plan.table
print(f"hex: {len(parsed)} blocks parsed, table decoded equal: {decoded == plan.table}")

# C header: the byte arrays, in block order.
header = files["c"].read_text()
c_blocks = [bytes(int(b, 16) for b in re.findall(r"0x([0-9A-F]{2})", body))
            for body in re.findall(r"stepramp_block_\\d+\\[\\] = \\{([^}]*)\\}", header)]
assert c_blocks == blocks
print(f"C header: {len(c_blocks)} arrays equal to the blocks")

# Bus writes: per block WCR 20, WAR 20 − length, then DWR last byte first.
bus_blocks, data = [], []
for line in files["bus"].read_text().splitlines():
    if line.startswith("#"):  # the CRC-32 line
        continue
    reg, value = line.split()
    if reg == "WCR":
        data = []
    elif reg == "WAR":
        length = 0x20 - int(value, 16)
    else:
        data.append(int(value, 16))
        if len(data) == length:
            bus_blocks.append(bytes(reversed(data)))
assert bus_blocks == blocks
assert decode_upload(bus_blocks) == plan.table
print(f"bus writes: {len(bus_blocks)} blocks rebuilt, table decoded equal")"""),
    ("md", """\
## PPMC-312 ASCII init frame

The best stall-safe linear init table for the same move, with common
accel/decel counts (the serial init command cannot carry separate ones),
sent to slave address 1."""),
    ("code", """\
init = plan_init(motor, "linear", PULSES, separate_decel=False)
print(init.info)
print(f"move of {PULSES} pulses: {init.duration_s * 1e3:.2f} ms "
      f"(free curve {plan.duration_s * 1e3:.2f} ms)")
frame = encode_serial_init(init.table, address=1)
print("frame:", frame)
init_path = out / "init-linear.upload.hex"
init_path.write_bytes(render([frame], "hex"))
show(init_path)

assert decode_serial_init(frame) == init.table
from_file = decode_upload(parse_upload(init_path.read_bytes()))
assert from_file == init.table
print("decoded:", from_file)"""),
    ("md", """\
## A-Link ALUM settings

The fastest stall-safe start speed, high speed and acceleration for this move
(the unit ramps linearly), as command words with pair codes, in a settings file
that carries a CRC-32 of the words (the A-Link protocol has no check)."""),
    ("code", """\
alink = plan_settings(motor, pulses=PULSES)
settings = alink.table
print(settings)
ratio = alink.duration_s / exact_optimum(motor, PULSES).duration_s
print(f"predicted move {alink.duration_s * 1e3:.2f} ms ({alink.extras['shape']}), "
      f"{ratio:.3f}× the exact optimum; bound by {alink.binds}")
commands = settings_commands(settings)
words_path = out / "alink-settings.txt"
words_path.write_bytes(alink_files.render(commands, "text"))
show(words_path, lines=8)"""),
    ("code", """\
parsed = alink_files.parse(words_path.read_bytes())
print(f"{parsed.format} file, {parsed.integrity}: {parsed.detail}")
assert parsed.items == commands
for c in parsed.items:
    print(f"{c.name:10s} func {c.func:2d} para {c.para:7d} pair {c.pair}")
rebuilt = settings_from_commands(parsed.items)
assert rebuilt == settings
print("settings rebuilt from the words:", rebuilt == settings)"""),
    ("md", """\
## MC-200 position stream

The servo follows the staircase's own position (pulses emitted by each
time, from the chip model `simulate_move`), one position command per 250 µs
SPI period."""),
    ("code", """\
execution = simulate_move(plan.table, PULSES)
packets = stream_move(execution.position_at, execution.duration_s, PULSES, period_us=250)
stream_hex = out / "mc200-stream.hex"
stream_bin = out / "mc200-stream.bin"
payload = encode_stream(packets)
for path, fmt in ((stream_hex, "hex"), (stream_bin, "bin")):  # chunk-wise, as the CLI does
    path.write_bytes(b"".join(mc200_files.render_chunks([payload], fmt)))
show(stream_hex, lines=8)

for path in (stream_hex, stream_bin):
    parsed = mc200_files.parse(path.read_bytes())
    back = decode_stream(b"".join(parsed.items))
    assert back == packets, path.name
    print(f"{path.name}: {len(back)} packets decoded equal ({parsed.integrity})")
positions = [p.value for p in back if p.value_kind == "position" and p.servo]
assert positions[-1] == PULSES and positions == sorted(positions)
steps = [b - a for a, b in pairwise(positions)]
print(f"commands rise monotonically to {positions[-1]} pulses; "
      f"largest step per period {max(steps)} pulses")"""),
    ("code", """\
for path in sorted(out.iterdir()):
    print(f"{path.name:28s} {path.stat().st_size:8d} bytes")
workdir.cleanup()  # skip this cell to keep the files"""),
]

def cells_from(name: str) -> list[Cell]:
    """CELLS of notebooks/NAME.py: notebooks kept in a file of their own (eases merging)."""
    import importlib.util

    spec = importlib.util.spec_from_file_location(f"notebook_cells_{name}", HERE / f"{name}.py")
    assert spec is not None and spec.loader is not None
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    return list(module.CELLS)


NOTEBOOKS: dict[str, list[Cell]] = {
    "design-free-curve": DESIGN,
    "linear-vs-free-curve": LINEAR_VS_FREE,
    "upload-files": UPLOAD,
    "two-axis-move": cells_from("two_axis_move"),
    "machine-to-table": cells_from("machine_to_table"),
    "design-interactive": cells_from("design_interactive"),
}


def notebook(stem: str, cells: list[Cell]) -> Any:
    import nbformat
    from nbformat.v4 import new_code_cell, new_markdown_cell, new_notebook

    nb = new_notebook(metadata={
        "kernelspec": {"display_name": "Python 3", "language": "python", "name": "python3"},
        "language_info": {"name": "python"},
    })
    for i, (kind, source) in enumerate(cells):
        c = new_markdown_cell(source) if kind == "md" else new_code_cell(source)
        c.id = f"{stem}-{i:02d}"  # fixed ids: the build is reproducible
        nb.cells.append(c)
    nbformat.validate(nb)
    return nb


def write_notebooks(out_dir: Path) -> list[Path]:
    import nbformat

    out_dir.mkdir(parents=True, exist_ok=True)
    written = []
    for stem, cells in NOTEBOOKS.items():
        path = out_dir / f"{stem}.ipynb"
        nbformat.write(notebook(stem, cells), str(path))
        written.append(path)
    return written


def write_figure(path: Path = FIGURE) -> Path:
    """compare_table(plan.table, NEMA17, 10 000 pulses).figure() as the README PNG."""
    import matplotlib

    matplotlib.use("Agg")
    sys.path.insert(0, str(ROOT))  # a plain checkout works without installing
    from profiles.motor import bundled_motor_paths, load_motor
    from profiles.ppmc312.planner import plan_free_curve
    from verify.compare import compare_table

    motor = load_motor(next(p for p in bundled_motor_paths() if "nema17" in p.name))
    plan = plan_free_curve(motor, pulses=FIGURE_PULSES)
    fig = compare_table(plan.table, motor, FIGURE_PULSES).figure()
    path.parent.mkdir(parents=True, exist_ok=True)
    # Direct savefig: the README image is a committed file, 110 dpi keeps it small.
    fig.savefig(path, dpi=110)
    return path


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("what", nargs="?", choices=("all", "notebooks", "figures"), default="all")
    ap.add_argument("--out", type=Path, default=HERE, help="folder for the notebooks")
    args = ap.parse_args(argv)
    if args.what in ("all", "notebooks"):
        for path in write_notebooks(args.out):
            print(path)
    if args.what in ("all", "figures"):
        print(write_figure())
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
