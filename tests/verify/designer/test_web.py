"""`stepramp design`: the designer as a web page (verify/designer/web.py, verify/cli/design.py).

In-process: the command's refusals and the page's controls, verdict and files. In a
real headless Chromium driven by Playwright: the served page, a slider dragged with the
mouse, the verdict changing, the downloads checked by `stepramp check`, Ctrl-C."""

from __future__ import annotations

import json
import os
import re
import selectors
import shutil
import signal
import subprocess
import sys
import time
from collections.abc import Iterator
from pathlib import Path
from typing import Any

import pytest

from profiles.ppmc312 import decode_upload
from profiles.ppmc312.formats import parse_upload
from profiles.ppmc312.table import load_table
from tests.support.designer_settings import NEMA17, NEMA17_PATH, RINGS
from tests.support.paths import ROOT
from tests.support.subprocess_env import checkout_env
from verify.designer import JUDGING, TIGHTENING, design

CHROMIUM_ARGS = ["--headless", "--no-sandbox", "--disable-gpu", "--disable-quic",
                 "--no-first-run", "--disable-background-networking",
                 "--disable-component-update", "--disable-sync"]


@pytest.mark.slow  # 2–4 s: the quick suite's budget; CI runs it
def test_page_controls_drive_the_verdict_and_the_files() -> None:
    from verify.designer import verdict
    from verify.designer.web import DesignPage

    page = DesignPage(NEMA17, pulses=5_000, motor_name="nema17")
    assert page.result is not None
    first = page.result
    assert 'data-level="safe"' in page.verdict.object.replace("'", '"')
    assert page.figure.object[:8] == b"\x89PNG\r\n\x1a\n"
    # The verdict shown is the library's for the same settings.
    assert verdict(first).text in page.verdict.object
    assert design(NEMA17, page.settings).plan.table == first.plan.table

    page.controls["plan_to_aim"].value = False  # the plain criterion's table: the aim
    plain = page.result                          # then only moves the verdict
    assert plain is not None and plain is not first
    page.controls["load_angle_aim_deg"].value = 10.0
    assert "past-aim" in page.verdict.object and "aim 10°" in page.verdict.object
    assert page.result is not plain and page.result.plan.table == plain.plan.table

    page.upload_format.value = "ihex"
    names = [b.filename for b in page.downloads.values()]
    assert names == ["design-nema17-5000.table.json", "design-nema17-5000.upload.ihex"]
    (_, table_json), (_, upload) = page.files()
    assert json.loads(table_json)["format"] == "stepramp.table/1"
    assert decode_upload(parse_upload(upload)) == page.result.plan.table

    page.controls["load_torque_nm"].value = page.controls["load_torque_nm"].end
    page.controls["safety_factor"].value = 0.1  # the load now exceeds the motor's torque
    assert "NO TABLE" in page.verdict.object and "cannot accelerate" in page.verdict.object
    assert all(b.disabled for b in page.downloads.values())


def chromium() -> str:
    """Debian's Chromium (Playwright cannot download its own here); skips locally without
    it, fails in CI, which must run this test (.ci/run installs it)."""
    found = shutil.which("chromium") or shutil.which("chromium-browser")
    why = None
    if found is None:
        why = "no Chromium (Debian package `chromium`; .ci/run installs it)"
    else:
        try:
            import playwright  # noqa: F401
        except ImportError:
            why = "no playwright (pip install -e '.[dev]')"
    if why:
        if os.environ.get("CI"):
            pytest.fail(f"{why}: the browser test must run in CI")
        pytest.skip(why)
    assert found is not None
    return found


@pytest.fixture
def server() -> Iterator[tuple[subprocess.Popen[str], str]]:
    """`stepramp design --no-browser --port 0` in a subprocess, and the address it prints."""
    pytest.importorskip("panel")
    proc = subprocess.Popen(
        [sys.executable, "-m", "verify.cli", "design", "--motor", str(NEMA17_PATH),
         "--no-browser", "--port", "0", "--pulses", "5000"],
        stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True, cwd=ROOT,
        env=checkout_env(MPLBACKEND="Agg"))
    try:
        line = _read_line(proc, timeout_s=180)
        found = re.search(r"http://127\.0\.0\.1:\d+/", line)
        assert found, f"no address in {line!r}; stderr: {proc.stderr.read() if proc.stderr else ''}"
        yield proc, found.group(0)
    finally:
        if proc.poll() is None:
            proc.kill()
            proc.wait()


