"""Data sampling: up to 8 channels of motion-kernel signals recorded every `rate` motion cycles
into a ring of SAMP_RING records in the card, a triggered capture with pre-trigger, and
continuous (auto) sampling the host drains [M §4.9.4, Table 4-4; spec adlink.md §2.19, Q28].

The manual documents the sources only; the API comes from ADLINK's headers [X1], [X3], so its
semantics are the spec's Q28 proposal (ASSUMPTION): a record is {tick, data[8]}, the tick the
motion-cycle counter; `rate` is in cycles (1 = every cycle); an F64 source fills its channel with
the low and the next channel with the high I32 word of the IEEE double; the trigger is the
trigger channel's value crossing `level` (edge 0 rising: before < level <= now; 1 falling:
before > level >= now), judged from one sample to the next. vdevd's further choices, also Q28:
the trigger is armed once PreTrgLen records are held (a capture always has its pre-trigger
records), the trigger record is the first after them, parameters change only while nothing
samples (-15), and a capture or auto sampling runs one at a time (-15).
"""

from __future__ import annotations

import struct
from typing import TYPE_CHECKING

import numpy as np
from vdevmaps.adlink import SAMP_RING, SAMP_WORDS, Bar, SampState, samp_records_per_reply
from vdevmaps.aps_defs import (
    MAX_SAMPL_CH,
    MIO_EZ,
    MIO_INP,
    MIO_ORG,
    MTS_ACC,
    MTS_CSTP,
    MTS_DEC,
    MTS_MDN,
    MTS_VM,
    SAMP_AXIS_MASK,
    SAMP_CMD_VEL,
    SAMP_CMD_VEL_F64,
    SAMP_COM_POS,
    SAMP_COM_POS_F64,
    SAMP_CONTROL_VOL,
    SAMP_CONTROL_VOL_F64,
    SAMP_ENCODER_RAW,
    SAMP_ERR_POS_F64,
    SAMP_ERROR_COUNTER,
    SAMP_FBK_POS,
    SAMP_FBK_POS_F64,
    SAMP_FBK_VEL,
    SAMP_FBK_VEL_F64,
    SAMP_GTY_DEVIATION,
    SAMP_MIO,
    SAMP_MIO_INP,
    SAMP_MIO_ORG,
    SAMP_MIO_ZERO,
    SAMP_MSTS,
    SAMP_MSTS_ACC,
    SAMP_MSTS_CSTP,
    SAMP_MSTS_DEC,
    SAMP_MSTS_MV,
    SAMP_MSTS_NSTP,
    SAMP_PA_EDGE,
    SAMP_PA_LEVEL,
    SAMP_PA_RATE,
    SAMP_PA_SRC_CH0,
    SAMP_PA_SRC_CH3,
    SAMP_PA_TRIGCH,
    SAMP_PARAM_MASK,
    SAMP_PTBUFF_COMP_ACC_F64,
    SAMP_PTBUFF_COMP_VEL_F64,
    SAMP_PTBUFF_RUN_INDEX,
    SAMP_PWM_DUTY_CYCLE_F64,
    SAMP_PWM_FREQUENCY_F64,
    SAMP_PWM_WIDTH_F64,
    SAMP_VAO_COMP_VEL_F64,
)

from vdevd.devices.adlink.errors import busy, invalid

if TYPE_CHECKING:
    from vdevd.devices.adlink.kernel import Kernel

