"""profiles.ppmc312.table + clock loader (stepramp.table/1) and its JSON Schema agree."""

from __future__ import annotations

import copy
import json
from pathlib import Path
from typing import Any

import jsonschema  # a test dependency ([dev]): missing, the suite fails, never skips
import pytest
from hypothesis import assume, given, settings
from hypothesis import strategies as st

from profiles.errors import FieldRangeError, FormatError, StepRampError
from profiles.ppmc312.clock import Clock
from profiles.ppmc312.table import (
    FreeCurveTable,
    InitTable,
    dump_table,
    load_table,
    table_from_json,
)
from tests.support.paths import ROOT

SCHEMA = json.loads((ROOT / "profiles" / "data" / "table.schema.json").read_text("utf-8"))


VALIDATOR = jsonschema.Draft202012Validator(SCHEMA)


FREE: dict[str, Any] = {"format": "stepramp.table/1", "device": "ppmc312", "kind": "free_curve",
                        "clock": "8MHz", "rates": [400, 500, 600], "accel_pulses": [10, 20, 30]}


INIT: dict[str, Any] = {"format": "stepramp.table/1", "device": "ppmc312", "kind": "init",
                        "clock": "1MHz", "shape": "s_curve", "start_rate": 2000,
                        "high_rate": 300, "accel_pulses": 5000}


def with_(base: dict[str, Any], **kw: Any) -> dict[str, Any]:
    out = copy.deepcopy(base)
    for k, v in kw.items():
        if v is _DROP:
            out.pop(k, None)
        else:
            out[k] = v
    return out


_DROP = object()


def loads(obj: Any) -> bool:
    try:
        table_from_json(obj)
    except StepRampError:
        return False
    return True


def test_schema_is_valid_draft_2020_12() -> None:
    jsonschema.Draft202012Validator.check_schema(SCHEMA)
    assert SCHEMA["$schema"].endswith("/draft/2020-12/schema")


@pytest.mark.parametrize("obj, exc, words", [
    ([], FormatError, "one JSON object"),
    (with_(FREE, format="stepramp.table/2"), FormatError, "format: expected"),
    (with_(FREE, device="mc200"), FormatError, "device: expected 'ppmc312'"),
    (with_(FREE, kind="ramp"), FormatError, "kind: expected"),
    (with_(FREE, colour="red"), FormatError, "unknown key(s) for a free_curve table: colour"),
    (with_(INIT, rates=[1, 2]), FormatError, "unknown key(s) for a init table: rates"),
    (with_(FREE, rates=_DROP), FormatError, "missing key(s) for a free_curve table: rates"),
    (with_(FREE, rates=[400, 500]), FormatError, "rates: 2 entries"),
    (with_(FREE, rates="400"), FormatError, "rates: expected a list"),
    (with_(FREE, rates=[400, 5.5, 600]), FormatError, "rates[1]: expected an integer"),
    (with_(FREE, rates=[400, True, 600]), FormatError, "rates[1]: expected an integer"),
    (with_(FREE, rates=[400, 0x10000, 600]), FieldRangeError, "rates[1]: 65536 (0x10000) is "
     "outside the allowed range 0..65535"),
    (with_(FREE, accel_pulses=[10, -1, 30]), FieldRangeError, "accel_pulses[1]: -1"),
    (with_(FREE, accel_pulses=[10, 0x1000000, 30]), FieldRangeError, "0..16777215"),
    (with_(FREE, rates=[400] * 256, accel_pulses=[2] * 256), FieldRangeError, "stage count"),
    (with_(FREE, clock="7MHz"), FormatError, "clock: '7MHz' is not one of"),
    (with_(FREE, clock={"extck_hz": 0}), FieldRangeError, "clock.extck_hz"),
    (with_(FREE, clock={"extck_hz": 3e7}), FieldRangeError, "clock.extck_hz"),
    (with_(FREE, clock={"extck_hz": 1e6, "edge": "up"}), FormatError, "clock.edge"),
    (with_(FREE, clock={"extck_hz": 1e6, "hz": 1}), FormatError, "unknown key(s) ['hz']"),
    (with_(FREE, clock=8), FormatError, "neither a clock name"),
    (with_(INIT, shape="cubic"), FormatError, "shape: 'cubic'"),
    (with_(INIT, stop_rate=3000), FormatError, "stop_rate and decel_pulses go together"),
    (with_(INIT, decel_pulses=10), FormatError, "stop_rate and decel_pulses go together"),
    (with_(INIT, start_rate="2000"), FormatError, "start_rate: expected an integer"),
    (with_(INIT, high_rate=70000), FieldRangeError, "high_rate: 70000"),
])
def test_loader_refuses_with_one_clear_line(obj: Any, exc: type[Exception], words: str) -> None:
    with pytest.raises(exc) as e:
        table_from_json(obj)
    assert words in str(e.value)
    assert "\n" not in str(e.value)
    assert not VALIDATOR.is_valid(obj) or words == "rates: 2 entries"


