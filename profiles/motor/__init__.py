"""The motor: its model and file format (`model`), and where a motor file comes from and
how it moves: a datasheet's electrical model (`datasheet`), vendor curves and machine
units (`units`), the load it drives (`loads`), the JSON Schema (`schema`), the
load-angle dynamics (`rotor`, compiled in `rotor_kernel`), tolerance boxes (`tolerance`) and
resonance bands (`resonance`)."""

from .model import (
    DEFAULT_DAMPING_RATIO,
    DEFAULT_PHASES,
    DEFAULT_ROTOR_TEETH,
    FORMAT,
    Motor,
    bundled_motor_paths,
    load_motor,
)

__all__ = [
    "DEFAULT_DAMPING_RATIO",
    "DEFAULT_PHASES",
    "DEFAULT_ROTOR_TEETH",
    "FORMAT",
    "Motor",
    "bundled_motor_paths",
    "load_motor",
]
