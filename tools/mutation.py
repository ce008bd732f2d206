"""Mutation testing: do the tests notice a wrong rule?

A small AST mutator. For each module it makes one mutant per site:
- comparison operators: < ↔ <=, > ↔ >=, == ↔ !=, in ↔ not in, is ↔ is not
- integer constants ± 1
- min ↔ max, any ↔ all
- a call made for its effect (a statement `f(…)`) deleted
- and ↔ or
and runs the module's tests against it (in a forked child that imports the mutant in
place of the module; a mutant that hangs is killed after --timeout seconds and counts as
killed). A mutant is *killed* when a test fails; the score is killed / (mutants −
equivalent), where `EQUIVALENT` lists, with the reason, each mutant that cannot change
behaviour. Text inside f-strings (messages) is not mutated: the verdicts, codes and
numbers are what the tests pin.

Hypothesis never shrinks in a mutant's run (a failing example is enough to kill it).

Usage: python bench/mutation.py [MODULE …] [--timeout S] [--list] [--only N,N]
(modules: upload, frames, checks, execution, criterion, stall; default all). Kept out of
the test suite: the full run (1 318 mutants) takes about 16 minutes on a shared 2-core
machine. Its per-mutant lines (stderr) are kept in bench/results/; scores are
recomputed from them without running anything:
    python bench/mutation.py --rescore bench/results/full.log bench/results/full.rerun.log
"""

from __future__ import annotations

import argparse
import ast
import importlib.abc
import importlib.util
import os
import re
import signal
import sys
import time
from collections.abc import Iterator
from dataclasses import dataclass
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]

MODULES: dict[str, tuple[str, list[str]]] = {
    "upload": ("profiles.ppmc312.upload",
               ["tests/test_ppmc312_upload.py", "tests/test_ppmc312_frames.py"]),
    "frames": ("profiles.ppmc312.frames",
               ["tests/test_ppmc312_frames.py", "tests/test_ppmc312_upload.py"]),
    "checks": ("verify.chip_rules", ["tests/test_checks.py", "tests/test_checks_pins.py"]),
    "execution": ("profiles.ppmc312.execution", [
        "tests/test_execution.py",
        "tests/test_every_move.py::test_families_partition_every_length_and_fix_the_segment_rates"]),
    "criterion": ("profiles.ppmc312.criterion", [
        "tests/test_criterion_pins.py", "tests/test_stall.py",
        "tests/test_every_move.py::test_a_downward_switch_is_caught_and_named_by_its_shortest_move",
        "tests/test_every_move.py::test_all_length_verdict_equals_brute_force"]),
    "stall": ("verify.criterion", [
        "tests/test_stall.py", "tests/test_stall_pins.py",
        "tests/test_every_move.py::test_a_downward_switch_is_caught_and_named_by_its_shortest_move"]),
}

# (module key, line, mutation) → why the mutant cannot change what the module does.
# Keyed by line: re-check the keys when a module's lines move (a stale key is reported
# as SURVIVED, never silently kept). The checks entries follow verify/chip_rules.py as of
# the lazy finding messages (main 45fab7f).
_PREFIX_LEN = ("every parameter-block prefix (header, length) is 2 bytes whatever header "
               "and length it is built for: n is 2 either way")
_UNUSED_CLIP_TOP = ("idx = searchsorted(side='right') − 1 is at most len − 1 (the clip's top "
                    "never acts: max(…, 0) only matters without segments, where every caller "
                    "returns before using idx); its bottom only acts for t < 0 (idx −1), "
                    "which every caller masks (position 0, speed 0, accel 0)")
_BEFORE_START = ("within < 0 only for t < 0 (the segment found starts after t), and the next "
                 "line maps every t ≤ 0 to 0")
_AT_ZERO = ("for ticks in (−1, 0] the segment is the first and ⌊ticks / rate⌋ is clipped to "
            "0: the position is 0 without the mask")
