"""The environment a test gives a Python subprocess of the checkout."""

from __future__ import annotations

import os

from tests.support.paths import ROOT


def checkout_env(**extra: str) -> dict[str, str]:
    """os.environ with the checkout first on PYTHONPATH, then what the caller had there,
    and `extra`."""
    kept = [p for p in os.environ.get("PYTHONPATH", "").split(os.pathsep) if p]
    return {**os.environ, "PYTHONPATH": os.pathsep.join([str(ROOT), *kept]), **extra}
