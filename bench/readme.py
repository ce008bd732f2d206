"""The README's measured blocks and figures, generated from bench/results/*.json (the
benchmarks) and reports/*.json (the test campaigns' summaries: fuzz, mutation).

    python bench/readme.py            rewrite every marked block, draw stale figures
    python bench/readme.py --check    exit 1 listing every block or figure that disagrees

A block is any section of any results or report file (bench/benchlib.py describes the
format):

    <!-- bench:<name>:<section> -->
    (generated: the section's table, its note, and where and when it was measured)
    <!-- /bench -->

A figure is drawn from a results file's `values["figures"][<id>]` (bench/benchfigures.py)
into docs/img/<id>.png, named by a marker on the line before its image:

    <!-- bench-figure:<name>:<id> -->
    ![what it shows](docs/img/<id>.png)

Each PNG carries the hash of the data it was drawn from, so `--check` knows a figure is
current without drawing it (tests/docs/test_readme.py runs the check).
"""

from __future__ import annotations

import argparse
import json
import os
import re
import sys
import tempfile
from pathlib import Path
from typing import Any

ROOT = Path(__file__).resolve().parent.parent
sys.path.insert(0, str(ROOT / "bench"))

from benchfigures import fingerprint, png_bytes, stamp_of  # noqa: E402
from benchlib import RESULTS, markdown_table  # noqa: E402

README = ROOT / "README.md"
REPORTS = ROOT / "reports"  # the test campaigns' summaries (not benchmarks)
IMAGES = ROOT / "docs" / "img"
BLOCK = re.compile(r"(<!-- bench:([\w.-]+):([\w.-]+) -->\n)(.*?)(<!-- /bench -->)", re.S)
FIGURE = re.compile(r"<!-- bench-figure:([\w.-]+):([\w.-]+) -->")


def load_results(folder: Path = RESULTS, reports: Path | None = REPORTS
                 ) -> dict[str, dict[str, Any]]:
    """Every results file, and every report of `reports`, by its name (with the file it
    came from as `_path`)."""
    out = {}
    for path in sorted([*folder.glob("*.json"),
                        *(reports.glob("*.json") if reports is not None else [])]):
        doc = json.loads(path.read_text(encoding="utf-8"))
        doc["_path"] = (str(path.relative_to(ROOT)) if path.is_relative_to(ROOT)
                        else str(path))
        out[doc.get("name", path.stem)] = doc
    return out


def render_section(doc: dict[str, Any], section_id: str) -> str:
    """A section as the README shows it: the table, its note, the measurement's line."""
    sec = doc["sections"][section_id]
    parts = [markdown_table(sec["columns"], sec["rows"])]
    if sec.get("note"):
        parts.append(sec["note"])
    m = doc.get("machine", {})
    load = ""
    if m.get("load_avg_before") is not None:
        load = f", load average {m['load_avg_before']:g}"
        if m.get("load_avg_after") is not None:
            load += f" → {m['load_avg_after']:g}"
    parts.append(f"<sub>`{doc['command']}`, {doc['measured_at'][:10]}, "
                 f"{m.get('cpus', '?')} CPUs{load}.</sub>")
    return "\n\n".join(parts) + "\n"


def render(text: str, results: dict[str, dict[str, Any]]) -> tuple[str, list[str]]:
    """`text` with every block regenerated, and the blocks that could not be (a results
    file or a section missing)."""
    missing: list[str] = []

    def block(m: re.Match[str]) -> str:
        name, section = m.group(2), m.group(3)
        doc = results.get(name)
        if doc is None or section not in doc.get("sections", {}):
            missing.append(f"bench:{name}:{section}: no such "
                           + ("results file" if doc is None else "section"))
            return m.group(0)
        return m.group(1) + "\n" + render_section(doc, section) + "\n" + m.group(5)

    return BLOCK.sub(block, text), missing


def figures(text: str, results: dict[str, dict[str, Any]], images: Path = IMAGES
            ) -> tuple[list[tuple[Path, dict[str, Any]]], list[str]]:
    """The figures the README names: (path, data) each, and those without data."""
    found, missing = [], []
    for m in FIGURE.finditer(text):
        name, fig = m.group(1), m.group(2)
        spec = results.get(name, {}).get("values", {}).get("figures", {}).get(fig)
        if spec is None:
            missing.append(f"bench-figure:{name}:{fig}: no such figure in the results")
        else:
            found.append((images / f"{fig}.png", spec))
    return found, missing


def problems(readme: Path = README, folder: Path = RESULTS, images: Path = IMAGES
             ) -> list[str]:
    """Every block and figure of `readme` that disagrees with the results in `folder`."""
    text = readme.read_text(encoding="utf-8")
    results = load_results(folder)
    new, out = render(text, results)
    old_blocks = {(m.group(2), m.group(3)): m.group(4) for m in BLOCK.finditer(text)}
    for m in BLOCK.finditer(new):
        if old_blocks.get((m.group(2), m.group(3))) != m.group(4):
            source = results[m.group(2)]["_path"]
            out.append(f"bench:{m.group(2)}:{m.group(3)}: the README's block differs from "
                       f"{source} (run python bench/readme.py)")
    drawn, missing = figures(text, results, images)
    out += missing
    for path, spec in drawn:
        stamp = stamp_of(path.read_bytes()) if path.is_file() else None
        if stamp != fingerprint(spec):
            out.append(f"{path.relative_to(ROOT) if path.is_relative_to(ROOT) else path}: "
                       "not drawn from the committed results (run python bench/readme.py)")
    return out


def write_whole(path: Path, data: bytes) -> None:
    fd, tmp = tempfile.mkstemp(dir=path.parent, prefix=f".{path.name}.", suffix=".tmp")
    with os.fdopen(fd, "wb") as f:
        f.write(data)
    os.replace(tmp, path)


def regenerate(readme: Path = README, folder: Path = RESULTS, images: Path = IMAGES
               ) -> list[str]:
    """Rewrite the blocks and draw the figures whose data changed; what could not be."""
    text = readme.read_text(encoding="utf-8")
    results = load_results(folder)
    new, missing = render(text, results)
    if new != text:
        write_whole(readme, new.encode("utf-8"))
    drawn, no_data = figures(new, results, images)
    for path, spec in drawn:
        if not path.is_file() or stamp_of(path.read_bytes()) != fingerprint(spec):
            path.parent.mkdir(parents=True, exist_ok=True)
            write_whole(path, png_bytes(spec))
            print(f"drew {path}")
    return missing + no_data


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--check", action="store_true",
                    help="change nothing; exit 1 listing what disagrees with the results")
    args = ap.parse_args(argv)
    found = problems() if args.check else regenerate()
    for line in found:
        print(line, file=sys.stderr)
    return 1 if found else 0


if __name__ == "__main__":
    sys.exit(main())
