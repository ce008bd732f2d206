# %% [markdown]
# # Upload files for the three devices
#
# One plan, written out as the bytes each device takes, then read back and
# decoded to show nothing was lost:
#
# - PPMC-312 free-curve upload in REV 1.3 blocks (at most 14 bytes after the
#   length byte): hex, C header and bus register writes, each with the answer the
#   chip gives to every block, and the bus script run through the emulated chip;
# - PPMC-312 ASCII init frame (the best linear init table, LE=0: the serial
#   command has no separate decel counts);
# - A-Link ALUM settings command words, with the CRC-32 the words lack;
# - MC-200 SPI packet stream following the staircase, with the CRC-32 its packet
#   checksum cannot give.
#
# The files go to a temporary folder, removed by the last cell.

# %%
import re
import tempfile
from itertools import pairwise
from pathlib import Path

from profiles.alink import plan_settings, settings_commands, settings_from_commands
from profiles.alink import formats as alink_files
from profiles.mc200 import decode_stream, encode_stream, stream_move
from profiles.mc200 import formats as mc200_files
from profiles import decode_upload, load_motor, plan_free_curve, plan_init, render
from profiles.ppmc312 import encode_free_curve, parse, parse_upload, simulate_move
from profiles.ppmc312.ascii import decode_serial_init, encode_serial_init
from profiles.ppmc312.bus import run_bus_script
from profiles.ppmc312.emulator import expected_answers
from verify.references import exact_optimum

PULSES = 10_000
motor = load_motor("nema17-1600")
plan = plan_free_curve(motor, pulses=PULSES)
print(motor.name)
print(plan.info)

workdir = tempfile.TemporaryDirectory(prefix="stepramp-upload-")
out = Path(workdir.name)


def show(path, lines=6):
    text = path.read_text().splitlines()
    print(f"--- {path.name} ({path.stat().st_size} bytes, {len(text)} lines)")
    print("\n".join(text[:lines] + (["…"] if len(text) > lines else [])))


# %% [markdown]
# ## PPMC-312 free-curve upload
#
# The command block then the rate and pulse-count parameter blocks, in three
# renderings of the same blocks.

# %%
blocks = encode_free_curve(plan.table)
files = {"hex": out / "free-curve.upload.hex", "c": out / "free-curve.h",
         "bus": out / "free-curve.bus.txt"}
for fmt, path in files.items():
    path.write_bytes(render(blocks, fmt))
    show(path)
print(f"\n{len(blocks)} blocks, {sum(map(len, blocks))} bytes")

# %%
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
            for body in re.findall(r"stepramp_block_\d+\[\] = \{([^}]*)\}", header)]
assert c_blocks == blocks
print(f"C header: {len(c_blocks)} arrays equal to the blocks")

# Bus script: per block, wait MWEF = 0, WCR 20, WAR 20 − size, DWR last byte first;
# then read the chip's answer (manual §5-8: wait MREF = 0, dummy RCR, RAR, DRR) before
# the next block. The chip keeps ONE answer buffer (§5-4): a block written over an
# unread answer raises alarm F4 01 and stops it. Run the script through the chip at
# register level, then the same script with one answer's reads left out.
bus_text = files["bus"].read_text()
run = run_bus_script(bus_text)
assert run.ok and run.blocks == len(blocks) and run.answers == tuple(expected_answers(blocks))
print(f"bus script: {run.message}")
print("first answers:", ", ".join(a.hex(" ").upper() for a in run.answers[:3]), "…")

lines = bus_text.splitlines()
first_read = next(i for i, line in enumerate(lines) if line.startswith("WAIT CSR.MREF"))
next_block = next(i for i, line in enumerate(lines) if i > first_read
                  and line.startswith("WAIT CSR.MWEF"))
skipped = run_bus_script("\n".join(lines[:first_read] + lines[next_block:]))
assert not skipped.ok and skipped.alarm == 0x01
print(f"one read skipped: {skipped.message}")


# %% [markdown]
# ## PPMC-312 ASCII init frame
#
# The best stall-safe linear init table for the same move, with common
# accel/decel counts (the serial init command cannot carry separate ones),
# sent to slave address 1.

# %%
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
print("decoded:", from_file)

# %% [markdown]
# ## A-Link ALUM settings
#
# The fastest stall-safe start speed, high speed and acceleration for this move
# (the unit ramps linearly), as command words with pair codes, in a settings file
# that carries a CRC-32 of the words (the A-Link protocol has no check).

# %%
alink = plan_settings(motor, pulses=PULSES)
settings = alink.table
print(settings)
ratio = alink.duration_s / exact_optimum(motor, PULSES).duration_s
print(f"predicted move {alink.duration_s * 1e3:.2f} ms ({alink.extras['shape']}), "
      f"{ratio:.3f}× the exact optimum; bound by {alink.binds}")
commands = settings_commands(settings)
words_path = out / "alink-settings.txt"
words_path.write_bytes(alink_files.render(commands, "text"))
show(words_path, lines=8)

# %%
parsed = alink_files.parse(words_path.read_bytes())
print(f"{parsed.format} file, {parsed.integrity}: {parsed.detail}")
assert parsed.items == commands
for c in parsed.items:
    print(f"{c.name:10s} func {c.func:2d} para {c.para:7d} pair {c.pair}")
rebuilt = settings_from_commands(parsed.items)
assert rebuilt == settings
print("settings rebuilt from the words:", rebuilt == settings)

# %% [markdown]
# ## MC-200 position stream
#
# The servo follows the staircase's own position (pulses emitted by each
# time, from the chip model `simulate_move`), one position command per 250 µs
# SPI period.

# %%
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
      f"largest step per period {max(steps)} pulses")

# %%
for path in sorted(out.iterdir()):
    print(f"{path.name:28s} {path.stat().st_size:8d} bytes")
workdir.cleanup()  # skip this cell to keep the files
