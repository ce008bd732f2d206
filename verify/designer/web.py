"""The designer as a web page: what `stepramp design` serves (Panel, extra `design`).

A page of controls and a figure, no code: sliders for the move, the load (inertia,
load torque, friction) and the aim (safety factor, load-angle aim), the clock and
the stage budget; the staircase against the exact optimum, the stall margins and
the load angle in one figure (`DesignFigure`), the verdict (`verdict`) and the
numbers beside it; buttons that download the table (`stepramp.table/1`) and an
upload file in any format. Everything it shows comes from verify/designer/model.py,
which the notebook widget uses too: this module only lays out widgets.

A change shows its steps (`design_steps`) one per turn of the server (a next-tick
callback of the tab's document, so the browser receives each before the next is
computed): the first table (the plain criterion's, marked as being tightened: verdict
level "tightening"), the final table judged for moves and decel stops (its verdict
saying the other commands are being judged), then its verdict over every command.
The downloads are enabled at the last step only; a newer change drops pending steps.

One server process serves every tab; `serve` warms the load-angle kernel (numba)
once before it says where it listens, so the first slider change is as fast as
the others. Panel is imported only when a page is built or served.
"""

from __future__ import annotations

import dataclasses
import html
import io
import signal
import threading
import time
import webbrowser
from collections.abc import Callable, Iterator
from typing import Any

from profiles.errors import StepRampError
from profiles.motor import Motor
from profiles.ppmc312.clock import INTERNAL_HZ

from .figure import DesignFigure
from .model import (
    AUTO_CLOCK,
    OPENING_PULSES,
    UPLOAD_FORMATS,
    ControlSpec,
    Design,
    Settings,
    control_specs,
    design,
    design_files,
    design_stem,
    design_steps,
    settings_from,
    verdict,
)

INSTALL_HINT = "pip install 'stepramp[design]'"
COLORS = {"safe": "#1b7f3b", "past-aim": "#b36b00", "unsafe": "#b00020", "none": "#b00020",
          "tightening": "#5f6368"}
GROUPS = (("move", "The move"), ("load", "The load"), ("aim", "The aim"), ("table", "The table"))


def require_panel() -> Any:
    """The `panel` module, or a one-line error naming the extra that installs it."""
    try:
        import panel
    except ImportError:
        raise StepRampError(f"the web designer needs Panel: {INSTALL_HINT}") from None
    return panel


