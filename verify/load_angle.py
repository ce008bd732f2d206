"""Kept for `verify/designer.py` alone (it imports `trace_load_angle` from here) until
the designer's split lands: the load angle through one execution is the PPMC-312's, in
`profiles.ppmc312.load_angle_trace` (issue 34 item 2). Remove with the designer's
imports."""

from profiles.ppmc312.load_angle_trace import trace_load_angle

__all__ = ["trace_load_angle"]
