"""The layout rules import-linter cannot state (its contracts are in pyproject.toml and
.ci/run runs `lint-imports`: cli → verify → devices → motor → shared nouns, the devices
independent of each other, profiles never importing verify, lazy imports included):

- every module sits in a layer (a module in no layer would escape the contract);
- no private name is imported across modules;
- no function in profiles/ or verify/ is over 80 lines;
- every device in the registry has what its entry names, and the axes file's schema
  agrees with the registry's axes entries;
- the tests mirror the packages (docs/architecture.md, "Tests"): a unit test of
  `profiles/x/y.py` is `tests/profiles/x/test_y.py`, at least MIRRORED_SHARE of the
  modules have one, and every test module there names a module that exists; the other
  tests sit in tests/contract, tests/docs or tests/repo, what they share in
  tests/support; no test module imports another, and bench/ and tools/ do not put
  tests/ on sys.path (they import `tests.support.*` with the repository root on it);
  the checkout's folders come from tests/support/paths.py's ROOT, never from a test
  file's own place (its `__file__`), which moves with the file.
"""

from __future__ import annotations

import ast
import functools
import importlib
import json
import re
import tomllib
from pathlib import Path

import pytest

from tests.support.paths import ROOT

MAX_FUNCTION_LINES = 80
MIRRORED_SHARE = 0.8
TEST_FOLDERS = {"profiles", "verify", "contract", "docs", "repo", "support"}


def contracts() -> list[dict[str, object]]:
    doc = tomllib.loads((ROOT / "pyproject.toml").read_text(encoding="utf-8"))
    return list(doc["tool"]["importlinter"]["contracts"])


def layer_modules() -> set[str]:
    layers = next(c for c in contracts() if c["type"] == "layers")["layers"]
    assert isinstance(layers, list)
    out: set[str] = set()
    for layer in layers:
        out |= {m.strip() for m in layer.replace("|", ":").split(":")}
    return out


def children(package: str) -> set[str]:
    """The modules and packages directly in `package` (its __init__ and data aside)."""
    folder = ROOT.joinpath(*package.split("."))
    return ({f"{package}.{p.stem}" for p in folder.glob("*.py") if p.stem != "__init__"}
            | {f"{package}.{p.name}" for p in folder.iterdir()
               if (p / "__init__.py").exists()})


def test_every_module_is_in_a_layer() -> None:
    listed = layer_modules()
    missing = (children("verify") | children("profiles")) - listed - {"profiles.data"}
    assert missing == set(), "add these to a layer in pyproject.toml"
    assert listed - (children("verify") | children("profiles") | {"verify.cli"}) == set()


def test_the_contracts_hold_what_the_issue_asks() -> None:
    kinds = {c["type"]: c for c in contracts()}
    assert set(kinds) == {"layers", "independence", "forbidden", "acyclic_siblings"}
    # no circle of imports in any package, not even behind a function-level import
    assert set(kinds["acyclic_siblings"]["ancestors"]) == {"profiles", "verify"}  # type: ignore[arg-type]
    assert set(kinds["independence"]["modules"]) == {  # type: ignore[arg-type]
        "profiles.ppmc312", "profiles.alink", "profiles.mc200"}
    assert kinds["forbidden"]["source_modules"] == ["profiles"]
    assert kinds["forbidden"]["forbidden_modules"] == ["verify"]


def sources() -> list[Path]:
    return sorted([*(ROOT / "profiles").rglob("*.py"), *(ROOT / "verify").rglob("*.py")])


@functools.cache
def parsed(path: Path) -> ast.Module:
    return ast.parse(path.read_text(encoding="utf-8"), str(path))


def private_imports(path: Path) -> list[str]:
    """`from x import _name` anywhere in `path` (module top or inside a function), and
    `module._name` of a module it imports (`import x.y as m; m._name`)."""
    tree = parsed(path)
    found = [f"{node.lineno}: {alias.name}" for node in ast.walk(tree)
             if isinstance(node, ast.ImportFrom) for alias in node.names
             if _private(alias.name)]
    modules = {alias.asname or alias.name.partition(".")[0] for node in ast.walk(tree)
               if isinstance(node, ast.Import) for alias in node.names}
    return found + [f"{node.lineno}: {node.value.id}.{node.attr}" for node in ast.walk(tree)
                    if isinstance(node, ast.Attribute) and isinstance(node.value, ast.Name)
                    and node.value.id in modules and _private(node.attr)]


def _private(name: str) -> bool:
    return name.startswith("_") and not name.startswith("__")


