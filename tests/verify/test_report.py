"""verify.report: text, JSON and JUnit renderings of per-file check results."""

from __future__ import annotations

import json
import xml.etree.ElementTree as ET
from pathlib import Path

import pytest

from profiles.errors import FormatError
from profiles.findings import Finding
from profiles.ppmc312.chip_rules import check_table
from profiles.ppmc312.table import load_table
from tests.support.paths import ROOT
from verify.report import FileResult, finding_line, render

EXAMPLES = ROOT / "examples"


ERR = Finding("error", "rate-min", "rates[3] = 1 is ≤ 1: raise it to ≥ 4", 0x18, 3)


WARN = Finding("warning", "decel-stage-count", "6 accel stages but 4 decel stages")


RESULTS = [
    FileResult("a.json", True, []),
    FileResult("b.json", False, [ERR, WARN]),
    FileResult("c.json", False, [], error="c.json: not valid JSON (line 1, column 2: x)"),
]


def test_text_lines_and_summary() -> None:
    lines = render(RESULTS, "text").splitlines()
    assert lines == [
        "b.json: error [rate-min] stage 3 (chip 0x18): rates[3] = 1 is ≤ 1: raise it to ≥ 4",
        "b.json: warning [decel-stage-count]: 6 accel stages but 4 decel stages",
        "c.json: unusable: c.json: not valid JSON (line 1, column 2: x)",
        "3 files checked: 1 ok, 2 failed (1 error, 1 warning, 1 unusable)",
    ]
    assert render([FileResult("a.json", True)], "text") == \
        "1 file checked: 1 ok, 0 failed (0 errors, 0 warnings)\n"


def test_json_shape_is_exact() -> None:
    doc = json.loads(render(RESULTS, "json"))
    assert list(doc) == ["files"]
    a, b, c = doc["files"]
    assert a == {"path": "a.json", "ok": True, "findings": []}
    assert set(b) == {"path", "ok", "findings"}
    assert b["findings"][0] == {"severity": "error", "rule": "rate-min", "chip_code": "0x18",
                                "stage": 3, "message": ERR.message}
    assert b["findings"][1]["chip_code"] is None and b["findings"][1]["stage"] is None
    assert c["error"].startswith("c.json: not valid JSON") and c["ok"] is False


def test_junit_parses_back_with_counts() -> None:
    root = ET.fromstring(render(RESULTS, "junit"))
    assert root.tag == "testsuite" and root.get("name") == "stepramp check"
    assert (root.get("tests"), root.get("failures"), root.get("errors")) == ("3", "1", "1")
    cases = root.findall("testcase")
    assert [c.get("name") for c in cases] == ["a.json", "b.json", "c.json"]
    assert list(cases[0]) == []
    fail = cases[1].find("failure")
    assert fail is not None and fail.get("type") == "rate-min"
    assert fail.get("message") == ERR.message and "(chip 0x18)" in (fail.text or "")
    out = cases[1].find("system-out")
    assert out is not None and "decel-stage-count" in (out.text or "")
    err = cases[2].find("error")
    assert err is not None and "not valid JSON" in (err.get("message") or "")


def test_junit_escapes_markup_and_drops_illegal_characters() -> None:
    nasty = 'we<ird> & "quoted" \'file\'\x01.json'
    msg = "a < b && c > d\x1b[0m"
    res = [FileResult(nasty, False, [Finding("error", "rate-min", msg, 0x18, 0)],
                      error="bad ]]> cdata")]
    text = render(res, "junit")
    root = ET.fromstring(text)   # well-formed despite markup and control characters
    case = root.find("testcase")
    assert case is not None
    assert case.get("name") == nasty.replace("\x01", "\ufffd")
    fail = case.find("failure")
    assert fail is not None and fail.get("message") == msg.replace("\x1b", "\ufffd")
    err = case.find("error")
    assert err is not None and err.text == "bad ]]> cdata"
    # The JSON rendering carries the same strings exactly.
    doc = json.loads(render(res, "json"))
    assert doc["files"][0]["path"] == nasty and doc["files"][0]["findings"][0]["message"] == msg


def test_unknown_format_is_refused() -> None:
    with pytest.raises(FormatError, match="'yaml' is not one of text, json, junit"):
        render(RESULTS, "yaml")


def test_real_check_results_render_in_every_format() -> None:
    results = []
    for name in ("free-curve-nema17.json", "init-linear.json", "free-curve-bad.json"):
        path = EXAMPLES / name
        findings = check_table(load_table(path))
        ok = all(f.severity != "error" for f in findings)
        results.append(FileResult(str(path), ok, findings))
    text = render(results, "text")
    assert text.count("free-curve-bad.json: error [") == sum(
        f.severity == "error" for f in results[2].findings) >= 3
    assert text.splitlines()[-1].startswith("3 files checked: 2 ok, 1 failed")
    doc = json.loads(render(results, "json"))
    assert [f["ok"] for f in doc["files"]] == [True, True, False]
    assert {f["chip_code"] for f in doc["files"][2]["findings"]} >= {"0x18", "0x19"}
    root = ET.fromstring(render(results, "junit"))
    assert int(root.get("failures") or 0) == sum(
        any(f.severity == "error" for f in r.findings) for r in results) == 1


def heavy_findings() -> list[Finding]:
    """The example NEMA17 table on the heavy NEMA23: 84 criterion findings of 5 rules."""
    from profiles.motor import load_motor
    from profiles.ppmc312.criterion import check_stall

    table = load_table(EXAMPLES / "free-curve-nema17.json")
    return check_stall(table, load_motor("nema23-heavy"))


