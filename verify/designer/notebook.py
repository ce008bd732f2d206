"""The designer as a notebook widget: `designer(motor)` (ipywidgets, extra `notebook`).

Sliders and pickers (`control_specs`), the figure (`DesignFigure`) and the numbers
beside it; buttons that solve the slow references (toppra, ruckig, casadi) and write the
table and its upload files. Everything it shows is computed by verify/designer/model.py,
which the web page (verify/designer/web.py) shows too: this module only lays out
widgets. ipywidgets is imported only when a designer is built.
"""

from __future__ import annotations

import html
import time
from pathlib import Path
from typing import Any

from profiles.compiling import announce
from profiles.errors import StepRampError
from profiles.motor import Motor
from profiles.ppmc312.clock import INTERNAL_HZ

from .figure import DesignFigure
from .model import (
    AUTO_CLOCK,
    JUDGING,
    MOTOR_SPECIFIC,
    OPENING_PULSES,
    SLOW_REFERENCES,
    TIGHTENING,
    ControlSpec,
    Design,
    Settings,
    bundled_motors,
    control_specs,
    design_stem,
    design_steps,
    settings_from,
    write_design,
)


class Designer:
    """The widget: `controls` (sliders and pickers by name), `buttons`, `image` (the figure
    PNG), `summary`, `status`; `result` is the latest `Design`. Display it in a notebook
    (it shows its widget); setting a control from code recomputes as dragging it does."""

    def __init__(self, motor: Motor | None = None, *, pulses: int = OPENING_PULSES,
                 out_dir: str | Path = ".", motors: dict[str, Motor] | None = None,
                 load_angle: bool = True) -> None:
        try:
            import ipywidgets as w
        except ImportError:
            raise StepRampError("the designer needs ipywidgets: pip install "
                                "'stepramp[notebook]'") from None

        self.motors = dict(motors) if motors is not None else bundled_motors()
        if motor is not None:
            same = motor.to_json()
            name = next((k for k, m in self.motors.items() if m.to_json() == same), None)
            if name is None:
                name = motor.name or "motor"
                self.motors = {name: motor, **self.motors}
            self.motors[name] = motor
        else:
            name = next(iter(self.motors))
        # a machine's first design compiles the kernels: say so in the cell's output
        announce(lambda line: print(f"stepramp designer: {line}", flush=True))
        self.out_dir = Path(out_dir)
        self.load_angle = load_angle
        self.result: Design | None = None
        self.slow: dict[str, Any] = {}
        self.written: list[Path] = []
        self.draw_ms = 0.0
        self._held = False
        self._figure: DesignFigure | None = None
        base = self.motors[name]
        self.controls: dict[str, Any] = _widgets(w, list(self.motors), name,
                                                 control_specs(base, pulses))
        self.buttons: dict[str, Any] = {
            "references": w.Button(description="solve toppra, ruckig, casadi",
                                   layout=w.Layout(width="17em")),
            "write": w.Button(description="write table + upload files",
                              layout=w.Layout(width="17em")),
        }
        self.image = w.Image(format="png")
        self.summary = w.HTML()
        self.status = w.HTML()
        self.controls["motor"].observe(self._motor_changed, names="value")
        for key, control in self.controls.items():
            if key != "motor":
                control.observe(lambda _change: self.recompute(), names="value")
        self.buttons["references"].on_click(lambda _b: self.solve_references())
        self.buttons["write"].on_click(lambda _b: self.write())
        self.widget = w.HBox([
            w.VBox([*self.controls.values(), w.HBox(list(self.buttons.values())),
                    self.summary, self.status]),
            self.image])
        self.recompute()

    # --- actions ---------------------------------------------------------------------------
    @property
    def settings(self) -> Settings:
        return settings_from({k: c.value for k, c in self.controls.items() if k != "motor"})

    @property
    def motor(self) -> Motor:
        return self.motors[self.controls["motor"].value]

    def recompute(self) -> None:
        """Replan and redraw for the controls' current values (slow references dropped)."""
        if self._held:
            return
        self.slow = {}
        last = self.result
        try:
            for result in design_steps(self.motor, self.settings, load_angle=self.load_angle):
                self.result = result  # the first table, then the final one, each shown
                self._show()
                if not result.final:
                    self._say(f"{TIGHTENING} the first table (the stall criterion alone) is "
                              "shown; the final table follows")
                elif not result.complete:
                    self._say(f"the final table: {JUDGING}")
        except StepRampError as e:
            if self.result is not last and last is not None:
                self.result = last  # a first table whose final has none: the last design
                self._show()
            self._say(f"no table for these settings: {e}", error=True)
            return
        self._say("slow references: press “solve toppra, ruckig, casadi”")

    def solve_references(self) -> None:
        """toppra, ruckig and casadi on the current move (seconds, not milliseconds)."""
        from verify.references import references

        if self.result is None:
            return
        self._say("solving toppra, ruckig, casadi …")
        refs = references(self.result.motor, self.result.settings.pulses,
                          include=SLOW_REFERENCES)
        self.slow = {k: r for k, r in refs.items() if k != "exact"}
        self._show()
        self._say("references: " + ", ".join(
            f"{k} {r.duration_s * 1e3:.2f} ms" for k, r in self.slow.items()))

    def write(self) -> list[Path]:
        """Write the current table and its upload files into `out_dir`."""
        if self.result is None or not self.result.complete:
            return []  # a table not judged in full is never written
        stem = design_stem(self.controls["motor"].value, self.result)
        try:
            self.written = write_design(self.result, self.out_dir, stem)
        except StepRampError as e:
            self._say(str(e), error=True)
            return []
        self._say("wrote " + ", ".join(str(p) for p in self.written))
        return self.written

    # --- display ---------------------------------------------------------------------------
    def _motor_changed(self, change: dict[str, Any]) -> None:
        specs = control_specs(self.motor, int(self.controls["pulses"].value))
        # One recompute for the whole motor switch, not one per slider it resets.
        self._held = True
        try:
            for key in MOTOR_SPECIFIC:
                control, spec = self.controls[key], specs[key]
                # widen first: ipywidgets clamps the value to the range it has
                control.min, control.max = min(control.min, spec.lo), max(control.max, spec.hi)
                control.value = spec.value
                control.min, control.max, control.step = spec.lo, spec.hi, spec.step
        finally:
            self._held = False
        self.recompute()

    def _show(self) -> None:
        assert self.result is not None
        t0 = time.perf_counter()
        if self._figure is None:
            self._figure = DesignFigure()
        self.image.value = self._figure.update(self.result, self.slow)
        self.draw_ms = (time.perf_counter() - t0) * 1e3
        text = self.result.summary() + f"\nfigure drawn in {self.draw_ms:.0f} ms"
        self.summary.value = "<pre style='line-height:1.3'>" + _escape(text) + "</pre>"

    def _say(self, text: str, *, error: bool = False) -> None:
        color = "#b00" if error else "#444"
        self.status.value = f"<span style='color:{color}'>{_escape(text)}</span>"

    def snapshot(self) -> Any:
        """A static copy (figure and summary) for viewers without a live kernel."""
        import base64

        from IPython.display import HTML

        png = base64.b64encode(self.image.value).decode("ascii")
        return HTML(f"<div class='stepramp-designer-snapshot'>{self.summary.value}"
                    f"<img alt='designer figure' src='data:image/png;base64,{png}'/></div>")

    def _repr_mimebundle_(self, **kwargs: Any) -> Any:
        return self.widget._repr_mimebundle_(**kwargs)


