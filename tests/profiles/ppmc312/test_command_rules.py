"""profiles.ppmc312.command_rules: a motion command's rules, as findings."""

from __future__ import annotations

from typing import Any

from hypothesis import given, settings
from hypothesis import strategies as st

from profiles.ppmc312.motion import COMMANDS


@settings(max_examples=300, deadline=None)
@given(st.sampled_from([(c, f) for c in COMMANDS.values() for f in c.forms]),
       st.binary(min_size=11, max_size=11))
def test_any_block_of_a_motion_command_is_judged_never_unusable(case: Any,
                                                                noise: bytes) -> None:
    from profiles.ppmc312.command_rules import move_block_findings, move_notes

    command, frame = case
    assert frame.size is not None
    block = bytes([0x03, frame.size - 2, command.code]) + noise[:frame.size - 3]
    findings = move_block_findings(block, 0)
    notes = move_notes([block])
    assert len(notes) >= 1
    assert all(f.rule.startswith("move-") for f in findings)
