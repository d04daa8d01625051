"""APS watchdog timer [M §4.10.2.3; spec adlink.md §2.22, §4.12]: timer 0 only, milliseconds,
actions bit 0 servo off, bit 1 DO off, bit 2 PWM off (spec Q27)."""

from __future__ import annotations

from typing import Any

from vdevclient._aps_session import as_int, board, guarded, put


@guarded
def APS_wdt_start(Board_ID: int, TimerNo: int, TimeOut: int) -> int:
    """Start the watchdog with `TimeOut` ms from now; 0 stops it."""
    return board(Board_ID).post("wdt_start", as_int(TimerNo), as_int(TimeOut))[0]


@guarded
def APS_wdt_get_timeout_period(Board_ID: int, TimerNo: int, TimeOut: Any) -> int:
    rc, out = board(Board_ID).post("wdt_get_timeout_period", as_int(TimerNo))
    if rc == 0:
        put(TimeOut, out[0])
    return rc


@guarded
def APS_wdt_reset_counter(Board_ID: int, TimerNo: int) -> int:
    """Kick the watchdog: its count starts from 0 again."""
    return board(Board_ID).post("wdt_reset_counter", as_int(TimerNo))[0]


@guarded
def APS_wdt_get_counter(Board_ID: int, TimerNo: int, Counter: Any) -> int:
    """The ms counted since the start or the last kick [X1]."""
    rc, out = board(Board_ID).post("wdt_get_counter", as_int(TimerNo))
    if rc == 0:
        put(Counter, out[0])
    return rc


@guarded
def APS_wdt_set_action_event(Board_ID: int, TimerNo: int, EventByBit: int) -> int:
    return board(Board_ID).post("wdt_set_action_event", as_int(TimerNo), as_int(EventByBit))[0]


@guarded
def APS_wdt_get_action_event(Board_ID: int, TimerNo: int, EventByBit: Any) -> int:
    rc, out = board(Board_ID).post("wdt_get_action_event", as_int(TimerNo))
    if rc == 0:
        put(EventByBit, out[0])
    return rc


__all__ = [n for n in dir() if n.startswith("APS_")]
