"""General-purpose I/O of a Turbo PMAC2: the JIO port (32 lines), the JTHW multiplexer port (16
lines), their buffer-direction bits, and the JANA analog inputs with automatic A/D
de-multiplexing [A §"Turbo PMAC General Purpose I/O Use" L487-675; spec pmac.md §1.2].

Registers (DSPGATE2 MACRO IC 0 at $078400):

* Y:$078400 bits 0-23 / Y:$078401 bits 0-7: JIO data I/O00-I/O31; the matching X bits are the
  per-line direction (1 = output) [A L501-530].
* Y:$078402: JTHW DAT0-7 (bits 0-7) and SEL0-7 (bits 8-15); X:$078402 their direction [A L578-600].
* X:$078404 / X:$078405 (JIO) and X:$078406 (JTHW): inversion, 1 = inverting (0 = +5 V) [A L545-556,
  L620-629]; Y:$078404-$078406: alternate-use selects, stored only (no supplemental channel
  functions are modelled) [A L558-562, L631-635].
* Y:$070800: buffer-IC direction, bits 0-3 the four JIO bytes, bits 4-5 JTHW DAT and SEL
  (PC-bus layout) [A L532-541, L604-609].
* Y:$078800: JANA ADC pair — a write selects and starts, a read returns ANAI00-07 in bits 0-11 and
  ANAI08-15 in bits 12-23 [A L651-655].

Electrical model: a line is driven by the card when its ASIC direction bit and its byte's buffer
bit are both 1; its level is then the data latch XOR the inversion bit. Any other line carries
the level the world puts on it (`set_input`), +5 V by default through the 10 kΩ pull-up
[A L493-495]. A data bit reads the latch for an ASIC output, else the line level XOR inversion.
"""

from __future__ import annotations

import math

from vdevd.devices.pmac.ivars import IVars
from vdevd.devices.pmac.memory import WORD, Memory

JIO = 0x078400
BUFFER_DIRECTION = 0x070800
JANA = 0x078800
DEMUX_RESULTS = 0x003400
#: A/D de-multiplexing I-variables [A L657-675, L3249, L3257]
I_RING_SIZE, I_ADDRESS, I_ENABLE, I_CODE = 5060, 5061, 5080, 5081
#: phase cycles per servo cycle = I7002 + 1 (Servo IC 0 supplies the clocks)
I_SERVO_DIVIDER = 7002
ADC_FULL_SCALE_V = 5.0
ADC_CODES = 4096


