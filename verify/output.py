"""Output at the edge: write a file whole or not at all, and respect what is there.

- `-` (or None) is stdout.
- A regular file (or a new one) is written to a temp file in the *target's* folder and
  renamed over it, so a reader never sees half a file; a symlink is written through to
  the file it points to (the link stays a link); an existing file keeps its mode (and,
  as root, its owner); a new file gets the umask's mode, like the shell's `>`.
- FIFOs, character devices and the /dev/stdout family are written straight into: they
  are streams, and replacing them (as root: the device node itself) is never wanted.
- A directory is refused.
- Data is a str, bytes, or an iterable of str/bytes chunks written as they come, so
  memory does not grow with the output's length.
- Several outputs of one command (`write_outputs`) are written all or none: every file
  is staged first and only renamed into place once every one of them is complete.
- On any failure, including Ctrl-C and SIGTERM/SIGHUP, no temp file is left behind.
  Errors name OUT as the user wrote it, never the temp file. A run killed outright
  (SIGKILL, a power cut) cannot clean up: its temp files carry the host and process
  that made them (`.OUT.HOST-PID-xxxx.part`, `.orig`), and the next run writing OUT
  removes those whose process no longer runs on this host (another host's, and those
  named before this scheme, once a day old).
- Before a command reads anything (`refuse_unsafe_outputs`): an output path ending in
  `/` or naming a directory, naming one of the command's inputs (the same file: device
  and inode, through symlinks and hard links), or named by two outputs, is refused.
"""

from __future__ import annotations

import contextlib
import os
import signal
import stat
import sys
import threading
from collections.abc import Iterable, Iterator, Sequence
from dataclasses import dataclass
from types import FrameType
from typing import BinaryIO

from profiles.errors import OutputError, echo
from profiles.reading import display_path

Chunk = str | bytes
Data = str | bytes | Iterable[Chunk]
STDOUT = "-"
_STREAM_PREFIXES = ("/dev/stdout", "/dev/stderr", "/dev/fd/", "/proc/self/fd/")
__all__ = ["OutputError", "OutputInterrupted", "refuse_unsafe_outputs", "write_output",
           "write_outputs"]


def write_output(out: str | None, data: Data) -> None:
    """Write `data` to `out` (see the module doc for what each kind of target gets)."""
    write_outputs([(out, data)])


def write_outputs(outputs: Sequence[tuple[str | None, Data]]) -> None:
    """Write several outputs all or none: files are staged, then renamed together; a
    failure anywhere (also in producing the data) leaves every target as it was."""
    targets = [_Target.resolve(out) for out, _ in outputs]
    with _cleanup_on_signals():
        try:
            # Files first (staged, invisible), streams next, renames last: a stream that
            # fails still leaves every file untouched.
            for target, (_, data) in zip(targets, outputs, strict=True):
                if target.kind == "file":
                    target.stage(data)
            for target, (_, data) in zip(targets, outputs, strict=True):
                if target.kind != "file":
                    target.stream(data)
            _commit([t for t in targets if t.kind == "file"])
        finally:
            for target in targets:
                target.discard()


def refuse_unsafe_outputs(outputs: Sequence[tuple[str, str]], inputs: Sequence[str], *,
                          folders: Sequence[tuple[str, str]] = (),
                          folder_ok: bool = False) -> None:
    """Refuse, before anything is read or written, an output that would lose data or
    land where the user did not mean: `outputs` are (option, path) of files, `folders`
    (option, path) of output folders, `inputs` the paths the command reads. A file
    output ending in `/` or naming a directory is not a file name; any output that is
    one of the inputs would overwrite what is being read; two outputs naming one file
    would leave only one of them. stdout (`-`) and the /dev/stdout family are streams
    and never compared. `folder_ok`: the outputs' folder may not exist yet (the command
    makes it)."""
    seen: dict[object, str] = {}
    ins = {key: path for path in inputs if (key := _identity(path)) is not None}
    for option, out, is_folder in [*((o, p, False) for o, p in outputs),
                                   *((o, p, True) for o, p in folders)]:
        if out in ("", STDOUT) or out.startswith(_STREAM_PREFIXES):
            continue
        name = f"{option} {display_path(out)}"
        if not is_folder and out.endswith(("/", os.sep)):
            raise OutputError(f"{name}: names a folder (it ends in /); {option} takes a file "
                              "name")
        if not is_folder and os.path.isdir(out):
            raise OutputError(f"{name}: is a directory; {option} takes a file name")
        folder = os.path.dirname(os.path.realpath(out))
        if not is_folder and not folder_ok and not os.path.isdir(folder):
            raise OutputError(f"{name}: the folder {display_path(os.path.dirname(out) or '.')} "
                              "does not exist")
        key = _identity(out)
        if key is not None and key in ins:
            raise OutputError(f"{name}: is the input {display_path(ins[key])}; writing it "
                              "would overwrite what is read (give another file name)")
        where = key if key is not None else os.path.realpath(out)
        if where in seen:
            raise OutputError(f"{name}: {seen[where]} names the same file; each output "
                              "needs its own")
        seen[where] = name


