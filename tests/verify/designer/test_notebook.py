"""The designer as a notebook widget (verify/designer/notebook.py): its controls
in-process, its notebook driven from Python in an executed kernel, and a screenshot of the
rendered notebook in headless Chromium."""

from __future__ import annotations

import itertools
import json
import os
import shutil
import subprocess
from pathlib import Path
from typing import Any

import ipywidgets  # noqa: F401  (a [dev] dependency: missing, the suite fails)
import numpy as np
import pytest

from profiles.ppmc312 import decode_upload
from profiles.ppmc312.formats import parse_upload
from profiles.ppmc312.table import load_table
from tests.support.designer_settings import NEMA17, RINGS
from tests.support.paths import ROOT
from tests.support.subprocess_env import checkout_env
from verify.designer import (
    JUDGING,
    TIGHTENING,
    Designer,
    Settings,
    design,
    design_steps,
    designer,
    loaded_motor,
)


@pytest.fixture
def d(tmp_path: Path) -> Designer:
    return designer(NEMA17, pulses=5_000, out_dir=tmp_path, load_angle=True)

def test_it_opens_on_the_given_motor_with_a_figure(d: Designer) -> None:
    assert d.motor is NEMA17 and d.result is not None
    assert d.image.value[:8] == b"\x89PNG\r\n\x1a\n"
    assert d.result.settings == Settings(pulses=5_000, safety_factor=NEMA17.safety_factor,
                                         load_torque_nm=NEMA17.load_torque_nm,
                                         friction_torque_nm=NEMA17.friction_torque_nm)
    assert "5000 pulses" in d.summary.value and "load angle" in d.summary.value

@pytest.mark.parametrize(("control", "value", "slower"), [
    ("safety_factor", 0.3, True),
    ("load_inertia_kgm2", 3 * NEMA17.inertia_kgm2, True),
    ("load_torque_nm", 0.05, True),
    ("pulses", 8_000, True),
    ("max_stages", 8, True),
])
def test_each_slider_replans_and_redraws(d: Designer, control: str, value: Any,
                                         slower: bool) -> None:
    before = d.result
    assert before is not None
    png, summary = d.image.value, d.summary.value
    d.controls[control].value = value
    after = d.result
    assert after is not before and after is not None
    assert d.image.value != png and d.summary.value != summary
    assert (after.execution.duration_s > before.execution.duration_s) == slower
    # The plan is the one for the loaded motor the settings describe.
    assert after.motor.to_json() == loaded_motor(NEMA17, after.settings).to_json()
    assert after.plan.table == design(NEMA17, after.settings).plan.table

def test_stage_budget_and_clock_reach_the_table(d: Designer) -> None:
    d.controls["max_stages"].value = 12
    assert d.result is not None and len(d.result.plan.table.rates) <= 12
    d.controls["clock"].value = "1MHz"
    assert d.result.plan.table.clock.name == "1MHz"

def test_load_torque_is_the_motors_signed_load_torque(d: Designer) -> None:
    d.controls["load_torque_nm"].value = -0.04
    assert d.result is not None
    assert d.result.motor.load_torque_nm == pytest.approx(-0.04)
    assert d.result.motor.friction_torque_nm == NEMA17.friction_torque_nm
    assert d.controls["load_torque_nm"].min < 0 < d.controls["load_torque_nm"].max

def test_motor_picker_switches_motor_and_resets_its_sliders(d: Designer) -> None:
    other = next(k for k in d.motors if "nema23" in k)
    d.controls["safety_factor"].value = 0.3
    d.controls["motor"].value = other
    assert d.result is not None and d.motor is d.motors[other]
    assert d.result.settings.safety_factor == d.motors[other].safety_factor
    assert d.result.settings.load_inertia_kgm2 == 0.0
    assert d.result.motor.name == d.motors[other].name

def test_impossible_settings_say_why_and_keep_the_last_design(d: Designer) -> None:
    d.controls["load_torque_nm"].value = d.controls["load_torque_nm"].max
    kept, png = d.result, d.image.value
    d.controls["safety_factor"].value = 0.1  # the load torque now exceeds the motor's torque
    assert "no table for these settings" in d.status.value
    assert "cannot accelerate from rest" in d.status.value
    assert d.result is kept and d.image.value == png

def test_write_button_writes_the_table_and_upload_files_that_decode_back(
        d: Designer, tmp_path: Path) -> None:
    d.buttons["write"].click()
    names = sorted(p.name for p in d.written)
    assert names == sorted(f"design-nema17-1600-5000.{ext}" for ext in
                           ("table.json", "upload.hex", "upload.bin", "upload.h"))
    assert d.result is not None
    table = d.result.plan.table
    assert load_table(tmp_path / "design-nema17-1600-5000.table.json") == table
    for ext in ("hex", "bin"):
        blocks = parse_upload((tmp_path / f"design-nema17-1600-5000.upload.{ext}").read_bytes())
        assert decode_upload(blocks) == table
    assert "wrote" in d.status.value

@pytest.mark.slow
def test_reference_button_solves_the_slow_references(d: Designer) -> None:
    png = d.image.value
    d.buttons["references"].click()
    assert set(d.slow) == {"toppra", "ruckig", "casadi"}
    assert d.image.value != png
    assert d.result is not None
    for name in ("toppra", "casadi"):  # time-optimal solvers land on the exact optimum
        assert d.slow[name].duration_s == pytest.approx(d.result.exact.duration_s, rel=0.03)
    d.controls["pulses"].value = 6_000  # a new move: the old references no longer apply
    assert d.slow == {}

