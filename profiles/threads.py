"""Thread pools kept for the life of a process: starting threads costs more than a small
verdict's or plan's work. One pool per name and size; a forked child (a sweep's worker)
starts its own, since its parent's threads did not come with it."""

from __future__ import annotations

import os
import threading
from concurrent.futures import ThreadPoolExecutor

_POOLS: dict[tuple[int, str, int], ThreadPoolExecutor] = {}
_LOCK = threading.Lock()  # two threads asking at once (a duty cycle's plans) get one pool


def pool(name: str, threads: int) -> ThreadPoolExecutor:
    """This process's pool `name` of `threads` threads (named after it)."""
    key = (os.getpid(), name, threads)
    with _LOCK:
        if key not in _POOLS:
            _POOLS[key] = ThreadPoolExecutor(threads, thread_name_prefix=name)
        return _POOLS[key]
