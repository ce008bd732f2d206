"""profiles.ppmc312.answer_kinds: the kinds of answer the PPMC-312 gives (manual figures)."""

from __future__ import annotations

from typing import Any

from hypothesis import given
from hypothesis import strategies as st

from profiles.ppmc312 import frames as F
from profiles.ppmc312.answer_kinds import BY_KEY, KINDS, SOURCES, Kind
from profiles.ppmc312.answers import (
    decode_answer,
    decode_answers,
    decode_read_order,
    encode_answer,
)
from tests.support.strategies import answer_fields


# --- every kind round-trips ----------------------------------------------------------------------
@st.composite
def kind_and_values(draw: st.DrawFn) -> tuple[Kind, dict[str, Any]]:
    kind = draw(st.sampled_from(KINDS))
    return kind, draw(answer_fields(kind))


@given(kind_and_values())
def test_every_kind_round_trips(case: tuple[Kind, dict[str, Any]]) -> None:
    kind, values = case
    data = encode_answer(kind.key, **values)
    a = decode_answer(data)
    assert a.kind is kind and a.raw == data
    fields = {k: v for k, v in values.items() if k not in ("source", "next")}
    assert dict(a.fields) == fields
    assert a.header["source"] == values.get("source", SOURCES[kind.fixed_bit("resp") or 0])
    if "next" in values:
        assert a.header["next"] == values["next"]
    assert len(a.describe()) == 2 + len(fields)
    assert decode_answers(data + data) == [a, a]


@given(st.lists(kind_and_values(), min_size=1, max_size=4))
def test_a_capture_in_read_order_is_the_same_answers(cases: list[tuple[Kind, dict[str, Any]]]
                                                     ) -> None:
    # §5-8: DRR gives each answer lowest parameter first, header last, one after another
    blocks = [encode_answer(kind.key, **values) for kind, values in cases]
    read = b"".join(block[::-1] for block in blocks)
    assert decode_read_order(read) == decode_answers(b"".join(blocks))


def test_the_kinds_are_the_manual_s() -> None:
    codes = {k.code for k in KINDS if k.code is not None}
    assert {0xE0, 0xE1, 0xE2, 0xE3, 0xE4, 0xE8, 0xE9} <= codes
    assert {0xF0, 0xF1, 0xF2, 0xF4, 0xF5, 0xF6, 0xF7, 0xF8, 0xF9} <= codes
    assert len({k.key for k in KINDS}) == len(KINDS)
    assert len({k.name for k in KINDS}) == len(KINDS)
    # the emulator's response frames are reused, only their header made general
    assert BY_KEY["F1"].block.fields[1:] == F.STATE_ERROR.fields[1:]
    assert BY_KEY["01 done"].block.fields[1:] == F.FC_DONE.fields[1:]
    assert BY_KEY["41 rates"].block.fields[1:] == F.READ_RATES.fields[1:]
    assert BY_KEY["F4"].block.fields[1:] == F.ALARM.fields[1:]
