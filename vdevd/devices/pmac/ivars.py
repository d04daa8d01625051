"""The I-variable table of a Turbo PMAC2: numbering, factory defaults, ranges, hex display.

Numbering [spec pmac.md §2.2]: I0-I99 global, Ixx = I(100*xx + yy) for motor xx (1-32), Isx =
I(5000 + 100*s + x) for coordinate system s (1-16), I7mn0-I7mn9 for Servo IC m channel n,
I8000-I8191 the encoder conversion table [A L2445]. All values live in one float array indexed by
the I-variable number (`IVars.values`), so the servo loop reads a motor's gains with one fancy
index (`values[100 * motors + 30]`).

Defaults are those of a Turbo PMAC2 with Servo ICs 0 and 1 (eight on-board channels, the Geo Brick
layout of the default CID 603382) and no MACRO IC; where the sources give none the value is an
assumption recorded in the card README.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

COUNT = 8192
MAX_MOTORS = 32
#: Servo IC base addresses, IC m = 0..9 [SRM p.213, digest §2.1]
SERVO_IC_BASE = (0x078000, 0x078100, 0x078200, 0x078300, 0x079200,
                 0x079300, 0x07A200, 0x07A300, 0x07B200, 0x07B300)
#: the largest magnitude a 48-bit PMAC float or fixed value holds (divide by zero saturates here)
BIG = float(2**47)


@dataclass(frozen=True)
class IVar:
    """One I-variable's definition: factory default, accepted range, integer-only, shown in hex
    when I9 bit 1 is set (address variables and Ixx24 [A L1811])."""

    default: float = 0.0
    lo: float = -BIG
    hi: float = BIG
    integer: bool = False
    hex: bool = False


def channel_base(motor: int) -> int:
    """The PMAC2 Servo IC channel base address of on-board channel `motor` (1-based): IC
    (motor-1)//4, channel (motor-1)%4 at +8 per channel [A Ixx25 table, digest §1.5]."""
    ic, ch = divmod(motor - 1, 4)
    return SERVO_IC_BASE[ic % len(SERVO_IC_BASE)] + 8 * ch


def _u24(hex_: bool = False, default: float = 0) -> IVar:
    return IVar(default, 0, 0xFFFFFF, integer=True, hex=hex_)


def _int(lo: float, hi: float, default: float = 0, hex_: bool = False) -> IVar:
    return IVar(default, lo, hi, integer=True, hex=hex_)


_ADDR = _u24(hex_=True)
_FLAG = _int(0, 1)

#: global I-variables with non-trivial definitions [SRM via digest §2.2; addendum §1.5, §1.8]
GLOBAL: dict[int, IVar] = {
    3: _int(0, 3, 1),           # I/O handshake (ACK/LF framing)
    4: _int(0, 3, 1),           # communications integrity mode
    5: _int(0, 3, 2),           # PLC programs enabled
    6: _int(0, 3, 1),           # error reporting mode (assumed default 1)
    7: _int(0, 15, 0),
    8: _int(0, 255, 2),         # real-time interrupt period, servo cycles - 1
    9: _int(0, 3, 2),           # full/abbreviated listing, hex/decimal address reporting
    10: _int(0, 8_388_607, 3_713_707),  # servo interrupt time, 1/8,388,608 ms
    12: _FLAG,                  # lookahead time splining [A L1408]
    13: _FLAG,                  # foreground in-position check [A L3254]
    15: _FLAG,                  # degrees (0) / radians (1) [A L1137]
    16: _int(0, 8_388_607, 5),  # rotary buffer request on point, lines (ASSUMPTION: default)
    17: _int(0, 8_388_607, 10),  # rotary buffer request off point, lines [Turbo SRM I17]
    20: _ADDR, 21: _ADDR, 22: _ADDR, 23: _ADDR,  # MACRO IC 0-3 bases, $0 = absent [A L3228]
    24: _ADDR,
    30: _FLAG,                  # compensation-table wrap [A L1420]
    37: _int(0, 0x032403, 0, hex_=True),  # additional wait states [A L1432]
    40: _int(0, 255, 0),        # watchdog timer reset value [A L3227]
    41: _int(0, 0xFFFFFF, 0, hex_=True),  # I-variable lockout [A L3227]
    44: _int(0, 0, 0),          # PMAC Ladder: standard firmware cannot set it [A L1452]
    47: _int(0, 255, 0), 48: _FLAG, 49: _FLAG, 50: _int(0, 255, 0),  # DPRAM reporting
    51: _FLAG,                  # compensation tables enable [A L3135]
    52: _int(0, 31, 7),
    55: _FLAG, 56: _FLAG, 57: _FLAG,
    58: _int(0, 1, 1),          # DPRAM ASCII enable, set at reset when DPRAM is present [A L3250]
    59: _int(0, 3, 0),
    60: _int(0, 255, 15),       # filtered-velocity sample time [SRM p.65]
    63: _FLAG,                  # echo ^X
    65: _int(0, 0xFFFFFF, 0),   # user identity
    68: _int(0, 15, 15),        # coordinate systems activated - 1
}

