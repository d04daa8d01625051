"""The watchdog of the kernel [M §4.10.2.3; spec adlink.md §2.22, §4.12, Q27].

An internal timer the host must kick: `APS_wdt_start` sets its timeout (ms, 0 stops it),
`APS_wdt_reset_counter` kicks it; when the count reaches the timeout the configured actions run
once (until the next kick): bit 0 servo off on every axis (a moving axis stops with code 3,
STOP_SVNO, and ASTP), bit 1 every DO off, bit 2 every PWM output off (plain and VAO, through
the PWM unit's `pwm_off`; the TRG pulse outputs are left alone). ASSUMPTIONS (spec §2.22, Q27):
timer 0 only; milliseconds; the count advances in the host cycle, 2 ms at a time, and is
checked there. The timer's state is the board parameters PRB_WDT0_LIMIT (the timeout),
PRB_WDT0_COUNTER (the count: reading it reads the count, writing 0 kicks) and PRB_WDT0_ACTION
(the actions), so APS_set_board_param reaches the same timer [spec §3.1]. EMG, ALM, the limits
and the position-error protection are the kernel's `protect` (kernel.py).
"""

from __future__ import annotations

from typing import TYPE_CHECKING

import numpy as np
from vdevmaps.aps_defs import (
    PRB_WDT0_ACTION,
    PRB_WDT0_COUNTER,
    PRB_WDT0_LIMIT,
    ERR_ParametersInvalid,
)

from vdevd.devices.adlink.errors import ApsError

if TYPE_CHECKING:
    from vdevd.devices.adlink.kernel import Kernel

HOST_CYCLE_US = 2000  # the host cycle that counts and checks the timer (spec §2.22 ASSUMPTION)
WDT_SERVO_OFF, WDT_DO_OFF, WDT_PWM_OFF = 1 << 0, 1 << 1, 1 << 2
_I32_MAX = 2**31 - 1


class WatchdogUnit:
    """Watchdog timer 0 of a card."""

    def __init__(self, k: Kernel) -> None:
        self.k = k
        self.us = 0  # microseconds toward the next host cycle
        self.expired = False  # the actions ran; a kick re-arms

    def reset(self) -> None:
        self.us = 0
        self.expired = False

    def busy(self) -> bool:
        """Counting (an expired timer waits for its kick and costs nothing)."""
        values = self.k.board_params.values
        return self.limit > 0 and (not self.expired or values[PRB_WDT0_COUNTER] == 0)

    @property
    def limit(self) -> int:
        return int(self.k.board_params.values[PRB_WDT0_LIMIT])

    @property
    def counter(self) -> int:
        return int(self.k.board_params.values[PRB_WDT0_COUNTER])

    def kick(self) -> None:
        """APS_wdt_reset_counter: the count from 0 again, the actions re-armed."""
        self.k.board_params.values[PRB_WDT0_COUNTER] = 0.0
        self.us = 0
        self.expired = False

    def before_motion(self, t: float) -> None:
        pass

    def after_motion(self, t: float) -> None:
        """The host cycle's part: count, and run the actions when the timeout is reached."""
        limit = self.limit
        if limit <= 0:
            return
        values = self.k.board_params.values
        if self.expired:
            if values[PRB_WDT0_COUNTER] != 0:
                return  # it counts no further until a kick
            self.kick()  # PRB_WDT0_COUNTER written 0 through APS_set_board_param
        self.us += self.k.cycle_us
        while self.us >= HOST_CYCLE_US and not self.expired:
            self.us -= HOST_CYCLE_US
            values[PRB_WDT0_COUNTER] = float(min(self.counter + HOST_CYCLE_US // 1000, _I32_MAX))
            if self.counter >= limit:
                self.expired = True
                self.timeout()

    def timeout(self) -> None:
        """The configured actions [M §4.10.2.3; spec Q27]."""
        k = self.k
        action = int(k.board_params.values[PRB_WDT0_ACTION])
        if action & WDT_SERVO_OFF:
            k.servo(np.arange(k.n), False)
        if action & WDT_DO_OFF:
            k.do_word = 0
        if action & WDT_PWM_OFF:
            for u in k.units:  # the PWM unit's hook (pwm.py)
                pwm_off = getattr(u, "pwm_off", None)
                if pwm_off is not None:
                    pwm_off()


def _unit(k: Kernel, timer: int) -> WatchdogUnit:
    if timer != 0:
        raise ApsError(ERR_ParametersInvalid, f"TimerNo {timer}: the card has timer 0 only")
    return next(u for u in k.units if isinstance(u, WatchdogUnit))


def wdt_start(k: Kernel, timer: int, timeout: int) -> None:
    """APS_wdt_start(Board_ID, TimerNo, TimeOut): the timeout in ms, counted from now; 0 stops
    the watchdog [M §4.10.2.3]."""
    unit = _unit(k, timer)
    if not 0 <= timeout <= _I32_MAX:
        raise ApsError(ERR_ParametersInvalid, f"TimeOut {timeout}")
    k.board_params.values[PRB_WDT0_LIMIT] = float(timeout)
    unit.kick()


def wdt_get_timeout_period(k: Kernel, timer: int) -> int:
    _unit(k, timer)
    return int(k.board_params.values[PRB_WDT0_LIMIT])


def wdt_reset_counter(k: Kernel, timer: int) -> None:
    """APS_wdt_reset_counter: the kick [M §4.10.2.3]."""
    _unit(k, timer).kick()


def wdt_get_counter(k: Kernel, timer: int) -> int:
    """APS_wdt_get_counter [X1]: the ms counted since the start or the last kick."""
    return _unit(k, timer).counter


def wdt_set_action_event(k: Kernel, timer: int, event_by_bit: int) -> None:
    """APS_wdt_set_action_event: bit 0 servo off, bit 1 DO off, bit 2 PWM off (spec Q27)."""
    _unit(k, timer)
    if not 0 <= event_by_bit <= WDT_SERVO_OFF | WDT_DO_OFF | WDT_PWM_OFF:
        raise ApsError(ERR_ParametersInvalid, f"EventByBit {event_by_bit:#x}")
    k.board_params.values[PRB_WDT0_ACTION] = float(event_by_bit)


def wdt_get_action_event(k: Kernel, timer: int) -> int:
    _unit(k, timer)
    return int(k.board_params.values[PRB_WDT0_ACTION])