@pytest.mark.slow  # 2–3 s: the quick suite's budget; CI runs it
def test_no_private_name_is_imported_across_modules() -> None:
    found = {str(p.relative_to(ROOT)): names for p in sources()
             if (names := private_imports(p))}
    assert found == {}


def long_functions(path: Path) -> list[tuple[str, int]]:
    """Every function (methods and nested ones too) over MAX_FUNCTION_LINES lines, from
    its `def` to its last line, docstring and comments included."""
    tree = parsed(path)
    return [(node.name, node.end_lineno - node.lineno + 1) for node in ast.walk(tree)
            if isinstance(node, ast.FunctionDef | ast.AsyncFunctionDef)
            and node.end_lineno is not None
            and node.end_lineno - node.lineno + 1 > MAX_FUNCTION_LINES]


def test_no_function_is_over_80_lines() -> None:
    found = {(str(p.relative_to(ROOT)), name): n for p in sources()
             for name, n in long_functions(p)}
    assert not found, found


def test_the_scans_see_what_they_look_for(tmp_path: Path) -> None:
    src = tmp_path / "mod.py"
    body = "\n".join(f"    x{i} = {i}" for i in range(80))
    src.write_text("from a import _hidden, __version__, shown\n"
                   "def f():\n    from .b import _also\n"
                   f"def g():\n{body}\n"
                   "class C:\n    def short(self):\n        return 1\n"
                   "import p.q as m\nm._inner(m.__name__, self._own)\n", encoding="utf-8")
    assert private_imports(src) == ["1: _hidden", "3: _also", "89: m._inner"]
    assert long_functions(src) == [("g", 81)]


@pytest.mark.parametrize("name", ["ppmc312", "alink", "mc200"])
def test_every_registry_entry_points_at_what_it_names(name: str) -> None:
    from profiles.formats import FormatTable
    from verify.devices import get

    device = get(name)
    assert importlib.import_module(device.package)
    assert isinstance(device.format_table(), FormatTable)
    assert callable(device.judge_module().check)
    if device.sync is not None:
        sync = device.sync_module()
        for hook in ("plan_sync", "sync_files", "output_names", "check_axis_names",
                     "move_commands"):
            assert callable(getattr(sync, hook)), hook
        assert callable(device.sync_judge().axis_verdict)
    if device.command is not None:
        assert (ROOT / "verify" / "cli" / f"{device.command}.py").exists()


def test_the_axes_schema_agrees_with_the_registry() -> None:
    from verify.devices import DEFAULT, axes_entries

    schema = json.loads((ROOT / "profiles" / "data" / "axes.schema.json").read_text("utf-8"))
    device = schema["properties"]["device"]
    entries = axes_entries()
    assert device["enum"] == list(entries) and device["default"] == DEFAULT.name
    assert schema["properties"]["axes"]["maxItems"] == entries[DEFAULT.name].most
    pulses = schema["$defs"]["axis"]["properties"]["pulses"]
    assert pulses["maximum"] == entries[DEFAULT.name].pulses_max
    for name, entry in entries.items():  # each other device: its own limits in if/then
        if name == DEFAULT.name:
            continue
        assert schema["if"]["properties"]["device"]["const"] == name
        then = schema["then"]["properties"]["axes"]
        assert then["maxItems"] == entry.most
        assert then["items"]["properties"]["pulses"]["maximum"] == entry.pulses_max


def architecture_paths() -> dict[str, set[str]]:
    """The module paths docs/architecture.md's tables name, by package root: each cell's
    backticked `*.py` names, a name without a folder taking the cell's previous folder."""
    text = (ROOT / "docs" / "architecture.md").read_text(encoding="utf-8")
    out: dict[str, set[str]] = {"profiles": set(), "verify": set()}
    root = None
    for line in text.splitlines():
        if line.startswith("## profiles/"):
            root = "profiles"
        elif line.startswith("## verify/"):
            root = "verify"
        elif line.startswith("## "):
            root = None
        if root is None or not line.startswith("| `"):
            continue
        folder = ""
        for name in re.findall(r"`([\w/]+\.py)`", line.split("|")[1]):
            if "/" in name:
                folder = name.rpartition("/")[0]
            else:
                name = f"{folder}/{name}" if folder else name
            out[root].add(name)
    return out


def test_the_architecture_lists_every_module_and_no_other() -> None:
    listed = architecture_paths()
    for root, names in listed.items():
        files = {str(p.relative_to(ROOT / root)) for p in (ROOT / root).rglob("*.py")}
        assert names - files == set(), f"{root}: listed but gone"
        assert {f for f in files if not f.endswith("__init__.py")} - names == set(), \
            f"{root}: missing from docs/architecture.md"


