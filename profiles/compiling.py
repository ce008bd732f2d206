"""Saying so when stepramp's kernels are being compiled.

numba compiles a kernel on its first call on a machine and caches it on disk; for a
plan and its verdict that is about half a minute, once (later processes load the cache
in about a second). Half a minute of silence reads as a hang, so a front end hands
`announce` a way to say one line (the command line: stderr; the notebook designer: the
cell's output), and the first compilation of one of our kernels in the process says
it. Loading from the cache says nothing.

Each kernel module calls `watch()` after importing numba; `announce` itself never
imports numba, so a command that runs no kernel never pays for it.

The cache needs a writable folder: numba takes NUMBA_CACHE_DIR, else the package's own
`__pycache__`, else the user's cache folder (~/.cache/numba), and with none of them
(a read-only install and an unwritable HOME) every kernel module failed at import
("no locator available"; under threads an ImportError). So `watch()`, before the first
kernel is declared, checks that numba will find one; if not, it points numba at a
private folder under the temporary folder, or, with none writable, turns the cache off
(every run compiles), and says so once.

The command line's own process (`lean()`, from `stepramp`'s entry) loads numba leaner:
whenever numba first runs or loads a kernel it imports its registries, and two of them
import what no kernel of ours uses: numba.np.arraymath checks for BLAS (for `np.dot`) by
importing scipy.linalg, and numba.core.typing.cffi_utils imports cffi and pycparser, a
tenth of a second or more of every `plan` and `check --motor` together
(bench/bench_plantime.py measures the command's start). `watch()` imports those two
numba modules first with scipy.linalg and cffi unavailable, then makes them available
again for whatever else wants them; only in a process with one thread (no other thread
can be importing them meanwhile) and when neither is imported yet. It also marks numba's
third-party extensions as loaded: numba looks for them (entry points `numba_extensions`)
by reading every installed package's metadata, a few hundredths of a second, and our
kernels use none. And it loads a cached kernel without numba's registries: numba's
cache refreshes the whole typing and lowering registry before it loads a kernel (every
numpy function numba can compile imported and installed, about a tenth of a second of
`check --motor`), which only a compilation reads, and numba's compiler refreshes them
itself; a loaded kernel needs only numba's runtime (NRT: its arrays), which is
initialised instead. Before numba is imported, `coverage` is kept from being imported
by numba's coverage support (a few hundredths of a second where coverage is installed;
a process measured by coverage imported it already and is left alone). A library
caller's process (a notebook that may compile its own kernels with `np.dot` or an
extension's types) is left alone.
"""

from __future__ import annotations

import os
import stat
import sys
import tempfile
import threading
from collections.abc import Callable
from pathlib import Path
from typing import Any

NOTICE = ("compiling the kernels for this machine (once: about half a minute; "
          "later runs load them from the cache) …")
OURS = ("profiles.", "verify.")   # the modules whose kernels are announced
QUIET_ENV = "STEPRAMP_COMPILE_NOTICE"  # "0": nothing is said

CACHE_FALLBACK = "stepramp-numba-cache"  # the folder under the temporary folder
KERNELS = Path(__file__).resolve().parent   # every *_kernel.py lies under it

_lock = threading.Lock()
_say: Callable[[str], None] | None = None
_channel: Callable[[str], None] | None = None  # also when the compile notice is quiet
_said = False
_watching = False
_lean = False
LEAN_WITHOUT = ("scipy.linalg", "cffi")  # what numba's registries import that we never use
LEAN_FIRST = ("numba.np.arraymath", "numba.core.typing.cffi_utils")  # the modules that do


def announce(say: Callable[[str], None] | None) -> None:
    """Have `say` told NOTICE on the first compilation of one of our kernels in this
    process (None, or STEPRAMP_COMPILE_NOTICE=0 in the environment: say nothing), and
    where the kernels are cached when numba's own folders are not writable."""
    global _say, _channel
    with _lock:
        _channel = say
        _say = None if os.environ.get(QUIET_ENV, "1") == "0" else say


LEAN_BEFORE_NUMBA = ("coverage",)  # what numba's import pulls in that we never use


def lean() -> None:
    """This process is the `stepramp` command: numba may be imported without coverage and
    its registries loaded without scipy.linalg and cffi, and cached kernels loaded
    without the registries (the module docstring)."""
    global _lean
    _lean = True
    if "numba" not in sys.modules:
        for name in LEAN_BEFORE_NUMBA:
            sys.modules.setdefault(name, None)  # type: ignore[arg-type]  # until watch()


def lean_registries() -> bool:
    """Import numba's registry modules that would import scipy.linalg and cffi with those
    unavailable, and skip numba's search for extensions, when this is safe (one thread,
    neither imported yet, numba's modules not yet either); whether it did."""
    if (threading.active_count() > 1 or any(m in sys.modules for m in LEAN_WITHOUT)
            or any(m in sys.modules for m in LEAN_FIRST)):
        return False
    for name in LEAN_WITHOUT:
        sys.modules[name] = None  # type: ignore[assignment]  # import of it: ImportError
    try:
        for name in LEAN_FIRST:
            __import__(name)
    finally:
        for name in LEAN_WITHOUT:
            if sys.modules.get(name, 0) is None:
                del sys.modules[name]
    from numba.core import entrypoints

    entrypoints._already_initialized = True  # no extension's entry point looked for
    load_without_registries()
    return True


