"""`stepramp expand` (verify/cli/expand.py): an init table expanded to its stages."""

from __future__ import annotations

from pathlib import Path

import pytest

from profiles.ppmc312.table import load_table
from tests.support.cli import run
from tests.support.paths import ROOT

GOOD = ROOT / "examples" / "free-curve-nema17.json"


INIT = ROOT / "examples" / "init-linear.json"


def test_expand_init_table(capsys: pytest.CaptureFixture[str], tmp_path: Path) -> None:
    from profiles.ppmc312.init_model import expand_init
    from profiles.ppmc312.table import FreeCurveTable

    out = tmp_path / "free.json"
    assert run(capsys, "expand", INIT, "-o", out)[0] == 0
    free = load_table(out)
    assert isinstance(free, FreeCurveTable)
    assert free == expand_init(load_table(INIT))  # type: ignore[arg-type]
    init = load_table(INIT)
    assert free.accel_total == init.accel_pulses  # type: ignore[union-attr]
    assert run(capsys, "expand", GOOD)[0] == 2
