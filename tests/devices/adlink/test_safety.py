"""The watchdog's actions on the kernel alone, no daemon [M §4.10.2.3; spec §2.22, Q27]: the
DO word and the PWM outputs."""

from __future__ import annotations

import numpy as np
from vdevmaps.adlink import BAR_SIZE
from vdevmaps.aps_defs import MTS_ASTP, STOP_SVNO

from vdevd.devices.adlink import motion, pwm, safety
from vdevd.devices.adlink.kernel import Kernel


def kernel() -> Kernel:
    k = Kernel(bytearray(BAR_SIZE), 4, 0x204, 0, 1000, "ideal", lambda: None)
    k.servo(np.arange(4), True)
    return k


def run(k: Kernel, ms: int) -> None:
    for _ in range(ms):
        k.cycle()


def test_do_and_pwm_off_run_once_at_the_timeout() -> None:
    k = kernel()
    outputs = pwm.unit(k).out
    pwm.set_pwm_on(k, 1, 1)
    k.do_word = 0xFF00FF
    safety.wdt_set_action_event(k, 0, safety.WDT_DO_OFF | safety.WDT_PWM_OFF)
    safety.wdt_start(k, 0, 5)  # odd: the 2 ms host cycle checks it at 6 ms
    run(k, 5)
    assert k.do_word == 0xFF00FF and outputs[1].on
    run(k, 1)
    assert k.do_word == 0 and not outputs[1].on and k.svon.all()
    k.do_word = 0x1
    pwm.set_pwm_on(k, 1, 1)
    run(k, 20)
    assert k.do_word == 0x1 and outputs[1].on  # once, until a kick
    safety.wdt_reset_counter(k, 0)
    run(k, 6)
    assert k.do_word == 0 and not outputs[1].on


def test_servo_off_stops_moving_axes_and_leaves_idle_ones_alone() -> None:
    k = kernel()
    motion.vel(k, 1, 0, 1000.0, *[float("nan")] * 5)
    safety.wdt_set_action_event(k, 0, 0b111)
    safety.wdt_start(k, 0, 4)
    run(k, 4)
    assert not k.svon.any() and not k.moving().any()
    k.status_words()
    assert k.stop_code[1] == STOP_SVNO and k.msts[1] >> MTS_ASTP & 1
    assert k.stop_code[0] == 0


def test_a_running_watchdog_keeps_the_card_busy() -> None:
    k = kernel()
    unit = next(u for u in k.units if isinstance(u, safety.WatchdogUnit))
    assert not unit.busy()
    safety.wdt_start(k, 0, 4)
    assert unit.busy()
    run(k, 4)
    assert not unit.busy()  # expired: it waits for a kick
