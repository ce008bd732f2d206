"""The load angle's landmarks, in electrical degrees (profiles.motor.rotor has the model).

Defined once, importable without numpy, so a command's --help can state them.
"""

SLIP_DEG = 180.0   # the rotor slips a pole
PEAK_DEG = 90.0    # the restoring torque peaks: the stable side ends
AIM_DEG = 75.0     # what planners aim at and verdicts warn past: 15° of margin to the peak
