"""verify.check_options: every front end draws the same number of samples by default."""

from __future__ import annotations

from tests.support.paths import ROOT
from verify.check_file import check_file


def test_every_front_end_draws_the_same_number_of_samples_by_default() -> None:
    """One default (verify.check_options.DEFAULT_SAMPLES) for the library's judges and the
    commands' --samples, and the guide says it."""
    import argparse
    import inspect
    import re

    from profiles.ppmc312.tolerance_box import judge_box
    from verify import cli
    from verify.check_options import DEFAULT_SAMPLES, CheckOptions
    from verify.cli._common import sample_count
    from verify.safety import judge_safety

    for fn in (check_file, judge_safety, judge_box):
        assert inspect.signature(fn).parameters["samples"].default == DEFAULT_SAMPLES, fn
    assert CheckOptions().samples == DEFAULT_SAMPLES
    parser = cli.build_parser()
    commands = next(a for a in parser._actions if isinstance(a, argparse._SubParsersAction))
    def tolerance_samples(a: argparse.Action) -> bool:  # not simulate's --samples OUT.csv
        return a.dest == "samples" and a.type is sample_count

    with_samples = {name: next(a.default for a in sub._actions if tolerance_samples(a))
                    for name, sub in commands.choices.items()
                    if any(tolerance_samples(a) for a in sub._actions)}
    assert with_samples and set(with_samples.values()) == {DEFAULT_SAMPLES}, with_samples
    guide = (ROOT / "docs" / "guide.md").read_text(encoding="utf-8")
    said = re.search(r"`--samples N` \(default (\d+)\)", guide)
    assert said is not None and int(said.group(1)) == DEFAULT_SAMPLES == 1000