_AT_END = ("at ticks == the move's ticks the last segment's own formula gives all its pulses "
           "(before + count = pulses): the mask changes nothing there")
_MERGED = ("breakpoints past a_total + d_total + 1 are all trapezoids with a cruise, the same "
           "segment rates: move_families merges them into the last family")
_RATE_DIFF_KNOWN = "the extra breakpoint c + 1 = rate_diff it lets in is already in the set"
_ONE_STAGE = "a single stage has no partial sums from its slow end either way (counts[:-1] empty)"
_EMPTY_SIDE = "_up/_down of an empty side is empty whatever the count"
_NO_SHARED = ("a_sh + d_sh = 0 makes a_total + d_total = rate_diff, so the trapezoid branch "
              "takes every move that reaches this line: the else value is never used")
_LEVEL = ("_no_accel gets the cruise rate, already ≥ the high rate > acc[-2] rate: its max with "
          "acc[-2]'s rate, and (rates ascending, as the chip runs them) with acc[0]'s rate or "
          "the slowest stage's index, is the cruise rate unchanged")
_ZERO_CRUISE = "a 0-pulse cruise is dropped by runs(): the same segments"
_COUNT_ZERO = "with count 0 the loop only skips stages (take 0): the same plan, a little later"
_TAKE_EQUAL = "p == count gives take = p = count either way"
_CHUNK = "the chunk size only cuts the text into pieces; pulse_times_csv joins them"
_CRUISE_LEN = ("the trapezoid judged runs the same stages with the same dwell counts whatever "
               "its cruise (0, 1, 2 or 0xFFFFFFFF − a − d pulses): the cruise sits at the top "
               "rate, a step of 0 on both sides")
_INNER_GUARD = ("the inner where only keeps 0 out of the divisor where the outer where picks "
                "inf anyway (need is never negative); the outer one's mutants are killed by "
                "test_a_repeated_speed_has_no_step_and_an_infinite_margin")
_SORT_GUARD = "the guard only skips sorting a list of 0 or 1 findings, already in order"
_KEY_NONE = ("the third key element of a finding without a stage is only ever compared with "
             "another such finding's (the second element separates them from staged ones)")
_PREFILTER = ("a pre-filter before the exact per-stage test: entering the loop more often "
              "finds nothing more")
_SIDE_IN_RATES = ("a side never has more stages than there are rates (FreeCurveTable refuses "
                  "it): i < len(rates) always and the else value is never used")
_AT_TENTH = ("the candidate test differs only at equality, where the neighbours' mean is "
             "exactly 10·t and the exact test refuses the stage anyway: 0.1 · (10·t) rounds "
             "to t (0.1's float error is 5.6e-17 relative, under half an ulp), and t < t is "
             "false")
