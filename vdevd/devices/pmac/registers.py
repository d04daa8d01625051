"""Firmware registers in data memory: the global words, the motor blocks, P- and Q-variables.

Motor block n at $000080 + $80·(n−1) [spec pmac.md §2.1, suggested M-variables]: D:+$08 commanded
position, D:+$0B actual position (both in 1/(Ixx08·32) count), X:+$1D actual velocity (1/(Ixx09·32)
count per servo cycle), D:+$10 compensation correction (Mxx69), X:+$30 status word 1, X:+$3F servo
output (16-bit DAC value in bits 8-23), Y:+$40 status word 2, D:+$47 target position, Y:+$4E home
capture position (counts), L:+$57 variable jog position/distance (counts, Mxx72). Everything else
in a block is plain storage. P-variable n is L:$006000+n [M-vars "M11->L:$6000"], Q-variable n of
coordinate system 1 L:$008000+n (ASSUMPTION, README).
"""

from __future__ import annotations

from typing import TYPE_CHECKING

import numpy as np

from vdevd.devices.pmac.numbers import from_pmac_float_words, pmac_float_words, round_to_int, wrap

if TYPE_CHECKING:
    from vdevd.devices.pmac.firmware import Firmware

MOTOR_BASE, MOTOR_STRIDE = 0x80, 0x80
CS_BASE, CS_STRIDE = 0x2000, 0x100
P_BASE, Q_BASE = 0x6000, 0x8000
WORD = 0xFFFFFF
HOME_COMPLETE_BIT = 1 << 10  # status word 2 [§2.6]
#: motor-block D: registers -> the Motors report they show (0x10, Mxx69, is the firmware's)
_FIXED = {0x08: "commanded", 0x0B: "position", 0x10: "", 0x47: "target"}
#: L:+$4F/+$50/+$51 scale factor of X/U/A/B/C, Y/V, Z/W (Mxx91-93), +$52 offset (Mxx94) [§2.1]
_AXIS_REGS = {0x4F: "XUABC", 0x50: "YV", 0x51: "ZW", 0x52: ""}
#: C.S. block L:+$41.. the target positions of axes A B C U V W X Y Z [§2.8]
_AXIS_TARGETS = {0x41 + k: axis for k, axis in enumerate("ABCUVWXYZ")}


