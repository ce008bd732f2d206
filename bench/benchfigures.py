"""The README's figures as data: a bench stores what a figure shows in its results
(`values["figures"][<id>]`, a dict with a `kind`), and `bench/readme.py` draws it from
there into docs/img/<id>.png, so the figure shows what the committed results say.

Kinds:
- `comparison`: a table's move against its references, drawn by
  `verify.plot.comparison_figure` exactly as `stepramp compare --plot` draws it, from
  the table itself, the references' sampled curves (the failed ones named, the exact
  optimum from the table's start), the verdict, the move's load angle and the stall
  margins (data stored before these were drawn without them).
"""

from __future__ import annotations

import hashlib
import json
import math
from collections.abc import Callable
from types import SimpleNamespace
from typing import Any

import numpy as np

CURVE_POINTS = 400   # samples kept of each reference's curve


def _thin(values: Any, points: int = CURVE_POINTS) -> list[float | None]:
    arr = np.asarray(values, dtype=float)
    if len(arr) > points:
        arr = arr[np.unique(np.linspace(0, len(arr) - 1, points).round().astype(int))]
    return [float(f"{x:.6g}") if math.isfinite(x) else None for x in arr.tolist()]


def comparison_data(cmp: Any) -> dict[str, Any]:
    """A `verify.compare.Comparison` as the data its figure needs."""
    verdict = cmp.every_verdict
    return {
        "kind": "comparison",
        "motor": cmp.motor.name, "pulses": cmp.pulses, "table": cmp.table.to_json(),
        "steps_per_rev": cmp.motor.steps_per_rev,
        "travel_mm_per_rev": cmp.motor.travel_mm_per_rev,
        "ratio": cmp.ratio, "safe": cmp.safe, "failed": cmp.failed_judges,
        "references": {name: _curve(r) for name, r in cmp.references.items()},
        "margins": {k: (_thin(v, 10**6) if k != "min" else v)
                    for k, v in cmp.margins.items() if v is not None},
        "worst_load_angle_deg": (None if verdict.load_angle is None
                                 else verdict.load_angle.worst_deg),
        "failed_references": dict(cmp.failed_references),
        "from_table_start": (None if cmp.from_table_start is None else _curve(
            cmp.from_table_start)),
        "aim_deg": cmp.move_verdict.aim_deg,
        "load_angle": [{"label": label, "t_s": _thin(tr.lag_t_s),
                        "angle_deg": _thin(tr.angle_deg), "worst_time_s": tr.worst_time_s,
                        "worst_angle_deg": tr.worst_angle_deg, "slipped": tr.slipped,
                        "slip_time_s": tr.slip_time_s}
                       for label, tr in cmp.load_angle_curves()],
    }


def _curve(ref: Any) -> dict[str, Any]:
    return {"duration_s": ref.duration_s, "t_s": _thin(ref.t_s),
            "x_pulses": _thin(ref.x_pulses), "v_pps": _thin(ref.v_pps)}


def _array(values: list[float | None]) -> np.ndarray:
    return np.asarray([math.nan if v is None else v for v in values], dtype=float)


def _reference(r: dict[str, Any]) -> Any:
    return SimpleNamespace(duration_s=r["duration_s"], t_s=_array(r["t_s"]),
                           x_pulses=_array(r["x_pulses"]), v_pps=_array(r["v_pps"]))


def draw_comparison(spec: dict[str, Any]) -> Any:
    from profiles.ppmc312.execution import simulate_move
    from profiles.ppmc312.table import table_from_json
    from verify.plot import comparison_figure

    table = table_from_json(spec["table"])
    refs = {name: _reference(r) for name, r in spec["references"].items()}
    start = spec.get("from_table_start")
    angles = [(a["label"], SimpleNamespace(
        lag_t_s=_array(a["t_s"]), angle_deg=_array(a["angle_deg"]),
        worst_time_s=a["worst_time_s"], worst_angle_deg=a["worst_angle_deg"],
        slipped=a["slipped"], slip_time_s=a["slip_time_s"]))
        for a in spec.get("load_angle", [])]
    margins = {k: (_array(v) if isinstance(v, list) else v)
               for k, v in spec["margins"].items()}
    shown = SimpleNamespace(
        table=table, execution=simulate_move(table, spec["pulses"]), references=refs,
        table_s=float(simulate_move(table, spec["pulses"]).duration_s), ratio=spec["ratio"],
        safe=spec["safe"], failed_judges=spec["failed"], pulses=spec["pulses"],
        motor=SimpleNamespace(name=spec["motor"], steps_per_rev=spec.get("steps_per_rev"),
                              travel_mm_per_rev=spec.get("travel_mm_per_rev")),
        margins=margins,
        stall_margin=math.inf if spec["margins"]["min"] is None else spec["margins"]["min"],
        failed_references=spec.get("failed_references", {}),
        from_table_start=None if start is None else _reference(start),
        move_verdict=SimpleNamespace(aim_deg=spec.get("aim_deg")))
    fig = comparison_figure(shown, angles=angles)
    if spec.get("worst_load_angle_deg") is not None:
        title = fig.get_suptitle()
        fig.suptitle(title + f", worst load angle {spec['worst_load_angle_deg']:.1f}° "
                     "over every move length", color="k" if spec["safe"] else "tab:red")
    return fig


KINDS: dict[str, Callable[[dict[str, Any]], Any]] = {"comparison": draw_comparison}


def fingerprint(spec: dict[str, Any]) -> str:
    """What a drawn figure is stamped with: the hash of the data it was drawn from."""
    text = json.dumps(spec, sort_keys=True, ensure_ascii=True, separators=(",", ":"))
    return hashlib.sha256(text.encode()).hexdigest()


def png_bytes(spec: dict[str, Any]) -> bytes:
    """The figure of `spec` as PNG bytes, stamped with its data's fingerprint."""
    import io

    import matplotlib.pyplot as plt

    from verify.plot import SAVE_DPI, fit_texts

    fig = KINDS[spec["kind"]](spec)
    fig.set_dpi(SAVE_DPI)
    fit_texts(fig)
    buf = io.BytesIO()
    fig.savefig(buf, format="png", dpi=SAVE_DPI,
                metadata={"Source": f"bench data sha256:{fingerprint(spec)}"})
    plt.close(fig)
    return buf.getvalue()


def stamp_of(png: bytes) -> str | None:
    """The fingerprint a PNG drawn by `png_bytes` carries (None: none)."""
    import struct

    pos = 8
    while pos + 8 <= len(png):
        length, kind = struct.unpack(">I4s", png[pos:pos + 8])
        data = png[pos + 8:pos + 8 + length]
        if kind == b"tEXt":
            key, _, value = data.partition(b"\0")
            if key == b"Source" and value.startswith(b"bench data sha256:"):
                return value.split(b":", 1)[1].decode("ascii")
        if kind == b"IEND":
            break
        pos += 12 + length
    return None
