"""The notebooks: committed clean and reproducible, and each runs top to bottom.

Execution uses a kernel of THIS interpreter (the one with stepramp's dependencies):
the `python3` kernel spec when it launches this interpreter, otherwise one
registered into a temporary folder, so a fresh machine needs nothing installed
beyond the `dev` extra. The kernel gets MPLBACKEND=Agg (headless), the
repository root on PYTHONPATH (a plain checkout works without `pip install`)
and a temporary working directory.
"""

from __future__ import annotations

import json
import os
import time
from pathlib import Path
from typing import Any

import pytest

from tests.support.notebooks import (
    FALLBACK_KERNEL,
    kernel_for_this_interpreter,
    runs_this_interpreter,
)
from tests.support.paths import ROOT, load_script

NOTEBOOK_DIR = ROOT / "notebooks"


NOTEBOOKS = ("design-free-curve", "linear-vs-free-curve", "upload-files", "two-axis-move",
             "machine-to-table", "design-interactive")


CELL_TIMEOUT_S = 120


def _load_build() -> Any:
    return load_script(NOTEBOOK_DIR / "build.py", "notebooks_build")


@pytest.mark.parametrize("stem", NOTEBOOKS)
def test_committed_notebook_is_valid_and_stripped(stem: str) -> None:
    import nbformat

    path = NOTEBOOK_DIR / f"{stem}.ipynb"
    nb = nbformat.read(str(path), as_version=nbformat.NO_CONVERT)
    assert nb.nbformat == 4
    nbformat.validate(nb)
    code = [c for c in nb.cells if c.cell_type == "code"]
    assert code, f"{path.name} has no code cells"
    for c in code:
        assert c.outputs == [], f"{path.name} cell {c.id} carries outputs"
        assert c.execution_count is None, f"{path.name} cell {c.id} has an execution count"
    assert nb.metadata.kernelspec.name == "python3"


def test_notebook_folder_holds_exactly_the_built_notebooks_and_their_sources() -> None:
    assert sorted(p.stem for p in NOTEBOOK_DIR.glob("*.ipynb")) == sorted(NOTEBOOKS)
    assert sorted(_load_build().NOTEBOOKS) == sorted(NOTEBOOKS)
    # each notebook's source is a jupytext percent-format file beside it, nothing else
    sources = sorted(p.stem for p in NOTEBOOK_DIR.glob("*.py") if p.name != "build.py")
    assert sources == sorted(NOTEBOOKS)
    for stem in NOTEBOOKS:
        assert (NOTEBOOK_DIR / f"{stem}.py").read_text().startswith("# %%"), stem


def test_committed_notebooks_match_a_fresh_build(tmp_path: Path) -> None:
    build = _load_build()
    written = build.write_notebooks(tmp_path)
    assert [p.name for p in written] == [f"{s}.ipynb" for s in build.NOTEBOOKS]
    for path in written:
        committed = NOTEBOOK_DIR / path.name
        assert path.read_text() == committed.read_text(), (
            f"{path.name} differs from its source notebooks/{path.stem}.py: run "
            "`python notebooks/build.py notebooks` and commit")


def test_notebooks_find_the_repository_through_the_packages() -> None:
    for stem in NOTEBOOKS:
        text = (NOTEBOOK_DIR / f"{stem}.ipynb").read_text()
        source = (NOTEBOOK_DIR / f"{stem}.py").read_text()
        # motors by name (`load_motor("nema17-1600")`) or the bundled list, never a path
        assert "/work/" not in text and "profiles/data/" not in text, stem
        assert "bundled_motor_paths()" in source or 'load_motor("' in source, stem


def test_readme_figure_is_committed_and_small() -> None:
    path = ROOT / "docs" / "img" / "compare-nema17.png"
    data = path.read_bytes()
    assert data[:8] == b"\x89PNG\r\n\x1a\n"
    assert len(data) <= 300 * 1024


def test_kernel_spec_of_this_interpreter_is_used_as_is(tmp_path: Path) -> None:
    from jupyter_client.kernelspec import KernelSpecManager

    # No python3 spec on the search path: ipykernel's own (native) spec is this interpreter.
    bare = KernelSpecManager(kernel_dirs=[str(tmp_path / "none")])
    name, ksm = kernel_for_this_interpreter(tmp_path / "prefix", manager=bare)
    assert (name, ksm) == ("python3", bare)
    assert not (tmp_path / "prefix").exists()


