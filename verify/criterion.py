"""Kept for `verify/designer.py` alone (it imports `stall_margins` from here) until the
designer's split lands: the criterion, its findings and margins are the PPMC-312's,
in `profiles.ppmc312.criterion` (issue 34 item 2). Remove with the designer's imports."""

from profiles.ppmc312.criterion import stall_margins

__all__ = ["stall_margins"]
