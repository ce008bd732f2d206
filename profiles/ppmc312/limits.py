"""The PPMC-312 free-curve rules (SPEC §1.4, manual §7-2), in one place.

The planners obey them, the checks and the chip emulator enforce them.
"""

STAGES_MIN, STAGES_MAX = 2, 127   # stage count per side [error 0x11]
RATE_MIN = 2                      # a rate ≤ 1 is refused [0x18]
RATE_MAX = 0xFFFF                 # a 2-byte rate entry
STAGE_PULSES_MIN = 2              # a count ≤ 1 is refused [0x19]
STAGE_PULSES_MAX = 0xFFFFF        # per stage
SIDE_TOTAL_MAX = 0xFFFFF          # accel (decel) total [0x1A]
MIN_STAGE_TICKS = 256             # pulses × rate ≥ 256 clock ticks (no error code)
