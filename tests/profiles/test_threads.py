"""The thread pools a process keeps (profiles.threads): one per name and size, the same
pool however many threads ask at once, and a fresh one in a forked child."""

from __future__ import annotations

import threading

import pytest

from profiles import threads


def test_one_pool_per_name_and_size() -> None:
    a = threads.pool("test-a", 2)
    assert threads.pool("test-a", 2) is a
    assert threads.pool("test-b", 2) is not a and threads.pool("test-a", 3) is not a
    assert a.submit(threading.current_thread).result().name.startswith("test-a")


def test_threads_asking_at_once_get_one_pool() -> None:
    got: list[object] = []
    start = threading.Barrier(8)

    def ask() -> None:
        start.wait()
        got.append(threads.pool("test-race", 2))

    workers = [threading.Thread(target=ask) for _ in range(8)]
    for w in workers:
        w.start()
    for w in workers:
        w.join()
    assert len(got) == 8 and all(p is got[0] for p in got)


def test_a_forked_child_starts_its_own(monkeypatch: pytest.MonkeyPatch) -> None:
    parent = threads.pool("test-fork", 2)
    monkeypatch.setattr(threads.os, "getpid", lambda: -1)  # as a child sees itself
    child = threads.pool("test-fork", 2)
    assert child is not parent and threads.pool("test-fork", 2) is child
