"""Names a package re-exports from its modules, imported on first use.

A front door (`from profiles import plan_free_curve`) must not make every command pay
for the planner's numpy and numba: `stepramp check` without `--motor` imports
`profiles` and never plans. A package lists where each public name lives and
installs the `__getattr__` this returns (PEP 562)."""

from __future__ import annotations

import importlib
from collections.abc import Callable, Mapping
from typing import Any


def lazy_exports(package: str, where: Mapping[str, str]) -> Callable[[str], Any]:
    """The module `__getattr__` of `package`: `where[name]` is the module (relative to
    `package` when it starts with a dot) that defines `name`."""
    def __getattr__(name: str) -> Any:
        module = where.get(name)
        if module is None:
            raise AttributeError(f"module {package!r} has no attribute {name!r}")
        return getattr(importlib.import_module(module, package), name)

    return __getattr__
