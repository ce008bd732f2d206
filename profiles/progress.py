"""Progress of long work, reported through an optional callback.

Library code that can run for seconds (planning over many candidates, encoding
millions of packets) takes `progress: Progress | None` and calls it with
(done, total) as it goes; it never draws anything. The caller decides what a
report means: the CLI shows a tqdm bar on a terminal (verify/cli/_common.py),
tests record the calls, notebooks pass nothing.
"""

from __future__ import annotations

from collections.abc import Callable, Iterable, Iterator
from typing import TypeVar

Progress = Callable[[int, int], None]  # (units done, units in all)

T = TypeVar("T")


def report(progress: Progress | None, done: int, total: int) -> None:
    """Tell `progress` (if any) that `done` of `total` units are finished."""
    if progress is not None:
        progress(done, total)


def track(items: Iterable[T], progress: Progress | None, total: int | None = None
          ) -> Iterator[T]:
    """Yield `items`, reporting (0, n) first and (k, n) after the k-th item is done (n:
    `total`, or len(items))."""
    total = len(items) if total is None else total  # type: ignore[arg-type]
    report(progress, 0, total)
    for done, item in enumerate(items, start=1):
        yield item
        report(progress, done, total)


def chunks(total: int, size: int, progress: Progress | None) -> Iterator[range]:
    """Split range(total) into ranges of `size`, reporting after each one is done."""
    report(progress, 0, total)
    for start in range(0, total, size):
        yield range(start, min(start + size, total))
        report(progress, min(start + size, total), total)