EQUIVALENT: dict[tuple[str, int, str], str] = {
    ("frames", 104, "1 → 0"): ("RESPONSE_HEADER is used one byte at a time through "
                               "pack_int/unpack_int, which never read its size"),
    ("frames", 104, "1 → 2"): ("RESPONSE_HEADER is used one byte at a time through "
                               "pack_int/unpack_int, which never read its size"),
    ("upload", 119, "0 → 1"): _PREFIX_LEN,
    ("upload", 119, "1 → 2"): _PREFIX_LEN,
    ("upload", 215, "0 → 1"): _PREFIX_LEN,
    ("upload", 215, "1 → 2"): _PREFIX_LEN,
    ("upload", 155, "0 → 1"): ("accel_stages is ≥ 1 (the command frame's lo=1): max with 1 "
                               "or −1 for an LE=0 table is accel_n unchanged"),
    ("upload", 155, "0 → -1"): ("accel_stages is ≥ 1 (the command frame's lo=1): max with 1 "
                                "or −1 for an LE=0 table is accel_n unchanged"),
    ("upload", 218, "0 → 1"): ("need is count · size minus whole entries, a multiple of the "
                               "entry size (2 or 3): need > 1 is need > 0"),
    ("execution", 134, "0 → -1"): _UNUSED_CLIP_TOP,
    ("execution", 134, "1 → 0"): _UNUSED_CLIP_TOP,
    ("execution", 134, "0 → 1"): _UNUSED_CLIP_TOP,
    ("execution", 142, "0 → -1"): _BEFORE_START,
    ("execution", 144, "0 → -1"): _AT_ZERO,
    ("execution", 144, "<= → <"): _AT_ZERO,
    ("execution", 145, ">= → >"): _AT_END,
    ("execution", 153, "0 → -1"): _BEFORE_START,
    ("execution", 155, "0 → -1"): _AT_ZERO,
    ("execution", 155, "<= → <"): _AT_ZERO,
    ("execution", 156, ">= → >"): _AT_END,
    ("execution", 185, "0 → -1"): "sample's instants are linspace(0, duration): never t < 0",
    ("execution", 185, "< → <="): ("the last sample (t = duration) lies in the last segment, "
                                   "whose slope is 0 by definition"),
    ("execution", 279, "> → >="): ("a stage at exactly the level rate joins the tail only as "
                                   "its fastest stage: it adds breakpoints (tail total + its "
                                   "pulses, + 1) of no effect, merged by move_families, and "
                                   "drops none that matter (the tail total itself is a "
                                   "boundary only when its fastest stage has 1 pulse, and then "
                                   "it is also c + 1 of the partial sums)"),
    ("execution", 283, "<= → <"): ("no breakpoint of a move that cannot accelerate reaches "
                                   "0xFFFFFFFF: its decel tail holds at most 127 × 0xFFFFFF "
                                   "pulses"),
    ("execution", 291, "1 → 0"): _RATE_DIFF_KNOWN,
    ("execution", 291, "< → <="): _RATE_DIFF_KNOWN,
    ("execution", 302, "1 → 2"): _MERGED,
    ("execution", 302, "min → max"): _MERGED,
    ("execution", 308, "1 → 0"): _ONE_STAGE,
    ("execution", 308, "> → >="): _ONE_STAGE,
    ("execution", 454, "0 → 1"): _NO_SHARED,
    ("execution", 454, "0 → -1"): _NO_SHARED,
    ("execution", 456, "0 → 1"): _EMPTY_SIDE,
    ("execution", 456, "0 → -1"): _EMPTY_SIDE,
    ("execution", 459, "0 → 1"): _EMPTY_SIDE,
    ("execution", 459, "0 → -1"): _EMPTY_SIDE,
    ("execution", 474, "1 → 2"): _LEVEL,
    ("execution", 474, "1 → 0"): _LEVEL,
    ("execution", 477, ">= → >"): _ZERO_CRUISE,
    ("execution", 487, "0 → -1"): _COUNT_ZERO,
    ("execution", 487, "<= → <"): _COUNT_ZERO,
    ("execution", 489, "< → <="): _TAKE_EQUAL,
    ("execution", 523, "1 → 2"): _CHUNK,
    ("execution", 523, "16 → 17"): _CHUNK,
    ("execution", 523, "16 → 15"): _CHUNK,
    ("criterion", 113, "2 → 1"): ("with one segment np.diff is empty: every per-step array is "
                                  "empty and the loop adds nothing"),
    ("criterion", 116, "> → >="): ("a step of 0 is never a problem (bad_cap needs dv ≠ 0, "
                                   "bad_jump |dv| > jump ≥ 0), so its side is never read"),
    ("criterion", 151, "1 → 2"): _CRUISE_LEN,
    ("criterion", 151, "1 → 0"): _CRUISE_LEN,
    ("criterion", 151, "min → max"): _CRUISE_LEN,
    ("stall", 50, "2 → 1"): "with one stage every [1:] slice is empty: the block assigns nothing",
    ("stall", 71, "0 → -1"): _INNER_GUARD,
    ("stall", 71, "> → >="): _INNER_GUARD,
    ("stall", 130, "0 → -1"): "top-speed stays the first rule (−1 < 1)",
    ("stall", 131, "6 → 7"): "jerk stays the last rule (7 > 5)",
    ("checks", 76, "1 → 0"): _SORT_GUARD,
    ("checks", 76, "> → >="): _SORT_GUARD,
    ("checks", 82, "1 → 2"): _KEY_NONE,
    ("checks", 82, "1 → 0"): _KEY_NONE,
    ("checks", 113, "< → <="): "the branch runs only when the two counts differ",
    ("checks", 114, "<= → <"): ("n_short is the shorter side's count and rates has the "
                                "longer side's: n_short < len(rates) whenever this runs"),
    ("checks", 129, "1 → 2"): _PREFILTER + (" (with rmin 2 and ≤ 2 Mpps, the loop's limit "
                                            "min_rate_for(hz) is 2: nothing is below it)"),
    ("checks", 129, "> → >="): _PREFILTER + (" (at exactly 2 Mpps min_rate_for(hz) is rmin "
                                             "itself)"),
    ("checks", 154, "< → <="): _PREFILTER,
    ("checks", 161, "> → >="): _PREFILTER,
    ("checks", 175, "< → <="): _PREFILTER,
    ("checks", 199, "< → <="): _SIDE_IN_RATES,
    ("checks", 199, "0 → 1"): _SIDE_IN_RATES,
    ("checks", 199, "0 → -1"): _SIDE_IN_RATES,
    ("checks", 206, "2 → 1"): ("with one stage the only candidate test, 10·t0 ≤ t0, holds "
                               "only for t0 = 0, and then 0 < 0.1·0 is false"),
    ("checks", 217, "10 → 9"): _PREFILTER,
    ("checks", 218, "20 → 19"): _PREFILTER,
    ("checks", 219, "10 → 9"): _PREFILTER,
    ("checks", 217, "<= → <"): _AT_TENTH,
    ("checks", 218, "<= → <"): _AT_TENTH,
    ("checks", 219, "<= → <"): _AT_TENTH,
    ("checks", 260, "< → <="): ("the branch only sees values outside MIN..MAX, never MIN "
                                "itself"),
}