#: motor I-variables Ixx yy (yy -> definition) [SRM quick reference via digest §2.2, addendum §1.5]
MOTOR: dict[int, IVar] = {
    0: _FLAG,                   # activation (set for the card's motors)
    1: _int(0, 3, 0),           # commutation enable
    2: _ADDR, 3: _ADDR, 4: _ADDR, 5: _ADDR,
    7: IVar(96, 1, 2**23), 8: IVar(96, 1, 2**23), 9: IVar(96, 1, 2**23),
    10: _ADDR,
    11: IVar(32000, 0, 8_388_607), 12: IVar(16000, 0, 8_388_607),
    13: IVar(0, -(2.0**35), 2.0**35), 14: IVar(0, -(2.0**35), 2.0**35),
    15: IVar(0.25, 0, 2**23), 16: IVar(32, 0, 2**23), 17: IVar(0.5, 0, 2**23),
    19: IVar(0.15625, 0, 2**23), 20: IVar(0, 0, 8_388_607), 21: IVar(50, 0, 8_388_607),
    22: IVar(32, 0, 2**23), 23: IVar(32, -(2.0**23), 2**23),
    24: _int(0, 0xFFFFFF, 1, hex_=True),   # flag mode, PMAC2 default $000001 [A L1813]
    25: _ADDR,
    26: IVar(0, -(2.0**35), 2.0**35),
    27: IVar(0, -(2.0**35), 2.0**35),
    28: IVar(160, 0, 8_388_607),
    29: IVar(0, -32768, 32767),
    30: IVar(2000, -8_388_608, 8_388_607, integer=True),
    31: IVar(1280, -8_388_608, 8_388_607, integer=True),
    32: IVar(1280, -8_388_608, 8_388_607, integer=True),
    33: IVar(0, -8_388_608, 8_388_607, integer=True),
    34: _int(0, 1, 1),           # integrate only at zero desired velocity [digest §2.2 quick ref]
    35: IVar(0, -8_388_608, 8_388_607, integer=True),
    36: IVar(0, -2, 2), 37: IVar(0, -2, 2), 38: IVar(0, -2, 2), 39: IVar(0, -2, 2),
    42: _ADDR, 43: _ADDR,
    60: _int(0, 255, 0),
    63: IVar(4_194_304, -8_388_608, 8_388_607, integer=True),
    64: IVar(0, -32768, 32767, integer=True), 65: IVar(0, 0, 8_388_607, integer=True),
    67: IVar(4_194_304, 0, 8_388_607, integer=True),
    68: IVar(0, 0, 32767, integer=True),
    69: IVar(20480, 0, 32767, integer=True),
    70: _int(0, 255, 1), 71: _int(0, 16_777_215, 1000),
    75: _int(0, 16_777_215, 0),   # negative values are converted by the interpreter [A L2191]
    80: _int(0, 7, 0),
    81: _ADDR, 82: _ADDR, 83: _ADDR,
    85: _int(0, 8_388_607, 0),   # backlash take-up rate, 1/16 count per cycle [Turbo SRM Ixx85]
    86: _int(0, 8_388_607, 0),   # backlash size, 1/16 count [Turbo SRM Ixx86]
    87: _int(0, 8_388_607, 64),  # backlash hysteresis, 1/16 count (PMAC(1) I99's default) [Turbo SRM Ixx87]
    88: _int(0, 255, 0),
    90: IVar(0, 0, 1, integer=True),
    91: _ADDR, 92: IVar(10, 1, 8_388_607, integer=True),
    95: _ADDR, 96: _FLAG, 97: _int(0, 3, 0),
}

#: coordinate-system Isx variables (x -> definition) [SRM via digest §2.2, §2.8]
CS: dict[int, IVar] = {
    11: _int(-8_388_608, 8_388_607), 12: _int(-8_388_608, 8_388_607),  # countdown timers
    13: IVar(0, 0, 8_388_607), 20: _int(0, 65535, 0), 50: _FLAG,  # Isx50 kinematics enable
    87: IVar(0, 0, 8_388_607), 88: IVar(50, 0, 8_388_607), 89: IVar(1000, 0, 8_388_607),
    90: IVar(1000, 0, 8_388_607), 93: _ADDR, 94: IVar(1644, 0, 8_388_607),
    95: IVar(1644, 0, 8_388_607),
    96: IVar(0, 0, 2.0**35),   # circle radius error limit, units (0: no error) [Turbo SRM Isx96]
    97: IVar(0, 0, 2.0),       # minimum arc, half-circles (0: 2^-20) [Turbo SRM Isx97]
}

#: data gathering I5000-I5051 [digest §2.2; DLS-ctl gather.py; PComm Gather.h GATMODE]: I5000 mode
#: (0 stop when full, 1 wrap; 2, 3 the same in the DPRAM), I5001-I5048 sources (hex:
#: format digit + address), I5049 period in servo cycles, I5050/I5051 source masks (hex)
GATHER: dict[int, IVar] = {
    5000: _int(0, 3, 0),
    **dict.fromkeys(range(5001, 5049), _ADDR),
    5049: _int(0, 0x7FFFFF, 0),
    5050: _ADDR, 5051: _ADDR,
}

