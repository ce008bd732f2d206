"""Saying so when stepramp's kernels are being compiled.

numba compiles a kernel on its first call on a machine and caches it on disk; for a
plan and its verdict that is about half a minute, once (later processes load the cache
in about a second). Half a minute of silence reads as a hang, so a front end hands
`announce` a way to say one line (the command line: stderr; the notebook designer: the
cell's output), and the first compilation of one of our kernels in the process says
it. Loading from the cache says nothing.

Each kernel module calls `watch()` after importing numba; `announce` itself never
imports numba, so a command that runs no kernel never pays for it.
"""

from __future__ import annotations

import os
import threading
from collections.abc import Callable
from typing import Any

NOTICE = ("compiling the kernels for this machine (once: about half a minute; "
          "later runs load them from the cache) …")
OURS = ("profiles.", "verify.")   # the modules whose kernels are announced
QUIET_ENV = "STEPRAMP_COMPILE_NOTICE"  # "0": nothing is said

_lock = threading.Lock()
_say: Callable[[str], None] | None = None
_said = False
_watching = False


def announce(say: Callable[[str], None] | None) -> None:
    """Have `say` told NOTICE on the first compilation of one of our kernels in this
    process (None, or STEPRAMP_COMPILE_NOTICE=0 in the environment: say nothing)."""
    global _say
    if os.environ.get(QUIET_ENV, "1") == "0":
        say = None
    with _lock:
        _say = say


def watch() -> None:
    """Listen to numba's compilations (once per process; a kernel module calls it)."""
    global _watching
    with _lock:
        if _watching:
            return
        from numba.core import event

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


def _first() -> None:
    global _said
    with _lock:
        if _said or _say is None:
            return
        _said, say = True, _say
    say(NOTICE)
