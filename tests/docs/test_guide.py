"""docs/guide.md stays in step with the CLI: every command in it is run.

Convention (docs/guide.md, "```console" blocks): a line `$ stepramp ARGS` is a
command (a trailing `\\` continues it; a trailing `# exit N` gives its exit code,
default 0); the lines under it, up to the next `$`, are its output (stdout, then
stderr). Shown output is complete unless marked: a line `…` stands for any
number of omitted lines, and a line ending in `…` for one line starting with
the text before it. Commands run in guide order in one temporary directory
holding copies of `examples/` and the bundled motors at the paths the guide uses,
so outputs of one command feed the next and nothing is written into the
repository.

- fast: every command that needs no heavy solver, in-process through
  `verify.cli.main` (the `stepramp` entry point);
- slow (run in CI): every command, `compare` with toppra/casadi included, as a
  `python -m verify.cli` subprocess.

Also checked against the code: every sub-command has an example, every motor
and table key and every finding rule is documented, the JSON examples load, the
capability numbers are the motor's, and the C headers the guide writes compile.
"""

from __future__ import annotations

import contextlib
import io
import math
import os
import re
import shlex
import shutil
import subprocess
import sys
from collections.abc import Callable, Iterator
from dataclasses import dataclass, field
from glob import glob
from pathlib import Path

import pytest

from profiles.motor import OPTIONAL_KEYS as MOTOR_OPTIONAL
from profiles.motor import REQUIRED_KEYS as MOTOR_REQUIRED
from profiles.motor import Motor, load_motor
from profiles.ppmc312.table import _KEYS as TABLE_KEYS
from profiles.ppmc312.table import table_from_json
from tests.support.paths import ROOT
from tests.support.subprocess_env import checkout_env
from verify import cli

LINK_COMMANDS = ("init", "move", "poll", "position", "errors", "stop")


GUIDE = ROOT / "docs" / "guide.md"


ELLIPSIS = "…"


_EXIT = re.compile(r"\s+#\s*exit\s+(\d+)\s*$")


@dataclass
class Command:
    line: int            # line number in the guide, for messages
    text: str            # as written after `$ `, continuations joined
    argv: list[str]      # after `stepramp`
    exit_code: int
    shown: list[str] = field(default_factory=list)

    @property
    def slow(self) -> bool:
        """Commands that run the toppra or casadi solvers."""
        if self.argv[:1] == ["compare"]:
            refs = "toppra,ruckig,casadi"
            if "--references" in self.argv:
                refs = self.argv[self.argv.index("--references") + 1]
            return bool({"toppra", "casadi"} & set(refs.split(",")))
        return "--from" in self.argv and self.argv[self.argv.index("--from") + 1] == "toppra"

    @property
    def name(self) -> str:
        """The sub-command, e.g. `check`, `alink settings` or `link poll`."""
        words = [a for a in self.argv if not a.startswith("-")]
        if not words:  # `stepramp --version`
            return ""
        if words[0] == "link":  # options (with values) come before link's sub-command
            return "link " + next(w for w in words[1:] if w in LINK_COMMANDS)
        return " ".join(words[:2]) if words[0] in ("alink", "mc200", "motor") else words[0]

    @property
    def background(self) -> bool:
        """Commands that serve until stopped (`emulate --pty`): started, checked, left
        running. (`emulate --bus` runs a script and ends, as any command.)"""
        return self.argv[:1] == ["emulate"] and "--pty" in self.argv


def guide_text() -> str:
    return GUIDE.read_text(encoding="utf-8")


def fenced_blocks(lang: str) -> list[tuple[int, list[str]]]:
    """(line number of the first content line, lines) of every ```lang block."""
    out: list[tuple[int, list[str]]] = []
    lines = guide_text().splitlines()
    i = 0
    while i < len(lines):
        if lines[i].strip() == f"```{lang}":
            start = i + 1
            j = start
            while not lines[j].startswith("```"):
                j += 1
            out.append((start + 1, lines[start:j]))
            i = j
        i += 1
    return out