def _read_line(proc: subprocess.Popen[str], timeout_s: float) -> str:
    assert proc.stdout is not None
    with selectors.DefaultSelector() as sel:
        sel.register(proc.stdout, selectors.EVENT_READ)
        if not sel.select(timeout_s):
            raise AssertionError(f"the server said nothing in {timeout_s} s")
    return proc.stdout.readline()


def _drag(page: Any, key: str, fraction: float) -> None:
    """Drag slider `key`'s handle with the mouse to `fraction` of its track."""
    handle = page.locator(f".sr-{key} .noUi-handle")
    track = page.locator(f".sr-{key} .noUi-base").bounding_box()
    box = handle.bounding_box()
    y = box["y"] + box["height"] / 2
    page.mouse.move(box["x"] + box["width"] / 2, y)
    page.mouse.down()
    page.mouse.move(track["x"] + fraction * track["width"], y, steps=8)
    page.mouse.up()


def _download(page: Any, key: str, folder: Path) -> Path:
    with page.expect_download() as info:
        page.click(f".sr-{key} button")
    folder.mkdir(exist_ok=True)
    path = folder / info.value.suggested_filename
    info.value.save_as(path)
    return path


def _check(*files: Path) -> subprocess.CompletedProcess[str]:
    return subprocess.run([sys.executable, "-m", "verify.cli", "check", "--motor",
                           str(NEMA17_PATH), *map(str, files)], capture_output=True, text=True,
                          cwd=ROOT, timeout=300, env=checkout_env())


@pytest.mark.slow
def test_in_a_browser_sliders_change_the_verdict_and_downloads_check(
        server: tuple[subprocess.Popen[str], str], tmp_path: Path) -> None:
    from playwright.sync_api import sync_playwright

    executable = chromium()
    proc, url = server
    failed: list[str] = []
    with sync_playwright() as pw:
        browser = pw.chromium.launch(executable_path=executable, args=CHROMIUM_ARGS)
        try:
            page = browser.new_page(viewport={"width": 1400, "height": 1100},
                                    accept_downloads=True)
            page.on("requestfailed", lambda r: failed.append(r.url))
            page.goto(url)
            verdict = page.locator("#sr-verdict")
            verdict.wait_for(timeout=60_000)
            assert verdict.get_attribute("data-level") == "safe", verdict.inner_text()
            assert "5000 pulses" in page.locator(".sr-numbers").inner_text()

            # The safe design's files, as the browser saves them, pass `stepramp check`.
            table = _download(page, "table", tmp_path)
            upload = _download(page, "upload", tmp_path)
            assert (table.name, upload.name) == ("design-nema17-1600-5000.table.json",
                                                 "design-nema17-1600-5000.upload.hex")
            done = _check(table, upload)
            assert done.returncode == 0, done.stdout + done.stderr
            assert decode_upload(parse_upload(upload.read_bytes())) == load_table(table)

            # Plan by the plain criterion, then tighten the aim below the design's load
            # angle: the verdict says so.
            page.click(".sr-plan_to_aim input")
            page.locator("#sr-verdict[data-level='past-aim']").wait_for(timeout=60_000)
            _drag(page, "load_angle_aim_deg", 0.0)
            page.locator("#sr-verdict[data-level='past-aim']", has_text="aim 10°").wait_for(
                timeout=60_000)
            # Plan at the whole pull-out torque: the rotor slips a pole.
            _drag(page, "safety_factor", 1.0)
            page.locator("#sr-verdict[data-level='unsafe']").wait_for(timeout=60_000)
            assert "UNSAFE" in verdict.inner_text()
            numbers = page.locator(".sr-numbers").inner_text()
            unsafe = _download(page, "table", tmp_path / "unsafe")
            stages = len(load_table(unsafe).rates)
            assert f"{stages} stages" in numbers
            # That table breaks the motor file's criterion (safety factor 0.6): exit 1.
            assert _check(unsafe).returncode == 1
        finally:
            browser.close()
    assert not failed, f"requests failed (the page must load offline): {failed}"
    # Ctrl-C stops the server cleanly: exit 0, one line, no traceback.
    proc.send_signal(signal.SIGINT)
    assert proc.wait(timeout=60) == 0
    err = proc.stderr.read() if proc.stderr else ""
    assert "stopped" in err and "Traceback" not in err, err


@pytest.mark.slow
def test_the_server_stops_on_sigterm_too(server: tuple[subprocess.Popen[str], str]) -> None:
    proc, _ = server
    t0 = time.perf_counter()
    proc.terminate()
    assert proc.wait(timeout=60) == 0
    assert time.perf_counter() - t0 < 30


