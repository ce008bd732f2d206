"""What every figure test asks of a matplotlib figure, the figures a run saves, a figure's
second scales, and closing a figure."""

from __future__ import annotations

from typing import Any

import pytest
from matplotlib.figure import Figure

from verify.plot import texts_outside


def problems(fig: Any) -> list[str]:
    """Texts past the canvas and lines without a legend entry."""
    out = [f"outside the canvas: {t.get_text()!r}" for t in texts_outside(fig)]
    legends = [ax.get_legend() for ax in fig.axes] + list(fig.legends)
    entries = {t.get_text() for lg in legends if lg is not None for t in lg.get_texts()}
    for ax in fig.axes:
        out += [f"line without a legend entry: {line.get_label()!r}"
                for line in ax.get_lines() if line.get_label() not in entries]
    return out


def record_saved(monkeypatch: pytest.MonkeyPatch) -> list[Figure]:
    """The figures `Figure.savefig` saves from now on (until the test ends), in the
    order saved; each is still saved as asked."""
    figures: list[Figure] = []
    original = Figure.savefig

    def record(self: Figure, *args: Any, **kwargs: Any) -> None:
        figures.append(self)
        original(self, *args, **kwargs)

    monkeypatch.setattr(Figure, "savefig", record)
    return figures


def scale_labels(ax: Any) -> list[str]:
    """The labels of the second scales (real units) on `ax`."""
    return [c.get_ylabel() or c.get_xlabel() for c in ax.child_axes]


def close(fig: Any) -> None:
    """Close `fig` (pyplot keeps every figure it made open)."""
    import matplotlib.pyplot as plt

    plt.close(fig)