_AXIS = "axis"
#: source -> what its index numbers (axis, PWM channel 0-3, VAO 0-1, point table 0-1)
#: [M §4.9.4, Table 4-4; X2]
SOURCES: dict[int, str] = {
    **{s: _AXIS for s in (
        SAMP_COM_POS, SAMP_FBK_POS, SAMP_CMD_VEL, SAMP_FBK_VEL, SAMP_MIO, SAMP_MSTS,
        SAMP_MSTS_ACC, SAMP_MSTS_MV, SAMP_MSTS_DEC, SAMP_MSTS_CSTP, SAMP_MSTS_NSTP, SAMP_MIO_INP,
        SAMP_MIO_ZERO, SAMP_MIO_ORG, SAMP_CONTROL_VOL, SAMP_GTY_DEVIATION, SAMP_ENCODER_RAW,
        SAMP_ERROR_COUNTER, SAMP_COM_POS_F64, SAMP_FBK_POS_F64, SAMP_CMD_VEL_F64,
        SAMP_FBK_VEL_F64, SAMP_CONTROL_VOL_F64, SAMP_ERR_POS_F64)},
    SAMP_PWM_FREQUENCY_F64: "pwm", SAMP_PWM_DUTY_CYCLE_F64: "pwm", SAMP_PWM_WIDTH_F64: "pwm",
    SAMP_VAO_COMP_VEL_F64: "vao", SAMP_PTBUFF_COMP_VEL_F64: "table",
    SAMP_PTBUFF_COMP_ACC_F64: "table", SAMP_PTBUFF_RUN_INDEX: "table",
}
_INDEXES = {"pwm": 4, "vao": 2, "table": 2}
#: the sources recorded as F64 (two channels)
F64_SOURCES = frozenset(range(SAMP_COM_POS_F64, SAMP_PTBUFF_COMP_ACC_F64 + 1)) & set(SOURCES)
#: the status bits of the single-bit sources: (word 0 MSTS / 1 MIO, bit)
_BITS = {SAMP_MSTS_ACC: (0, MTS_ACC), SAMP_MSTS_MV: (0, MTS_VM), SAMP_MSTS_DEC: (0, MTS_DEC),
         SAMP_MSTS_CSTP: (0, MTS_CSTP), SAMP_MSTS_NSTP: (0, MTS_MDN), SAMP_MIO_INP: (1, MIO_INP),
         SAMP_MIO_ZERO: (1, MIO_EZ), SAMP_MIO_ORG: (1, MIO_ORG)}
_STATUS = frozenset({SAMP_MIO, SAMP_MSTS, *_BITS})
_D = struct.Struct("<d")
_LOHI = struct.Struct("<ii")
def _i32(v: float) -> int:
    """A value as the I32 the card records: rounded, wrapping at 2^32 like its counters (Q20)."""
    return (int(round(v)) + 2**31) % 2**32 - 2**31