@dataclass(frozen=True)
class Site:
    index: int
    line: int
    what: str


_CMP_SWAP: dict[type[ast.cmpop], type[ast.cmpop]] = {
    ast.Lt: ast.LtE, ast.LtE: ast.Lt, ast.Gt: ast.GtE, ast.GtE: ast.Gt,
    ast.Eq: ast.NotEq, ast.NotEq: ast.Eq, ast.In: ast.NotIn, ast.NotIn: ast.In,
    ast.Is: ast.IsNot, ast.IsNot: ast.Is,
}
_SYMBOL = {ast.Lt: "<", ast.LtE: "<=", ast.Gt: ">", ast.GtE: ">=", ast.Eq: "==",
           ast.NotEq: "!=", ast.In: "in", ast.NotIn: "not in", ast.Is: "is", ast.IsNot: "is not"}
_CALL_SWAP = {"min": "max", "max": "min", "any": "all", "all": "any"}


class _Mutator(ast.NodeTransformer):
    """Walks the tree in a fixed order; counts sites; applies site `target` only."""

    def __init__(self, target: int | None) -> None:
        self.target = target
        self.sites: list[Site] = []
        self.in_fstring = 0
        self.in_docstring_or_annotation = 0

    def _site(self, node: ast.AST, what: str) -> bool:
        index = len(self.sites)
        self.sites.append(Site(index, getattr(node, "lineno", 0), what))
        return index == self.target

    def visit_JoinedStr(self, node: ast.JoinedStr) -> ast.AST:
        return node  # messages are not mutated

    def visit_AnnAssign(self, node: ast.AnnAssign) -> ast.AST:
        if node.value is not None:
            node.value = self.visit(node.value)
        return node

    def visit_arg(self, node: ast.arg) -> ast.AST:
        return node  # annotations

    def visit_FunctionDef(self, node: ast.FunctionDef) -> ast.AST:
        node.returns = node.returns  # annotations untouched
        node.args = self.visit(node.args)
        node.body = [self.visit(s) for s in node.body]
        node.body = [s for s in node.body if s is not None]
        node.decorator_list = [self.visit(d) for d in node.decorator_list]
        return node

    def visit_ImportFrom(self, node: ast.ImportFrom) -> ast.AST:
        return node

    def visit_Compare(self, node: ast.Compare) -> ast.AST:
        self.generic_visit(node)
        for i, op in enumerate(node.ops):
            swap = _CMP_SWAP.get(type(op))
            if swap is not None and self._site(node, f"{_SYMBOL[type(op)]} → {_SYMBOL[swap]}"):
                node.ops[i] = swap()
        return node

    def visit_Constant(self, node: ast.Constant) -> ast.AST:
        v = node.value
        if isinstance(v, int) and not isinstance(v, bool):
            for delta in (1, -1):
                if self._site(node, f"{v} → {v + delta}"):
                    return ast.copy_location(ast.Constant(v + delta), node)
        return node

    def visit_Call(self, node: ast.Call) -> ast.AST:
        self.generic_visit(node)
        if isinstance(node.func, ast.Name) and node.func.id in _CALL_SWAP:
            new = _CALL_SWAP[node.func.id]
            if self._site(node, f"{node.func.id} → {new}"):
                node.func = ast.copy_location(ast.Name(new, ast.Load()), node.func)
        return node

    def visit_BoolOp(self, node: ast.BoolOp) -> ast.AST:
        self.generic_visit(node)
        old, new = ("and", "or") if isinstance(node.op, ast.And) else ("or", "and")
        if self._site(node, f"{old} → {new}"):
            node.op = ast.Or() if isinstance(node.op, ast.And) else ast.And()
        return node

    def visit_Expr(self, node: ast.Expr) -> ast.AST:
        if isinstance(node.value, ast.Constant) and isinstance(node.value.value, str):
            return node  # a docstring
        self.generic_visit(node)
        if isinstance(node.value, ast.Call):
            name = ast.unparse(node.value.func)
            if self._site(node, f"call {name}(…) deleted"):
                return ast.copy_location(ast.Pass(), node)
        return node


