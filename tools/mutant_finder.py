"""The import hook that puts one mutant in place of its module: in the mutation run's
forked child, and in every Python process a test starts from it (a CLI run in a
subprocess), through tools/mutant_site/sitecustomize.py and the environment."""

from __future__ import annotations

import importlib.abc
import importlib.machinery
import importlib.util
import json
import os
import sys
from pathlib import Path
from typing import Any

ENV = "STEPRAMP_MUTANT"   # {"name", "path", "source_file"} of the mutant, as JSON
SITE = Path(__file__).resolve().parent / "mutant_site"


class MutantFinder(importlib.abc.MetaPathFinder, importlib.abc.Loader):
    """Serves the mutated source for one module name; everything else imports as usual."""

    def __init__(self, name: str, path: Path, source: str) -> None:
        self.name, self.path, self.source = name, path, source

    def find_spec(self, fullname: str, path: object, target: object = None
                  ) -> importlib.machinery.ModuleSpec | None:
        if fullname != self.name:
            return None
        return importlib.util.spec_from_file_location(
            fullname, self.path, loader=self,
            submodule_search_locations=[str(self.path.parent)]
            if self.path.name == "__init__.py" else None)

    def create_module(self, spec: importlib.machinery.ModuleSpec) -> None:
        return None

    def exec_module(self, module: Any) -> None:
        exec(compile(self.source, str(self.path), "exec"), module.__dict__)


def install(name: str, path: Path, source: str, source_file: Path) -> None:
    """The mutant in this process, and in the Python processes it starts: `source_file`
    holds the source for them (the environment names it; sitecustomize reads it)."""
    source_file.write_text(source)
    os.environ[ENV] = json.dumps({"name": name, "path": str(path),
                                  "source_file": str(source_file)})
    os.environ["PYTHONPATH"] = os.pathsep.join(
        p for p in (str(SITE), os.environ.get("PYTHONPATH", "")) if p)
    sys.meta_path.insert(0, MutantFinder(name, path, source))


def install_from_env() -> None:
    """In a process a mutant's test started: the same mutant, when the environment says one."""
    spec = os.environ.get(ENV)
    if not spec:
        return
    m = json.loads(spec)
    sys.meta_path.insert(0, MutantFinder(m["name"], Path(m["path"]),
                                         Path(m["source_file"]).read_text()))