def guide_commands() -> list[Command]:
    commands: list[Command] = []
    for first_line, lines in fenced_blocks("console"):
        current: Command | None = None
        k = 0
        while k < len(lines):
            line, number = lines[k], first_line + k
            if line.startswith("$ "):
                text = line[2:]
                while text.endswith("\\"):
                    k += 1
                    text = text[:-1] + " " + lines[k].strip()
                match = _EXIT.search(text)
                exit_code = int(match.group(1)) if match else 0
                words = shlex.split(text, comments=True)
                assert words and words[0] == "stepramp", \
                    f"guide line {number}: console commands start with `$ stepramp`"
                current = Command(number, text, words[1:], exit_code)
                commands.append(current)
            else:
                assert current is not None, f"guide line {number}: output before any command"
                current.shown.append(line.strip())
            k += 1
    return commands


def output_mismatch(shown: list[str], real: list[str]) -> str | None:
    """None when `real` output agrees with the `shown` lines, else what differs."""
    real = [r.strip() for r in real]
    pos = 0
    gap = False  # may lines be skipped before the next shown line?
    for s in shown:
        if s == ELLIPSIS:
            gap = True
            continue
        def ok(r: str, s: str = s) -> bool:
            return r.startswith(s[:-1]) if s.endswith(ELLIPSIS) else r == s
        candidates = range(pos, len(real)) if gap else range(pos, min(pos + 1, len(real)))
        found = next((i for i in candidates if ok(real[i])), None)
        if found is None:
            where = "any later line" if gap else f"output line {pos + 1}"
            return f"shown {s!r} is not {where}"
        pos, gap = found + 1, False
    if not gap and pos < len(real):
        return f"output goes on beyond what is shown (mark it with {ELLIPSIS}): {real[pos]!r}"
    return None


def expand_globs(argv: list[str], cwd: Path) -> list[str]:
    """Expand `*`/`?` arguments like a shell would (sorted; unmatched ones stay as written)."""
    out: list[str] = []
    for arg in argv:
        matches = sorted(glob(arg, root_dir=cwd)) if any(c in arg for c in "*?[") else []
        out.extend(matches or [arg])
    return out


@contextlib.contextmanager
def workdir() -> Iterator[Path]:
    """A temporary directory holding `examples/`, the bundled motors and an empty
    `motors/`, the user motor folder the guide's examples run with (STEPRAMP_MOTORS)."""
    import tempfile

    with tempfile.TemporaryDirectory(prefix="stepramp-guide-") as tmp:
        root = Path(tmp)
        shutil.copytree(ROOT / "examples", root / "examples")
        (root / "profiles" / "data").mkdir(parents=True)
        for motor in (ROOT / "profiles" / "data").glob("motor-*.json"):
            shutil.copy(motor, root / "profiles" / "data" / motor.name)
        (root / "motors").mkdir()
        saved = os.environ.get("STEPRAMP_MOTORS")
        os.environ["STEPRAMP_MOTORS"] = "motors"  # relative: commands run in `root`
        try:
            yield root
        finally:
            if saved is None:
                os.environ.pop("STEPRAMP_MOTORS", None)
            else:
                os.environ["STEPRAMP_MOTORS"] = saved


Runner = Callable[[list[str], Path], tuple[int, str]]


def run_in_process(argv: list[str], cwd: Path) -> tuple[int, str]:
    out = io.TextIOWrapper(io.BytesIO(), encoding="utf-8", errors="replace")
    err = io.StringIO()
    old = Path.cwd()
    os.chdir(cwd)
    try:
        with contextlib.redirect_stdout(out), contextlib.redirect_stderr(err):
            code = cli.main(argv)
    finally:
        os.chdir(old)
    out.flush()
    stdout = out.buffer.getvalue().decode("utf-8", errors="replace")  # type: ignore[attr-defined]
    return code, stdout + err.getvalue()


def run_subprocess(argv: list[str], cwd: Path) -> tuple[int, str]:
    env = checkout_env(MPLBACKEND="Agg")
    done = subprocess.run([sys.executable, "-m", "verify.cli", *argv], cwd=cwd, env=env,
                          capture_output=True, timeout=600)
    text = (done.stdout.decode("utf-8", errors="replace")
            + done.stderr.decode("utf-8", errors="replace"))
    return done.returncode, text


