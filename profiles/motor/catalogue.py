"""Motors by name: the motors bundled with stepramp and the user's own motor folders.

A name is looked up in these folders, in this order; the first match wins:

1. each folder of the environment variable STEPRAMP_MOTORS (several separated by
   `os.pathsep`, like PATH);
2. the user's config folder: `platformdirs.user_config_path("stepramp") / "motors"`
   (on Linux `$XDG_CONFIG_HOME/stepramp/motors`, by default `~/.config/stepramp/motors`);
3. the motors bundled with stepramp (`profiles/data/motor-*.json`, installed with the
   package).

A motor's name is its file name without `.json`, a `.motor` suffix and a `motor-` prefix
(`motor-nema17-1600.json` → `nema17-1600`, `x-axis.motor.json` → `x-axis`). A user's
motor named like a bundled one replaces it, as a command earlier in PATH does: the user
decides what a name means on their machine; `stepramp motor list` still shows the
shadowed entry, marked. Two files of one name in one folder: the first in sorted order.

`resolve` is the one place a command's motor argument becomes a file: an existing file
is always a path (a path still works); an argument that looks like a path (a folder
separator, or ending in `.json`) stays a path even when missing, so the error names the
file; anything else is a name, and an unknown name is a one-line error naming the close
ones, or `./NAME.json` when that file exists (the user meant the file).

A user's folder may hold other JSON (an editor's settings, another tool's files): only
files that declare the motor format in their head are motors (`is_motor_file`); a motor
file that fails to load is still listed, saying why.
"""

from __future__ import annotations

import difflib
import os
from dataclasses import dataclass
from pathlib import Path

from ..errors import FormatError

ENV_VAR = "STEPRAMP_MOTORS"
BUNDLED = "bundled"
USER_CONFIG = "user config"
BUNDLED_DIR = Path(__file__).resolve().parent.parent / "data"


@dataclass(frozen=True)
class Entry:
    """One motor file of the catalogue: its name, file, where it comes from (`ENV_VAR`,
    `USER_CONFIG` or `BUNDLED`) and, when an earlier folder holds the same name, that
    entry's source (it shadows this one)."""

    name: str
    path: Path
    source: str
    shadowed_by: str | None = None


def user_config_dir() -> Path:
    """The user's motor folder under the platform's config folder."""
    import platformdirs

    return platformdirs.user_config_path("stepramp") / "motors"


def motor_dirs() -> list[tuple[str, Path]]:
    """(source, folder) in lookup order; folders that do not exist are included (the
    listing says so), empty entries of the variable are not."""
    out = [(ENV_VAR, Path(p)) for p in os.environ.get(ENV_VAR, "").split(os.pathsep) if p]
    out.append((USER_CONFIG, user_config_dir()))
    out.append((BUNDLED, BUNDLED_DIR))
    return out


def motor_name(path: Path) -> str:
    """The catalogue name of a motor file."""
    name = path.name.removesuffix(".json").removesuffix(".motor")
    return name.removeprefix("motor-") or name


# A motor file says what it is in its first bytes (`motor new` writes "format" first; a
# hand-written file keeps it within the first kilobytes): enough to tell it from other
# tools' JSON sharing the folder without reading those whole.
MOTOR_MARK = b'"stepramp.motor/'
HEAD_BYTES = 64 * 1024


def is_motor_file(path: Path) -> bool:
    """Whether `path` declares itself a motor file (its head names the format
    stepramp.motor/…): a broken motor file still does, another tool's JSON does not."""
    try:
        with open(path, "rb") as fh:
            return MOTOR_MARK in fh.read(HEAD_BYTES)
    except OSError:  # unreadable: listed, so the listing says why
        return True


def _files(folder: Path, source: str) -> list[Path]:
    pattern = "motor-*.json" if source == BUNDLED else "*.json"  # data/ holds schemas too
    try:
        found = sorted(p for p in folder.glob(pattern) if p.is_file())
    except OSError:  # unreadable folder: nothing to list from it
        return []
    # a user's folder may hold other JSON (settings, other tools' files): motors only
    return found if source == BUNDLED else [p for p in found if is_motor_file(p)]


def entries() -> list[Entry]:
    """Every motor file of every folder, in lookup order, shadowed ones marked."""
    out: list[Entry] = []
    first: dict[str, str] = {}
    for source, folder in motor_dirs():
        for path in _files(folder, source):
            name = motor_name(path)
            out.append(Entry(name, path, source, first.get(name)))
            first.setdefault(name, source)
    return out


def find(name: str) -> Entry | None:
    """The entry a name resolves to (the first, unshadowed one), or None."""
    return next((e for e in entries() if e.name == name and e.shadowed_by is None), None)


def looks_like_path(spec: str) -> bool:
    """A folder separator or a `.json` ending: meant as a file, never as a name."""
    seps = [s for s in (os.sep, os.altsep, "/") if s]
    return spec in ("", "-") or any(s in spec for s in seps) or spec.lower().endswith(".json")


def is_name(spec: str, base: Path | None = None) -> bool:
    """`spec` names a catalogue motor rather than a file (in `base`, else the current
    folder): it does not look like a path and no such file exists."""
    return not looks_like_path(spec) and not ((base or Path()) / spec).exists()


def resolve(spec: str | Path) -> str | Path:
    """The motor file `spec` names: a path, as given (see the module docstring; `''` stays
    an empty name, which the reader refuses, not the current folder), or a catalogue
    motor's file."""
    if isinstance(spec, Path) or looks_like_path(spec) or os.path.exists(spec):
        return spec
    entry = find(spec)
    if entry is not None:
        return entry.path
    local = next((f"./{spec}{ext}" for ext in (".json", ".motor.json")
                  if Path(spec + ext).is_file()), None)
    if local is not None:  # the file the user most likely meant: say so first
        raise FormatError(f"motor {spec!r}: no motor of that name; did you mean {local}? "
                          "(a name is looked up in the motor folders, a file needs its "
                          "path: `stepramp motor list` lists the names)")
    names = sorted({e.name for e in entries()})
    close = difflib.get_close_matches(spec.lower(), names, n=4, cutoff=0.5)
    close += [n for n in names if spec.lower() in n.lower() and n not in close]
    hint = (f"close names: {', '.join(close[:4])}" if close
            else f"{len(names)} known: {', '.join(names[:6])}{', …' if len(names) > 6 else ''}")
    raise FormatError(f"motor {spec!r}: no such file and no motor of that name ({hint}; "
                      "`stepramp motor list` lists them)")