def test_chip_rule_breaks_still_load() -> None:
    # Rate 1 and 1-pulse stages fit the wire: profiles.ppmc312.chip_rules reports them, not
    # the loader.
    t = table_from_json(with_(FREE, rates=[1, 500, 600], accel_pulses=[1, 1, 1]))
    assert isinstance(t, FreeCurveTable) and t.rates[0] == 1


def test_load_table_file_errors(tmp_path: Path) -> None:
    with pytest.raises(FormatError, match="no such file"):
        load_table(tmp_path / "missing.json")
    (tmp_path / "empty.json").write_text("  \n")
    with pytest.raises(FormatError, match="empty"):
        load_table(tmp_path / "empty.json")
    (tmp_path / "bad.json").write_text('{"format": ')
    with pytest.raises(FormatError, match=r"not valid JSON \(line 1"):
        load_table(tmp_path / "bad.json")


clocks = st.one_of(st.sampled_from(["8MHz", "1MHz", "500kHz", "250kHz", "62.5kHz",
                                    "15.625kHz"]).map(Clock.internal),
                   st.builds(Clock.extck, st.floats(1.0, 20e6),
                             st.sampled_from(["rising", "falling"])))


@st.composite
def wire_tables(draw: st.DrawFn) -> FreeCurveTable | InitTable:
    clock = draw(clocks)
    if draw(st.booleans()):
        n = draw(st.integers(0, 40))
        rates = draw(st.lists(st.integers(0, 0xFFFF), min_size=n, max_size=n))
        pulses = st.integers(0, 0xFFFFFF)
        decel = None
        if n and draw(st.booleans()):
            decel = tuple(draw(st.lists(pulses, min_size=1, max_size=n)))
            accel = tuple(draw(st.lists(pulses, min_size=n if len(decel) < n else 0,
                                        max_size=n)))
        else:
            accel = tuple(draw(st.lists(pulses, min_size=n, max_size=n)))
        return FreeCurveTable(clock, tuple(rates), accel, decel)
    rate, pulses_ = st.integers(0, 0xFFFF), st.integers(0, 0xFFFFFF)
    sep = draw(st.booleans())
    return InitTable(clock, draw(st.sampled_from(["linear", "s_curve"])), draw(rate),
                     draw(rate), draw(pulses_), draw(rate) if sep else None,
                     draw(pulses_) if sep else None)


@settings(max_examples=150, deadline=None)
@given(wire_tables())
def test_round_trip_and_schema_accepts_what_we_write(t: FreeCurveTable | InitTable) -> None:
    obj = t.to_json()
    assert table_from_json(obj) == t
    text = dump_table(t)
    assert table_from_json(json.loads(text)) == t
    assert VALIDATOR.is_valid(json.loads(text))


def test_examples_load_and_validate() -> None:
    for path in sorted((ROOT / "examples").glob("*.json")):
        obj = json.loads(path.read_text("utf-8"))
        if obj.get("format") != "stepramp.table/1":
            continue
        assert VALIDATOR.is_valid(obj), path
        assert load_table(path).to_json() == obj


VALUES = st.one_of(
    st.none(), st.booleans(), st.integers(-2, 3), st.integers(0xFFFE, 0x10001),
    st.integers(0xFFFFFE, 0x1000001), st.floats(-1, 3e7, allow_nan=False), st.just(2.5),
    st.sampled_from(["8MHz", "EXTCK", "linear", "s_curve", "init", "free_curve", "rising"]),
    st.lists(st.integers(-1, 0x10001), max_size=4),
    st.just({"extck_hz": 1e6}), st.just({"extck_hz": 1e6, "edge": "falling"}),
    st.just({"extck_hz": 1e6, "edge": "left"}), st.just({"edge": "rising"}),
)


KEYS = ["format", "device", "kind", "clock", "rates", "accel_pulses", "decel_pulses", "shape",
        "start_rate", "high_rate", "stop_rate", "shade"]


