"""Interactive free-curve design: `designer(motor)` in a notebook, `stepramp design` in a
browser, one computation behind both.

- `model`: what a change computes (`Settings`, `design_steps`, `Design`, `verdict`,
  `design_files`) and the sliders' ranges (`control_specs`);
- `figure`: the one figure both views show (`DesignFigure`), drawn in milliseconds;
- `notebook`: the ipywidgets view (`designer`, `Designer`);
- `web`: the Panel page `stepramp design` serves (imported on its own: Panel is heavy).
"""

from .figure import DesignFigure, render_figure
from .model import (
    AUTO_CLOCK,
    JUDGING,
    OPENING_PULSES,
    PLANNED_COMMANDS,
    SLOW_REFERENCES,
    TIGHTENING,
    UPLOAD_FORMATS,
    ControlSpec,
    Design,
    DesignVerdict,
    Settings,
    bundled_motors,
    control_specs,
    design,
    design_files,
    design_stem,
    design_steps,
    first_design,
    judged_in_full,
    loaded_motor,
    settings_from,
    verdict,
    write_design,
)
from .notebook import Designer, designer

__all__ = [
    "AUTO_CLOCK", "JUDGING", "OPENING_PULSES", "PLANNED_COMMANDS", "SLOW_REFERENCES",
    "TIGHTENING", "UPLOAD_FORMATS", "ControlSpec", "Design", "DesignFigure", "DesignVerdict",
    "Designer", "Settings", "bundled_motors", "control_specs", "design", "design_files",
    "design_stem", "design_steps", "designer", "first_design", "judged_in_full",
    "loaded_motor", "render_figure", "settings_from", "verdict", "write_design"]