def start_background(argv: list[str], cwd: Path) -> tuple[subprocess.Popen[str], str]:
    """A serving command (`emulate`) as a subprocess, and the first line it prints."""
    env = checkout_env()
    proc = subprocess.Popen([sys.executable, "-m", "verify.cli", *argv], cwd=cwd, env=env,
                            stdout=subprocess.PIPE, stderr=subprocess.STDOUT, text=True)
    assert proc.stdout is not None
    return proc, proc.stdout.readline()


def run_guide(run: Runner, cwd: Path, include_slow: bool) -> list[str]:
    """Run the guide's commands in order; one message per disagreement."""
    problems: list[str] = []
    serving: list[subprocess.Popen[str]] = []
    try:
        _run_guide(run, cwd, include_slow, problems, serving)
    finally:
        for proc in serving:
            proc.terminate()
            proc.wait(timeout=30)
    return problems


def _run_guide(run: Runner, cwd: Path, include_slow: bool, problems: list[str],
               serving: list[subprocess.Popen[str]]) -> None:
    for c in guide_commands():
        if c.slow and not include_slow:
            continue
        where = f"guide line {c.line}: $ {c.text}"
        if c.background:
            proc, first = start_background(c.argv, cwd)
            serving.append(proc)
            mismatch = output_mismatch(c.shown, [first])
            if mismatch:
                problems.append(f"{where}\n  {mismatch}\n  first line: {first!r}")
            continue
        code, output = run(expand_globs(c.argv, cwd), cwd)
        if "Traceback (most recent call last)" in output:
            problems.append(f"{where}\n  printed a traceback:\n{output}")
            continue
        if code != c.exit_code:
            problems.append(f"{where}\n  exit {code}, the guide says {c.exit_code}\n{output}")
            continue
        mismatch = output_mismatch(c.shown, output.splitlines())
        if mismatch:
            problems.append(f"{where}\n  {mismatch}\n  real output:\n{output}")


@pytest.fixture(scope="module")
def fast_run() -> Iterator[tuple[Path, list[str]]]:
    with workdir() as root:
        yield root, run_guide(run_in_process, root, include_slow=False)


@pytest.mark.slow  # the whole guide in-process; CI runs it, and as subprocesses
def test_guide_commands(fast_run: tuple[Path, list[str]]) -> None:
    _, problems = fast_run
    assert not problems, "\n\n".join(problems)


@pytest.mark.slow
def test_guide_commands_as_subprocesses_including_solvers() -> None:
    assert any(c.slow for c in guide_commands()), "the guide has no solver example"
    with workdir() as root:
        problems = run_guide(run_subprocess, root, include_slow=True)
        assert not problems, "\n\n".join(problems)
        assert (root / "nema17-plan.png").stat().st_size > 1000


def test_guide_writes_nothing_outside_its_directory() -> None:
    # Every output path the guide names is relative: it lands in the work directory.
    for c in guide_commands():
        for flag in ("-o", "--output", "--csv", "--plot"):
            if flag in c.argv:
                target = c.argv[c.argv.index(flag) + 1]
                assert not Path(target).is_absolute() and ".." not in Path(target).parts, c.text
                assert not target.startswith(("examples/", "profiles/")), c.text


def test_output_matching_rules() -> None:
    real = ["a 1", "b 2", "c 3"]
    assert output_mismatch(["a 1", "b 2", "c 3"], real) is None
    assert output_mismatch(["a 1", ELLIPSIS, "c 3"], real) is None
    assert output_mismatch(["a …", "b 2", ELLIPSIS], real) is None
    assert output_mismatch([ELLIPSIS, "c 3"], real) is None
    assert output_mismatch(["a 1", "c 3"], real) is not None     # a skipped line, unmarked
    assert output_mismatch(["a 1", "b 2"], real) is not None     # output goes on, unmarked
    assert output_mismatch(["b 2", ELLIPSIS], real) is not None  # the first line is not shown
    assert output_mismatch(["a 1", ELLIPSIS, "x …"], real) is not None
    assert output_mismatch([], []) is None
    assert output_mismatch([], ["unexpected"]) is not None