class DesignPage:
    """One browser tab: `controls` by `Settings` field, `downloads` ("table", "upload"),
    the `verdict`, `summary` and `figure` panes; `result` is the latest `Design`. Setting a
    control's value from Python recomputes as moving it in the browser does."""

    def __init__(self, motor: Motor, *, pulses: int = OPENING_PULSES, motor_name: str = "",
                 cruise_reserve: str = "2x,10%") -> None:
        """`motor_name`: the short name the downloaded files carry (default: the motor's);
        `cruise_reserve`: the torque reserve every plan keeps at its top speed."""
        pn = require_panel()
        self.motor = motor
        self.cruise_reserve = cruise_reserve
        self.motor_name = motor_name or motor.name or "motor"
        self.result: Design | None = None
        self.first_ms = 0.0       # from the change to the first table shown
        self.recompute_ms = 0.0   # from the change to the final table shown
        self.complete_ms = 0.0    # from the change to its verdict over every command
        self._figure = DesignFigure(dpi=80)
        self._lock = threading.Lock()
        self._changes = 0         # a pending final of an older change is dropped
        self._doc = pn.state.curdoc  # the tab's document when served (None in Python)
        specs = control_specs(motor, pulses)
        self._groups = {key: spec.group for key, spec in specs.items()}
        self._groups.update(clock="table", plan_to_aim="aim")
        self.controls: dict[str, Any] = {key: _slider(pn, key, spec) for key, spec in specs.items()}
        select, checkbox = pn.widgets.Select, pn.widgets.Checkbox
        self.controls["clock"] = select(
            **_label(select, "clock"), options=[AUTO_CLOCK, *INTERNAL_HZ], value=AUTO_CLOCK,
            css_classes=["sr-clock"])
        self.controls["plan_to_aim"] = checkbox(
            **_label(checkbox, "plan to the aim (as stepramp plan does)"),
            value=True, css_classes=["sr-plan_to_aim"])
        self.verdict = pn.pane.HTML("", css_classes=["sr-verdict"], sizing_mode="stretch_width")
        self.summary = pn.pane.HTML("", css_classes=["sr-summary"], sizing_mode="stretch_width")
        self.figure = pn.pane.PNG(None, css_classes=["sr-figure"])
        self.upload_format = select(**_label(select, "upload format"),
                                    options=list(UPLOAD_FORMATS), value="hex",
                                    css_classes=["sr-upload-format"])
        self.downloads = {
            "table": pn.widgets.FileDownload(callback=lambda: self._file(0), filename="x",
                                             label="download table (JSON)",
                                             css_classes=["sr-table"]),
            "upload": pn.widgets.FileDownload(callback=lambda: self._file(1), filename="x",
                                              label="download upload file",
                                              css_classes=["sr-upload"]),
        }
        for control in self.controls.values():
            control.param.watch(lambda _event: self.recompute(), "value")
        self.upload_format.param.watch(lambda _event: self._name_files(), "value")
        self.recompute(deferred=False)  # the page opens on a final table

    @property
    def settings(self) -> Settings:
        return dataclasses.replace(settings_from({key: c.value for key, c in
                                                  self.controls.items()}),
                                   cruise_reserve=self.cruise_reserve)

    def recompute(self, *, deferred: bool = True) -> None:
        """Replan, judge and redraw for the controls' current values: the first table at
        once, the final one on the server's next turn when served (`deferred`), else
        at once too."""
        self._changes += 1
        steps = design_steps(self.motor, self.settings)
        self._step(steps, self._changes, time.perf_counter(), deferred)

    def _step(self, steps: Iterator[Design], change: int, t0: float, deferred: bool) -> None:
        if change != self._changes:
            return  # a newer change came first
        with self._lock:
            try:
                result = next(steps, None)
            except StepRampError as e:
                self._refuse(e)
                return
            if result is None:
                return
            self._show(result, (time.perf_counter() - t0) * 1e3)
        if result.complete:
            return
        if deferred and self._doc is not None and self._doc.session_context is not None:
            self._doc.add_next_tick_callback(lambda: self._step(steps, change, t0, deferred))
        else:
            self._step(steps, change, t0, deferred)

    def _show(self, result: Design, shown_ms: float) -> None:
        self.result = result
        if not result.complete:  # off before a verdict that is not the whole one shows
            for button in self.downloads.values():
                button.disabled = True
        self.figure.object = self._figure.update(result)
        said = verdict(result)
        self._show_verdict(said.level, said.text)
        if result.complete:
            self.complete_ms = shown_ms
            timing = (f"judged in full in {shown_ms:.0f} ms (first table shown in "
                      f"{self.first_ms:.0f} ms, final in {self.recompute_ms:.0f} ms)")
        elif result.final:
            self.recompute_ms = shown_ms
            timing = (f"final table shown in {shown_ms:.0f} ms (first in {self.first_ms:.0f} "
                      "ms)")
        else:
            self.first_ms = shown_ms
            timing = f"first table shown in {shown_ms:.0f} ms"
        text = result.summary() + f"\n{timing}"
        self.summary.object = f"<pre class='sr-numbers'>{html.escape(text)}</pre>"
        if result.complete:  # on once the whole verdict shows
            self._name_files()
            for button in self.downloads.values():
                button.disabled = False

    def _refuse(self, error: StepRampError) -> None:
        self._show_verdict("none", f"NO TABLE for these settings: {error}")
        self.summary.object = ("<pre class='sr-numbers'>no table: the figure shows the "
                               "last design that had one</pre>")
        for button in self.downloads.values():
            button.disabled = True

    def files(self) -> list[tuple[str, bytes]]:
        """The table and the upload file (in the chosen format) of the current design."""
        assert self.result is not None and self.result.complete
        return design_files(self.result, design_stem(self.motor_name, self.result),
                            (self.upload_format.value,))

    def view(self) -> Any:
        """The page: the controls by group on the left; the verdict, the downloads, the
        figure and the numbers on the right."""
        pn = require_panel()
        left: list[Any] = [pn.pane.Markdown(f"## stepramp design\n{self.motor.name}")]
        for group, title in GROUPS:
            left.append(pn.pane.Markdown(f"**{title}**"))
            left += [c for key, c in self.controls.items() if self._groups[key] == group]
        right = [self.verdict, pn.Row(self.downloads["table"], self.upload_format,
                                      self.downloads["upload"]), self.figure, self.summary]
        return pn.Row(pn.Column(*left, width=470), pn.Column(*right, width=760))

    def _file(self, index: int) -> io.BytesIO:
        return io.BytesIO(self.files()[index][1])

    def _name_files(self) -> None:
        if self.result is not None and self.result.complete:
            for (name, _), button in zip(self.files(), self.downloads.values(), strict=True):
                button.filename = name

    def _show_verdict(self, level: str, text: str) -> None:
        self.verdict.object = (
            f"<div id='sr-verdict' data-level='{level}' style='padding:.5em .8em;"
            f"border-radius:4px;color:white;background:{COLORS[level]};font-weight:600'>"
            f"{html.escape(text)}</div>")


