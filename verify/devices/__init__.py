"""The devices stepramp knows, in one place (Klipper's kinematics by name; cantools'
format dispatch): every part of the tool that needs something of a device asks here,
never switches on a device's name.

Each `Device` says where its parts are, as import paths loaded only when used (so
`stepramp check` on a table never imports another device):

- `package`: its models, planners and codecs (profiles/<name>/);
- `formats`: its format table (`profiles.formats.FormatTable`: render, parse, sniff), from
  which the CLI builds `--format`;
- `detect`: whether a file's bytes are one of its files (None: the default device, which
  reads what no other claims); `documents`: its own JSON documents, by "format";
- `judge`: its module in verify/devices/: `check(raw, path, options)`, the verdict
  `stepramp check` gives on one of its files, and, for a device with synchronised moves,
  `axis_verdict(axis)`, each axis's safety in sync's report;
- `safety`: its safety verdict on what its planners make (`judge_safety` hands it the
  tables whose type its package made: `safety_judge`), "module:function";
- `command`: its own command group (verify/cli/<command>.py), and `reader`, the command
  that reads its files back (a file `decode` cannot read names it);
- `axes`: its entry in axes files (profiles/axes.py): how many axes, how many pulses;
- `sync`: its synchronised moves (profiles/<name>/sync/: `plan_sync`, `sync_files`,
  `output_names`, `check_axis_names`, `move_commands`);
- `simulates`: `stepramp simulate --axes` runs an axes file's tables of this device.

Adding a device: its package under profiles/, its judge under verify/devices/, and one
entry in `DEVICES` (docs/architecture.md).
"""

from __future__ import annotations

import importlib
from collections.abc import Callable, Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import TYPE_CHECKING, Any, Protocol, cast

# a stepramp document's "format", read early (its devices' `documents` are told by it)
from profiles.reading import document_format

if TYPE_CHECKING:
    from profiles.axes import AxesEntry, AxesFile
    from profiles.formats import FormatTable
    from profiles.verdict import SafetyVerdict
    from verify.report import FileResult

    from ..check_options import CheckOptions


class Judge(Protocol):
    """A device's judge module (verify/devices/<name>.py)."""

    def check(self, raw: bytes, path: str, options: CheckOptions) -> FileResult: ...


class SyncJudge(Judge, Protocol):
    """The judge of a device with synchronised moves: each axis's safety in sync's report."""

    def axis_verdict(self, axis: Any) -> tuple[bool, dict[str, Any]]: ...


class SyncModule(Protocol):
    """A device's synchronised moves (profiles/<name>/sync/)."""

    def plan_sync(self, axes: Sequence[tuple[str, Any, int]], mode: Any) -> Any: ...
    def sync_files(self, plan: Any, *, command: str | None = None) -> dict[str, bytes]: ...
    def output_names(self, names: Sequence[str]) -> list[str]: ...
    def check_axis_names(self, names: Sequence[str]) -> None: ...
    def move_commands(self, plan: Any) -> list[Any]: ...


@dataclass(frozen=True)
class Device:
    """One device and where each of its parts is (see the module docstring)."""

    name: str                 # an axes file's and sync report's "device"
    title: str                # as people write it
    files: str                # what its files hold ("upload", "stream", "settings")
    reader: str               # the command that reads its files back
    package: str
    formats: str              # "module:attribute"
    judge: str                # module
    detect: str | None = None  # "module:function"; None: the default device
    documents: tuple[str, ...] = ()
    command: str | None = None
    axes: tuple[int, int] | None = None  # (most axes, most pulses of one axis's move)
    sync: str | None = None   # module
    simulates: bool = False
    safety: str | None = None  # "module:function": its verdict on its tables

    def format_table(self) -> FormatTable[Any]:
        return cast("FormatTable[Any]", _attribute(self.formats))

    def claims(self, raw: bytes) -> bool:
        """Whether `raw` is one of this device's files (the default device claims none:
        it reads what no other device claims)."""
        if self.detect is None:
            return False
        return bool(cast(Callable[[bytes], bool], _attribute(self.detect))(raw))

    def judge_module(self) -> Judge:
        return cast(Judge, importlib.import_module(self.judge))

    def sync_judge(self) -> SyncJudge:
        self.sync_module()  # a device without synchronised moves: one line naming those with
        return cast(SyncJudge, self.judge_module())

    def sync_module(self) -> SyncModule:
        from profiles.errors import FormatError

        if self.sync is None:
            raise FormatError(f"the {self.title} has no synchronised moves (stepramp sync "
                              f"plans for {', '.join(d.name for d in synchronised())})")
        return cast(SyncModule, importlib.import_module(self.sync))


