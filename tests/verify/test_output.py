"""verify/output.py: each kind of target gets what it should, whole or not at all."""

from __future__ import annotations

import os
import signal
import stat
import subprocess
import sys
import threading
from collections.abc import Iterator
from pathlib import Path

import pytest

from tests.support.paths import ROOT
from verify import output
from verify.output import OutputError, OutputInterrupted, write_output, write_outputs


def _leftovers(folder: Path) -> list[str]:
    return sorted(p.name for p in folder.iterdir() if p.name.startswith("."))


@pytest.fixture
def umask_027() -> Iterator[None]:
    old = os.umask(0o027)
    yield
    os.umask(old)


def test_a_new_file_gets_the_umasks_mode(tmp_path: Path, umask_027: None) -> None:
    out = tmp_path / "new.txt"
    write_output(str(out), "hello\n")
    assert out.read_text() == "hello\n"
    assert stat.S_IMODE(out.stat().st_mode) == 0o640
    assert _leftovers(tmp_path) == []


def test_an_existing_file_keeps_its_mode(tmp_path: Path, umask_027: None) -> None:
    out = tmp_path / "old.txt"
    out.write_text("old")
    out.chmod(0o604)
    write_output(str(out), b"new")
    assert out.read_bytes() == b"new"
    assert stat.S_IMODE(out.stat().st_mode) == 0o604


def test_an_existing_executable_keeps_its_mode(tmp_path: Path) -> None:
    out = tmp_path / "run.sh"
    out.write_text("old")
    out.chmod(0o755)
    write_output(str(out), "#!/bin/sh\n")
    assert stat.S_IMODE(out.stat().st_mode) == 0o755


def test_a_symlink_is_written_through_and_stays_a_link(tmp_path: Path) -> None:
    real = tmp_path / "real.txt"
    real.write_text("old")
    real.chmod(0o640)
    link = tmp_path / "out"
    link.symlink_to("real.txt")
    write_output(str(link), "new\n")
    assert link.is_symlink() and os.readlink(link) == "real.txt"
    assert real.read_text() == "new\n"
    assert stat.S_IMODE(real.stat().st_mode) == 0o640


def test_a_symlink_into_another_folder_is_written_atomically_there(tmp_path: Path) -> None:
    (tmp_path / "a").mkdir()
    (tmp_path / "b").mkdir()
    real = tmp_path / "b" / "real.txt"
    real.write_text("old")
    (tmp_path / "a" / "link").symlink_to("../b/real.txt")
    (tmp_path / "a" / "link2").symlink_to("link")  # a chain of links
    write_output(str(tmp_path / "a" / "link2"), "new")
    assert real.read_text() == "new"
    assert (tmp_path / "a" / "link2").is_symlink() and (tmp_path / "a" / "link").is_symlink()
    assert _leftovers(tmp_path / "a") == [] and _leftovers(tmp_path / "b") == []


def test_a_dangling_symlink_creates_its_target(tmp_path: Path) -> None:
    link = tmp_path / "out"
    link.symlink_to("made.txt")
    write_output(str(link), "x")
    assert link.is_symlink() and (tmp_path / "made.txt").read_text() == "x"


def test_a_fifo_is_written_straight_into(tmp_path: Path) -> None:
    fifo = tmp_path / "f"
    os.mkfifo(fifo)
    got: list[bytes] = []
    reader = threading.Thread(target=lambda: got.append(fifo.read_bytes()), daemon=True)
    reader.start()
    write_output(str(fifo), ["a", b"b", "c\n"])
    reader.join(10)
    assert got == [b"abc\n"]
    assert stat.S_ISFIFO(fifo.stat().st_mode)
    assert _leftovers(tmp_path) == []


def test_dev_null_stays_a_device() -> None:
    before = os.stat("/dev/null")
    write_output("/dev/null", "discarded\n")
    after = os.stat("/dev/null")
    assert stat.S_ISCHR(after.st_mode) and after.st_rdev == before.st_rdev
    assert stat.S_IMODE(after.st_mode) == stat.S_IMODE(before.st_mode)


def test_a_full_device_names_out() -> None:
    if not os.path.exists("/dev/full"):
        pytest.skip("no /dev/full on this system")  # a platform fact, not a dependency
    with pytest.raises(OutputError) as e:
        write_output("/dev/full", "x" * 100_000)
    assert str(e.value).startswith("/dev/full: cannot write")


_DEV_STDOUT = ("import sys; sys.path.insert(0, {root!r}); from verify.output import "
               "write_output; print('first', flush=True); "
               "write_output('/dev/stdout', 'to stdout\\n')")


def test_dev_stdout_into_a_pipe() -> None:
    r = subprocess.run([sys.executable, "-c", _DEV_STDOUT.format(root=str(ROOT))],
                       capture_output=True, text=True, timeout=60)
    assert r.returncode == 0, r.stderr
    assert r.stdout == "first\nto stdout\n"


