"""bench/readme.py loaded as a module, for the tests of the README's measured blocks."""

from __future__ import annotations

from typing import Any

from tests.support.paths import ROOT


def bench_readme() -> Any:
    """bench/readme.py, the generator of the README's measured blocks and figures."""
    import importlib.util
    import sys

    spec = importlib.util.spec_from_file_location("stepramp_bench_readme",
                                                  ROOT / "bench" / "readme.py")
    assert spec is not None and spec.loader is not None
    module = importlib.util.module_from_spec(spec)
    sys.modules[spec.name] = module
    spec.loader.exec_module(module)
    return module
