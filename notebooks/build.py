"""Generate the notebooks (outputs stripped) from their sources, and the README figure.

    python notebooks/build.py              # notebooks and docs/img/compare-nema17.png
    python notebooks/build.py notebooks    # the .ipynb only
    python notebooks/build.py figures      # the PNG only
    python notebooks/build.py notebooks --out DIR   # write the notebooks elsewhere

Each notebook's source is `notebooks/<name>.py` in jupytext's percent format (`# %%`
starts a code cell, `# %% [markdown]` a text cell): edit those, not the .ipynb files.
The notebooks are written with fixed cell ids and no outputs, so running this twice
gives byte-identical files (tests/docs/test_notebooks.py checks the committed ones against a
fresh build).
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

NOTEBOOKS = ("design-free-curve", "linear-vs-free-curve", "upload-files", "two-axis-move",
             "machine-to-table", "design-interactive")


def source_path(stem: str) -> Path:
    return HERE / f"{stem}.py"


def notebook(stem: str) -> Any:
    """The notebook of `stem`'s percent-format source, with fixed cell ids."""
    import jupytext
    import nbformat
    from nbformat.v4 import new_code_cell, new_markdown_cell, new_notebook

    cells = [(c.cell_type, c.source) for c in jupytext.read(source_path(stem)).cells]

    nb = new_notebook(metadata={
        "kernelspec": {"display_name": "Python 3", "language": "python", "name": "python3"},
        "language_info": {"name": "python"},
    })
    for i, (kind, source) in enumerate(cells):
        c = new_markdown_cell(source) if kind == "markdown" else new_code_cell(source)
        c.id = f"{stem}-{i:02d}"  # fixed ids: the build is reproducible
        nb.cells.append(c)
    nbformat.validate(nb)
    return nb


def write_notebooks(out_dir: Path) -> list[Path]:
    import nbformat

    out_dir.mkdir(parents=True, exist_ok=True)
    written = []
    for stem in NOTEBOOKS:
        path = out_dir / f"{stem}.ipynb"
        nbformat.write(notebook(stem), str(path))
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
