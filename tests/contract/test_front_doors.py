"""The front doors: `profiles`, `profiles.ppmc312` and `verify` name their public API,
each name the very object its module defines, loaded on first use."""

from __future__ import annotations

import importlib
import subprocess
import sys

import pytest

import profiles
import profiles.ppmc312
import verify
from profiles.lazy import lazy_exports

DOORS = [profiles, profiles.ppmc312, verify]


@pytest.mark.parametrize("door", DOORS, ids=lambda m: m.__name__)
def test_every_listed_name_is_there(door: object) -> None:
    for name in door.__all__:  # type: ignore[attr-defined]
        assert getattr(door, name) is not None, name


def test_the_names_are_the_deep_objects() -> None:
    from profiles.motor import Motor, load_motor
    from profiles.ppmc312.chip_rules import check_table
    from profiles.ppmc312.formats import render
    from profiles.ppmc312.planner import plan_free_curve
    from profiles.ppmc312.upload import encode_table
    from verify.compare import compare_table
    from verify.safety import judge_safety

    assert (profiles.Motor, profiles.load_motor, profiles.plan_free_curve,
            profiles.encode_table, profiles.render) == (
        Motor, load_motor, plan_free_curve, encode_table, render)
    assert profiles.ppmc312.plan_free_curve is plan_free_curve
    assert (verify.judge_safety, verify.check_table, verify.compare_table) == (
        judge_safety, check_table, compare_table)


def test_an_unknown_name_is_an_attribute_error_and_submodules_still_import() -> None:
    with pytest.raises(AttributeError, match="'profiles' has no attribute 'nope'"):
        _ = profiles.nope  # type: ignore[attr-defined]
    assert importlib.import_module("verify.cli").main  # `from verify import cli` still works
    getter = lazy_exports("profiles", {"Clock": ".ppmc312.clock"})
    assert getter("Clock") is profiles.Clock


def test_the_front_doors_do_not_load_numpy() -> None:
    # `stepramp check` without --motor imports them; numpy (and numba) come with a plan.
    code = ("import sys, profiles, profiles.ppmc312, verify; "
            "print('numpy' in sys.modules)")
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True,
                         check=True).stdout.strip()
    assert out == "False"