# Values that are right for a key in at least one kind, so that many edits stay valid.
_RATE, _PULSES = st.integers(0, 0xFFFF), st.integers(0, 0xFFFFFF)


FITTING: dict[str, st.SearchStrategy[Any]] = {
    "clock": st.one_of(st.sampled_from(["8MHz", "15.625kHz"]),
                       st.fixed_dictionaries({"extck_hz": st.floats(0.5, 2.1e7)},
                                             optional={"edge": st.just("falling")})),
    "rates": st.lists(_RATE, min_size=3, max_size=3),
    "accel_pulses": st.one_of(_PULSES, st.lists(_PULSES, min_size=3, max_size=3)),
    "decel_pulses": st.one_of(_PULSES, st.lists(_PULSES, min_size=1, max_size=3)),
    "shape": st.sampled_from(["linear", "s_curve"]),
    "start_rate": _RATE, "high_rate": _RATE, "stop_rate": _RATE,
}


@st.composite
def edits_(draw: st.DrawFn) -> list[tuple[str, Any]]:
    out = []
    for key in draw(st.lists(st.sampled_from(KEYS), max_size=3)):
        fitting = FITTING.get(key)
        if fitting is not None and draw(st.integers(0, 3)):
            value = draw(fitting)     # 3 in 4: a value of the right type and range
        else:
            value = draw(st.one_of(st.just(_DROP), VALUES))
        out.append((key, value))
    return out


def inexpressible(obj: Any) -> bool:
    """The two loader rules JSON Schema cannot state (see the schema's description)."""
    def integral_float(x: Any) -> bool:
        if isinstance(x, float):
            return x.is_integer()
        if isinstance(x, list):
            return any(integral_float(i) for i in x)
        return False
    if any(integral_float(v) for k, v in obj.items() if k != "clock"):
        return True
    if obj.get("kind") == "free_curve":
        dec = obj.get("decel_pulses") or []
        return len(obj["rates"]) != max(len(obj["accel_pulses"]), len(dec))
    return False


@settings(max_examples=200, deadline=None)
@given(st.sampled_from([FREE, INIT, with_(INIT, stop_rate=2100, decel_pulses=10),
                        with_(FREE, decel_pulses=[1, 2])]),
       edits_())
def test_schema_agrees_with_loader(base: dict[str, Any], edits: list[tuple[str, Any]]) -> None:
    obj = copy.deepcopy(base)
    for key, value in edits:
        obj = with_(obj, **{key: value})
    # A list/dict "kind" crashes the loader (test_unhashable_kind_is_a_format_error).
    assume(not isinstance(obj.get("kind"), list | dict))
    schema_ok = VALIDATOR.is_valid(obj)
    if schema_ok and inexpressible(obj):
        return
    assert loads(obj) == schema_ok, (obj, schema_ok)


@pytest.mark.parametrize("obj", [
    FREE, INIT, with_(INIT, stop_rate=2100, decel_pulses=10),
    with_(FREE, decel_pulses=[1, 2]), with_(FREE, decel_pulses=None),
    with_(FREE, clock={"extck_hz": 20e6}), with_(FREE, clock={"extck_hz": 5, "edge": "falling"}),
    with_(FREE, rates=[], accel_pulses=[]),
])
def test_schema_and_loader_accept(obj: dict[str, Any]) -> None:
    assert VALIDATOR.is_valid(obj) and loads(obj)


@pytest.mark.parametrize("obj", [
    with_(INIT, decel_pulses=10), with_(INIT, stop_rate=None, decel_pulses=None),
    with_(FREE, clock={"extck_hz": 20e6 + 1}), with_(FREE, clock={"extck_hz": True}),
    with_(FREE, clock={"edge": "rising"}), with_(FREE, accel_pulses=[1, 2, None]),
    with_(FREE, shape="linear"), with_(INIT, kind="free_curve"), with_(FREE, kind="init"),
    with_(INIT, high_rate=-1), with_(INIT, accel_pulses=0x1000000),
])
def test_schema_and_loader_refuse(obj: dict[str, Any]) -> None:
    assert not VALIDATOR.is_valid(obj) and not loads(obj)


@pytest.mark.parametrize("kind", [["init"], {"a": 1}])
def test_unhashable_kind_is_a_format_error(kind: Any) -> None:
    with pytest.raises(FormatError, match="kind: expected"):
        table_from_json(with_(FREE, kind=kind))