def test_profiles_gives_the_motor_model_on_first_use() -> None:
    """`profiles.Motor` and `profiles.load_motor` are the motor package's, imported when
    first asked for (a table's check never needs numpy); any other name is an error."""
    import profiles
    import profiles.motor

    assert profiles.Motor is profiles.motor.Motor
    assert profiles.load_motor is profiles.motor.load_motor
    with pytest.raises(AttributeError):
        profiles.no_such_thing  # noqa: B018


def mirror_of(module: Path) -> Path:
    """The unit-test file of a module of profiles/ or verify/ (`_common.py`: test_common.py)."""
    rel = module.relative_to(ROOT)
    return ROOT / "tests" / rel.parent / f"test_{rel.stem.lstrip('_')}.py"


def package_modules() -> list[Path]:
    return [p for p in sources() if p.stem not in ("__init__", "__main__")]


def test_the_tests_mirror_the_packages() -> None:
    modules = package_modules()
    mirrored = [m for m in modules if mirror_of(m).is_file()]
    share = len(mirrored) / len(modules)
    assert share >= MIRRORED_SHARE, (
        f"{len(mirrored)} of {len(modules)} modules have tests/<path>/test_<module>.py; "
        f"without one: {sorted(str(m.relative_to(ROOT)) for m in modules if m not in mirrored)}")
    known = {mirror_of(m) for m in modules}
    for root in ("profiles", "verify"):
        stray = [t for t in (ROOT / "tests" / root).rglob("test_*.py") if t not in known]
        assert stray == [], f"test modules named after no module: {stray}"


def test_the_tests_folder_holds_only_the_layouts_folders() -> None:
    tests = ROOT / "tests"
    assert sorted(p.name for p in tests.glob("*.py")) == ["__init__.py", "conftest.py"]
    folders = {p.name for p in tests.iterdir() if p.is_dir() and p.name != "__pycache__"}
    assert folders == TEST_FOLDERS
    for folder in tests.rglob("*"):
        if folder.is_dir() and folder.name != "__pycache__" and any(folder.glob("*.py")):
            assert (folder / "__init__.py").is_file(), f"{folder} needs an __init__.py"


def test_the_import_scan_sees_what_it_looks_for(tmp_path: Path) -> None:
    src = tmp_path / "t.py"
    src.write_text("import a.b\nfrom tests.support.x import y\nfrom . import z\n"
                   "def f():\n    from test_other import w\n", encoding="utf-8")
    assert imported_modules(src) == ["a.b", "tests.support.x", ".", "test_other"]


def imported_modules(path: Path) -> list[str]:
    """Every module `path` imports, at its top or inside a function (`.` for relative)."""
    out = []
    for node in ast.walk(parsed(path)):
        if isinstance(node, ast.Import):
            out += [alias.name for alias in node.names]
        elif isinstance(node, ast.ImportFrom):
            out.append(node.module if node.level == 0 and node.module else ".")
    return out


def test_no_test_module_imports_another() -> None:
    test_stems = {p.stem for p in (ROOT / "tests").rglob("test_*.py")}
    found = {}
    for path in (ROOT / "tests").rglob("*.py"):
        bad = [m for m in imported_modules(path)
               if m == "." or m.split(".")[0] in test_stems | {"conftest"}
               or (m.startswith("tests.") and not m.startswith("tests.support"))]
        if bad:
            found[str(path.relative_to(ROOT))] = bad
    assert found == {}, "tests share through tests/support (tests.support.*) only"


def test_bench_and_tools_do_not_reach_into_tests_by_path() -> None:
    found = {}
    for path in [*(ROOT / "bench").rglob("*.py"), *(ROOT / "tools").rglob("*.py")]:
        lines = path.read_text(encoding="utf-8").splitlines()
        bad = [f"{i}: {line.strip()}" for i, line in enumerate(lines, 1)
               if ("sys.path" in line or "spec_from_file_location" in line)
               and re.search(r"""["'/]tests\b""", line)]
        if bad:
            found[str(path.relative_to(ROOT))] = bad
    assert found == {}, "import tests.support.* with the repository root on sys.path"


def test_the_checkouts_folders_come_from_one_root() -> None:
    found = [str(p.relative_to(ROOT)) for p in (ROOT / "tests").rglob("*.py")
             if p != ROOT / "tests" / "support" / "paths.py"
             and re.search(r"Path\(__file__\)|\b__file__\)\.parent",
                           p.read_text(encoding="utf-8"))]
    assert found == [], "use tests.support.paths.ROOT"