def test_excess_and_move_are_read_from_the_stall_messages() -> None:
    # Pinned on real findings: a change of wording in profiles/ppmc312/criterion.py must fail here.
    import math

    from verify.report import excess, move_pulses

    found = heavy_findings()
    by_rule: dict[str, list[Finding]] = {}
    for f in found:
        by_rule.setdefault(f.rule, []).append(f)
    assert set(by_rule) == {"stall-top-speed", "stall-start-speed", "stall-jump",
                            "stall-accel", "stall-decel"}
    assert all(move_pulses(f) is not None for f in found)
    assert all(excess(f) is not None for f in found)
    top = by_rule["stall-top-speed"][0]   # runs 20000 pps, top usable 12000 pps
    assert (excess(top), move_pulses(top)) == (pytest.approx(20000 / 12000), 2588)
    [start] = by_rule["stall-start-speed"]  # 800 pps at a start speed of 300 pps, 1 pulse
    assert (excess(start), move_pulses(start)) == (pytest.approx(800 / 300), 1)
    jump = next(f for f in by_rule["stall-jump"] if f.stage == 25)  # +800 over a 300 jump
    assert excess(jump) == pytest.approx(800 / 300)
    cannot = next(f for f in by_rule["stall-accel"] if f.stage == 1)
    assert "cannot accelerate" in cannot.message and excess(cannot) == math.inf
    decel = next(f for f in by_rule["stall-decel"] if f.stage == 6)  # 149972 / 26525.8
    assert excess(decel) == pytest.approx(149972 / 26525.8, rel=1e-5)
    assert excess(ERR) is None and move_pulses(ERR) is None


def test_many_findings_of_a_rule_are_summarised() -> None:
    from verify.report import excess, move_pulses

    found = heavy_findings()
    result = [FileResult("t.json", False, found)]
    lines = render(result, "text").splitlines()
    assert len(lines) == 13 < len(found)  # 3 + 1 + 2 + 3 + 3 lines for 5 rules, a summary
    decel = [f for f in found if f.rule == "stall-decel"]
    worst = max(decel, key=lambda f: excess(f) or 0.0)
    shortest = min(decel, key=lambda f: move_pulses(f) or 0)
    i = lines.index(f"t.json: error [stall-decel]: {len(decel)} findings at stages 1–23")
    assert lines[i + 1] == f"t.json:   worst, stage {worst.stage}: {worst.message}"
    assert lines[i + 2] == f"t.json:   shortest move, stage {shortest.stage}: {shortest.message}"
    # one finding of a rule: its own line, as before
    [start] = [f for f in found if f.rule == "stall-start-speed"]
    assert f"t.json: error [stall-start-speed] stage 25: {start.message}" in lines
    # the worst is also the shortest move: one line says both
    assert any(line.startswith("t.json:   worst, and the shortest move, stage 25: stage 25 → 24")
               for line in lines)
    assert lines[-1] == ("1 file checked: 0 ok, 1 failed (84 errors, 0 warnings); 83 findings "
                         "summarised by rule (--verbose lists each)")
    verbose = render(result, "text", verbose=True).splitlines()
    assert len(verbose) == len(found) + 1
    assert verbose[:-1] == [finding_line("t.json", f) for f in found]  # the checks' order
    assert len(json.loads(render(result, "json"))["files"][0]["findings"]) == len(found)
    assert len(list(ET.fromstring(render(result, "junit")).iter("failure"))) == len(found)


def test_a_summary_of_findings_without_numbers_shows_the_first() -> None:
    found = [Finding("warning", "stage-short", f"stage {k} is short", None, k)
             for k in (3, 4, 5, 9, 11, 12, 20, 30, 31)]
    lines = render([FileResult("a.json", True, found)], "text").splitlines()
    assert lines[:2] == ["a.json: warning [stage-short]: 9 findings at stages 3–5, 9, 11–12, "
                         "20, …",
                         "a.json:   first, stage 3: stage 3 is short"]
    few = render([FileResult("a.json", True, found[:3])], "text").splitlines()
    assert len(few) == 4  # three findings are listed as they are


def test_a_note_a_finding_already_says_is_not_repeated() -> None:
    box = "tolerance box: worst load angle 183.9° electrical at corner 2"
    r = FileResult("t.json", False, [Finding("error", "load-angle", box)],
                   notes=[box, "MC-200 stream file"])
    lines = render([r], "text").splitlines()
    assert lines == [f"t.json: error [load-angle]: {box}", "t.json: note: MC-200 stream file",
                     "1 file checked: 0 ok, 1 failed (1 error, 0 warnings)"]


@pytest.mark.slow
def test_the_issue_case_fits_in_40_lines(tmp_path: Path) -> None:
    # issue #19: a table planned for the nominal NEMA17, checked against its tolerance box
    # (196 lines before the summaries).
    import contextlib
    import io

    from verify import cli

    table = str(tmp_path / "t.json")
    with contextlib.redirect_stdout(io.StringIO()):
        assert cli.main(["plan", "--motor", "nema17-1600", "-o", table]) == 0
    out = io.StringIO()
    with contextlib.redirect_stdout(out):
        code = cli.main(["check", table, "--motor",
                         str(EXAMPLES / "motor-nema17-tolerances.json")])
    lines = out.getvalue().splitlines()
    assert code == 1 and len(lines) <= 40, out.getvalue()
    # the box's summary once (the command families' notes say "over the tolerance box")
    assert sum("note: tolerance box:" in line for line in lines) == 1
