"""profiles.ppmc312.listing: a table's stage listing (`stepramp show`), byte-stable."""

from __future__ import annotations

from profiles.ppmc312.clock import Clock
from profiles.ppmc312.table import FreeCurveTable


def test_show_json_is_byte_stable() -> None:
    """The listing's JSON text, whole: users keep it in their repositories and diff it in
    CI, so its layout (keys in order, one-space indent, a final newline) is pinned."""
    from profiles.ppmc312.listing import list_stages

    table = FreeCurveTable(Clock.internal("8MHz"), (4000,), (10,), None)
    fields = ('"stage": 0', '"rate": 4000', '"speed_pps": 2000.0', '"speed_rpm": null',
              '"accel_pulses": 10', '"accel_s": 0.005', '"accel_cum_s": 0.005',
              '"decel_pulses": 10', '"decel_s": 0.005', '"decel_cum_s": 0.005')
    head = ('"kind": "free_curve"', '"modelled": false', '"clock": "8MHz"',
            '"separate_decel": false', '"accel_pulses": 10', '"decel_pulses": 10',
            '"accel_s": 0.005', '"decel_s": 0.005')
    expected = ("{\n" + "".join(f" {f},\n" for f in head) + ' "stages": [\n  {\n'
                + ",\n".join(f"   {f}" for f in fields) + "\n  }\n ]\n}\n")
    assert list_stages(table).render("json") == expected
