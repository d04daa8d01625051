"""Board and axis parameters of the AMP-204C/208C motion kernel [M §4.1-4.10; spec adlink.md
§3.1-3.2]: numbers, names, types, ranges and defaults, and the per-axis values as numpy rows.

Every parameter is stored as F64 (`APS_set_axis_param` truncates to I32 on the way out, spec
§3). Numbers the AMP does not use (closed-loop gains, other cards' homing extras) are accepted
and kept without effect (spec §3.2 "Not applicable"); a number in no table is -10.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Any

import numpy as np

INF = math.inf


@dataclass(frozen=True, slots=True)
class Param:
    """One parameter: number, ADLINK name, F64 or I32, range (inclusive), default."""

    no: int
    name: str
    f64: bool
    lo: float
    hi: float
    default: float


def _p(no: int, name: str, f64: bool, lo: float, hi: float, default: float) -> Param:
    return Param(no, name, f64, lo, hi, default)


I32_MIN, I32_MAX = -(2**31), 2**31 - 1
POS = 1e-12  # "> 0"

#: axis parameters [spec §3.2]
AXIS_PARAMS: tuple[Param, ...] = (
    _p(0x00, "PRA_EL_LOGIC", False, 0, 1, 0),
    _p(0x01, "PRA_ORG_LOGIC", False, 0, 1, 0),
    _p(0x02, "PRA_EL_MODE", False, 0, 1, 0),  # 0 immediate, 1 decelerate (Q4)
    _p(0x03, "PRA_MDM_CONDI", False, 0, 1, 0),  # 1: MDN waits for INP
    _p(0x04, "PRA_ALM_LOGIC", False, 0, 1, 0),
    _p(0x05, "PRA_INP_LOGIC", False, 0, 1, 0),
    _p(0x06, "PRA_EZ_LOGIC", False, 0, 1, 0),
    _p(0x07, "PRA_SD_DEC", True, POS, INF, 1e6),
    _p(0x08, "PRA_SPEL_EN", False, 0, 1, 0),
    _p(0x09, "PRA_SMEL_EN", False, 0, 1, 0),
    _p(0x0A, "PRA_SPEL_POS", True, -INF, INF, 0),
    _p(0x0B, "PRA_SMEL_POS", True, -INF, INF, 0),
    _p(0x10, "PRA_HOME_MODE", False, 0, 2, 0),
    _p(0x11, "PRA_HOME_DIR", False, 0, 1, 0),
    _p(0x12, "PRA_HOME_CURVE", True, 0, 1, 0),
    _p(0x13, "PRA_HOME_ACC", True, POS, INF, 1e6),
    _p(0x14, "PRA_HOME_VS", True, 0, INF, 0),
    _p(0x15, "PRA_HOME_VM", True, POS, INF, 1e5),
    _p(0x17, "PRA_HOME_SHIFT", True, -INF, INF, 0),
    _p(0x18, "PRA_HOME_EZA", False, 0, 1, 0),
    _p(0x19, "PRA_HOME_VO", True, POS, INF, 5e4),
    _p(0x1B, "PRA_HOME_POS", True, -INF, INF, 0),
    _p(0x20, "PRA_SF", True, 0, 1, 0),
    _p(0x21, "PRA_ACC", True, POS, INF, 1e6),
    _p(0x22, "PRA_DEC", True, POS, INF, 1e6),
    _p(0x23, "PRA_VS", True, 0, INF, 0),
    _p(0x24, "PRA_VM", True, POS, INF, 1e5),
    _p(0x25, "PRA_VE", True, 0, INF, 0),
    _p(0x2A, "PRA_PRE_EVENT_DIST", True, 0, INF, 0),
    _p(0x2B, "PRA_POST_EVENT_DIST", True, 0, INF, 0),
    _p(0x32, "PRA_PT_STOP_ENDO", False, I32_MIN, I32_MAX, 0),
    _p(0x33, "PRA_PT_STOP_DO", False, I32_MIN, I32_MAX, 0),
    _p(0x34, "PRA_PWM_OFF", False, I32_MIN, I32_MAX, 0),
    _p(0x35, "PRA_DO_OFF", False, I32_MIN, I32_MAX, 0),
    _p(0x40, "PRA_JG_MODE", False, 0, 1, 0),
    _p(0x41, "PRA_JG_DIR", False, 0, 1, 0),
    _p(0x42, "PRA_JG_SF", True, 0, 1, 0),
    _p(0x43, "PRA_JG_ACC", True, POS, INF, 1e6),
    _p(0x44, "PRA_JG_DEC", True, POS, INF, 1e6),
    _p(0x45, "PRA_JG_VM", True, POS, INF, 1e4),
    _p(0x46, "PRA_JG_OFFSET", True, POS, INF, 1000),
    _p(0x47, "PRA_JG_DELAY", False, 0, 10_000_000, 0),
    _p(0x48, "PRA_JG_MAP_DI_EN", False, 0, 7, 0),
    _p(0x49, "PRA_JG_P_JOG_DI", False, 0, 23, 0),
    _p(0x4A, "PRA_JG_N_JOG_DI", False, 0, 23, 0),
    _p(0x4B, "PRA_JG_JOG_DI", False, 0, 23, 0),
    _p(0x50, "PRA_MDN_DELAY", False, 0, I32_MAX, 0),
    _p(0x51, "PRA_SINP_WDW", False, 0, I32_MAX, 0),
    _p(0x52, "PRA_SINP_STBL", False, 0, I32_MAX, 0),
    _p(0x53, "PRA_SERVO_LOGIC", False, 0, 1, 0),
    _p(0x60, "PRA_GEAR_MASTER", False, -1, 7, -1),
    _p(0x61, "PRA_GEAR_ENGAGE_RATE", True, POS, INF, 1e9),
    _p(0x62, "PRA_GEAR_RATIO", True, -INF, INF, 1.0),
    _p(0x63, "PRA_GANTRY_PROTECT_1", True, 0, INF, 0),
    _p(0x64, "PRA_GANTRY_PROTECT_2", True, 0, INF, 0),
    _p(0x80, "PRA_ENCODER_MODE", False, 0, 8, 4),
    _p(0x81, "PRA_PULSE_OUT_MODE", False, 0, 3, 0),
    _p(0x85, "PRA_ENCODER_DIR", False, 0, 1, 0),
    _p(0x86, "PRA_POS_UNIT_FACTOR", True, POS, INF, 1.0),
    _p(0x124, "PRA_ERR_POS_LEVEL", True, 0, INF, 0),
)

#: numbers other cards use: accepted and kept, no effect on the AMP [spec §3.2 "Not applicable"]
INERT_AXIS = tuple(
    list(range(0x0C, 0x10)) + [0x16, 0x1A] + list(range(0x1C, 0x20)) + list(range(0x26, 0x2A))
    + [0x30, 0x31, 0x82, 0x83, 0x84, 0x88] + list(range(0x90, 0xA1))
    + [n for n in range(0x100, 0x142) if n != 0x124])

#: board parameters [spec §3.1]; 0x8000 is vdevd's motion cycle (spec Q1)
BOARD_PARAMS: tuple[Param, ...] = (
    _p(0x00, "PRB_EMG_LOGIC", False, 0, 1, 0),
    _p(0x10, "PRB_WDT0_LIMIT", False, 0, I32_MAX, 0),
    _p(0x11, "PRB_WDT0_COUNTER", False, 0, I32_MAX, 0),
    _p(0x12, "PRB_WDT0_UNIT", False, 0, I32_MAX, 0),
    _p(0x13, "PRB_WDT0_ACTION", False, 0, 7, 0),
    _p(0x14, "PRB_DO_LOGIC", False, 0, 1, 0),
    _p(0x15, "PRB_DI_LOGIC", False, 0, 1, 0),
    _p(0x110, "PRB_PWM0_MAP_DO", False, -1, 0x1FF, -1),
    _p(0x111, "PRB_PWM1_MAP_DO", False, -1, 0x1FF, -1),
    _p(0x112, "PRB_PWM2_MAP_DO", False, -1, 0x1FF, -1),
    _p(0x113, "PRB_PWM3_MAP_DO", False, -1, 0x1FF, -1),
    _p(0x8000, "PRB_VDEVD_MOTION_CYCLE", False, 500, 2000, 1000),
)

def image_entries(image: Any) -> tuple[list[tuple[int, Any]], int]:
    """The (number, value) entries of a saved image keyed by hex numbers ("0x21"), and how many
    entries are not such (a flash image another program or version left, spec adlink.md §4.1
    ASSUMPTION: they are left out)."""
    if not isinstance(image, dict):
        return [], 1
    out, bad = [], 0
    for key, value in image.items():
        try:
            out.append((int(key, 16), value))
        except (TypeError, ValueError):
            bad += 1
    return out, bad


def is_number(v: Any) -> bool:
    return isinstance(v, (int, float)) and not isinstance(v, bool)


AXIS_BY_NO: dict[int, Param] = {p.no: p for p in AXIS_PARAMS}
BOARD_BY_NO: dict[int, Param] = {p.no: p for p in BOARD_PARAMS}
BOARD_CYCLE = 0x8000


class AxisParams:
    """The axis parameters of n axes: one F64 row per parameter number (`row(no)`), so the
    kernel reads them vectorised (`p.row(0x21)[axes]`)."""

    def __init__(self, n: int) -> None:
        self.n = n
        self.numbers = tuple(p.no for p in AXIS_PARAMS) + INERT_AXIS
        self._index = {no: i for i, no in enumerate(self.numbers)}
        self.values = np.zeros((len(self.numbers), n))
        self.defaults()

    def defaults(self) -> None:
        self.values[:] = 0.0
        for p in AXIS_PARAMS:
            self.values[self._index[p.no]] = p.default

    def known(self, no: int) -> bool:
        return no in self._index

    def index(self, no: int) -> int:
        """Where parameter `no`'s row is in `values`."""
        return self._index[no]

    def row(self, no: int) -> np.ndarray:
        return self.values[self._index[no]]

    def get(self, axis: int, no: int) -> float:
        return float(self.values[self._index[no], axis])

    def check(self, no: int, value: float) -> bool:
        """True when `value` is legal for parameter `no` (finite unless its range is open, in
        range, whole for an I32 parameter)."""
        if no not in self._index or math.isnan(value):
            return False
        p = AXIS_BY_NO.get(no)
        if p is None:
            return math.isfinite(value)
        if not p.f64 and value != int(value):
            return False
        return p.lo <= value <= p.hi and (math.isfinite(value) or not math.isfinite(p.hi))

    def set(self, axis: int, no: int, value: float) -> None:
        self.values[self._index[no], axis] = value

    def image(self) -> dict[str, list[float]]:
        return {f"{no:#x}": self.values[i].tolist() for i, no in enumerate(self.numbers)}

    def restore(self, image: Any) -> int:
        """Take a saved image's rows: a row of this card's n axes whose every value `check`
        allows; the count of entries left out (their parameters keep their values)."""
        entries, dropped = image_entries(image)
        for no, vals in entries:
            if (no in self._index and isinstance(vals, list) and len(vals) == self.n
                    and all(is_number(v) and self.check(no, float(v)) for v in vals)):
                self.values[self._index[no]] = np.asarray(vals, dtype=float)
            else:
                dropped += 1
        return dropped


class BoardParams:
    """The board parameters [spec §3.1]."""

    def __init__(self) -> None:
        self.values = {p.no: p.default for p in BOARD_PARAMS}

    def defaults(self) -> None:
        self.values = {p.no: p.default for p in BOARD_PARAMS}

    def check(self, no: int, value: float) -> bool:
        p = BOARD_BY_NO.get(no)
        if p is None or math.isnan(value) or value != int(value):
            return False
        if no == BOARD_CYCLE:
            return int(value) in (500, 1000, 2000)
        return p.lo <= value <= p.hi

    def image(self) -> dict[str, float]:
        return {f"{no:#x}": v for no, v in self.values.items()}

    def restore(self, image: Any) -> int:
        """Take a saved image's legal values; the count of entries left out."""
        entries, dropped = image_entries(image)
        for no, v in entries:
            if no in self.values and is_number(v) and self.check(no, float(v)):
                self.values[no] = float(v)
            else:
                dropped += 1
        return dropped