# Records, in the page, every verdict the server sends (its HTML) and whether the table's
# download was enabled then: the steps of a change come faster than a test could poll.
RECORD_VERDICTS = """() => {
  const doc = Bokeh.documents[0];
  const models = [...(doc.all_models || doc._all_models.values())];
  const has = (m, c) => (m.css_classes || []).includes(c);
  const verdict = models.find(m => has(m, 'sr-verdict'));
  const table = models.find(m => has(m, 'sr-table'));
  window.srVerdicts = [];
  window.srTask = 0;  // counts the page's turns: steps sent in one message share one
  if (!verdict || !table) return false;
  verdict.property('text').change.connect(() => {
    window.srVerdicts.push([verdict.text, !table.disabled, window.srTask]);
    setTimeout(() => { window.srTask += 1; }, 0);
  });
  return true;
}"""


@pytest.mark.slow
def test_in_a_browser_a_change_shows_its_first_table_marked_then_the_final(
        server: tuple[subprocess.Popen[str], str]) -> None:
    """The browser receives each step of a change (issue #32 item 9): the first table
    marked as being tightened, the final table while the other commands are judged, then
    the verdict over every command; the downloads only at the last."""
    from playwright.sync_api import sync_playwright


    executable = chromium()
    _, url = server
    with sync_playwright() as pw:
        browser = pw.chromium.launch(executable_path=executable, args=CHROMIUM_ARGS)
        try:
            page = browser.new_page(viewport={"width": 1400, "height": 1100})
            page.goto(url)
            page.locator("#sr-verdict[data-level='safe']").wait_for(timeout=60_000)
            assert page.evaluate(RECORD_VERDICTS), "no #sr-verdict in the page"
            _drag(page, "pulses", 0.04)  # about 8 000 pulses: a new plan, tightened
            page.wait_for_function(  # the change's last step: a verdict over every command
                f"() => window.srVerdicts.some(([t]) => !t.includes({TIGHTENING!r}) && "
                f"!t.includes({JUDGING!r}))", timeout=60_000)
            numbers = page.locator(".sr-numbers", has_text="judged in full in")
            assert "first table shown in" in numbers.inner_text()
            assert page.locator(".sr-table button").is_enabled()
            steps: list[list[Any]] = []  # each verdict the page showed, its download state
            shown = page.evaluate("() => window.srVerdicts")
            # the first table came in a message of its own, before the tightening was done
            assert shown[0][2] != shown[-1][2], shown
            for text, downloads, _turn in shown:
                level = re.search(r"data-level=(?:&#x27;|')([a-z-]+)", text)  # escaped
                step = [level and level.group(1), TIGHTENING in text, JUDGING in text,
                        downloads]
                if not steps or steps[-1] != step:
                    steps.append(step)
            # the downloads stay off until the verdict over every command shows
            assert steps == [["tightening", True, False, False], ["safe", False, True, False],
                             ["safe", False, False, False]], steps
        finally:
            browser.close()


@pytest.mark.slow  # a Panel page: about 2 s
def test_the_page_shows_the_first_table_then_the_final_on_the_next_turn() -> None:
    pytest.importorskip("panel")
    from verify.designer.web import DesignPage

    page = DesignPage(NEMA17, pulses=3_000, motor_name="nema17")
    assert page.result is not None and page.result.final  # it opens on a final table
    later: list[Any] = []

    class Doc:  # a served tab's document: callbacks run on the server's next turn
        session_context = object()

        def add_next_tick_callback(self, callback: Any) -> None:
            later.append(callback)

    page._doc = Doc()
    page.controls["pulses"].value = RINGS.pulses
    assert page.result.final is False and len(later) == 1
    assert "data-level='tightening'" in page.verdict.object
    assert all(b.disabled for b in page.downloads.values())
    assert TIGHTENING in page.summary.object
    page.controls["pulses"].value = 5_200  # a newer change before the final came
    later.pop(0)()                          # the older final is dropped
    assert page.result.settings.pulses == 5_200 and not page.result.final
    later.pop(0)()
    assert page.result.final and page.result.plan.table == design(
        NEMA17, page.settings).plan.table
    assert "data-level='safe'" in page.verdict.object and JUDGING in page.verdict.object
    assert all(b.disabled for b in page.downloads.values())  # not judged in full yet
    assert "final table shown in" in page.summary.object
    later.pop(0)()
    assert page.result.complete and not later
    assert "data-level='safe'" in page.verdict.object and JUDGING not in page.verdict.object
    assert not any(b.disabled for b in page.downloads.values())
    assert "judged in full in" in page.summary.object