DEVICES: tuple[Device, ...] = (
    Device("ppmc312", "PPMC-312", "upload", "stepramp decode", "profiles.ppmc312",
           "profiles.ppmc312.formats:FORMATS", "verify.devices.ppmc312",
           documents=("stepramp.table/1", "stepramp.program/1"), axes=(16, 0xFFFFFFFF),
           sync="profiles.ppmc312.sync", simulates=True,
           safety="profiles.ppmc312.safety:judge_table"),
    Device("alink", "A-Link ALUM", "settings", "stepramp alink read", "profiles.alink",
           "profiles.alink.formats:FORMATS", "verify.devices.alink",
           detect="profiles.alink.formats:is_settings_file", command="alink",
           axes=(2, (1 << 27) - 1),  # one unit's two axes; MOVE_R's 28-bit signed para
           sync="profiles.alink.sync", safety="profiles.alink.verdict:judge_ramp"),
    Device("mc200", "MC-200", "stream", "stepramp mc200 decode", "profiles.mc200",
           "profiles.mc200.formats:FORMATS", "verify.devices.mc200",
           detect="profiles.mc200.formats:is_stream_file", command="mc200"),
)
DEFAULT = next(d for d in DEVICES if d.detect is None)  # reads what no other device claims


def get(name: str) -> Device:
    """The device called `name`; a FormatError naming the known ones otherwise."""
    from profiles.errors import FormatError, echo

    for d in DEVICES:
        if d.name == name:
            return d
    raise FormatError(f"device: {echo(name)} is not one of {', '.join(d.name for d in DEVICES)}")


def detect(raw: bytes) -> Device:
    """The device whose file `raw` is: its own documents first (no device module is even
    imported for them: cold start), then each device's `detect`, else the default."""
    fmt = document_format(raw)
    for d in DEVICES:
        if fmt is not None and fmt in d.documents:
            return d
    if fmt is None:
        for d in DEVICES:
            if d.claims(raw):
                return d
    return DEFAULT


def safety_judge(table: Any) -> Callable[..., SafetyVerdict]:
    """The safety verdict of the device whose package made `table`'s type (a PPMC-312
    table, an A-Link ramp): its registry entry's `safety`; a FormatError otherwise."""
    from profiles.errors import FormatError

    module = type(table).__module__
    for d in DEVICES:
        if d.safety is not None and module.startswith(d.package + "."):
            return cast("Callable[..., SafetyVerdict]", _attribute(d.safety))
    raise FormatError(f"no device judges a {type(table).__name__} (judged: "
                      f"{', '.join(d.name for d in DEVICES if d.safety is not None)})")


def synchronised() -> tuple[Device, ...]:
    """The devices an axes file may name (those with synchronised moves)."""
    return tuple(d for d in DEVICES if d.axes is not None)


def command_groups() -> tuple[str, ...]:
    """Every device's own command group, in registry order."""
    return tuple(d.command for d in DEVICES if d.command is not None)


def axes_entries() -> dict[str, AxesEntry]:
    """Every device's entry in axes files, by name (profiles/axes.py), the default first."""
    from profiles.axes import AxesEntry

    return {d.name: AxesEntry(*d.axes) for d in sorted(synchronised(), key=lambda d: d
                                                       is not DEFAULT) if d.axes is not None}


def load_axes(path: str | Path, *, load_motors: bool = True) -> AxesFile:
    """An axes file, its devices and their limits from this registry."""
    from profiles.axes import load_axes as load

    return load(path, axes_entries(), load_motors=load_motors)


def _attribute(spec: str) -> Any:
    module, _, name = spec.partition(":")
    return getattr(importlib.import_module(module), name)