class Sampling:
    """The sampling unit of one card (a kernel unit, kernel.py)."""

    def __init__(self, k: Kernel, size: int = SAMP_RING) -> None:
        self.k = k
        self.size = size  # records the ring holds
        self.ring = np.zeros((size, SAMP_WORDS), dtype=np.int32)
        self.reset()

    def reset(self) -> None:
        self.rate, self.edge, self.level, self.trig_ch = 1, 0, 0, 0
        self.sources: list[tuple[int, int]] = [(SAMP_COM_POS, 0)] * MAX_SAMPL_CH
        self.state = SampState(0)
        self.head = self.tail = 0  # records written and the first one held (ring indexes)
        self.length = self.pre = 0
        self.since = 0  # cycles since sampling started
        self.seen = 0  # records taken while the capture waits for its trigger
        self.prev: float | None = None  # the trigger channel's value at the last record

    # -- the unit --------------------------------------------------------------------------------
    def busy(self) -> bool:
        return bool(self.state & SampState.AUTO) or self.capturing()

    def capturing(self) -> bool:
        return (self.state & (SampState.ARMED | SampState.DONE)) == SampState.ARMED

    def before_motion(self, t: float) -> None:
        pass

    def after_motion(self, t: float) -> None:
        if not self.busy():
            return
        self.since += 1
        if self.since % self.rate:
            return
        self.sample()
        self.publish()  # at once: the host's wait on Bar.SAMP_STATUS sees this very cycle

    def sample(self) -> None:
        """Take one record: into the auto ring, or the capture's pre-trigger or post part."""
        values = self.record()
        if self.state & SampState.AUTO:
            self.head += 1
            if self.head - self.tail > self.size:
                self.tail = self.head - self.size
                self.state |= SampState.LOST
            return
        now = values[self.trig_ch]
        if not self.state & SampState.TRIGGERED:
            if self.seen >= self.pre and self.prev is not None and self.crossed(self.prev, now):
                self.state |= SampState.TRIGGERED
                self.tail = self.head - self.pre
            self.seen += 1
            self.prev = now
        self.head += 1
        if not self.state & SampState.TRIGGERED:
            self.tail = max(self.tail, self.head - self.pre)
        elif self.head - self.tail >= self.length:
            self.state |= SampState.DONE

    def crossed(self, before: float, now: float) -> bool:
        if self.edge == 0:
            return before < self.level <= now
        return before > self.level >= now

    def record(self) -> list[float]:
        """Write the record at `head` (not yet counted); the channels' values for the trigger:
        an I32 channel's word, an F64 source's double on its first channel."""
        k = self.k
        if any(src in _STATUS for src, _ in self.sources):
            k.status_words()  # this cycle's, not the last one's (the kernel's events() follow)
        row = self.ring[self.head % self.size]
        row[0] = _i32(k.cycles)
        values: list[float] = [0.0] * MAX_SAMPL_CH
        ch = 0
        while ch < MAX_SAMPL_CH:
            src, idx = self.sources[ch]
            v = self.value(src, idx)
            if src in F64_SOURCES:
                lo, hi = _LOHI.unpack(_D.pack(v))
                row[1 + ch], row[2 + ch] = lo, hi
                values[ch], values[ch + 1] = v, hi
                ch += 2
            else:
                word = _i32(v)
                row[1 + ch] = word
                values[ch] = word
                ch += 1
        return values

    def value(self, src: int, i: int) -> float:
        """A source's value now, pulses and pulses/s [M §4.9.4, Table 4-4]."""
        k = self.k
        ax = k.core.axes
        if src in (SAMP_COM_POS, SAMP_COM_POS_F64):
            return float(ax.cmd_pos[i])
        if src in (SAMP_FBK_POS, SAMP_ENCODER_RAW, SAMP_FBK_POS_F64):
            return float(ax.encoder[i])
        if src in (SAMP_CMD_VEL, SAMP_CMD_VEL_F64):
            return float(ax.cmd_vel[i])
        if src in (SAMP_FBK_VEL, SAMP_FBK_VEL_F64):
            return float(ax.vel[i] if k.drive == "servo" else ax.cmd_vel[i] * k.svon[i])
        if src in (SAMP_ERROR_COUNTER, SAMP_ERR_POS_F64):
            return float(ax.cmd_pos[i] - ax.fb[i])
        if src == SAMP_MSTS:
            return float(k.msts[i])
        if src == SAMP_MIO:
            return float(k.mio[i])
        if src in _BITS:
            word, bit = _BITS[src]
            return float((int((k.mio if word else k.msts)[i]) >> bit) & 1)
        for u in k.units:  # PWM, VAO, point table: the unit that has it answers
            sample = getattr(u, "sample", None)
            got = sample(src, i) if sample is not None else None
            if got is not None:
                return float(got)
        return 0.0  # the output voltage (closed loop only), a gantry deviation no unit reports

    def publish(self) -> None:
        buf = self.k.buf
        struct.pack_into("<II", buf, Bar.SAMP_STATUS, int(self.state), self.head - self.tail)

    # -- parameters --------------------------------------------------------------------------------
    def source(self, ch: int, src: int, idx: int, channels: int) -> tuple[int, int]:
        """A checked source of channel `ch` of a `channels`-channel form (-10)."""
        kind = SOURCES.get(src)
        if kind is None:
            raise invalid(f"channel {ch}: source {src:#x} unknown")
        count = self.k.n if kind == _AXIS else _INDEXES[kind]
        if not 0 <= idx < count:
            raise invalid(f"channel {ch}: {kind} {idx} outside 0..{count - 1}")
        if src in F64_SOURCES and ch == channels - 1:
            raise invalid(f"channel {ch}: an F64 source needs two channels")
        return src, idx

    def check_common(self, rate: int, edge: int, trig_ch: int) -> None:
        if self.busy():
            raise busy("sampling runs")
        if rate < 1:
            raise invalid(f"rate {rate} below 1 cycle")
        if edge not in (0, 1):
            raise invalid(f"edge {edge} not 0 (rising) or 1 (falling)")
        if not 0 <= trig_ch < MAX_SAMPL_CH:
            raise invalid(f"trigger channel {trig_ch} outside 0..{MAX_SAMPL_CH - 1}")


