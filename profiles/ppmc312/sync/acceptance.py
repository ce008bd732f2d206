"""What a synchronised table must pass before sync uses it.

`accepted(table, motor)`: the criterion over every move length the chip can run with the
table (`criterion.all_length_safe`, the one `verify.criterion.check_stall` reports).
"""

from __future__ import annotations

from ...motor import Motor
from ..criterion import all_length_safe
from ..table import FreeCurveTable


def accepted(table: FreeCurveTable, motor: Motor) -> bool:
    """Whether `table` is safe for `motor` over every move length (see the module)."""
    return all_length_safe(table, motor)