class Port:
    """A bank of I/O lines: data latch, per-line direction and inversion, per-byte buffer direction."""

    def __init__(self, lines: int) -> None:
        self.lines = lines
        self.mask = (1 << lines) - 1
        self.level_in = self.mask     # what the world drives; the pull-ups hold undriven lines high
        self.reset(0, 0, 0)

    def reset(self, direction: int, buffer: int, latch: int) -> None:
        self.latch = latch
        self.direction = direction
        self.inversion = 0
        self.alternate = 0
        self.buffer = buffer          # one bit per byte

    def driven(self) -> int:
        """Lines the card drives: ASIC output and buffer output."""
        buf = 0
        for byte in range((self.lines + 7) // 8):
            if self.buffer >> byte & 1:
                buf |= 0xFF << (8 * byte)
        return self.direction & buf & self.mask

    def levels(self) -> int:
        """Electrical level of each line (1 = +5 V)."""
        drv = self.driven()
        return (((self.latch ^ self.inversion) & drv) | (self.level_in & ~drv)) & self.mask

    def data(self) -> int:
        """What the data register reads."""
        return ((self.latch & self.direction) |
                ((self.level_in ^ self.inversion) & ~self.direction)) & self.mask


class GeneralIO:
    """JIO, JTHW, the buffer-direction word and JANA with A/D de-multiplexing, as memory Devices."""

    def __init__(self, memory: Memory, ivars: IVars) -> None:
        self.memory = memory
        self.ivars = ivars
        self.jio = Port(32)
        self.thw = Port(16)
        self.analog = [0.0] * 16
        memory.mount(JIO, JIO + 7, self)
        memory.mount(BUFFER_DIRECTION, BUFFER_DIRECTION, self)
        memory.mount(JANA, JANA, self)
        self.reset()

    def reset(self) -> None:
        """Power-up/reset: JIO all inputs, non-inverting, general purpose; JTHW DAT inputs and SEL
        outputs at 0, non-inverting [A L543, L556, L560, L593, L629, L635]."""
        self.jio.reset(direction=0, buffer=0, latch=0)
        self.thw.reset(direction=0xFF00, buffer=0b10, latch=0)
        self._buffer_other = 0
        self._plain: dict[tuple[str, int], int] = {}
        self._select = 0
        self._ring = 0

    # -- backdoor --------------------------------------------------------------------------------
    def set_input(self, line: int, level: bool) -> None:
        """The electrical level the world puts on JIO line 0-31 (True = +5 V)."""
        self.jio.level_in = _setbit(self.jio.level_in, line, level)

    def outputs(self) -> int:
        """The 32 JIO lines as they are on the connector (bit n = I/O n, 1 = +5 V)."""
        return self.jio.levels()

    def driven(self) -> int:
        """The JIO lines the card drives."""
        return self.jio.driven()

    def set_thw_input(self, line: int, level: bool) -> None:
        """The level on JTHW line 0-15 (DAT0-7 = 0-7, SEL0-7 = 8-15)."""
        self.thw.level_in = _setbit(self.thw.level_in, line, level)

    def thw_outputs(self) -> int:
        return self.thw.levels()

    def set_analog(self, channel: int, volts: float) -> None:
        """The voltage on ANAI00-15."""
        self.analog[channel] = volts

    # -- JANA [A L651-655] -----------------------------------------------------------------------
    def convert(self, channel: int, bipolar: bool) -> int:
        """12-bit code of ANAI `channel`: unipolar 0..+5 V straight binary, bipolar −2.5..+2.5 V
        two's complement; 5 V / 4096 per LSB, rounded, saturating (ASSUMPTION: coding not given)."""
        code = math.floor(self.analog[channel] / ADC_FULL_SCALE_V * ADC_CODES + 0.5)
        if bipolar:
            return max(-ADC_CODES // 2, min(ADC_CODES // 2 - 1, code)) & (ADC_CODES - 1)
        return max(0, min(ADC_CODES - 1, code))

    def _pair(self) -> int:
        lo, hi = self._select & 0xF, (self._select >> 12) & 0xF
        return self.convert(hi & 7 | 8, bool(hi & 8)) << 12 | self.convert(lo & 7, bool(lo & 8))

    # -- A/D de-multiplexing [A L657-675] --------------------------------------------------------
    def tick(self) -> None:
        """One servo cycle of de-multiplexing: the firmware converts one pair per phase cycle, so
        I7002+1 pairs of the I5060-pair ring are converted here, each written with its I5081+k
        code to its I5061+k address (0 = $078800) and its two 12-bit values stored in bits 12-23
        of Y:$003400+2k (low converter) and Y:$003401+2k (high). I5080=0 disables [A L3257]."""
        v = self.ivars.values
        if not v[I_ENABLE]:
            return
        pairs = min(int(v[I_RING_SIZE]), 16)
        if pairs <= 0:
            return
        for _ in range(min(int(v[I_SERVO_DIVIDER]) + 1, pairs)):
            k = self._ring % pairs
            self._ring = (k + 1) % pairs
            addr = int(v[I_ADDRESS + k]) & WORD or JANA
            self.memory.write("Y", addr, int(v[I_CODE + k]) & WORD)
            word = self.memory.read("Y", addr)
            self.memory.write("Y", DEMUX_RESULTS + 2 * k, (word & 0xFFF) << 12)
            self.memory.write("Y", DEMUX_RESULTS + 2 * k + 1, word & 0xFFF000)

    # -- Device ----------------------------------------------------------------------------------
    def read_word(self, space: str, addr: int) -> int:
        x = space == "X"
        if addr == BUFFER_DIRECTION:
            return (self.jio.buffer | self.thw.buffer << 4 | self._buffer_other) if not x else \
                self._plain.get((space, addr), 0)
        if addr == JANA:
            return self._plain.get((space, addr), 0) if x else self._pair()
        match addr - JIO:
            case 0 | 1 as i:
                reg = self.jio.direction if x else self.jio.data()
                return (reg >> (24 * i)) & (WORD if i == 0 else 0xFF)
            case 2:
                return self.thw.direction if x else self.thw.data()
            case 4 | 5 as i:
                reg = self.jio.inversion if x else self.jio.alternate
                return (reg >> (24 * (i - 4))) & (WORD if i == 4 else 0xFF)
            case 6:
                return self.thw.inversion if x else self.thw.alternate
        return self._plain.get((space, addr), 0)

    def write_word(self, space: str, addr: int, value: int) -> None:
        x = space == "X"
        if addr == BUFFER_DIRECTION and not x:
            self.jio.buffer = value & 0xF
            self.thw.buffer = (value >> 4) & 0x3
            self._buffer_other = value & ~0x3F
            return
        if addr == JANA and not x:
            self._select = value
            return
        match addr - JIO:
            case 0 | 1 as i:
                lo, width = 24 * i, 24 if i == 0 else 8
                if x:
                    self.jio.direction = _field(self.jio.direction, lo, width, value)
                else:
                    self.jio.latch = _field(self.jio.latch, lo, width, value)
            case 2:
                if x:
                    self.thw.direction = value & 0xFFFF
                else:
                    self.thw.latch = value & 0xFFFF
            case 4 | 5 as i:
                lo, width = 24 * (i - 4), 24 if i == 4 else 8
                if x:
                    self.jio.inversion = _field(self.jio.inversion, lo, width, value)
                else:
                    self.jio.alternate = _field(self.jio.alternate, lo, width, value)
            case 6:
                if x:
                    self.thw.inversion = value & 0xFFFF
                else:
                    self.thw.alternate = value & 0xFFFF
            case _:
                self._plain[(space, addr)] = value


def _setbit(word: int, bit: int, level: bool) -> int:
    return word | (1 << bit) if level else word & ~(1 << bit)


def _field(word: int, lo: int, width: int, value: int) -> int:
    mask = ((1 << width) - 1) << lo
    return (word & ~mask) | ((value << lo) & mask)
