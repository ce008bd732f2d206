"""The layout's one rule: data flows one way, profiles (what produces) never imports verify
(what judges) — not at module top, not inside a function, not relatively."""

from __future__ import annotations

import ast
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]


def verify_imports(path: Path, root: Path = ROOT) -> set[str]:
    """The verify modules (first two name parts) that `path` imports, wherever the
    import statement is."""
    package = path.relative_to(root).with_suffix("").parts[:-1]
    found = set()
    for node in ast.walk(ast.parse(path.read_text(encoding="utf-8"), str(path))):
        if isinstance(node, ast.Import):
            names = [alias.name for alias in node.names]
        elif isinstance(node, ast.ImportFrom):
            base = node.module or ""
            if node.level:  # relative: resolve against the file's package
                parent = package[:len(package) - node.level + 1]
                base = ".".join([*parent, base] if base else parent)
            names = [f"{base}.{alias.name}" if base else alias.name for alias in node.names]
        else:
            continue
        found |= {".".join(n.split(".")[:2]) for n in names
                  if n == "verify" or n.startswith("verify.")}
    return found


def test_profiles_never_imports_verify() -> None:
    found = {str(p.relative_to(ROOT)): verify_imports(p)
             for p in sorted((ROOT / "profiles").rglob("*.py"))}
    violations = {path: names for path, names in found.items() if names}
    assert violations == {}


def test_the_scan_sees_every_kind_of_import(tmp_path: Path) -> None:
    # a module in a package tree like the repository's: the scanner must see each form
    pkg = tmp_path / "profiles" / "sub"
    pkg.mkdir(parents=True)
    src = pkg / "mod.py"
    src.write_text("import os\nfrom profiles import motor\n"
                   "def f():\n    import verify.chip_rules.deep\n"
                   "class C:\n    def g(self):\n        from verify import criterion\n"
                   "from ... import verify as v\n", encoding="utf-8")
    assert verify_imports(src, tmp_path) == {"verify.chip_rules", "verify.criterion", "verify"}
    src.write_text("import os\nfrom .. import motor\nfrom profiles.verifying import x\n",
                   encoding="utf-8")
    assert verify_imports(src, tmp_path) == set()