def test_commands_parse_exit_codes_and_continuations() -> None:
    commands = guide_commands()
    assert any(c.exit_code == 1 for c in commands) and any(c.exit_code == 2 for c in commands)
    for c in commands:
        assert "#" not in " ".join(c.argv), c.text


def test_every_command_has_an_example() -> None:
    parser = cli.build_parser()
    names: set[str] = set()
    [top] = [a for a in parser._actions if a.__class__.__name__ == "_SubParsersAction"]
    for name, sub in top.choices.items():  # type: ignore[union-attr]
        nested = [a for a in sub._actions if a.__class__.__name__ == "_SubParsersAction"]
        names |= {f"{name} {n}" for n in nested[0].choices} if nested else {name}
    expected = {"check", "show", "export", "decode", "move", "expand", "plan", "simulate",
                "compare", "alink settings", "alink decode", "mc200 stream", "mc200 decode",
                "emulate", *(f"link {name}" for name in LINK_COMMANDS)}
    assert names >= expected
    documented = {c.name for c in guide_commands()}
    assert names - documented == set(), "commands without an example in the guide"
    for name in names:
        assert f"## `stepramp {name}`" in guide_text(), f"no section for stepramp {name}"


def test_every_file_key_is_documented() -> None:
    text = guide_text()
    keys = set(MOTOR_REQUIRED) | set(MOTOR_OPTIONAL)
    for required, optional in TABLE_KEYS.values():
        keys |= set(required) | set(optional)
    keys |= {"extck_hz", "edge"}
    # Documented: in a table row as `key`, or (the clock object's keys) as a JSON key.
    missing = sorted(k for k in keys if f"`{k}`" not in text and f'"{k}":' not in text)
    assert not missing, f"keys the guide does not document: {missing}"


def test_every_rule_is_documented() -> None:
    rules: set[str] = set()
    for path in sorted((ROOT / "verify").rglob("*.py")):
        source = path.read_text(encoding="utf-8")
        # the severity may be a literal or an expression ("error" if strict else "warning")
        rules |= set(re.findall(r'Finding\(\s*[^,()]+,\s*"([a-z0-9-]+)"', source))
        # rules kept as (severity, rule) pairs in a table (verify/devices/alink.py's RULES)
        rules |= set(re.findall(r'\(\s*"(?:error|warning)",\s*"([a-z0-9-]+)"\s*\)', source))
        for template in re.findall(r'Finding\(\s*"(?:error|warning)",\s*f"\{side\}-([a-z-]+)"',
                                   source):
            rules |= {f"accel-{template}", f"decel-{template}"}
    assert len(rules) > 20, rules  # the regexes still find the rules
    missing = sorted(r for r in rules if f"`{r}`" not in guide_text())
    assert not missing, f"finding rules the guide does not document: {missing}"


def test_json_examples_load() -> None:
    blocks = fenced_blocks("json")
    assert blocks
    import json

    for line, lines in blocks:
        obj = json.loads("\n".join(lines))
        if obj["format"] == "stepramp.table/1":
            table = table_from_json(obj)
            import jsonschema

            schema = json.loads((ROOT / "profiles/data/table.schema.json").read_text())
            jsonschema.validate(obj, schema)
            assert table.kind == obj["kind"], line
        elif obj["format"] == "stepramp.axes/1":
            import jsonschema

            from profiles.axes import axes_from_json
            from verify.devices import axes_entries
            schema = json.loads((ROOT / "profiles/data/axes.schema.json").read_text())
            jsonschema.validate(obj, schema)
            assert axes_from_json(obj, axes_entries(), None, load_motors=False).axes, line
        elif obj["format"] == "stepramp.program/1":
            import jsonschema

            from profiles.ppmc312.program import program_from_json
            schema = json.loads((ROOT / "profiles/data/program.schema.json").read_text())
            jsonschema.validate(obj, schema)
            assert program_from_json(obj, ROOT / "examples").commands, line
        else:
            assert Motor.from_json(obj).to_json()["format"] == "stepramp.motor/1", line


