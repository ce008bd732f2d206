"""Continuous references: the exact oracle against hand kinematics, and the solvers
(toppra, ruckig, casadi) against the oracle and against the motor's capability."""

from __future__ import annotations

from tests.support.paths import ROOT


def test_no_heavy_imports_at_module_level() -> None:
    import subprocess
    import sys

    code = ("import sys, verify.references; "
            "print(sorted(m for m in ('toppra', 'casadi', 'ruckig') if m in sys.modules))")
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True,
                         check=True, cwd=str(ROOT))
    assert out.stdout.strip() == "[]"
