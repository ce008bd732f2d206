"""The bench results and the README generator (bench/benchlib.py, bench/readme.py): the
committed results keep the shared format, and the check catches a README block or a
figure that disagrees with them. No bench runs here: speed goals live in bench/."""

from __future__ import annotations

import json
import struct
import subprocess
import sys
import zlib
from pathlib import Path
from typing import Any

import pytest

from tests.support.bench_readme import bench_readme
from tests.support.paths import ROOT

gen = bench_readme()


benchlib = sys.modules["benchlib"]


benchfigures = sys.modules["benchfigures"]


def committed() -> list[Path]:
    return sorted((ROOT / "bench" / "results").glob("*.json"))


@pytest.mark.parametrize("path", committed(), ids=lambda p: p.stem)
def test_committed_results_keep_the_shared_format(path: Path) -> None:
    doc = json.loads(path.read_text(encoding="utf-8"))
    assert doc["name"] == path.stem
    assert doc["command"].startswith("python ")
    assert doc["measured_at"][:4].isdigit()
    assert {"cpus", "python", "load_avg_before", "note"} <= set(doc["machine"])
    assert isinstance(doc["values"], dict) and doc["values"]
    for sid, sec in doc["sections"].items():
        assert sec["columns"] and all(isinstance(c, str) for c in sec["columns"]), sid
        for row in sec["rows"]:
            assert len(row) == len(sec["columns"]), (sid, row)
            assert all(isinstance(c, str) for c in row), (sid, row)


def results_doc(measured: str) -> dict[str, Any]:
    res = benchlib.Results("demo", note="test")
    res.command = "python bench/bench_demo.py"
    res.values["x"] = 1.0
    res.section("goals", ["what", "measured", "goal"], [["a | b", measured, "≤ 1: met"]],
                note="a note", echo=False)
    return res.document()


def setup_readme(tmp_path: Path, doc: dict[str, Any], body: str) -> tuple[Path, Path]:
    results = tmp_path / "results"
    results.mkdir()
    (results / "demo.json").write_text(json.dumps(doc), encoding="utf-8")
    readme = tmp_path / "README.md"
    readme.write_text(body, encoding="utf-8")
    return readme, results


BODY = "intro\n\n<!-- bench:demo:goals -->\nhand-typed 1.02–1.06\n<!-- /bench -->\n\nend\n"


def test_a_block_is_rendered_from_its_section_and_then_agrees(tmp_path: Path) -> None:
    readme, results = setup_readme(tmp_path, results_doc("0.97"), BODY)
    [problem] = gen.problems(readme, results, tmp_path)
    assert problem.startswith("bench:demo:goals")
    assert gen.regenerate(readme, results, tmp_path) == []
    text = readme.read_text(encoding="utf-8")
    assert "hand-typed" not in text and "| a \\| b | 0.97 | ≤ 1: met |" in text
    assert "a note" in text and "`python bench/bench_demo.py`" in text
    assert text.startswith("intro\n") and text.endswith("<!-- /bench -->\n\nend\n")
    assert gen.problems(readme, results, tmp_path) == []


def test_a_changed_result_is_caught(tmp_path: Path) -> None:
    readme, results = setup_readme(tmp_path, results_doc("0.97"), BODY)
    gen.regenerate(readme, results, tmp_path)
    (results / "demo.json").write_text(json.dumps(results_doc("0.98")), encoding="utf-8")
    assert [p.split(":")[:3] for p in gen.problems(readme, results, tmp_path)] == \
        [["bench", "demo", "goals"]]


def test_a_missing_section_or_file_is_named(tmp_path: Path) -> None:
    body = (BODY + "<!-- bench:demo:other -->\n<!-- /bench -->\n"
            "<!-- bench:nope:x -->\n<!-- /bench -->\n")
    readme, results = setup_readme(tmp_path, results_doc("1"), body)
    found = gen.problems(readme, results, tmp_path)
    assert "bench:demo:other: no such section" in found
    assert "bench:nope:x: no such results file" in found


def png_with(text: dict[str, str]) -> bytes:
    """A minimal PNG carrying tEXt chunks."""
    def chunk(kind: bytes, data: bytes) -> bytes:
        return (struct.pack(">I", len(data)) + kind + data
                + struct.pack(">I", zlib.crc32(kind + data)))

    body = b"".join(chunk(b"tEXt", k.encode() + b"\0" + v.encode()) for k, v in text.items())
    ihdr = struct.pack(">IIBBBBB", 1, 1, 8, 0, 0, 0, 0)
    return (b"\x89PNG\r\n\x1a\n" + chunk(b"IHDR", ihdr) + body
            + chunk(b"IDAT", zlib.compress(b"\0\0")) + chunk(b"IEND", b""))


def test_a_figure_must_be_drawn_from_the_results_data(tmp_path: Path) -> None:
    doc = results_doc("1")
    spec = {"kind": "comparison", "pulses": 10}
    doc["values"]["figures"] = {"fig": spec}
    body = "<!-- bench-figure:demo:fig -->\n![f](docs/img/fig.png)\n"
    readme, results = setup_readme(tmp_path, doc, body)
    assert gen.problems(readme, results, tmp_path)[0].endswith(
        "not drawn from the committed results (run python bench/readme.py)")
    stamp = benchfigures.fingerprint(json.loads(json.dumps(spec)))
    (tmp_path / "fig.png").write_bytes(png_with({"Source": f"bench data sha256:{stamp}"}))
    assert gen.problems(readme, results, tmp_path) == []
    (tmp_path / "fig.png").write_bytes(png_with({"Source": "bench data sha256:0"}))
    assert len(gen.problems(readme, results, tmp_path)) == 1
    doc["values"]["figures"] = {}
    (results / "demo.json").write_text(json.dumps(doc), encoding="utf-8")
    assert gen.problems(readme, results, tmp_path) == [
        "bench-figure:demo:fig: no such figure in the results"]


def test_results_are_written_whole_with_finite_numbers(tmp_path: Path) -> None:
    res = benchlib.Results("demo", note="test")
    res.values.update(inf=float("inf"), nan=float("nan"), pi=3.14159265358979, n=3)
    path = res.write(tmp_path)
    doc = json.loads(path.read_text(encoding="utf-8"))
    assert doc["values"] == {"inf": None, "nan": None, "pi": 3.14159, "n": 3}
    assert [p.name for p in tmp_path.iterdir()] == ["demo.json"]  # no temporary left
    with pytest.raises(ValueError, match="2 cells, 3 columns"):
        res.section("bad", ["a", "b", "c"], [["1", "2"]], echo=False)


def test_check_without_a_motor_never_imports_numba() -> None:
    """`stepramp check` without --motor starts fast: the compiled kernels (numba) are
    loaded only when a load angle is judged."""
    code = ("import sys; from verify.cli import main; "
            "rc = main(['check', 'examples/free-curve-nema17.json']); "
            "print(rc, 'numba' in sys.modules)")
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True,
                         cwd=ROOT, check=True)
    assert out.stdout.split()[-2:] == ["0", "False"]