def unit(k: Kernel) -> Sampling:
    return k.sampling


def set_sampling_param(k: Kernel, no: int, value: int) -> None:
    """APS_set_sampling_param(Board, ParaNum, ParaDat) [X1, X2]: SAMP_PA_RATE (cycles),
    SAMP_PA_EDGE, SAMP_PA_LEVEL, SAMP_PA_TRIGCH, SAMP_PA_SRC_CH0-3 (signal | axis << 8)."""
    s = unit(k)
    rate, edge, trig_ch = s.rate, s.edge, s.trig_ch
    if no == SAMP_PA_RATE:
        rate = value
    elif no == SAMP_PA_EDGE:
        edge = value
    elif no == SAMP_PA_TRIGCH:
        trig_ch = value
    elif no not in (SAMP_PA_LEVEL, *range(SAMP_PA_SRC_CH0, SAMP_PA_SRC_CH3 + 1)):
        raise invalid(f"sampling parameter {no:#x} unknown")
    s.check_common(rate, edge, trig_ch)
    if SAMP_PA_SRC_CH0 <= no <= SAMP_PA_SRC_CH3:
        if value & ~(SAMP_AXIS_MASK | SAMP_PARAM_MASK):
            raise invalid(f"source word {value:#x}")
        ch = no - SAMP_PA_SRC_CH0
        s.sources[ch] = s.source(ch, value & SAMP_PARAM_MASK, (value & SAMP_AXIS_MASK) >> 8, 4)
    elif no == SAMP_PA_LEVEL:
        s.level = value
    s.rate, s.edge, s.trig_ch = rate, edge, trig_ch


def get_sampling_param(k: Kernel, no: int) -> int:
    s = unit(k)
    if SAMP_PA_SRC_CH0 <= no <= SAMP_PA_SRC_CH3:
        src, idx = s.sources[no - SAMP_PA_SRC_CH0]
        return src | idx << 8
    values = {SAMP_PA_RATE: s.rate, SAMP_PA_EDGE: s.edge, SAMP_PA_LEVEL: s.level,
              SAMP_PA_TRIGCH: s.trig_ch}
    if no not in values:
        raise invalid(f"sampling parameter {no:#x} unknown")
    return values[no]


def set_sampling_param_ex(k: Kernel, rate: int, edge: int, level: int, trig_ch: int,
                          by_ch: list[int]) -> None:
    """APS_set_sampling_param_ex(Board, SAMP_PARAM*) [X3]: all 8 channels at once,
    sourceByCh[ch] = {source, axis}; the channel after an F64 source holds its high word (its
    own entry is not used)."""
    s = unit(k)
    s.check_common(rate, edge, trig_ch)
    if len(by_ch) != 2 * MAX_SAMPL_CH:
        raise invalid("sourceByCh is 8 x 2")
    sources, ch = list(s.sources), 0
    while ch < MAX_SAMPL_CH:
        sources[ch] = s.source(ch, by_ch[2 * ch], by_ch[2 * ch + 1], MAX_SAMPL_CH)
        if sources[ch][0] in F64_SOURCES:
            sources[ch + 1] = (by_ch[2 * ch + 2], by_ch[2 * ch + 3])
            ch += 1
        ch += 1
    s.rate, s.edge, s.level, s.trig_ch, s.sources = rate, edge, level, trig_ch, sources