def sites(source: str) -> list[Site]:
    m = _Mutator(None)
    m.visit(ast.parse(source))
    return m.sites


def mutant(source: str, index: int) -> str:
    tree = ast.parse(source)
    _Mutator(index).visit(tree)
    ast.fix_missing_locations(tree)
    return ast.unparse(tree)


class _MutantFinder(importlib.abc.MetaPathFinder, importlib.abc.Loader):
    """Serves the mutated source for one module name; everything else imports as usual."""

    def __init__(self, name: str, path: Path, source: str) -> None:
        self.name, self.path, self.source = name, path, source

    def find_spec(self, fullname: str, path: object, target: object = None
                  ) -> importlib.machinery.ModuleSpec | None:
        if fullname != self.name:
            return None
        return importlib.util.spec_from_file_location(fullname, self.path, loader=self)

    def create_module(self, spec: importlib.machinery.ModuleSpec) -> None:
        return None

    def exec_module(self, module: object) -> None:
        exec(compile(self.source, str(self.path), "exec"), module.__dict__)  # type: ignore[attr-defined]


def _run_child(name: str, path: Path, source: str, tests: list[str]) -> int:
    import pytest

    sys.meta_path.insert(0, _MutantFinder(name, path, source))
    devnull = os.open(os.devnull, os.O_WRONLY)
    os.dup2(devnull, 1)
    os.dup2(devnull, 2)
    return int(pytest.main(["-x", "-q", "-p", "no:cacheprovider", "-p", "no:randomly",
                            "--no-header", "-o", "addopts=", *tests], plugins=[_FastFirst()]))


