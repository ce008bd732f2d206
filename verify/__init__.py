"""stepramp.verify: chip-rule checks, the one stall-safety verdict, comparison with the
time-optimal references, reports and the CLI.

The front door: `from verify import judge_safety, check_table, compare_table`. Each
loads on first use, so `stepramp --version` and a table check stay fast."""

from typing import TYPE_CHECKING

from profiles.lazy import lazy_exports

if TYPE_CHECKING:
    from profiles.ppmc312.chip_rules import check_table

    from .compare import compare_table
    from .safety import SafetyVerdict, judge_safety

__getattr__ = lazy_exports(__name__, {
    "check_table": "profiles.ppmc312.chip_rules", "compare_table": ".compare",
    "judge_safety": ".safety", "SafetyVerdict": ".safety",
})

__all__ = ["SafetyVerdict", "check_table", "compare_table", "judge_safety"]
