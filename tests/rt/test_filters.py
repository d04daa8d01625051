"""The PID family: the parallel law, integrator and output limits, feed-forward and offset."""

from __future__ import annotations

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from vdevd.rt import Pid

GAIN = st.floats(-10, 10)


def step(pid: Pid, e: np.ndarray, vel: np.ndarray, acc: np.ndarray) -> np.ndarray:
    pid.e[:] = e
    pid.cmd_vel[:] = vel
    pid.cmd_acc[:] = acc
    out = np.zeros(len(e))
    pid.update(out)
    return out


@settings(derandomize=True, max_examples=50, deadline=None)
@given(kp=GAIN, ki=GAIN, kd=GAIN, vff=GAIN, aff=GAIN, offset=GAIN,
       errors=st.lists(st.floats(-100, 100), min_size=1, max_size=20))
def test_output_is_the_parallel_law_with_feed_forward(kp: float, ki: float, kd: float, vff: float,
                                                      aff: float, offset: float,
                                                      errors: list[float]) -> None:
    pid = Pid(2)
    pid.set(slice(None), kp=kp, ki=ki, kd=kd, vff=vff, aff=aff, offset=offset)
    integ, prev = 0.0, 0.0
    for i, e in enumerate(errors):
        out = step(pid, np.array([e, -e]), np.array([10.0 * i, 0.0]), np.array([-3.0, 0.0]))
        integ += e
        pid_part = kp * e + ki * integ + kd * (e - prev)
        prev = e
        want = offset + pid_part + vff * 10.0 * i + aff * -3.0
        assert out[0] == pytest.approx(want, rel=1e-9, abs=1e-9)
        assert out[1] == pytest.approx(offset - pid_part, rel=1e-9, abs=1e-9)


def test_integrator_is_clamped_to_its_limit_both_ways() -> None:
    pid = Pid(2)
    pid.set(slice(None), ki=1.0, il=5.0)
    for _ in range(50):
        step(pid, np.array([1.0, -2.0]), np.zeros(2), np.zeros(2))
    assert list(pid.integ) == [5.0, -5.0]
    out = step(pid, np.array([-1.0, 2.0]), np.zeros(2), np.zeros(2))  # anti-windup: unwinds at once
    assert list(pid.integ) == [4.0, -3.0] and list(out) == [4.0, -3.0]


def test_output_is_clamped_symmetrically() -> None:
    pid = Pid(3)
    pid.set(slice(None), kp=100.0, out_limit=7.5)
    out = step(pid, np.array([1.0, -1.0, 0.01]), np.zeros(3), np.zeros(3))
    assert list(out) == [7.5, -7.5, pytest.approx(1.0)]


def test_limits_apply_per_axis() -> None:
    pid = Pid(2)
    pid.set(slice(None), kp=1.0)
    pid.set(0, out_limit=1.0)
    out = step(pid, np.array([10.0, 10.0]), np.zeros(2), np.zeros(2))
    assert list(out) == [1.0, 10.0]


def test_reset_clears_integrator_and_derivative_memory() -> None:
    pid = Pid(1)
    pid.set(0, ki=1.0, kd=1.0)
    step(pid, np.array([3.0]), np.zeros(1), np.zeros(1))
    pid.reset(0)
    out = step(pid, np.array([3.0]), np.zeros(1), np.zeros(1))
    assert out[0] == 3.0 + 3.0  # ki*I with I = 3, kd*(3 - 0)


def test_unknown_or_negative_parameters_are_refused() -> None:
    pid = Pid(1)
    with pytest.raises(ValueError):
        pid.set(0, kq=1.0)
    with pytest.raises(ValueError):
        pid.set(0, out_limit=-1.0)


def test_disabled_axes_output_exactly_zero() -> None:
    pid = Pid(2)
    pid.set(slice(None), kp=2.0, ki=1.0, vff=0.5, offset=0.25)
    pid.enable(np.array([True, False]))
    out = step(pid, np.array([3.0, 3.0]), np.array([4.0, 4.0]), np.zeros(2))
    assert list(out) == [0.25 + 6.0 + 3.0 + 2.0, 0.0]


def test_gains_take_one_value_per_selected_axis() -> None:
    pid = Pid(3)
    pid.set(np.array([0, 2]), kp=[1.0, 3.0])
    out = step(pid, np.ones(3), np.zeros(3), np.zeros(3))
    assert list(out) == [1.0, 0.0, 3.0]
    with pytest.raises(ValueError):
        pid.set(0, kp=float("nan"))