def test_le1_example_is_what_the_guide_says() -> None:
    import json

    from profiles.ppmc312.chip_rules import check_table

    [le1] = [json.loads("\n".join(b)) for _, b in fenced_blocks("json") if "decel_pulses" in
             "\n".join(b)]
    table = table_from_json(le1)
    rules = [f.rule for f in check_table(table)]
    assert "decel-stage-count" in rules
    assert table.clock.hz / table.rates[len(table.decel) - 1] == 10_000.0  # "stops at 10 000 pps"


def test_capability_numbers_are_the_motors() -> None:
    text = guide_text()
    motor = load_motor(ROOT / "profiles" / "data" / "motor-nema17-1600.json")
    rows = re.findall(r"^\| (\d+) \| ([\d.]+) \| ([\d.e+]+) \| ([\d.e+]+) \|$", text, re.M)
    assert len(rows) >= 3
    for v, torque, acc, dec in rows:
        assert float(torque) == pytest.approx(motor.torque_nm(float(v)))
        assert float(acc) == pytest.approx(motor.a_acc_pps2(float(v)), rel=1e-5)
        assert float(dec) == pytest.approx(motor.a_dec_pps2(float(v)), rel=1e-5)
    worked = re.search(r"a_acc\(0\) = \(0\.6 · 0\.40 − 0\.02\) / 6\.8e-6 · 1600 / 2π = "
                       r"([\d.e+]+) pps/s", text)
    assert worked
    assert float(worked.group(1)) == pytest.approx((0.6 * 0.40 - 0.02) / 6.8e-6 * 1600
                                                   / (2 * math.pi), rel=1e-5)
    assert float(worked.group(1)) == pytest.approx(motor.a_acc_pps2(0.0), rel=1e-5)


@pytest.mark.slow  # needs the guide's run
def test_c_headers_from_the_guide_compile(fast_run: tuple[Path, list[str]], tmp_path: Path
                                          ) -> None:
    root, _ = fast_run
    headers = sorted(root.glob("*.h"))
    assert len(headers) >= 2, "the guide writes the upload and A-Link C headers"
    compiler = shutil.which("cc") or shutil.which("gcc") or shutil.which("clang")
    if compiler is None:
        pytest.skip("no C compiler")
    source = tmp_path / "use.c"
    # Two includes of each: the guards must hold; -Werror: no warning either.
    source.write_text("".join(f'#include "{h}"\n#include "{h}"\n' for h in headers)
                      + "int main(void) { return 0; }\n")
    done = subprocess.run([compiler, "-std=c99", "-Wall", "-Werror", "-Wno-unused-const-variable",
                           "-Wno-unused-variable", "-fsyntax-only",
                           str(source)], capture_output=True, text=True, timeout=60)
    assert done.returncode == 0, done.stderr


def test_internal_links_resolve() -> None:
    text = guide_text()
    # GitHub's heading anchors: lower case, punctuation other than - and _ dropped,
    # spaces to hyphens.
    anchors = {re.sub(r"[^\w\- ]", "", h.strip().lower()).replace(" ", "-")
               for h in re.findall(r"^#{2,4} (.+)$", text, re.M)}
    links = re.findall(r"\]\(#([^)]+)\)", text)
    assert len(links) >= 10
    assert sorted(set(links) - anchors) == []
    for target in re.findall(r"\]\((\.\./[^)#]+)\)", text):
        assert (GUIDE.parent / target).exists(), target


def test_from_python_runs_and_prints_what_the_guide_shows(
        capsys: pytest.CaptureFixture[str]) -> None:
    # The "From Python" section's code block, run as written through the front doors, and
    # its output against the text block that follows it.
    section = guide_text().split("## From Python", 1)[1]
    [(at, code)] = [(n, lines) for n, lines in fenced_blocks("python")
                    if "from profiles import encode_table" in "\n".join(lines)]
    exec(compile("\n".join(code), f"docs/guide.md:{at}", "exec"), {})
    shown = section.split("```text\n", 1)[1].split("```", 1)[0].splitlines()
    assert output_mismatch(shown, capsys.readouterr().out.splitlines()) is None