def _widgets(w: Any, motors: list[str], motor: str, specs: dict[str, ControlSpec]
             ) -> dict[str, Any]:
    """The notebook's controls: the motor picker, a slider per spec, clock, plan-to-aim."""
    style = {"description_width": "11em"}
    layout = w.Layout(width="34em")
    controls: dict[str, Any] = {"motor": w.Dropdown(options=motors, value=motor,
                                                    description="motor", style=style,
                                                    layout=layout)}
    for key, spec in specs.items():
        cls = w.IntSlider if spec.integer else w.FloatSlider
        controls[key] = cls(value=spec.value, min=spec.lo, max=spec.hi, step=spec.step,
                            description=spec.label, readout_format=spec.fmt,
                            continuous_update=False, style=style, layout=layout)
    controls["clock"] = w.Dropdown(options=[AUTO_CLOCK, *INTERNAL_HZ], value=AUTO_CLOCK,
                                   description="clock", style=style, layout=layout)
    controls["plan_to_aim"] = w.Checkbox(value=True, description="plan to the aim",
                                         style=style, layout=layout)
    return controls


def designer(motor: Motor | None = None, **kw: Any) -> Designer:
    """The interactive designer for `motor` (default: the first bundled motor)."""
    return Designer(motor, **kw)



def _escape(text: str) -> str:
    return html.escape(text)
