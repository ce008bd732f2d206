"""The PPMC-312 as its host sees it on the parallel bus, register by register, and the bus
scripts stepramp writes (`--format bus`), run through it.

Registers (manual §4-1; RS2..0): 0 CSR (bit 3 MWEF: 1 = cannot write; bit 2 MREF:
0 = a response is waiting), 2 WCR (write) / RCR (read), 3 WAR / RAR, 5 DWR, 7 DRR.

Writing a block (§5-6): wait until CSR.MWEF = 0; WCR ← 20; WAR ← 20 − block size; the
block's bytes to DWR from its last byte down to the header. Writing the header issues
it. Reading an answer (§5-8): wait until CSR.MREF = 0; read RCR (a dummy read); read
RAR: the answer is 0x40 − RAR bytes; read them from DRR, lowest parameter first and the
header last (the reverse of the answer's byte order), each within 3.625 µs; after the
last byte MREF returns to 1.

The chip model (`BusChip`; choices recorded in docs/manual-notes.md):
- the chip (`emulator.ChipEmulator`) answers a block the moment its header is
  written, so MWEF reads 0 at the first CSR read after it; a WCR written with no CSR
  read since the last block was issued is reported (§5-6: MWEF 1 の時は書込み不可です。
  書込んだ時の動作保証はされません);
- every response kind has ONE buffer (§5-4). A block's answer goes into the command
  buffer; if that still holds an unread answer, the chip raises alarm F4 01 (§11-9:
  「命令の多重書込みが発生しました」): the new answer is replaced by `23 02 F4 01` in the
  alarm buffer (the first alarm is kept if that one is unread too), pulse output stops,
  and in the alarm state every later block is refused unexecuted (F1 00 with the ALM
  bit, `ChipEmulator.raise_alarm`) until a reset;
- waiting responses are read oldest first; an answer leaves its buffer when its last
  byte is read (a half-read answer still fills it). An RCR read starts (or restarts)
  reading the oldest one.

A bus script is one register access a line (`#` starts a comment; values are two hex
digits):

| line | the host |
|---|---|
| `WAIT CSR.MWEF 0` | polls CSR until MWEF reads 0 (before each block, §5-6) |
| `WCR 20` | writes 0x20 to WCR (the only value the chip takes) |
| `WAR XX` | writes 0x20 − the block's size to WAR |
| `DWR XX` | writes one block byte to DWR: last byte first, the header last (issues it) |
| `WAIT CSR.MREF 0` | polls CSR until MREF reads 0: an answer is waiting |
| `RCR --` | reads RCR, the dummy read (its value means nothing) |
| `RAR XX` | reads RAR, expecting XX = 0x40 − the answer's size |
| `DRR XX` | reads one answer byte from DRR, expecting XX: last byte first, the header last |

stepramp's files read each block's answer before the next block's `WCR 20`
(`answer_reads`). `run_bus_script` runs a script through `BusChip`, checking every
expected read, and reports the first mismatch, protocol slip or alarm by its line.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass

from ..errors import DecodeError, echo
from ..formats import content_lines, hex_bytes, text_of
from .emulator import ALARM_DOUBLE_WRITE, ChipEmulator
from .frames import ALARM, MAX_BLOCK_BYTES
from .upload import bus_writes

CSR_MWEF = 0x08  # bit 3: 1 = the chip cannot take a write
CSR_MREF = 0x04  # bit 2: 0 = a response is waiting
WCR_VALUE = 0x20  # WCR takes 0x20 only (§4-1.4)
READ_WINDOW = 0x40  # an answer is 0x40 − RAR bytes (§5-8)

WRITES = ("WCR", "WAR", "DWR")
READS = ("RCR", "RAR", "DRR")
CSR_BITS = {"MWEF": CSR_MWEF, "MREF": CSR_MREF}
_SYNTAX = "expected 'WCR|WAR|DWR XX', 'RCR --', 'RAR|DRR XX' or 'WAIT CSR.MWEF|MREF 0'"


@dataclass(frozen=True)
class BusLine:
    """One register access of a script: `op` a register (or WAIT), `value` the byte
    written or expected (None: RCR's dummy read), `bit` the CSR bit a WAIT polls."""

    number: int
    op: str
    value: int | None
    bit: str = ""


def read_bus_script(raw: bytes | str) -> list[BusLine]:
    """The accesses of a bus script (see the module docstring); a line that is none is a
    `DecodeError` naming it."""
    lines, _comments = content_lines(raw if isinstance(raw, str) else text_of(raw))
    return [_bus_line(number, content) for number, content in lines]


def _bus_line(number: int, content: str) -> BusLine:
    parts = content.split()
    where = f"line {number}"
    if len(parts) == 3 and parts[0] == "WAIT":
        reg, _, bit = parts[1].partition(".")
        if reg != "CSR" or bit not in CSR_BITS or parts[2] != "0":
            raise DecodeError(f"{where}: a wait is 'WAIT CSR.MWEF 0' or 'WAIT CSR.MREF 0', got "
                              f"{echo(content.strip())}")
        return BusLine(number, "WAIT", int(parts[2]), bit)
    if len(parts) != 2 or parts[0] not in WRITES + READS:
        raise DecodeError(f"{where}: {_SYNTAX}, got {echo(content.strip())}")
    if parts[0] == "RCR":
        if parts[1] != "--":
            raise DecodeError(f"{where}: RCR is a dummy read, written 'RCR --'")
        return BusLine(number, "RCR", None)
    byte = hex_bytes(parts[1], where)
    if len(byte) != 1:
        raise DecodeError(f"{where}: a register access carries one byte")
    return BusLine(number, parts[0], byte[0])


# --- rendering and reading back an upload ---------------------------------------------------
def answer_reads(answer: bytes, note: str = "") -> list[str]:
    """The lines that read `answer` (§5-8): the MREF wait, RCR's dummy read, RAR, then every
    byte from DRR, last byte first; `note` a comment on the wait line."""
    if not 1 <= len(answer) <= READ_WINDOW:
        raise DecodeError(f"an answer of {len(answer)} bytes cannot be read (RAR gives "
                          f"1..{READ_WINDOW})")
    return [f"WAIT CSR.MREF 0{'  # ' + note if note else ''}", "RCR --",
            f"RAR {READ_WINDOW - len(answer):02X}",
            *(f"DRR {b:02X}" for b in reversed(answer))]


def bus_script(blocks: Sequence[bytes], answers: Sequence[bytes] | None) -> list[str]:
    """The host's accesses for an upload: per block the MWEF wait and its writes (§5-6),
    then, with `answers` (one per block), the reads of its answer (§5-8)."""
    lines: list[str] = []
    for k, block in enumerate(blocks):
        lines.append("WAIT CSR.MWEF 0")
        lines += [f"{reg} {value:02X}" for reg, value in bus_writes(block)]
        if answers is not None:
            lines += answer_reads(answers[k], f"answer to block {k}: "
                                              + answers[k].hex(" ").upper())
    return lines


@dataclass(frozen=True)
class ScriptUpload:
    """What a bus script writes and expects: its blocks, and per block the answer it reads
    (None where it reads none) with the line that read starts on."""

    blocks: list[bytes]
    answers: list[bytes | None]
    answer_lines: list[int | None]


def script_upload(lines: Sequence[BusLine]) -> ScriptUpload:
    """The blocks a script writes and the answers it expects. Each block is WCR 20, WAR
    20 − size, its bytes to DWR last first, after any MWEF waits; its answer, if read,
    follows it whole: WAIT CSR.MREF 0, RCR --, RAR, the DRR reads (a file written before
    the handshake reads none)."""
    out = ScriptUpload([], [], [])
    k = 0
    while k < len(lines):
        if lines[k].op == "WAIT" and lines[k].bit == "MWEF":
            k += 1
            continue
        block, k = _script_block(lines, k)
        out.blocks.append(block)
        answer, first = None, None
        if k < len(lines) and _starts_read(lines[k]):
            first = lines[k].number
            answer, k = _script_answer(lines, k)
        out.answers.append(answer)
        out.answer_lines.append(first)
    if not out.blocks:
        raise DecodeError("the bus file holds no register writes")
    return out


def _starts_read(line: BusLine) -> bool:
    return line.op in READS or (line.op == "WAIT" and line.bit == "MREF")


def _script_block(lines: Sequence[BusLine], k: int) -> tuple[bytes, int]:
    first = lines[k]
    if first.op != "WCR" or first.value != WCR_VALUE:
        raise DecodeError(f"line {first.number}: a block starts with WCR 20, got {first.op} "
                          f"{_shown(first)}")
    if k + 1 >= len(lines) or lines[k + 1].op != "WAR":
        raise DecodeError(f"line {first.number}: WCR 20 is followed by WAR (0x20 − block size)")
    war = lines[k + 1]
    assert war.value is not None
    size = WCR_VALUE - war.value
    if not 1 <= size <= MAX_BLOCK_BYTES:
        raise DecodeError(f"line {war.number}: WAR {war.value:02X} gives a block of {size} "
                          f"bytes (1..{MAX_BLOCK_BYTES})")
    data = lines[k + 2:k + 2 + size]
    if len(data) != size or any(line.op != "DWR" for line in data):
        found = next((i for i, line in enumerate(data) if line.op != "DWR"), len(data))
        raise DecodeError(f"line {first.number}: WAR says {size} DWR writes follow; found "
                          f"{found}")
    return bytes(line.value or 0 for line in reversed(data)), k + 2 + size


def _script_answer(lines: Sequence[BusLine], k: int) -> tuple[bytes, int]:
    head = lines[k:k + 3]
    want = (("WAIT", "MREF", 0), ("RCR", "", None), ("RAR", "", None))
    for line, (op, bit, value) in zip(head, want, strict=False):
        if line.op != op or line.bit != bit or (op == "WAIT" and line.value != value):
            raise DecodeError(f"line {line.number}: an answer is read as WAIT CSR.MREF 0, "
                              f"RCR --, RAR XX, then the DRR reads (§5-8); got {line.op} "
                              f"{line.bit or _shown(line)}")
    if len(head) < 3:
        raise DecodeError(f"line {head[-1].number}: the answer's read stops before RAR (§5-8: "
                          "WAIT CSR.MREF 0, RCR --, RAR XX, the DRR reads)")
    rar = head[2]
    assert rar.value is not None
    size = READ_WINDOW - rar.value
    data = lines[k + 3:k + 3 + size]
    if size < 1 or len(data) != size or any(line.op != "DRR" for line in data):
        found = next((i for i, line in enumerate(data) if line.op != "DRR"), len(data))
        raise DecodeError(f"line {rar.number}: RAR {rar.value:02X} says {size} DRR reads "
                          f"follow; found {found}")
    return bytes(line.value or 0 for line in reversed(data)), k + 3 + size


def _shown(line: BusLine) -> str:
    return "--" if line.value is None else f"{line.value:02X}"


# --- the chip on its bus --------------------------------------------------------------------
@dataclass(frozen=True)
class Waiting:
    """A response in its buffer: `kind` command (a block's answer) or alarm, and the
    block that drew it."""

    kind: str
    response: bytes
    block: int


@dataclass
class _Reading:
    response: bytes
    size_read: bool = False  # RAR read: the DRR reads may start
    taken: int = 0           # DRR bytes read


class BusChip:
    """The chip's registers (see the module docstring): the host's writes and reads, the
    responses waiting in their buffers (`waiting`, oldest first), the blocks issued."""

    def __init__(self, chip: ChipEmulator | None = None) -> None:
        self.chip = chip if chip is not None else ChipEmulator()
        self.issued: list[bytes] = []
        self.waiting: list[Waiting] = []  # the responses in their buffers, oldest first
        self.reset()

    def reset(self) -> None:
        """Power-on: no table, no response waiting, nothing half-written."""
        self.chip.reset()
        self.issued.clear()
        self.waiting.clear()
        self._block: bytearray | None = None  # the block being written, last byte first
        self._size: int | None = None         # its size (from WAR)
        self._looked = True                   # a CSR read since the last block was issued
        self._reading: _Reading | None = None  # the response being read

    @property
    def reading(self) -> bytes | None:
        """The response being read (after RCR, before its last DRR byte)."""
        return None if self._reading is None else self._reading.response

    @property
    def alarm(self) -> int | None:
        """The F4 status while the chip is in the alarm state."""
        return self.chip.alarm

    def read_csr(self) -> int:
        """MWEF reads 0 (the chip took the last block at once); MREF 0 when a response
        is waiting."""
        self._looked = True
        return 0 if self.waiting else CSR_MREF

    def write(self, register: str, value: int) -> None:
        """A host write to WCR, WAR or DWR (§5-6); a slip of the procedure is a
        `DecodeError` saying which."""
        if register == "WCR":
            self._write_wcr(value)
        elif register == "WAR":
            if self._block is None or self._size is not None:
                raise DecodeError("WAR written without WCR 20 before it (§5-6: WCR, WAR, then "
                                  "the DWR bytes)")
            size = WCR_VALUE - value
            if not 1 <= size <= MAX_BLOCK_BYTES:
                raise DecodeError(f"WAR {value:02X} gives a block of {size} bytes "
                                  f"(1..{MAX_BLOCK_BYTES})")
            self._size = size
        elif register == "DWR":
            if self._block is None or self._size is None:
                raise DecodeError("DWR written before WCR 20 and WAR (§5-6)")
            self._block.append(value)
            if len(self._block) == self._size:
                self._issue(bytes(reversed(self._block)))
        else:
            raise DecodeError(f"{register} is not a register the host writes")

    def _write_wcr(self, value: int) -> None:
        if value != WCR_VALUE:
            raise DecodeError(f"WCR {value:02X}: WCR takes 0x20 only (§4-1.4)")
        if self._block is not None:
            raise DecodeError(f"WCR 20 with the block before it unfinished ({len(self._block)} "
                              f"of {self._size} DWR bytes written)")
        if not self._looked:
            raise DecodeError("WCR 20 with no CSR read since the last block was issued: "
                              "MWEF may still be 1 (§5-6: wait for CSR.MWEF = 0)")
        self._block = bytearray()

    def _issue(self, block: bytes) -> None:
        self._block, self._size, self._looked = None, None, False
        self.issued.append(block)
        answer = self.chip.feed(block)
        index = len(self.issued) - 1
        if self.unread("command") is None:
            self.waiting.append(Waiting("command", answer, index))
            return
        # §5-4: the command buffer still holds an unread answer; the new one is replaced
        # by the alarm response, which has a buffer of its own (one alarm kept).
        self.chip.raise_alarm(ALARM_DOUBLE_WRITE)
        if self.unread("alarm") is None:
            self.waiting.append(Waiting("alarm", ALARM.encode(status=ALARM_DOUBLE_WRITE), index))

    def unread(self, kind: str) -> Waiting | None:
        """The response waiting in buffer `kind` (command or alarm), if any."""
        return next((w for w in self.waiting if w.kind == kind), None)

    def read(self, register: str) -> int:
        """A host read of RCR, RAR or DRR (§5-8); a slip of the procedure is a
        `DecodeError` saying which."""
        if register == "RCR":
            if not self.waiting:
                raise DecodeError("RCR read with no response waiting (MREF = 1)")
            self._reading = _Reading(self.waiting[0].response)
            return 0x00
        reading = self._reading
        if reading is None:
            raise DecodeError(f"{register} read before RCR's dummy read (§5-8: RCR, RAR, then "
                              "DRR)")
        if register == "RAR":
            reading.size_read = True
            return READ_WINDOW - len(reading.response)
        if register != "DRR":
            raise DecodeError(f"{register} is not a register the host reads")
        if not reading.size_read:
            raise DecodeError("DRR read before RAR (§5-8: the size comes first)")
        reading.taken += 1  # the answer leaves its buffer with its last byte: never past it
        byte = reading.response[-reading.taken]
        if reading.taken == len(reading.response):
            self.waiting.pop(0)
            self._reading = None
        return byte


# --- running a script -----------------------------------------------------------------------
@dataclass(frozen=True)
class BusRun:
    """What a script did on `BusChip`: `ok`, or the first problem (`line`, `message`);
    `alarm` the F4 status if the chip raised one; the blocks issued and the answers read
    whole."""

    ok: bool
    message: str
    line: int | None = None
    alarm: int | None = None
    blocks: int = 0
    answers: tuple[bytes, ...] = ()


def run_bus_script(raw: bytes | str, bus: BusChip | None = None) -> BusRun:
    """Run a bus script from power-on through `BusChip` (see the module docstring): every
    expected read checked, stopped at the first mismatch, procedure slip or alarm, which
    `BusRun` names by its line. A line that is no register access, or a script with none,
    is a `DecodeError`."""
    lines = read_bus_script(raw)
    if not lines:  # nothing to run: no verdict to give (comments only, blank lines)
        raise DecodeError("the bus script holds no register access (only comments or blank "
                          "lines)")
    chip = bus if bus is not None else BusChip()
    chip.reset()
    answers: list[bytes] = []
    current = bytearray()
    for line in lines:
        try:
            problem = _step(chip, line, current)
        except DecodeError as e:
            problem = str(e)
        if problem is not None:
            return _run(chip, answers, f"line {line.number}: {problem}", line.number)
        if line.op == "DRR" and chip.reading is None:
            answers.append(bytes(reversed(current)))
            current.clear()
    if chip.waiting:
        kinds = ", ".join(f"block {w.block}'s {w.kind} response {w.response.hex(' ').upper()}"
                          for w in chip.waiting)
        return _run(chip, answers, f"the script ends with {kinds} unread: the next command "
                                   "would raise alarm F4 01", lines[-1].number if lines else None)
    return BusRun(True, f"{len(chip.issued)} blocks written, {len(answers)} answers read, "
                        "every expected read matched", None, None, len(chip.issued),
                  tuple(answers))


def _run(chip: BusChip, answers: list[bytes], message: str, line: int | None) -> BusRun:
    return BusRun(False, message, line, chip.alarm, len(chip.issued), tuple(answers))


def _step(chip: BusChip, line: BusLine, current: bytearray) -> str | None:
    """One access; the problem it meets, if any."""
    if line.op == "WAIT":
        if chip.read_csr() & CSR_BITS[line.bit]:  # MWEF always reads 0: the chip is quick
            return f"WAIT CSR.{line.bit} 0 would never end: no response is waiting"
        return None
    if line.op in WRITES:
        assert line.value is not None
        before = chip.unread("command")
        alarm = chip.alarm
        chip.write(line.op, line.value)
        if chip.alarm is not None and alarm is None and before is not None:
            return (f"block {len(chip.issued) - 1} is issued while block {before.block}'s answer "
                    f"{before.response.hex(' ').upper()} is still unread: the chip raises alarm "
                    f"F4 {chip.alarm:02X} (§5-4, §11-9: 命令の多重書込み), stops pulse output "
                    "and answers " + ALARM.encode(status=chip.alarm).hex(" ").upper()
                    + " instead")
        return None
    value = chip.read(line.op)
    if line.op == "RCR":
        current.clear()
        return None
    if line.op == "DRR":
        current.append(value)
    if line.value is not None and value != line.value:
        return f"{line.op} reads {value:02X}, the script expects {line.value:02X}" + (
            f" (the chip answers {_being_read(chip, current)})" if line.op == "DRR" else "")
    return None


def _being_read(chip: BusChip, current: bytearray) -> str:
    whole = chip.reading if chip.reading is not None else bytes(reversed(current))
    return whole.hex(" ").upper()


__all__ = ["BusChip", "BusLine", "BusRun", "ScriptUpload", "Waiting", "answer_reads",
           "bus_script", "read_bus_script", "run_bus_script", "script_upload"]
