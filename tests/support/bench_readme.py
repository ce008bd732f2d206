"""bench/readme.py loaded as a module, for the tests of the README's measured blocks."""

from __future__ import annotations

from typing import Any

from tests.support.paths import ROOT, load_script


def bench_readme() -> Any:
    """bench/readme.py, the generator of the README's measured blocks and figures."""
    return load_script(ROOT / "bench" / "readme.py", "stepramp_bench_readme")