class _FastFirst:
    """Example-based tests before hypothesis ones: with -x, most mutants die in the
    table-driven tests without paying for a property test's hundreds of examples; and
    hypothesis never shrinks."""

    def pytest_configure(self, config: object) -> None:
        """No shrinking: after the suite's conftest has loaded its hypothesis profile and
        before the test modules (and their @settings) are imported, the same profile
        without the shrink phase becomes the default. A mutant needs only *a* failing
        example; shrinking it (to report it) can take longer than every other test
        together. The verdict is the same."""
        from hypothesis import Phase, settings

        settings.register_profile("mutation", settings.default,
                                  phases=(Phase.explicit, Phase.reuse, Phase.generate))
        settings.load_profile("mutation")

    def pytest_collection_modifyitems(self, items: list[object]) -> None:
        items.sort(key=lambda item: bool(getattr(getattr(item, "obj", None),
                                                 "is_hypothesis_test", False)))


def run_one(name: str, path: Path, source: str, tests: list[str], timeout: float) -> str:
    """'killed', 'survived' or 'timeout' for one mutated source."""
    pid = os.fork()
    if pid == 0:  # child
        code = 3
        try:
            code = _run_child(name, path, source, tests)
        finally:
            os._exit(code)
    deadline = time.monotonic() + timeout
    while True:
        done, status = os.waitpid(pid, os.WNOHANG)
        if done:
            return "survived" if os.waitstatus_to_exitcode(status) == 0 else "killed"
        if time.monotonic() > deadline:
            os.kill(pid, signal.SIGKILL)
            os.waitpid(pid, 0)
            return "timeout"
        time.sleep(0.02)


def _sample(key: str, n: int, seed: int) -> set[int]:
    import random

    name = MODULES[key][0]
    count = len(sites((ROOT / (name.replace(".", "/") + ".py")).read_text()))
    return set(random.Random(f"{seed}-{key}").sample(range(count), min(n, count)))


def _prepare_parent() -> None:
    """Heavy imports once, before forking; the project's modules are NOT imported here
    (each child imports them fresh, the mutant among them)."""
    os.environ.setdefault("CI", "true")  # derandomised hypothesis: repeatable verdicts
    os.chdir(ROOT)
    sys.path.insert(0, str(ROOT))
    import hypothesis  # noqa: F401
    import numpy  # noqa: F401
    import pytest  # noqa: F401


def run_module(key: str, timeout: float, only: set[int] | None) -> dict[str, object]:
    name, tests = MODULES[key]
    path = ROOT / (name.replace(".", "/") + ".py")
    source = path.read_text()
    all_sites = sites(source)
    baseline = run_one(name, path, ast.unparse(ast.parse(source)), tests, timeout * 4)
    if baseline != "survived":
        raise SystemExit(f"{key}: the tests fail on the unmutated module ({baseline})")
    verdicts: list[tuple[Site, str]] = []
    for site in all_sites:
        if only is not None and site.index not in only:
            continue
        verdict = run_one(name, path, mutant(source, site.index), tests, timeout)
        verdicts.append((site, verdict))
        print(f"  {key} #{site.index} line {site.line}: {site.what}: {verdict}", flush=True,
              file=sys.stderr)
    return score(key, verdicts)


def score(key: str, verdicts: list[tuple[Site, str]]) -> dict[str, object]:
    """Counts and score of one module's verdicts: a survivor listed in EQUIVALENT counts
    as equivalent (left out of the score), with its reason."""
    counts = {"killed": 0, "timeout": 0, "survived": 0, "equivalent": 0}
    survivors: list[tuple[Site, str]] = []
    for site, verdict in verdicts:
        reason = EQUIVALENT.get((key, site.line, site.what))
        if verdict == "survived" and reason is not None:
            counts["equivalent"] += 1
            survivors.append((site, f"equivalent: {reason}"))
        else:
            counts[verdict] += 1
            if verdict == "survived":
                survivors.append((site, "SURVIVED"))
    scored = len(verdicts) - counts["equivalent"]
    return {"module": key, "mutants": len(verdicts), **counts,
            "score": (counts["killed"] + counts["timeout"]) / scored if scored else 1.0,
            "survivors": survivors}


