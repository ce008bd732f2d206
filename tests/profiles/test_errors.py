"""profiles/errors.py: the error classes in one place and the one number validator."""

from __future__ import annotations

import ast
import math

import numpy as np
import pytest

from profiles import errors as E
from profiles.errors import FieldRangeError, is_number, require_int, require_number
from tests.support.paths import ROOT


@pytest.mark.parametrize(("value", "number", "integral", "finite"), [
    (True, False, False, False), (np.bool_(True), False, False, False),
    (3, True, True, True), (np.int64(3), True, True, True), (np.uint8(3), True, True, True),
    (3.0, True, False, True), (np.float32(2.5), True, False, True),
    (math.nan, True, False, False), (-math.inf, True, False, False),
    (10**400, True, True, True),  # compared, never converted to float
    ("3", False, False, False), (None, False, False, False), (1 + 0j, False, False, False),
])
def test_is_number(value: object, number: bool, integral: bool, finite: bool) -> None:
    assert is_number(value) is number
    assert is_number(value, integral=True) is integral
    assert is_number(value, finite=True) is finite


def test_require_number_bounds_and_messages() -> None:
    assert require_number("x", 0, 0, 1) == 0 and require_number("x", 1.0, 0, 1) == 1.0
    assert require_number("x", np.float64(0.5), 0, 1) == 0.5
    for bad in (True, "1", None, math.nan, -0.001, 1.001, 10**400):
        with pytest.raises(FieldRangeError, match=r"^x: .* outside the allowed range 0\.\.1$"):
            require_number("x", bad, 0, 1)
    with pytest.raises(FieldRangeError, match=r"range above 0 up to 1$"):
        require_number("x", 0, 0, 1, lo_open=True)
    with pytest.raises(FieldRangeError, match=r"range 0\.\.1 \(1 excluded\)$"):
        require_number("x", 1, 0, 1, hi_open=True)
    with pytest.raises(FieldRangeError, match=r"above 0 up to 1 \(1 excluded\)$"):
        require_number("x", 1, 0, 1, lo_open=True, hi_open=True)
    with pytest.raises(FieldRangeError, match=r"^x: inf .*"):
        require_number("x", math.inf, 0, math.inf, hi_open=True)
    assert require_number("x", 1e300, 0, math.inf, hi_open=True) == 1e300
    with pytest.raises(FieldRangeError):
        require_number("x", 2.0, 0, 5, integral=True)


def test_require_int_returns_a_python_int() -> None:
    got = require_int("n", np.int32(7), 0, 9)
    assert got == 7 and type(got) is int
    for bad in (7.0, True, np.bool_(False), -1, 10):
        with pytest.raises(FieldRangeError, match=r"^n: "):
            require_int("n", bad, 0, 9)


def test_every_error_class_lives_in_errors_py() -> None:
    """A StepRampError subclass defined anywhere else under profiles/ or verify/ is a
    second home for errors; private control-flow exceptions (a leading _) are exempt."""
    names = {n for n, v in vars(E).items()
             if isinstance(v, type) and issubclass(v, Exception)}
    elsewhere = []
    for path in sorted([*(ROOT / "profiles").rglob("*.py"), *(ROOT / "verify").rglob("*.py")]):
        if path.name == "errors.py" and path.parent.name == "profiles":
            continue
        for node in ast.walk(ast.parse(path.read_text(encoding="utf-8"))):
            if isinstance(node, ast.ClassDef) and not node.name.startswith("_") and any(
                    isinstance(b, ast.Name) and (b.id in names or b.id.endswith("Error"))
                    for b in node.bases):
                elsewhere.append(f"{path.relative_to(ROOT)}:{node.name}")
    assert elsewhere == []


def test_a_chip_refusal_reads_as_its_message_and_keeps_the_code() -> None:
    """What the CLI prints after "stepramp link: " is the message alone."""
    from profiles.errors import ChipRefused, LinkError

    e = ChipRefused("slave 5: move: the chip refused it: state error (B5 43)", 0x43)
    assert isinstance(e, LinkError)
    assert str(e) == "slave 5: move: the chip refused it: state error (B5 43)"
    assert e.args == (str(e),) and e.code == 0x43