def test_dev_stdout_redirected_to_a_file_continues_it(tmp_path: Path) -> None:
    target = tmp_path / "log.txt"
    with open(target, "w") as fh:
        r = subprocess.run([sys.executable, "-c", _DEV_STDOUT.format(root=str(ROOT))],
                           stdout=fh, stderr=subprocess.PIPE, text=True, timeout=60)
    assert r.returncode == 0, r.stderr
    assert target.read_text() == "first\nto stdout\n"
    assert _leftovers(tmp_path) == []


def test_a_directory_is_refused(tmp_path: Path) -> None:
    with pytest.raises(OutputError, match="is a directory"):
        write_output(str(tmp_path), "x")
    assert _leftovers(tmp_path) == []


def test_a_missing_folder_is_refused(tmp_path: Path) -> None:
    with pytest.raises(OutputError, match="does not exist"):
        write_output(str(tmp_path / "no" / "out.txt"), "x")


def test_dash_and_none_are_stdout(capsysbinary: pytest.CaptureFixture[bytes]) -> None:
    write_output("-", "text\n")
    write_output(None, b"\x00\xff")
    write_output("-", iter(["a", "b\n"]))
    assert capsysbinary.readouterr().out == b"text\n\x00\xffab\n"


def test_an_empty_path_is_refused() -> None:
    with pytest.raises(OutputError, match="empty output path"):
        write_output("", "x")


def test_chunks_are_written_in_order(tmp_path: Path) -> None:
    out = tmp_path / "big.csv"
    write_output(str(out), (f"{i}\n" for i in range(100_000)))
    lines = out.read_text().splitlines()
    assert len(lines) == 100_000 and lines[-1] == "99999"


class Boom(Exception):
    pass


def _failing(after: int) -> Iterator[str]:
    for i in range(after):
        yield f"{i}\n"
    raise Boom


def test_a_failing_producer_leaves_the_old_file_and_no_temp(tmp_path: Path) -> None:
    out = tmp_path / "out.txt"
    out.write_text("old")
    with pytest.raises(Boom):
        write_output(str(out), _failing(1000))
    assert out.read_text() == "old"
    assert _leftovers(tmp_path) == []


def test_a_failing_producer_leaves_no_new_file(tmp_path: Path) -> None:
    with pytest.raises(Boom):
        write_output(str(tmp_path / "out.txt"), _failing(3))
    assert list(tmp_path.iterdir()) == []


def test_errors_name_out_never_the_temp_file(tmp_path: Path,
                                             monkeypatch: pytest.MonkeyPatch) -> None:
    def refuse(src: str, dst: str) -> None:
        raise PermissionError(13, "Permission denied", src)

    monkeypatch.setattr(output.os, "replace", refuse)
    out = tmp_path / "out.txt"
    with pytest.raises(OutputError) as e:
        write_output(str(out), "x")
    assert str(e.value) == f"{out}: cannot write (Permission denied)"
    assert ".part" not in str(e.value)
    monkeypatch.undo()
    assert list(tmp_path.iterdir()) == []


def test_several_outputs_all_or_none_when_one_producer_fails(tmp_path: Path) -> None:
    a, b = tmp_path / "a.csv", tmp_path / "b.csv"
    b.write_text("old b")
    with pytest.raises(Boom):
        write_outputs([(str(a), "A\n"), (str(b), _failing(10))])
    assert not a.exists() and b.read_text() == "old b"
    assert _leftovers(tmp_path) == []


def test_several_outputs_all_or_none_when_a_rename_fails(tmp_path: Path,
                                                         monkeypatch: pytest.MonkeyPatch) -> None:
    a, b, c = tmp_path / "a.csv", tmp_path / "b.csv", tmp_path / "c.csv"
    a.write_text("old a")
    real_replace = os.replace
    calls = []

    def replace_then_fail(src: str, dst: str) -> None:
        calls.append(dst)
        if dst == str(c):
            raise OSError(28, "No space left on device", src)
        real_replace(src, dst)

    monkeypatch.setattr(output.os, "replace", replace_then_fail)
    with pytest.raises(OutputError, match=f"^{c}: cannot write"):
        write_outputs([(str(a), "new a"), (str(b), "new b"), (str(c), "new c")])
    monkeypatch.undo()
    assert a.read_text() == "old a"  # restored from its backup link
    assert not b.exists() and not c.exists()  # new files removed again
    assert _leftovers(tmp_path) == []


def test_several_outputs_all_written(tmp_path: Path) -> None:
    a, b = tmp_path / "a", tmp_path / "b"
    a.write_text("old")
    write_outputs([(str(a), "1"), (str(b), iter([b"2", "3"]))])
    assert a.read_text() == "1" and b.read_text() == "23"
    assert _leftovers(tmp_path) == []