_LOG_LINE = re.compile(r"^\s*(\w+) #(\d+) line (\d+): (.*): (killed|survived|timeout)$")


def rescore(lines: list[str], reruns: list[str]) -> list[dict[str, object]]:
    """Scores from logged verdicts (stderr of earlier runs): each mutant's last verdict
    counts, so a re-run of survivors after new tests replaces their first verdict."""
    verdicts: dict[tuple[str, int], tuple[Site, str]] = {}
    for line in lines + [x for log in reruns for x in Path(log).read_text().splitlines()]:
        m = _LOG_LINE.match(line)
        if m:
            key, index, lineno, what, verdict = m.groups()
            verdicts[(key, int(index))] = (Site(int(index), int(lineno), what), verdict)
    results = []
    for key in MODULES:
        mine = [v for (k, _), v in sorted(verdicts.items()) if k == key]
        if mine:
            results.append(score(key, mine))
    return results


def _table(results: list[dict[str, object]]) -> Iterator[str]:
    yield "| module | mutants | killed | timeout | equivalent | survived | score |"
    yield "|---|---|---|---|---|---|---|"
    for r in results:
        yield (f"| {MODULES[str(r['module'])][0]} | {r['mutants']} | {r['killed']} | "
               f"{r['timeout']} | {r['equivalent']} | {r['survived']} | "
               f"{100 * float(r['score']):.1f} % |")  # type: ignore[arg-type]


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("modules", nargs="*", default=[], help=f"any of {', '.join(MODULES)}")
    ap.add_argument("--timeout", type=float, default=120.0, help="seconds per mutant")
    ap.add_argument("--list", action="store_true", help="list the mutation sites only")
    ap.add_argument("--only", help="comma-separated site indexes (one module)")
    ap.add_argument("--sample", type=int, metavar="N",
                    help="run a random sample of N mutants per module (seeded): the score "
                         "is then an estimate")
    ap.add_argument("--seed", type=int, default=13, help="the sample's seed")
    ap.add_argument("--rescore", metavar="LOG", nargs="+",
                    help="no run: score the per-mutant lines of earlier runs' stderr (later "
                         "files win: bench/results/*.log lists each module's full run "
                         "before its re-run of survivors)")
    ap.add_argument("--rerun", metavar="LOG", action="append",
                    help="with --rescore: later runs of some mutants (--only), which win")
    args = ap.parse_args()
    keys = args.modules or list(MODULES)
    if set(keys) - set(MODULES):
        ap.error(f"unknown module(s) {sorted(set(keys) - set(MODULES))}")
    if args.list:
        for key in keys:
            name = MODULES[key][0]
            source = (ROOT / (name.replace(".", "/") + ".py")).read_text()
            for s in sites(source):
                print(f"{key} #{s.index} line {s.line}: {s.what}")
        return 0
    if args.rescore:
        logs = [*args.rescore, *(args.rerun or [])]
        results = rescore(Path(logs[0]).read_text().splitlines(), logs[1:])
        for line in _table(results):
            print(line)
        for r in results:
            for site, why in r["survivors"]:  # type: ignore[attr-defined]
                print(f"- {MODULES[str(r['module'])][0]} line {site.line}: {site.what}: {why}")
        return 0
    only = {int(x) for x in args.only.split(",")} if args.only else None
    _prepare_parent()
    started = time.monotonic()
    results = [run_module(k, args.timeout, only if args.sample is None
                          else _sample(k, args.sample, args.seed)) for k in keys]
    for line in _table(results):
        print(line)
    for r in results:
        for site, why in r["survivors"]:  # type: ignore[attr-defined]
            print(f"- {MODULES[str(r['module'])][0]} line {site.line}: {site.what}: {why}")
    print(f"({time.monotonic() - started:.0f} s)")
    return 0


if __name__ == "__main__":
    sys.exit(main())