#: Servo IC variables I7mn k (k -> definition) and IC-global I7m0k [SRM p.213, addendum §1.1]
IC_CHANNEL: dict[int, IVar] = {
    0: _int(0, 15, 7),   # encoder decode: x4 quadrature, CW
    1: _int(0, 3, 0),
    2: _int(0, 15, 1),   # capture control: index high [PMAC2 SRM I9n2 default 1; Turbo SRM p.222]
    3: _int(0, 3, 0),    # capture flag select: 0 = HOMEn [Turbo SRM p.223]
    4: _int(0, 3, 0), 5: _int(0, 7, 0), 6: _int(0, 3, 0), 7: _int(0, 3, 0), 8: _int(0, 3, 0),
    9: _FLAG,            # hardware 1/T [A L2428]
}
IC_GLOBAL: dict[int, IVar] = {
    0: _int(0, 32767, 6527), 1: _int(0, 15, 0), 2: _int(0, 15, 3), 3: _int(0, 0xFFFFFF, 2258),
    4: _int(0, 255, 15), 5: _int(0, 0xFFFFFF, 0), 6: _int(0, 0xFFFFFF, 0xFFFFFE, hex_=True),
    7: _int(0, 3, 0), 8: _int(0, 3, 0), 9: _int(0, 3, 0),
}

_PLAIN = IVar()


def definition(n: int, motors: int = 8) -> IVar:
    """The definition of I-variable `n` with the card's defaults (motor-dependent addresses
    included); KeyError outside 0-8191."""
    if not 0 <= n < COUNT:
        raise KeyError(n)
    if n < 100:
        return GLOBAL.get(n, _PLAIN)
    if n < 3300:
        motor, yy = divmod(n, 100)
        spec = MOTOR.get(yy, _PLAIN)
        default = _motor_default(motor, yy, motors)
        return spec if default is None else _with_default(spec, default)
    if 5000 <= n < 5100:
        return GATHER.get(n, _PLAIN)
    if 5100 <= n < 6700:
        spec = CS.get(n % 100, _PLAIN)
        if n % 100 == 93:  # Isx93: the C.S.'s own host time base X:$002000+$100(s-1) (README)
            return _with_default(spec, float(0x2000 + 0x100 * (n // 100 - 51)))
        return spec
    if 7000 <= n < 8000:
        m, rest = divmod(n - 7000, 100)
        channel, k = divmod(rest, 10)
        spec = (IC_CHANNEL if channel else IC_GLOBAL).get(k, _PLAIN)
        return spec
    if n >= 8000:
        return _with_default(_ADDR, _ect_default(n - 8000, motors))
    return _PLAIN


def _with_default(spec: IVar, default: float) -> IVar:
    return IVar(default, spec.lo, spec.hi, spec.integer, spec.hex)


def _motor_default(motor: int, yy: int, motors: int) -> float | None:
    """Defaults that depend on the motor number [A Ixx02, Ixx25, Ixx83 tables; ECT defaults]."""
    base = channel_base(motor)
    onboard = motor <= 8
    match yy:
        case 0:
            return 1.0 if motor <= motors else 0.0
        case 2:
            return float(base + 2) if onboard else 0.0      # Y:b+2, DAC A
        case 3 | 4:
            return float(0x3501 + motor - 1) if onboard else 0.0  # one-line ECT entries
        case 25:
            return float(base) if onboard else 0.0
        case 83:
            return float(base + 1) if onboard else 0.0
    return None


def _ect_default(k: int, motors: int) -> float:
    """I8000-I8007: 1/T extension of the eight on-board encoders (PMAC2) [A L2445]."""
    return float(channel_base(k + 1)) if k < 8 else 0.0


class IVars:
    """The card's I-variables: one float array, factory defaults, range checks."""

    def __init__(self, motors: int) -> None:
        self.motors = motors
        self.defs = [definition(n, motors) for n in range(COUNT)]
        self.lo = np.array([d.lo for d in self.defs])
        self.hi = np.array([d.hi for d in self.defs])
        self.defaults = np.array([d.default for d in self.defs])
        self.values = self.defaults.copy()

    def factory(self) -> None:
        """`$$$***`: every I-variable to its factory default."""
        self.values[:] = self.defaults

    def check(self, n: int, value: float) -> float | None:
        """The value as stored (integers rounded), or None when it is out of range."""
        d = self.defs[n]
        if not math.isfinite(value):
            return None
        if d.integer:
            value = float(math.floor(value + 0.5))
        return value if d.lo <= value <= d.hi else None

    def hex(self, n: int) -> bool:
        return self.defs[n].hex

    def __getitem__(self, n: int) -> float:
        return float(self.values[n])

    def motor(self, yy: int) -> np.ndarray:
        """Ixx yy of the card's motors, one element per motor (a copy)."""
        return self.values[100 * np.arange(1, self.motors + 1) + yy]
