"""`Remembered`: the last `size` values by key, least recently used dropped first."""

from __future__ import annotations

import threading

from profiles.remembered import Remembered


def test_keeps_the_most_recently_used_and_computes_the_rest() -> None:
    calls: list[str] = []

    def compute(key: str) -> str:
        calls.append(key)
        return key.upper()

    kept: Remembered[str] = Remembered(2)
    assert kept.get("a", lambda: compute("a")) == ("A", False)
    assert kept.get("b", lambda: compute("b")) == ("B", False)
    assert kept.get("a", lambda: compute("a")) == ("A", True)   # a is now the most recent
    assert kept.get("c", lambda: compute("c")) == ("C", False)  # b, the least recent, goes
    assert kept.get("a", lambda: compute("a")) == ("A", True)
    assert kept.get("b", lambda: compute("b")) == ("B", False)
    assert calls == ["a", "b", "c", "b"]
    kept.clear()
    assert kept.get("a", lambda: compute("a")) == ("A", False)


def test_a_failed_computation_is_not_kept() -> None:
    kept: Remembered[int] = Remembered(4)

    def fail() -> int:
        raise ValueError("no")

    for _ in range(2):
        try:
            kept.get("k", fail)
        except ValueError:
            pass
    assert kept.get("k", lambda: 7) == (7, False)


def test_threads_share_one_store() -> None:
    kept: Remembered[int] = Remembered(64)
    out: list[tuple[int, bool]] = []

    def ask(i: int) -> None:
        out.append(kept.get(i % 8, lambda: i % 8))

    threads = [threading.Thread(target=ask, args=(i,)) for i in range(64)]
    for t in threads:
        t.start()
    for t in threads:
        t.join()
    assert len(out) == 64
    assert sorted({v for v, _ in out}) == list(range(8))
    assert all(kept.get(k, lambda: -1) == (k, True) for k in range(8))
