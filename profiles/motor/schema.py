"""Checking a motor file: the JSON Schema (profiles/data/motor.schema.json), then the rules the
schema cannot state, then the loader, each problem as (JSON pointer, message).

jsonschema is imported here, lazily: only `stepramp motor check` and the tests need it.
"""

from __future__ import annotations

import json
from functools import cache
from pathlib import Path
from typing import Any

from ..errors import FieldRangeError, StepRampError
from .model import OPTIONAL_KEYS, REQUIRED_KEYS, Motor
from .plausible import file_problems

SCHEMA_PATH = Path(__file__).parent.parent / "data" / "motor.schema.json"
Problem = tuple[str, str]   # (JSON pointer, message)


@cache
def schema() -> dict[str, Any]:
    loaded: dict[str, Any] = json.loads(SCHEMA_PATH.read_text(encoding="utf-8"))
    return loaded


def pointer(path: Any) -> str:
    """RFC 6901 JSON pointer of a path of keys and indices ("" is the whole document)."""
    return "".join("/" + str(p).replace("~", "~0").replace("/", "~1") for p in path)


def schema_problems(obj: Any) -> list[Problem]:
    import sys

    # jsonschema imports the optional IRI checker rfc3987_syntax when it is installed,
    # which compiles a Lark grammar at import: 5.7 s of an 8 s `motor check`. The motor
    # schema has no "iri" format; marking the module absent makes jsonschema skip it.
    if "jsonschema" not in sys.modules:
        sys.modules.setdefault("rfc3987_syntax", None)  # type: ignore[arg-type]
    import jsonschema

    validator = jsonschema.Draft202012Validator(schema())
    errors = sorted(validator.iter_errors(obj), key=lambda e: (list(map(str, e.absolute_path)),
                                                                e.message))
    return [(pointer(e.absolute_path), e.message) for e in errors]


def _rule_problems(obj: dict[str, Any]) -> list[Problem]:
    """What the schema cannot say (and the loader does not check yet for the new keys)."""
    out: list[Problem] = []
    for key, (lo, hi) in obj.get("tolerances", {}).items():
        if lo > hi:
            out.append((pointer(["tolerances", key]), f"low {lo} exceeds high {hi}"))
    for i, (lo, hi) in enumerate(obj.get("resonance_bands_pps", [])):
        if not lo < hi:
            out.append((pointer(["resonance_bands_pps", i]), f"lo {lo} is not below hi {hi}"))
    curve = obj["pullout_torque"]
    for i in range(1, len(curve)):
        if not curve[i][0] > curve[i - 1][0]:
            out.append((pointer(["pullout_torque", i, 0]),
                        f"speed {curve[i][0]} does not exceed the previous {curve[i - 1][0]}"))
    return out


def _loader_problem(obj: dict[str, Any]) -> Problem | None:
    try:
        Motor.from_json(obj)
    except FieldRangeError as e:
        return pointer([e.field.split(" ")[0]]), str(e)
    except StepRampError as e:
        head = str(e).split(":", 1)[0]
        where = pointer([head]) if head in REQUIRED_KEYS | OPTIONAL_KEYS else ""
        return where, str(e)
    return None


def problems(obj: Any) -> list[Problem]:
    """Every problem of a motor file's JSON object, schema first; [] when it is valid and
    stepramp loads it."""
    found = schema_problems(obj)
    if found:
        return found
    found = _rule_problems(obj)
    if found:
        return found
    # values no stepper has (a unit slip): motor check refuses them, the loader does not
    found = file_problems(obj)
    loader = _loader_problem(obj)
    return found + ([loader] if loader else [])