def _identity(path: str) -> tuple[int, int] | None:
    """(device, inode) of the file `path` names (symlinks followed), None when it does not
    exist or is a character device (a terminal or /dev/null is shared by design)."""
    if path in ("", STDOUT):
        return None
    try:
        st = os.stat(path)
    except (OSError, ValueError):
        return None
    return None if stat.S_ISCHR(st.st_mode) else (st.st_dev, st.st_ino)


def _commit(files: list[_Target]) -> None:
    done: list[_Target] = []
    try:
        for target in files:
            target.backup_original()
            target.rename_into_place()
            done.append(target)
    except BaseException:
        for target in reversed(done):
            target.roll_back()
        raise
    for target in files:
        target.drop_backup()


@dataclass
class _Target:
    out: str  # as the user wrote it: every message names this
    kind: str  # "stdout", "stream" or "file"
    path: str  # the file that is written (a symlink's target)
    existing: os.stat_result | None = None
    tmp: str | None = None
    backup: str | None = None

    @classmethod
    def resolve(cls, out: str | None) -> _Target:
        if out is None or out == STDOUT:
            return cls(STDOUT, "stdout", STDOUT)
        name = display_path(out)
        if out == "":
            raise OutputError(f"{echo(name)}: an empty output path (use - for stdout)")
        if out.startswith(_STREAM_PREFIXES):
            return cls(out, "stream", out)
        if out.endswith(("/", os.sep)):  # realpath would drop the slash and write a file
            raise OutputError(f"{name}: names a folder (it ends in /); give a file name")
        try:
            st = os.stat(out)  # follows symlinks: judge what is written to
        except FileNotFoundError:
            st = None
        except OSError as e:
            raise OutputError(f"{name}: cannot write ({_why(e)})") from None
        if st is not None and stat.S_ISDIR(st.st_mode):
            raise OutputError(f"{name}: is a directory (give a file name)")
        if st is not None and not stat.S_ISREG(st.st_mode):
            return cls(out, "stream", out)
        path = os.path.realpath(out)  # a (chain of) symlink(s): write the file it names
        folder = os.path.dirname(path) or "."
        if not os.path.isdir(folder):
            raise OutputError(f"{name}: the folder {display_path(os.path.dirname(out) or '.')}"
                              " does not exist")
        return cls(out, "file", path, existing=st)

    def _fail(self, e: OSError) -> OutputError:
        return OutputError(f"{display_path(self.out)}: cannot write ({_why(e)})")

    def stage(self, data: Data) -> None:
        import tempfile  # here: its imports are a tenth of `stepramp check`'s cold start

        folder = os.path.dirname(self.path) or "."
        clear_leftovers(folder, os.path.basename(self.path))
        try:
            fd, self.tmp = tempfile.mkstemp(prefix=f".{os.path.basename(self.path)}.{_OWNER}-",
                                            suffix=".part", dir=folder)
            with os.fdopen(fd, "wb") as fh:
                _write_chunks(fh, data)
                fh.flush()
                os.fsync(fh.fileno())
            self._set_mode()
        except OSError as e:
            raise self._fail(e) from None

    def _set_mode(self) -> None:
        assert self.tmp is not None
        if self.existing is None:
            os.chmod(self.tmp, 0o666 & ~_umask())
            return
        if os.geteuid() == 0 or self.existing.st_uid == os.geteuid():
            with contextlib.suppress(OSError):  # keep the owner where the rights allow
                os.chown(self.tmp, self.existing.st_uid, self.existing.st_gid)
        os.chmod(self.tmp, stat.S_IMODE(self.existing.st_mode))

    def backup_original(self) -> None:
        """A hard link to the file being replaced, so a failed commit can put it back."""
        if self.existing is None:
            return
        import secrets

        folder = os.path.dirname(self.path) or "."
        for _ in range(100):
            name = os.path.join(folder, f".{os.path.basename(self.path)}.{_OWNER}-"
                                        f"{secrets.token_hex(4)}.orig")
            try:
                os.link(self.path, name)
            except FileExistsError:
                continue
            except OSError:
                return  # no hard links here: a failed commit cannot restore this one
            self.backup = name
            return

    def rename_into_place(self) -> None:
        assert self.tmp is not None
        try:
            os.replace(self.tmp, self.path)
        except OSError as e:
            raise self._fail(e) from None
        self.tmp = None

    def roll_back(self) -> None:
        with contextlib.suppress(OSError):
            if self.backup is not None:
                os.replace(self.backup, self.path)
                self.backup = None
            elif self.existing is None:
                os.unlink(self.path)

    def drop_backup(self) -> None:
        if self.backup is not None:
            with contextlib.suppress(OSError):
                os.unlink(self.backup)
            self.backup = None

    def discard(self) -> None:
        """Remove whatever this target still holds in temp files (each on its own: one
        failing unlink does not keep the others)."""
        for attr in ("tmp", "backup"):
            name = getattr(self, attr)
            if name is not None:
                with contextlib.suppress(OSError):
                    os.unlink(name)
                setattr(self, attr, None)

    def stream(self, data: Data) -> None:
        if self.kind == "stdout":
            _write_stdout(data)
            return
        try:
            # O_APPEND: /dev/stdout redirected to a file by the shell continues where the
            # shell's descriptor is, instead of writing over it from offset 0.
            fd = os.open(self.out, os.O_WRONLY | os.O_APPEND)
            with os.fdopen(fd, "wb") as fh:
                _write_chunks(fh, data)
        except OSError as e:
            raise self._fail(e) from None