DRIVE = """\
import hashlib, json
def _state():
    return {"png": hashlib.sha256(design.image.value).hexdigest(),
            "summary": design.summary.value, "move_s": design.result.execution.duration_s,
            "stages": len(design.result.plan.table.rates),
            "clock": design.result.plan.table.clock.name}
_runs = {"start": _state()}
for _name, _value in [("pulses", 20000), ("safety_factor", 0.4),
                      ("load_inertia_kgm2", 8 * motor.inertia_kgm2), ("load_torque_nm", 0.03),
                      ("clock", "1MHz"), ("max_stages", 16), ("motor", "nema23-heavy")]:
    design.controls[_name].value = _value
    _runs[_name] = _state()
design.buttons["write"].click()
_runs["written"] = sorted(p.name for p in design.written)
print("DRIVE " + json.dumps(_runs))
"""

def execute_notebook(tmp_path: Path, extra: list[str], kernel: tuple[str, Any]) -> Any:
    import nbformat
    from jupyter_client.manager import KernelManager
    from nbclient import NotebookClient

    nb = nbformat.read(str(ROOT / "notebooks" / "design-interactive.ipynb"), as_version=4)
    for source in extra:
        nb.cells.append(nbformat.v4.new_code_cell(source))
    name, ksm = kernel
    env = checkout_env(MPLBACKEND="Agg")
    km = KernelManager(kernel_name=name, kernel_spec_manager=ksm)
    client = NotebookClient(nb, km=km, timeout=180, store_widget_state=True,
                            resources={"metadata": {"path": str(tmp_path)}})
    old = dict(os.environ)
    os.environ.update(env)
    try:
        client.execute()
    finally:
        os.environ.clear()
        os.environ.update(old)
    return nb

@pytest.fixture(scope="module")
def kernel(tmp_path_factory: pytest.TempPathFactory) -> tuple[str, Any]:
    from tests.support.notebooks import kernel_for_this_interpreter

    return kernel_for_this_interpreter(tmp_path_factory.mktemp("kernelspec"))

@pytest.mark.slow
def test_widgets_driven_in_a_kernel_change_the_outputs(tmp_path: Path,
                                                       kernel: tuple[str, Any]) -> None:
    nb = execute_notebook(tmp_path, [DRIVE], kernel)
    text = "".join(o.get("text", "") for o in nb.cells[-1].outputs if o.output_type == "stream")
    runs = json.loads(text.split("DRIVE ", 1)[1])
    steps = ["start", "pulses", "safety_factor", "load_inertia_kgm2", "load_torque_nm", "clock",
             "max_stages", "motor"]
    for previous, step in itertools.pairwise(steps):
        assert runs[step]["png"] != runs[previous]["png"], step
        assert runs[step]["summary"] != runs[previous]["summary"], step
    for step in ("pulses", "safety_factor", "load_inertia_kgm2", "load_torque_nm"):
        i = steps.index(step)
        assert runs[step]["move_s"] > runs[steps[i - 1]]["move_s"], step
    assert runs["clock"]["clock"] == "1MHz" and runs["max_stages"]["stages"] <= 16
    assert "NEMA23" in runs["motor"]["summary"]
    assert len(runs["written"]) == 4 and all((tmp_path / n).is_file() for n in runs["written"])
    # The widget's state went into the notebook (what a viewer renders).
    assert "application/vnd.jupyter.widget-state+json" in nb.metadata.get("widgets", {})

def browser() -> str | None:
    for name in ("chromium", "chromium-browser", "google-chrome", "chrome"):
        found = shutil.which(name)
        if found:
            return found
    return None

@pytest.mark.slow
def test_screenshot_of_the_rendered_notebook(tmp_path: Path, kernel: tuple[str, Any]) -> None:
    chrome = browser()
    if chrome is None:
        pytest.skip("no Chromium installed (Debian package `chromium`; .ci/run installs it)")
    from matplotlib.image import imread
    from nbconvert import HTMLExporter

    nb = execute_notebook(tmp_path, [], kernel)
    html, _ = HTMLExporter().from_notebook_node(nb)
    page = tmp_path / "design-interactive.html"
    page.write_text(html, encoding="utf-8")
    shot = tmp_path / "design-interactive.png"
    done = subprocess.run([chrome, "--headless", "--no-sandbox", "--disable-gpu",
                           "--hide-scrollbars", "--window-size=1280,4000",
                           f"--screenshot={shot}", page.as_uri()],
                          capture_output=True, text=True, timeout=180)
    assert shot.is_file(), done.stderr[-2000:]
    pixels = imread(str(shot))[..., :3]
    assert pixels.shape[0] >= 2000 and pixels.shape[1] >= 1000
    # The designer's figure is on the page: the staircase's red (tab:red) and the
    # exact optimum's grey lines, not a blank or an error page (the figure in-process
    # has about 500 such pixels, the page's scaled copy about 400).
    red = np.all(np.abs(pixels - np.array([214, 39, 40]) / 255) < 0.08, axis=-1)
    assert red.sum() > 250, f"{red.sum()} staircase-red pixels"
    assert pixels.std() > 0.05


def test_the_notebook_shows_both_tables_and_never_writes_a_first(tmp_path: Path) -> None:
    d = designer(NEMA17, pulses=3_000, out_dir=tmp_path)
    shown: list[str] = []
    d.summary.observe(lambda change: shown.append(change["new"]), names="value")
    d.controls["pulses"].value = RINGS.pulses
    assert len(shown) == 3 and TIGHTENING in shown[0] and JUDGING in shown[1]
    assert TIGHTENING not in shown[1] + shown[2] and JUDGING not in shown[2]
    assert d.result is not None and d.result.complete
    for step in list(design_steps(NEMA17, RINGS))[:2]:  # neither is judged in full
        d.result = step
        assert d.write() == [] and not any(tmp_path.iterdir())
