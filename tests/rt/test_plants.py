"""Plant models: the servo motor with amplifier, the stepper (pulse) axis, the encoder."""

from __future__ import annotations

import numpy as np
import pytest

from tests.rt.trace import idle, record
from vdevd.rt import MotionCore, PlantKind, ServoPlant, StepperPlant

MS = 1_000_000


def test_servo_step_is_semi_implicit_euler_with_implicit_damping() -> None:
    plant = ServoPlant(1, 1e-3)
    plant.set(0, amp_gain=2000.0, inertia=2.0, viscous=4.0, coulomb=0.0)
    pos, vel = np.array([10.0]), np.array([100.0])
    plant.step(np.array([3.0]), pos, vel)
    v = (100.0 + 1e-3 * 2000.0 * 3.0 / 2.0) / (1 + 4.0 * 1e-3 / 2.0)
    assert vel[0] == pytest.approx(v, rel=1e-12)
    assert pos[0] == pytest.approx(10.0 + v * 1e-3, rel=1e-12)


def test_servo_reaches_the_viscous_terminal_velocity() -> None:
    plant = ServoPlant(2, 1e-3)
    plant.set(slice(None), coulomb=0.0)
    pos, vel = np.zeros(2), np.zeros(2)
    for _ in range(20_000):
        plant.step(np.array([1.0, -0.5]), pos, vel)
    assert vel == pytest.approx([1000.0, -500.0], rel=1e-6)  # amp_gain * out / viscous


def test_servo_peak_torque_limits_acceleration() -> None:
    plant = ServoPlant(1, 1e-3)
    plant.set(0, peak_torque=100.0, viscous=1e-9, coulomb=0.0)
    pos, vel = np.zeros(1), np.zeros(1)
    for _ in range(10):
        plant.step(np.array([1e6]), pos, vel)
    assert vel[0] == pytest.approx(100.0 * 10 * 1e-3, rel=1e-6)


def test_servo_coulomb_friction_opposes_motion() -> None:
    plant = ServoPlant(1, 1e-3)
    plant.set(0, coulomb=1000.0, viscous=1e-9)
    pos, vel = np.zeros(1), np.array([50.0])
    plant.step(np.zeros(1), pos, vel)
    assert vel[0] == pytest.approx(49.0)


def test_servo_default_static_friction_lets_a_motor_at_rest_settle() -> None:
    """The default Coulomb friction (DEFAULT_COULOMB) ends the hunting of a motor held by its
    integrator: after a move the core reaches an exact fixed point (decision 0008), which it
    never does without friction."""
    def settles(coulomb: float) -> bool:
        core = MotionCore(2, 1e6, PlantKind.SERVO)
        core.plant.set(slice(None), coulomb=coulomb)
        core.servo_on(slice(None))
        core.move_absolute(slice(None), [5000, -3001], 50_000, 500_000, 500_000)
        for _ in range(5000):
            before = core.rest_state()
            core.tick()
            if before is not None and core.rest_state() == before:
                return True
        return False

    assert settles(ServoPlant(1, 1e-3).coulomb[0])
    assert not settles(0.0)


def test_stepper_max_rate_limits_pulses_and_keeps_whole_steps() -> None:
    plant = StepperPlant(2, 1e-3)
    plant.set(0, max_rate=2500.0)  # 2.5 pulses per tick on axis 0; axis 1 unlimited
    cmd, pos, vel = np.array([100.0, 37.4]), np.zeros(2), np.zeros(2)
    seen = []
    for _ in range(60):
        old = pos.copy()
        plant.step(cmd, pos, vel)
        seen.append(pos.copy())
        assert (np.abs(pos - old)[0] <= 3) and (pos == np.rint(pos)).all()
    assert seen[0][1] == 37.0 and list(pos) == [100.0, 37.0]
    assert seen[3][0] == 10.0  # 2.5 pulses per tick on average


def test_stepper_core_with_a_rate_limit_ends_exactly_on_target() -> None:
    core = MotionCore(1, MS, PlantKind.STEPPER)
    core.servo_on(0)
    core.stepper.set(0, max_rate=5000.0)
    core.move_absolute(0, 1234, 20_000, 1e6, 1e6)
    record(core, 10_000, lambda c: idle(c) and c.axes.pos[0] == 1234)
    assert core.axes.pos[0] == 1234 and core.axes.encoder[0] == 1234
    core.tick()
    assert core.axes.pos[0] == 1234 and core.axes.vel[0] == 0.0


def test_encoder_scale_quantises_in_encoder_counts() -> None:
    core = MotionCore(2, MS, PlantKind.IDEAL)
    core.servo_on(slice(None))
    core.set_encoder_scale(1, 4.0)
    core.move_absolute(slice(None), 1000, 10_000, 1e6, 1e6)
    record(core, 10_000, idle)
    core.tick()
    assert list(core.axes.encoder) == [1000, 4000]
    assert list(core.axes.ferr) == [0.0, 0.0]


def test_servo_coulomb_friction_holds_a_motor_at_rest_and_never_reverses_it() -> None:
    plant = ServoPlant(2, 1e-3)
    plant.set(slice(None), coulomb=1000.0, viscous=1e-9)
    pos, vel = np.zeros(2), np.array([0.0, 0.5])
    for _ in range(100):
        plant.step(np.array([0.9, 0.0]), pos, vel)  # 900 < 1000 counts/s^2 of friction
    assert list(vel) == [0.0, 0.0] and pos[0] == 0.0


def test_servo_plant_leaves_disabled_axes_alone() -> None:
    plant = ServoPlant(2, 1e-3)
    plant.enable(np.array([True, False]))
    pos, vel = np.array([1.0, 2.0]), np.zeros(2)
    plant.step(np.array([1.0, 1.0]), pos, vel)
    assert pos[1] == 2.0 and vel[1] == 0.0 and vel[0] > 0


def test_plant_parameters_are_checked() -> None:
    plant = ServoPlant(1, 1e-3)
    with pytest.raises(ValueError):
        plant.set(0, inertia=0.0)
    with pytest.raises(ValueError):
        plant.set(0, mass=1.0)
    with pytest.raises(ValueError):
        StepperPlant(1, 1e-3).set(0, max_rate=0.0)