def test_temp_files_go_even_when_unlinking_the_target_fails(
        tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    a, b = tmp_path / "a", tmp_path / "b"
    real_replace, real_unlink = os.replace, os.unlink

    def fail_on_b(src: str, dst: str) -> None:
        if dst == str(b):
            raise OSError(5, "Input/output error", src)
        real_replace(src, dst)

    def unlink(path: str) -> None:
        if path == str(a):  # rolling back the new a fails…
            raise PermissionError(13, "Permission denied", path)
        real_unlink(path)

    monkeypatch.setattr(output.os, "replace", fail_on_b)
    monkeypatch.setattr(output.os, "unlink", unlink)
    with pytest.raises(OutputError, match=f"^{b}: cannot write"):
        write_outputs([(str(a), "1"), (str(b), "2")])
    monkeypatch.undo()
    assert _leftovers(tmp_path) == []  # …yet b's temp file is gone


def test_sigterm_during_a_write_removes_the_temp_file(tmp_path: Path) -> None:
    out = tmp_path / "out.txt"
    out.write_text("old")

    def producer() -> Iterator[str]:
        yield "partial\n"
        os.kill(os.getpid(), signal.SIGTERM)
        yield "never\n"

    assert signal.getsignal(signal.SIGTERM) == signal.SIG_DFL
    with pytest.raises(OutputInterrupted):
        write_output(str(out), producer())
    assert out.read_text() == "old"
    assert _leftovers(tmp_path) == []
    assert signal.getsignal(signal.SIGTERM) == signal.SIG_DFL  # handler restored


def test_ctrl_c_during_a_write_removes_the_temp_file(tmp_path: Path) -> None:
    def producer() -> Iterator[str]:
        yield "partial\n"
        raise KeyboardInterrupt

    with pytest.raises(KeyboardInterrupt):
        write_output(str(tmp_path / "out.txt"), producer())
    assert list(tmp_path.iterdir()) == []


@pytest.mark.slow
def test_sigterm_to_the_cli_mid_stream_leaves_nothing(tmp_path: Path) -> None:
    import time

    out = tmp_path / "times.csv"
    proc = subprocess.Popen(
        [sys.executable, "-m", "verify.cli", "simulate", str(ROOT / "examples" /
                                                             "free-curve-nema17.json"),
         "--pulses", "10000000", "--pulse-times", str(out)],
        cwd=ROOT, stdout=subprocess.PIPE, stderr=subprocess.PIPE)
    deadline = time.monotonic() + 120
    while not _leftovers(tmp_path) and time.monotonic() < deadline and proc.poll() is None:
        time.sleep(0.05)
    assert _leftovers(tmp_path), "the temp file never appeared"
    proc.send_signal(signal.SIGTERM)
    _, err = proc.communicate(timeout=120)
    assert proc.returncode == 128 + signal.SIGTERM
    assert err.decode().count("\n") == 1 and "interrupted by signal 15" in err.decode()
    assert list(tmp_path.iterdir()) == []


# --- unsafe output paths, refused before anything is read (issue #20 items 9, 10) -----------------
def test_write_output_never_writes_a_file_for_a_folder_name(tmp_path: Path) -> None:
    with pytest.raises(OutputError, match="ends in /"):
        write_output(f"{tmp_path}/newdir/", "x")
    assert list(tmp_path.iterdir()) == []


def test_a_folder_name_is_refused(tmp_path: Path) -> None:
    (tmp_path / "d").mkdir()
    for out, says in ((f"{tmp_path}/new/", "ends in /"), (str(tmp_path / "d"), "is a directory"),
                      (f"{tmp_path}/d/", "ends in /"), (f"{tmp_path}/no/f", "does not exist")):
        with pytest.raises(OutputError, match=says):
            output.refuse_unsafe_outputs([("-o", out)], [])
    output.refuse_unsafe_outputs([("-o", f"{tmp_path}/no/f")], [], folder_ok=True)
    output.refuse_unsafe_outputs([], [], folders=[("-o", f"{tmp_path}/d/")])


def test_an_input_is_never_an_output(tmp_path: Path) -> None:
    f = tmp_path / "t.json"
    f.write_text("{}")
    (tmp_path / "link").symlink_to("t.json")
    os.link(f, tmp_path / "hard")
    for out in (f, tmp_path / "link", tmp_path / "hard", f"{tmp_path}/./t.json"):
        with pytest.raises(OutputError, match="is the input"):
            output.refuse_unsafe_outputs([("-o", str(out))], ["x", str(f)])
    with pytest.raises(OutputError, match="is the input"):  # an input named by a link
        output.refuse_unsafe_outputs([("-o", str(f))], [str(tmp_path / "link")])
    output.refuse_unsafe_outputs([("-o", str(tmp_path / "new"))], [str(f)])


def test_streams_and_devices_are_never_the_same_file() -> None:
    output.refuse_unsafe_outputs([("-o", "-"), ("--csv", "/dev/stdout"), ("--x", "/dev/null")],
                                 ["-", "/dev/null"])


def test_two_outputs_naming_one_file_are_refused(tmp_path: Path) -> None:
    with pytest.raises(OutputError, match=r"--csv .* names the same file"):
        output.refuse_unsafe_outputs([("--csv", str(tmp_path / "a")),
                                      ("--samples", f"{tmp_path}/./a")], [])
