"""The last few results the library is asked for again, by key (a small LRU, thread-safe).

What a call computes from values that have no hash of their own (a motor holds arrays)
is remembered under a key made of those values: a verdict by table and motors, a plan by
its arguments. `functools.lru_cache` keys by the arguments themselves, so it serves only
where they are hashable (the chip's move model of a table)."""

from __future__ import annotations

import threading
from collections import OrderedDict
from collections.abc import Callable, Hashable
from typing import Generic, TypeVar

V = TypeVar("V")


class Remembered(Generic[V]):
    """Up to `size` values by key, the least recently used dropped first."""

    def __init__(self, size: int) -> None:
        self.size = size
        self._kept: OrderedDict[Hashable, V] = OrderedDict()
        self._lock = threading.Lock()

    def get(self, key: Hashable, compute: Callable[[], V]) -> tuple[V, bool]:
        """The value kept under `key`, else `compute()` kept there; and whether it was
        kept before. Two threads asking at once may both compute; the last one is kept."""
        with self._lock:
            if key in self._kept:
                self._kept.move_to_end(key)
                return self._kept[key], True
        value = compute()
        with self._lock:
            self._kept[key] = value  # a new key goes last; another thread's stays where it is
            while len(self._kept) > self.size:
                self._kept.popitem(last=False)
        return value, False

    def peek(self, key: Hashable) -> V | None:
        """The value kept under `key` (kept as recently used), else None; nothing computed."""
        with self._lock:
            if key in self._kept:
                self._kept.move_to_end(key)
                return self._kept[key]
        return None

    def clear(self) -> None:
        with self._lock:
            self._kept.clear()