def load_without_registries() -> None:
    """numba's cache loads a kernel with its runtime initialised instead of every registry
    refreshed (a compilation refreshes them itself: numba.core.compiler)."""
    from numba.core import caching
    from numba.core.runtime import rtsys

    def load_overload(self: Any, sig: Any, target_context: Any) -> Any:
        rtsys.initialize(target_context)  # the arrays' allocator, as the refresh would
        with self._guard_against_spurious_io_errors():
            return self._load_overload(sig, target_context)

    caching.Cache.load_overload = load_overload  # type: ignore[method-assign]


def watch() -> None:
    """Listen to numba's compilations and make sure its cache has a folder (once per
    process; a kernel module calls it before declaring its kernels); in the command's
    own process, load numba's registries lean (`lean`)."""
    global _watching
    with _lock:
        if _watching:
            return
        from numba.core import event

        if _lean:
            for name in LEAN_BEFORE_NUMBA:
                if sys.modules.get(name, 0) is None:
                    del sys.modules[name]  # importable again, numba imported without it
            lean_registries()
        note = choose_cache()

        class Compiling(event.Listener):  # type: ignore[misc]
            def on_start(self, ev: Any) -> None:
                dispatcher = ev.data.get("dispatcher") if ev.data else None
                module = getattr(getattr(dispatcher, "py_func", None), "__module__", "")
                if module.startswith(OURS):
                    _first()

            def on_end(self, ev: Any) -> None:
                pass

        event.register("numba:compile", Compiling())
        _watching = True
        channel = _channel
    if note is not None and channel is not None:
        channel(note)


def _first() -> None:
    global _said
    with _lock:
        if _said or _say is None:
            return
        _said, say = True, _say
    say(NOTICE)


def writable(folder: str | Path) -> bool:
    """Whether a file can be made in `folder` (made if missing): numba's own test."""
    try:
        os.makedirs(folder, exist_ok=True)
        tempfile.TemporaryFile(dir=folder).close()
    except OSError:
        return False
    return True


def numba_finds_a_cache() -> bool:
    """Whether numba's locators find a writable folder for every kernel module: its
    NUMBA_CACHE_DIR, else each kernel folder's __pycache__, else the user cache."""
    from numba.core import config
    from numba.misc.appdirs import AppDirs

    folder = getattr(config, "CACHE_DIR", "")  # NUMBA_CACHE_DIR, read as numba loads
    if folder and writable(folder):
        return True
    folders = {p.parent / "__pycache__" for p in KERNELS.rglob("*_kernel.py")}
    return all(writable(f) for f in folders) or writable(
        AppDirs(appname="numba", appauthor=False).user_cache_dir)


def fallback_folder() -> str | None:
    """A cache folder only this user can write: <tmp>/stepramp-numba-cache-<uid>, kept
    across runs when it is this user's own and closed to others (numba's cache holds
    code: a folder another user could write into would run their code), else a fresh
    private folder for this process; None when the temporary folder is not writable."""
    uid = os.getuid() if hasattr(os, "getuid") else None
    shared = Path(tempfile.gettempdir()) / f"{CACHE_FALLBACK}-{uid if uid is not None else 'user'}"
    try:
        shared.mkdir(mode=0o700, exist_ok=True)
        st = shared.lstat()
        if (stat.S_ISDIR(st.st_mode) and not st.st_mode & 0o022
                and (uid is None or st.st_uid == uid) and writable(shared)):
            return str(shared)
    except OSError:
        pass
    try:
        return tempfile.mkdtemp(prefix=CACHE_FALLBACK + "-")
    except OSError:
        return None


def choose_cache() -> str | None:
    """Point numba's cache at a writable folder when its own are not (see the module
    docstring); the line that says so, or None when nothing changed."""
    if numba_finds_a_cache():
        return None
    from numba.core import config

    folder = fallback_folder()
    if folder is not None:
        # numba's first locator reads it as each kernel is declared
        config.CACHE_DIR = folder  # type: ignore[attr-defined]
        return (f"numba's cache folders are not writable (the installed package, "
                f"~/.cache): the kernels are cached in {folder}")
    from numba.core.dispatcher import Dispatcher

    # No writable folder at all: declaring a kernel with cache=True would fail, so the
    # cache is not enabled (the dispatcher keeps its NullCache) and every run compiles.
    Dispatcher.enable_caching = no_cache  # type: ignore[method-assign]
    return ("no writable folder for numba's cache: the kernels are compiled in every run "
            "(about half a minute)")


def no_cache(self: Any) -> None:
    pass
