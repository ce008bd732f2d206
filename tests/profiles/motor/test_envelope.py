"""profiles.motor.envelope: where synchronised axes can no longer accelerate."""

from __future__ import annotations

from profiles.motor import bundled_motor_paths, load_motor


def test_the_envelope_ends_where_the_axes_can_no_longer_accelerate_together() -> None:
    """A braked axis (friction eating its torque at speed) caps the line's top speed where
    it stops accelerating, below its own curve's end."""
    from dataclasses import replace

    from profiles.motor.envelope import envelope_motor

    free = load_motor(next(p for p in bundled_motor_paths() if "nema17" in p.name))
    braked = replace(free, friction_torque_nm=0.1)
    env = envelope_motor([braked, free], [1.0, 0.5])
    assert env.top_pps < braked.top_pps
    assert braked.a_acc_pps2(env.top_pps) <= 0 < braked.a_acc_pps2(0.99 * env.top_pps)
    assert env.a_acc_pps2(0.99 * env.top_pps) > 0