class GlobalRegisters:
    """X:$000000 servo-cycle counter, X:$000006 global status word 1 (`???`), L:$000017 the
    real-time clock in 1/1024 s [A L3268]; the rest of $0-$7F is storage."""

    def __init__(self, fw: Firmware) -> None:
        self.fw = fw
        self.words: dict[tuple[str, int], int] = {}

    def read_word(self, space: str, addr: int) -> int:
        fw = self.fw
        if space == "X" and addr == 0:
            return fw.servo_cycles & WORD
        if space == "X" and addr == 6:
            return fw.global_status()[0]
        if space == "Y" and addr == 6:  # global status word 2 (second word of `???`)
            return fw.global_status()[1]
        if addr == 0x17:
            clock = int(fw.now_ns * 1024 // 1_000_000_000)
            return (clock >> 24) & WORD if space == "X" else clock & WORD
        return self.words.get((space, addr), 0)

    def write_word(self, space: str, addr: int, value: int) -> None:
        if space == "X" and addr == 6:
            self.fw.global_bits = value
            return
        self.words[(space, addr)] = value


class MotorBlocks:
    """The motor blocks of motors 1-32, served from the motors' state."""

    def __init__(self, fw: Firmware) -> None:
        self.fw = fw
        self.words: dict[tuple[str, int], int] = {}

    def read_word(self, space: str, addr: int) -> int:
        motor, off = divmod(addr - MOTOR_BASE, MOTOR_STRIDE)
        fw = self.fw
        if motor >= fw.ivars.motors:
            return self.words.get((space, addr), 0)
        mot, rep = fw.motors, fw.motors.reports
        if off in _FIXED:  # 48-bit positions in 1/(Ixx08·32) count
            counts = fw.comp_correction(motor) if off == 0x10 else getattr(rep, _FIXED[off])()[motor]
            scale = fw.ivars.values[100 * (motor + 1) + 8] * 32
            v = wrap(round_to_int(counts * scale), 48, signed=False)
            return v >> 24 if space == "X" else v & WORD
        if space == "X" and off == 0x1D:
            vscale = fw.ivars.values[100 * (motor + 1) + 9] * 32
            return wrap(round_to_int(rep.velocity()[motor] * vscale), 24, signed=False)
        if space == "X" and off == 0x30:
            return int(rep.status_words()[0][motor])
        if space == "Y" and off == 0x40:
            return int(rep.status_words()[1][motor])
        if space == "X" and off == 0x3F:
            return wrap(round_to_int(rep.dac()[motor]), 16, signed=False) << 8
        if space == "Y" and off == 0x4E:
            return wrap(round_to_int(rep.capture()[motor]), 24, signed=False)
        if off == 0x57:
            x, y = pmac_float_words(float(mot.jog_register[motor]))
            return x if space == "X" else y
        if off == 0x4C:  # Mxx64 position bias, 1/(Ixx08·32) count [A L932]
            scale = fw.ivars.values[100 * (motor + 1) + 8] * 32
            v = wrap(round_to_int(fw.coord.bias[motor] * scale), 48, signed=False)
            return v >> 24 if space == "X" else v & WORD
        if off in _AXIS_REGS:  # Mxx91-Mxx94 axis scale factors and offset, L: floats
            x, y = pmac_float_words(self.read_float(addr))
            return x if space == "X" else y
        return self.words.get((space, addr), 0)

    def write_word(self, space: str, addr: int, value: int) -> None:
        motor, off = divmod(addr - MOTOR_BASE, MOTOR_STRIDE)
        if space == "Y" and off == 0x40 and motor < self.fw.ivars.motors:
            # status word 2: the home-complete bit is RAM the program may clear or set (homing
            # PLCs write Mxx45=0 before searching); the other bits are the firmware's (README)
            self.fw.motors.homing.home_complete[motor] = bool(value & HOME_COMPLETE_BIT)
            return
        if off == 0x57 and motor < self.fw.ivars.motors:
            jog = self.fw.motors.jog_register
            x, y = pmac_float_words(float(jog[motor]))
            x, y = (value, y) if space == "X" else (x, value)
            jog[motor] = from_pmac_float_words(x, y)
            return
        self.words[(space, addr)] = value

    def read_float(self, addr: int) -> float:
        motor, off = divmod(addr - MOTOR_BASE, MOTOR_STRIDE)
        if off == 0x57 and motor < self.fw.ivars.motors:
            return float(self.fw.motors.jog_register[motor])
        if off in _AXIS_REGS:
            d = self.fw.coord.defs[motor]
            if d is None or d.inverse:
                return 0.0
            if off == 0x52:
                return d.offset
            return sum(d.scale_of(a) for a in _AXIS_REGS[off])
        return from_pmac_float_words(self.read_word("X", addr), self.read_word("Y", addr))

    def write_float(self, addr: int, value: float) -> None:
        motor, off = divmod(addr - MOTOR_BASE, MOTOR_STRIDE)
        if off == 0x57 and motor < self.fw.ivars.motors:
            self.fw.motors.jog_register[motor] = value
            return
        x, y = pmac_float_words(value)
        self.words[("X", addr)], self.words[("Y", addr)] = x, y


class CsBlocks:
    """The coordinate-system blocks of C.S. 1-16 at $002000 + $100·(s−1) [M-vars; digest §2.8]:
    X:+$00 host-commanded time base and X:+$02 present time base (I10 units: I10·%/100; writing
    the first sets the feed-rate override), X:+$40 status word 1, Y:+$3F status word 2; the rest
    is storage."""

    def __init__(self, fw: Firmware) -> None:
        self.fw = fw
        self.words: dict[tuple[str, int], int] = {}

    def read_word(self, space: str, addr: int) -> int:
        cs, off = divmod(addr - CS_BASE, CS_STRIDE)
        fw = self.fw
        if space == "X" and off in (0x00, 0x02):  # commanded / present (slewing, timebase.py)
            pct = fw.feed[cs] if off == 0 else fw.timebase.present(cs)
            return round_to_int(fw.ivars.values[10] * pct / 100) & WORD
        if space == "X" and off == 0x40:
            return fw.cs_status(cs + 1)[0]
        if space == "Y" and off == 0x3F:
            return fw.cs_status(cs + 1)[1]
        if off == 0x15:  # X: Isx11, Y: Isx12 countdown timers [§2.8]
            n = 5100 + 100 * cs + (11 if space == "X" else 12)
            return round_to_int(fw.coord.timer(n)) & WORD
        if off in _AXIS_TARGETS:
            x, y = pmac_float_words(self.read_float(addr))
            return x if space == "X" else y
        return self.words.get((space, addr), 0)

    def read_float(self, addr: int) -> float:
        cs, off = divmod(addr - CS_BASE, CS_STRIDE)
        if off in _AXIS_TARGETS:
            return self.fw.axis_position(cs + 1, _AXIS_TARGETS[off])
        return from_pmac_float_words(self.read_word("X", addr), self.read_word("Y", addr))

    def write_word(self, space: str, addr: int, value: int) -> None:
        cs, off = divmod(addr - CS_BASE, CS_STRIDE)
        i10 = self.fw.ivars.values[10]
        if space == "X" and off == 0x00 and i10:
            self.fw.feed[cs] = value * 100 / i10
            self.fw.timebase.command(cs, float(self.fw.feed[cs]))
            return
        if off == 0x15:  # writing a timer sets Isx11/Isx12
            n = 5100 + 100 * cs + (11 if space == "X" else 12)
            v = value - (1 << 24) if value & (1 << 23) else value
            self.fw.set_ivar(n, float(v))
            return
        self.words[(space, addr)] = value


class FloatVariables:
    """P- or Q-variables as L: words: each address is one float of `values`."""

    def __init__(self, base: int, values: np.ndarray) -> None:
        self.base = base
        self.values = values

    def read_float(self, addr: int) -> float:
        return float(self.values[addr - self.base])

    def write_float(self, addr: int, value: float) -> None:
        self.values[addr - self.base] = value

    def read_word(self, space: str, addr: int) -> int:
        x, y = pmac_float_words(self.read_float(addr))
        return x if space == "X" else y

    def write_word(self, space: str, addr: int, value: int) -> None:
        x, y = pmac_float_words(self.read_float(addr))
        x, y = (value, y) if space == "X" else (x, value)
        self.write_float(addr, from_pmac_float_words(x, y))
