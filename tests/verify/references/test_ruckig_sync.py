"""verify.references.ruckig_sync: synchronised ruckig durations."""

from __future__ import annotations

import numpy as np

from profiles.motor import bundled_motor_paths, load_motor
from verify.sync import ruckig_sync

MOTORS = [load_motor(p) for p in bundled_motor_paths()]


NEMA17, NEMA23, PK566 = MOTORS


# --------------------------------------------------------------------------- ruckig
def test_ruckig_synchronised_durations_bracket_and_order() -> None:
    from verify.references import ruckig_reference

    rk = ruckig_sync([NEMA17, PK566], [12_000, -5_000])
    alone = [ruckig_reference(m, n).duration_s for m, n in ((NEMA17, 12_000), (PK566, 5_000))]
    # synchronising never makes the slowest axis faster than it is alone
    assert rk.time_feasible_s >= max(alone) * (1 - 1e-6)
    assert rk.phase_feasible_s >= rk.time_feasible_s * (1 - 1e-6)
    assert rk.time_optimistic_s <= rk.time_feasible_s
    _, x, _ = rk.trajectories["phase"]
    # phase synchronisation keeps the axes proportional: a straight line
    assert np.allclose(x[:, 1] / 5_000, x[:, 0] / 12_000, atol=1e-6)
