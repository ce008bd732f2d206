"""profiles.ppmc312.sync.acceptance: line mode falls back below the peak and says so."""

from __future__ import annotations

import pytest

from profiles.errors import SyncError
from tests.support.sync_checks import NEMA17


def test_line_mode_falls_back_below_the_peak_and_says_so(monkeypatch: pytest.MonkeyPatch
                                                         ) -> None:
    """Where no line-synchronised set keeps the load angle within the aim, sync takes
    one below the 90° peak, and its info says so; another judge's failure stands."""
    import profiles.ppmc312.sync as sync

    calls = []

    def fake(axes, *, accept):  # type: ignore[no-untyped-def]
        calls.append(accept)
        if accept is not sync.accepted_below_peak:
            raise SyncError("nothing this judge passes")
        return sync.SyncPlan("line", (), "line: leader x")

    monkeypatch.setattr(sync, "plan_line_sync", fake)
    plan = sync.plan_sync([("x", NEMA17, 1000)], "line")
    assert calls == [sync.accepted, sync.accepted_below_peak]
    assert "no set within the 75° load-angle aim" in plan.info
    with pytest.raises(SyncError):  # a caller's own judge gets no fallback
        sync.plan_sync([("x", NEMA17, 1000)], "line", accept=lambda t, m: True)
    assert len(calls) == 3  # tried once, no fallback