def test_kernel_fallback_registers_this_interpreter(tmp_path: Path) -> None:
    from jupyter_client.kernelspec import KernelSpecManager

    # A python3 spec of another interpreter comes first on the search path.
    other = tmp_path / "kernels" / "python3"
    other.mkdir(parents=True)
    (other / "kernel.json").write_text(json.dumps({
        "argv": [str(tmp_path / "elsewhere" / "python"), "-m", "ipykernel_launcher",
                 "-f", "{connection_file}"],
        "display_name": "another Python", "language": "python"}))
    shadowed = KernelSpecManager(kernel_dirs=[str(tmp_path / "kernels")])
    assert not runs_this_interpreter(shadowed.get_kernel_spec("python3").argv)
    name, ksm = kernel_for_this_interpreter(tmp_path / "prefix", manager=shadowed)
    assert name == FALLBACK_KERNEL
    spec = ksm.get_kernel_spec(name)
    assert runs_this_interpreter(spec.argv)
    assert "ipykernel_launcher" in spec.argv
    assert (tmp_path / "prefix" / "share" / "jupyter" / "kernels" / FALLBACK_KERNEL).is_dir()


@pytest.fixture(scope="module")
def kernel(tmp_path_factory: pytest.TempPathFactory) -> tuple[str, Any]:
    return kernel_for_this_interpreter(tmp_path_factory.mktemp("kernelspec"))


# Prepended to the in-memory copy only. Under Agg, plt.show() draws nothing, so a figure
# that fails only when drawn (limits, scales, layout) would pass unnoticed: after every
# cell, render each open figure to PNG and display it, as the inline backend does.
RENDER_FIGURES = """\
import io
import warnings

import matplotlib.pyplot as _plt
from IPython import get_ipython
from IPython.display import Image, display

warnings.filterwarnings("ignore", message=".*non-interactive.*")


def _render_open_figures():
    for num in _plt.get_fignums():
        buf = io.BytesIO()
        _plt.figure(num).savefig(buf, format="png", dpi=40)
        display(Image(buf.getvalue()))
    _plt.close("all")


get_ipython().events.register("post_execute", _render_open_figures)
"""


@pytest.mark.slow
@pytest.mark.parametrize("stem", NOTEBOOKS)
def test_notebook_runs_top_to_bottom(stem: str, kernel: tuple[str, Any], tmp_path: Path,
                                     monkeypatch: pytest.MonkeyPatch) -> None:
    import nbformat
    from jupyter_client.manager import KernelManager
    from nbclient import NotebookClient

    name, ksm = kernel
    monkeypatch.setenv("MPLBACKEND", "Agg")
    monkeypatch.setenv("PYTHONPATH", os.pathsep.join(
        [str(ROOT)] + [p for p in os.environ.get("PYTHONPATH", "").split(os.pathsep) if p]))
    nb = nbformat.read(str(NOTEBOOK_DIR / f"{stem}.ipynb"), as_version=4)
    nb.cells.insert(0, nbformat.v4.new_code_cell(RENDER_FIGURES, id="test-render-figures"))
    km = KernelManager(kernel_name=name, kernel_spec_manager=ksm)
    client = NotebookClient(nb, km=km, timeout=CELL_TIMEOUT_S,
                            resources={"metadata": {"path": str(tmp_path)}})
    t0 = time.perf_counter()
    client.execute()  # raises CellExecutionError on the first failing cell
    elapsed_s = time.perf_counter() - t0
    code = [c for c in nb.cells[1:] if c.cell_type == "code"]
    assert all(c.execution_count is not None for c in code)
    errors = [o for c in code for o in c.outputs if o.output_type == "error"]
    assert not errors, json.dumps(errors, default=str)[:2000]
    # Every figure the notebook shows was drawn and reached the output as an image.
    images = sum("image/png" in o.get("data", {}) for c in code for o in c.outputs)
    drawn = sum(c.source.count("plt.show()") for c in code)
    assert images >= drawn, f"{stem}: {drawn} plt.show() calls but {images} images"
    print(f"{stem}: {elapsed_s:.1f} s")