def _slider(pn: Any, key: str, spec: ControlSpec) -> Any:
    cls = pn.widgets.IntSlider if spec.integer else pn.widgets.FloatSlider
    from bokeh.models import PrintfTickFormatter

    return cls(**_label(cls, spec.label), start=spec.lo, end=spec.hi, step=spec.step,
               value=spec.value, format=PrintfTickFormatter(format=f"%{spec.fmt}"),
               css_classes=[f"sr-{key}"], width=440)


def _label(cls: Any, text: str) -> dict[str, str]:
    """A widget's caption: `label` where Panel has it (1.9+ deprecates `name` for it)."""
    return {"label" if "label" in cls.param else "name": text}


def warm(motor: Motor, pulses: int = OPENING_PULSES) -> float:
    """One design and one drawing, so the load-angle kernel is compiled (or loaded from
    its cache) and matplotlib imported before the first page asks; milliseconds taken."""
    t0 = time.perf_counter()
    DesignFigure().update(design(motor, Settings(pulses=pulses,
                                                 safety_factor=motor.safety_factor)))
    return (time.perf_counter() - t0) * 1e3


def free_port(host: str) -> int:
    """A port nobody listens on now (the OS's choice)."""
    import socket

    with socket.socket() as sock:
        sock.bind((host, 0))
        return int(sock.getsockname()[1])


def serve(motor: Motor, *, port: int, open_browser: bool, pulses: int = OPENING_PULSES,
          motor_name: str = "", say: Callable[[str], None] = print,
          cruise_reserve: str = "2x,10%") -> None:
    """Serve the designer for `motor` on 127.0.0.1:`port` (0: a free port) until Ctrl-C or
    SIGTERM; `say` is told the address once the server listens."""
    pn = require_panel()
    pn.config.throttled = True  # a slider recomputes when released, not while dragged
    control_specs(motor, pulses)  # a bad --pulses is refused before anything starts
    host = "127.0.0.1"
    port = port or free_port(host)
    try:  # the port is taken now, so a clash is said before the seconds of warming
        server = pn.serve({"/": lambda: DesignPage(motor, pulses=pulses, motor_name=motor_name,
                                                   cruise_reserve=cruise_reserve).view()},
                          port=port, address=host, show=False, start=False,
                          title=f"stepramp design: {motor.name or motor_name}", verbose=False,
                          websocket_origin=[f"{host}:{port}", f"localhost:{port}"])
    except OSError as e:
        raise StepRampError(f"--port {port}: {e.strerror or e}") from None
    warm_ms = warm(motor, pulses)
    url = f"http://{host}:{port}/"
    loop = server.io_loop

    def stop(_signum: int, _frame: Any) -> None:
        loop.add_callback_from_signal(loop.stop)

    # the handlers first: a signal right after the address is said must stop the loop too
    previous = {s: signal.signal(s, stop) for s in (signal.SIGINT, signal.SIGTERM)}
    try:
        say(f"serving the designer for {motor.name or motor_name} at {url} "
            f"(kernel warmed in {warm_ms:.0f} ms; Ctrl-C stops)")
        server.start()
        if open_browser:
            webbrowser.open(url)
        loop.start()
    finally:
        for s, handler in previous.items():
            signal.signal(s, handler)
        server.stop()
