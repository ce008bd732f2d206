"""tools/mutation.py's configuration (tools/mutation.toml) and verdict logs."""

from __future__ import annotations

import hashlib
import json
import tomllib
from dataclasses import dataclass
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
CONFIG = ROOT / "tools" / "mutation.toml"
LOGS = ROOT / "bench" / "results" / "mutation"


@dataclass(frozen=True)
class Module:
    name: str
    tests: list[str]
    env: dict[str, str]

    @property
    def path(self) -> Path:
        return module_path(self.name)


def module_path(name: str) -> Path:
    base = ROOT / name.replace(".", "/")
    return base / "__init__.py" if base.is_dir() else base.with_suffix(".py")


def load_config(path: Path = CONFIG) -> dict[str, object]:
    return tomllib.loads(path.read_text())


def modules(config: dict[str, object]) -> list[Module]:
    table = config["modules"]
    assert isinstance(table, dict)
    return [Module(name, list(spec["tests"]), dict(spec.get("env", {})))
            for name, spec in table.items()]


def equivalents(config: dict[str, object]) -> dict[tuple[str, str], str]:
    """(module, mutant id) → why it cannot change behaviour."""
    rows = config.get("equivalent", [])
    assert isinstance(rows, list)
    return {(r["module"], r["id"]): r["why"] for r in rows}


def source_hash(source: str) -> str:
    return hashlib.sha256(source.encode()).hexdigest()[:16]


def log_path(name: str) -> Path:
    return LOGS / f"{name}.jsonl"


def read_log(name: str) -> list[dict[str, object]]:
    path = log_path(name)
    if not path.exists():
        return []
    return [json.loads(line) for line in path.read_text().splitlines() if line.strip()]




def excluded(config: dict[str, object]) -> dict[str, str]:
    """Modules left out of the run → why."""
    table = config.get("excluded", {})
    assert isinstance(table, dict)
    return {str(k): str(v) for k, v in table.items()}
