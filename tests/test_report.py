"""verify.report: text, JSON and JUnit renderings of per-file check results."""

from __future__ import annotations

import json
import xml.etree.ElementTree as ET
from pathlib import Path

import pytest

from profiles.errors import FormatError
from profiles.ppmc312.table import load_table
from verify.chip_rules import check_table
from verify.findings import Finding
from verify.report import FileResult, render

EXAMPLES = Path(__file__).resolve().parents[1] / "examples"

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