def get_sampling_param_ex(k: Kernel) -> tuple[int, int, int, int, list[int]]:
    s = unit(k)
    return s.rate, s.edge, s.level, s.trig_ch, [v for pair in s.sources for v in pair]


def start_trigger_sampling(k: Kernel, length: int, pre: int) -> None:
    """APS_wait_trigger_sampling(_ex/_async): a capture of `length` records, `pre` of them
    before the trigger record; it starts sampling now (the client waits on Bar.SAMP_STATUS)."""
    s = unit(k)
    if s.busy():
        raise busy("sampling runs")
    if not 1 <= length <= s.size:
        raise invalid(f"Length {length} outside 1..{s.size}")
    if not 0 <= pre < length:
        raise invalid(f"PreTrgLen {pre} outside 0..Length-1")
    s.head = s.tail = s.since = s.seen = 0
    s.prev = None
    s.length, s.pre = length, pre
    s.state = SampState.ARMED


def stop_sampling(k: Kernel) -> None:
    """APS_stop_wait_sampling: the capture is abandoned (its records dropped); auto sampling
    goes on."""
    s = unit(k)
    if s.state & SampState.ARMED:
        s.state &= ~(SampState.ARMED | SampState.TRIGGERED | SampState.DONE)
        s.head = s.tail = 0


def auto_sampling(k: Kernel, start: int) -> None:
    """APS_auto_sampling(Board, StartStop): 1 records continuously into the ring (the oldest
    unread records are overwritten when it is full: LOST); 0 stops, the unread records stay."""
    s = unit(k)
    if start not in (0, 1):
        raise invalid(f"StartStop {start} not 0 or 1")
    if not start:
        s.state &= ~SampState.AUTO
        return
    if s.capturing():
        raise busy("a trigger capture runs")
    if not s.state & SampState.AUTO:
        s.head = s.tail = s.since = 0
        s.state = SampState.AUTO


def _rows(s: Sampling, first: int, count: int, channels: int) -> list[int]:
    idx = np.arange(first, first + count) % s.size
    return s.ring[idx, :1 + channels].ravel().tolist()


def _channels(channels: int) -> None:
    if channels not in (4, MAX_SAMPL_CH):
        raise invalid(f"records of {channels} channels (4CH or 8CH)")


def read_sampling(k: Kernel, first: int, count: int, channels: int) -> tuple[list[int]]:
    """Records first..first+count-1 of the capture (tick, data[channels] each), as many as one
    reply carries; the capture keeps them."""
    s = unit(k)
    _channels(channels)
    held = s.head - s.tail if s.state & SampState.ARMED else 0
    if first < 0 or count < 0 or first + count > held or count > samp_records_per_reply(channels):
        raise invalid(f"records {first}+{count} of {held}")
    return (_rows(s, s.tail + first, count, channels),)  # the reply's one field


def take_sampling(k: Kernel, count: int, channels: int) -> tuple[int, list[int]]:
    """APS_get_sampling_data(_ex): up to `count` of the oldest unread auto-sampling records (as
    many as one reply carries), removed from the ring; the status before LOST is cleared."""
    s = unit(k)
    _channels(channels)
    if count < 0:
        raise invalid(f"Length {count}")
    if s.state & SampState.ARMED:
        raise busy("the ring holds a trigger capture")
    n = min(count, s.head - s.tail, samp_records_per_reply(channels))
    rows = _rows(s, s.tail, n, channels)
    s.tail += n
    status = int(s.state)
    s.state &= ~SampState.LOST
    return status, rows