def host_tag() -> str:
    node = os.uname().nodename if hasattr(os, "uname") else os.environ.get("COMPUTERNAME", "")
    return "".join(c for c in node if c.isascii() and c.isalnum())[:12] or "host"


# Who makes a temp file, in its name: a later run can tell a dead run's leftovers.
_OWNER = f"{host_tag()}-{os.getpid()}"
_LEFTOVER = r"\.(?:(?P<host>[A-Za-z0-9]{1,12})-(?P<pid>[0-9]+)-)?[A-Za-z0-9_]+\.(?:part|orig)"
STALE_S = 24 * 3600   # another host's leftover (or one named without its owner) is this old


def clear_leftovers(folder: str, base: str) -> list[str]:
    """Remove the temp files earlier runs writing `base` in `folder` left when they were
    killed outright (see the module docstring); the names removed."""
    import re
    import time

    pattern = re.compile(re.escape(f".{base}") + _LEFTOVER)
    removed: list[str] = []
    try:
        entries = [e for e in os.scandir(folder) if e.name.startswith(f".{base}.")]
    except OSError:
        return removed
    for entry in entries:
        m = pattern.fullmatch(entry.name)
        if m is None or not entry.is_file(follow_symlinks=False):
            continue
        try:
            old = time.time() - entry.stat(follow_symlinks=False).st_mtime > STALE_S
        except OSError:
            continue
        mine = m["host"] == host_tag()
        if (mine and not _running(int(m["pid"]))) or (not mine and old):
            with contextlib.suppress(OSError):
                os.unlink(entry.path)
                removed.append(entry.name)
    return removed


def _running(pid: int) -> bool:
    """Whether process `pid` runs on this host (as anyone); unknown counts as running."""
    if pid == os.getpid():
        return True
    if os.name != "posix":  # os.kill(pid, 0) would end the process on Windows
        return True
    try:
        os.kill(pid, 0)
    except ProcessLookupError:
        return False
    except (PermissionError, OverflowError, OSError):
        return True
    return True


def _chunks(data: Data, encoding: str = "utf-8") -> Iterator[bytes]:
    # Text that the encoding cannot carry (a strict ASCII stdout, an odd file name held
    # as surrogates) is escaped rather than crashing half-way through an output.
    for chunk in [data] if isinstance(data, str | bytes) else data:
        yield (chunk.encode(encoding, "backslashreplace") if isinstance(chunk, str)
               else bytes(chunk))


def _write_chunks(fh: BinaryIO, data: Data) -> None:
    for chunk in _chunks(data):
        fh.write(chunk)


def _write_stdout(data: Data) -> None:
    buffer = getattr(sys.stdout, "buffer", None)
    if buffer is None:  # a text-only stream (tests, notebooks)
        for chunk in _chunks(data):
            sys.stdout.write(chunk.decode(errors="backslashreplace"))
        return
    sys.stdout.flush()
    for chunk in _chunks(data, sys.stdout.encoding or "utf-8"):
        buffer.write(chunk)
    buffer.flush()


def _umask() -> int:
    # Reading the umask means setting it; the CLI is single-threaded where it writes.
    with _UMASK_LOCK:
        mask = os.umask(0o022)
        os.umask(mask)
    return mask


_UMASK_LOCK = threading.Lock()


class OutputInterrupted(BaseException):
    """SIGTERM/SIGHUP during a write: unwinds like Ctrl-C so temp files are removed."""

    def __init__(self, signum: int) -> None:
        super().__init__(f"interrupted by signal {signum}")
        self.signum = signum


@contextlib.contextmanager
def _cleanup_on_signals() -> Iterator[None]:
    """While writing, SIGTERM and SIGHUP unwind the stack (Ctrl-C already does), so the
    `finally` that removes temp files runs; the handlers are restored afterwards."""
    if threading.current_thread() is not threading.main_thread():
        yield
        return

    def interrupt(signum: int, frame: FrameType | None) -> None:
        raise OutputInterrupted(signum)

    saved = {}
    for name in ("SIGTERM", "SIGHUP"):
        signum = getattr(signal, name, None)
        if signum is not None and signal.getsignal(signum) == signal.SIG_DFL:
            saved[signum] = signal.signal(signum, interrupt)
    try:
        yield
    finally:
        for signum, handler in saved.items():
            signal.signal(signum, handler)


def _why(e: OSError) -> str:
    return e.strerror or f"{e.__class__.__name__}: {e}"
