"""The checkout's folders, as the tests see them (one ROOT for every test)."""

from __future__ import annotations

import importlib.util
import sys
from pathlib import Path
from types import ModuleType

ROOT = Path(__file__).resolve().parents[2]
EXAMPLES = ROOT / "examples"
MOTOR_DATA = ROOT / "profiles" / "data"


def load_script(path: Path, name: str) -> ModuleType:
    """The script at `path` (bench/, tools/, notebooks/: not packages) imported as module
    `name`, registered in sys.modules (its dataclasses look their module up there)."""
    spec = importlib.util.spec_from_file_location(name, path)
    assert spec is not None and spec.loader is not None
    module = importlib.util.module_from_spec(spec)
    sys.modules[name] = module
    spec.loader.exec_module(module)
    return module
