"""PMAC2-style Servo IC (DSPGATE1) channel registers: flags, encoder counter, capture, outputs,
timers (1/T and MLDT) and the position-compare logic [A L94-203 MLDT, L750-894 compare, L2428-2443
I7mn9; spec pmac.md §1.1, §1.3, §1.5 "PMAC2 channel offset"].

Channel base b = IC base + 8·(n-1) (ICs 0 and 1 hold the on-board channels 1-8):

=====  ============================================  ==============================================
 off   X register                                    Y register
=====  ============================================  ==============================================
 b+0   flags/status (9 EQU, 11 capture, 14 CHC,      timer "between last two counts" / MLDT echo
       15 FAULT, 16 HMFL, 17 PLIM, 18 MLIM, 19 USER,  latch (I7mn0=12) / compare-A fraction bits
       20-23 W V U T)                                 0-11 when I7mn9=1 [A L871]
 b+1   24-bit encoder counter (read-only)             timer "since last count" / compare-B fraction
 b+2   (plain)                                        output A (DAC, Ixx02 default)
 b+3   captured position (a read re-arms capture)     output B
 b+4   (plain)                                        output C = PFM command (Mxx07) [A L138-157]
 b+5   control: 11 compare write enable (self-        ADC A
       clearing), 12 direct-write value, 18 extended
       count = I7mn9 [A L796-797, L859-863]
 b+6   compare auto-increment                         ADC B
 b+7   compare B                                      compare A
=====  ============================================  ==============================================

The compare logic runs once per servo cycle over the path the counter travelled since the last
cycle, vectorised over the channels whose compare is armed; with A = B and no auto-increment (the
power-up state) it can never change anything, so such channels cost nothing.
"""

from __future__ import annotations

import math
from collections.abc import Callable
from enum import IntEnum
from typing import Protocol

import numpy as np

from vdevd.devices.pmac.ivars import SERVO_IC_BASE, IVars
from vdevd.devices.pmac.memory import WORD, Memory

#: Servo IC master clock; SCLK = MASTER/2**(I7m03 bits 0-2), PFMCLK = MASTER/2**(bits 3-5) [SRM I7m03]
MASTER_CLOCK_HZ = 39_321_600.0
#: MLDT pulse timer frequency and the transducer's echo delay [A L201, L159, L423]
MLDT_TIMER_HZ = 117.96e6
MLDT_US_PER_MM = 0.35
#: 1/4096 count: the resolution of the extended-count compare [A L876]
SUB = 4096
_M36 = 1 << 36          # compare positions in 1/4096 count wrap with the 24-bit counter
_HALF36 = 1 << 35
#: most compare edges evaluated for one channel in one servo cycle (pathological auto-increments)
MAX_COMPARE_EVENTS = 4096


class ChannelFlag(IntEnum):
    """Bits of the channel status word X:b+0 [spec pmac.md §1.5, M-vars]."""

    COUNT_ERROR = 8
    EQU = 9
    CAPTURE = 11
    CHC = 14
    FAULT = 15
    HMFL = 16
    PLIM = 17
    MLIM = 18
    USER = 19
    W = 20
    V = 21
    U = 22
    T = 23


#: the input flags the card drives (set_flag); EQU and CAPTURE belong to the IC
INPUT_FLAGS = sum(1 << f for f in ChannelFlag if f not in (ChannelFlag.EQU, ChannelFlag.CAPTURE))
#: I7mn3 -> capture flag [SRM I7mn3]
_CAPTURE_FLAG_SELECT = np.array([ChannelFlag.HMFL, ChannelFlag.PLIM, ChannelFlag.MLIM, ChannelFlag.USER])

CTRL_WRITE_ENABLE = 1 << 11
CTRL_DIRECT_VALUE = 1 << 12
CTRL_EXTENDED = 1 << 18


class Encoders(Protocol):
    """Where the IC's counters come from: one value per channel, in counts (24-bit, wraps). A float
    array may carry the sub-count position (its fractional part), used by 1/T, hardware 1/T,
    extended-count compare and capture; an integer array means whole counts."""

    def encoder(self) -> np.ndarray: ...

    # optional: `encoder_into(out)` writes `encoder()` into a float array, with no allocation
    # (the IC reads the counters every cycle);
    # `keep_into(pos, counter)` keeps what `encoder()` is computed from now (the motors'
    # positions, floats, and counters, int64) and says whether it did, and
    # `encoder_from(pos, counter, out)` computes `encoder_into` from what it kept: the IC then
    # computes a cycle's counters only when they are looked at (`ServoIC.tick`)


def _s24(v: np.ndarray) -> np.ndarray:
    return ((v + (1 << 23)) & WORD) - (1 << 23)


def _s24i(v: int) -> int:
    return ((v + (1 << 23)) & WORD) - (1 << 23)


class ServoIC:
    """The channels of Servo ICs `ics` (default 0 and 1: on-board channels 1-8) as a memory Device."""

    def __init__(
        self, memory: Memory, ivars: IVars, encoders: Encoders, ics: tuple[int, ...] = (0, 1)
    ) -> None:
        self.ivars = ivars
        self.encoders = encoders
        self.n = 4 * len(ics)
        self.bases = [SERVO_IC_BASE[m] + 8 * ch for m in ics for ch in range(4)]
        self._channel_of = {b: c for c, b in enumerate(self.bases)}
        #: I-variable numbers I7mn0 and I7m00 per channel
        self._i7mn0 = np.array([7000 + 100 * m + 10 * (ch + 1) for m in ics for ch in range(4)])
        self._i7m00 = np.array([7000 + 100 * m for m in ics for _ in range(4)])
        self._first = np.array([4 * (c // 4) for c in range(self.n)])   # channel 1 of the same IC
        #: I7000.. up to the last IC's I7m49: watched for changes once per cycle
        self._cfg_span = slice(7000, 7000 + 100 * max(ics) + 50)
        self._cfg_values = ivars.values[self._cfg_span]  # a view: the array is never replaced
        self._not_first = np.arange(self.n) % 4 != 0
        for m in ics:
            memory.mount(SERVO_IC_BASE[m], SERVO_IC_BASE[m] + 0x1F, self)
        self.reset()

    # -- power-up / reset ------------------------------------------------------------------------
    def reset(self) -> None:
        """Power-up state: compare registers 0, outputs 0, flags low, capture armed, counter as now."""
        n = self.n
        self.flags = np.zeros(n, dtype=np.int64)
        self.equ = np.zeros(n, dtype=bool)
        self.cmp_a = np.zeros(n, dtype=np.int64)
        self.cmp_b = np.zeros(n, dtype=np.int64)
        self.cmp_inc = np.zeros(n, dtype=np.int64)
        self.frac_a = np.zeros(n, dtype=np.int64)
        self.frac_b = np.zeros(n, dtype=np.int64)
        self.ctrl = np.zeros(n, dtype=np.int64)
        self.cap_flag = np.zeros(n, dtype=bool)
        self.cap_armed = np.ones(n, dtype=bool)
        self.cap_pos = np.zeros(n, dtype=np.float64)
        self.y_regs = np.zeros((n, 8), dtype=np.int64)      # Y:b+2..b+6 stored as written
        self.plain: dict[tuple[str, int], int] = {}
        self.mldt_base_mm = np.zeros(n)
        self.mldt_latch = np.zeros(n, dtype=np.int64)
        self._pfm_phase = np.zeros(n)
        self._armed = np.zeros(n, dtype=bool)
        self._any_armed = False
        self._motors = m = len(self.encoders.encoder())
        self._wide = np.zeros(m)
        self._into = getattr(self.encoders, "encoder_into", None)
        self._pos = self._read_encoders()
        self._prev = self._pos.copy()
        #: the readings of this cycle (`_pos`) and the last (`_prev`) are computed when looked
        #: at (`materialize`): while stale, from the positions and counters kept at their cycle
        #: (lists, not arrays: derived state, out of `rest_state`, which looks at the readings)
        self._from = getattr(self.encoders, "encoder_from", None)
        self._keep = getattr(self.encoders, "keep_into", None) if self._from else None
        self._kept_pos: list[np.ndarray] = [np.zeros(m), np.zeros(m, dtype=np.int64)]
        self._kept_prev: list[np.ndarray] = [np.zeros(m), np.zeros(m, dtype=np.int64)]
        self._stale = [False, False]  # _pos, _prev
        self._cfg = b""
        self._mldt_ch = np.zeros(0, dtype=np.int64)
        self._cap_dirty = True

    # -- the servo cycle -------------------------------------------------------------------------
    def tick(self) -> None:
        """One servo cycle: sample the counters (what they are computed from, when the encoders
        can keep it: computed when looked at), run compare, capture and the MLDT timers. Idle
        channels cost nothing: compare runs when armed, capture when its inputs, arming or
        I7mn2/I7mn3 changed (it is level-triggered), the MLDT model only for I7mn0 = 12."""
        old, new = self._pos, self._prev  # two buffers in turn: no allocation per cycle
        self._prev, self._pos = old, new
        kept, stale = self._kept_prev, self._stale
        self._kept_prev, self._kept_pos = self._kept_pos, kept
        stale[1] = stale[0]
        keep = self._keep
        stale[0] = keep is not None and keep(kept[0], kept[1])
        if not stale[0]:
            self._read_encoders_into(new)
        if self._any_armed:
            self.materialize()
            self._compare(old, new)
        cfg = self._cfg_values.tobytes()
        if cfg != self._cfg:
            self._cfg = cfg
            self._mldt_ch = np.flatnonzero(self.ivars.values[self._i7mn0] == 12)
            self._cap_dirty = True
        if self._cap_dirty:
            self._cap_dirty = False
            self._capture()
        if self._mldt_ch.size:
            self._mldt(self._mldt_ch)

    def materialize(self) -> None:
        """The counters of this cycle and the last as they read: those still stale computed
        from what was kept at their cycle (every reader calls it; `rest_state` too)."""
        stale = self._stale
        if stale[0]:
            self._compute(self._pos, self._kept_pos)
            stale[0] = False
        if stale[1]:
            self._compute(self._prev, self._kept_prev)
            stale[1] = False

    def _compute(self, out: np.ndarray, kept: list[np.ndarray]) -> None:
        pos, counter = kept
        encoder_from = self._from
        assert encoder_from is not None  # kept only by encoders that compute from it
        self._fill(out, lambda values: encoder_from(pos, counter, values))

    def _read_encoders_into(self, out: np.ndarray) -> None:
        """`_read_encoders` into `out` (channels without a motor read 0)."""
        if self._into is None:  # an Encoders without the fast path
            np.copyto(out, self._read_encoders())
        else:
            self._fill(out, self._into)

    def _fill(self, out: np.ndarray, into: Callable[[np.ndarray], None]) -> None:
        """`into(values)` of the motors, onto the channels (channels without a motor read 0)."""
        m = self._motors
        if m == self.n:
            into(out)
        elif m < self.n:
            into(out[:m])
        else:
            into(self._wide)
            np.copyto(out, self._wide[: self.n])

    def _read_encoders(self) -> np.ndarray:
        v = np.array(self.encoders.encoder()[: self.n], dtype=np.float64)
        if v.size < self.n:
            v = np.concatenate([v, np.zeros(self.n - v.size)])
        return v

    def _ivar(self, k: int) -> np.ndarray:
        """I7mn k of every channel (ints)."""
        return self.ivars.values[self._i7mn0 + k].astype(np.int64)

    def extended_mode(self) -> np.ndarray:
        """I7mn9 = 1: hardware 1/T, sub-count compare and capture [A L859, L2441]."""
        return self.ivars.values[self._i7mn0 + 9] == 1

    # -- position compare [A L750-894] -----------------------------------------------------------
    def _update_armed(self, c: int) -> None:
        self._armed[c] = bool(self.cmp_a[c] != self.cmp_b[c] or self.cmp_inc[c] != 0
                              or self.frac_a[c] != self.frac_b[c])
        self._any_armed = bool(self._armed.any())

    def _compare_source(self) -> np.ndarray:
        """I7mn1=1 makes channels 2-4 compare on channel 1's encoder [A L774-776]."""
        return np.where(self._not_first & (self._ivar(1) == 1), self._first, np.arange(self.n))

    def _compare(self, old: np.ndarray, new: np.ndarray) -> None:
        """Toggle EQU where the counter left equality with A or B on its way from old to new, and
        step the other register by the auto-increment in the direction of motion [A L766-770].

        Both register kinds reduce to edges: leaving C upward is reaching C+1, downward reaching
        C-1; in extended-count mode the edges are C±1 + fraction/4096 [A L880]. Positions are in
        1/4096 count modulo 2**36; whole counts only unless the channel is in extended mode."""
        idx = np.flatnonzero(self._armed)
        src = self._compare_source()[idx]
        ext = self.extended_mode()[idx]
        p_old = np.where(ext, np.floor(old[src] * SUB), np.floor(old[src]) * SUB).astype(np.int64) % _M36
        p_new = np.where(ext, np.floor(new[src] * SUB), np.floor(new[src]) * SUB).astype(np.int64) % _M36
        d = (p_new - p_old + _HALF36) % _M36 - _HALF36
        keep = d != 0
        idx, ext, p_old, d = idx[keep], ext[keep], p_old[keep], d[keep]
        up = d > 0
        sign = np.where(up, 1, -1)
        dist = np.abs(d)
        done = np.zeros(idx.size, dtype=np.int64)
        for _ in range(MAX_COMPARE_EVENTS):
            if not idx.size:
                return
            a, b = self.cmp_a[idx], self.cmp_b[idx]
            fa = np.where(ext, self.frac_a[idx], 0)
            fb = np.where(ext, self.frac_b[idx], 0)
            ea = (a + sign) * SUB + fa
            eb = (b + sign) * SUB + fb
            da = np.where(up, ea - p_old, p_old - ea) % _M36
            db = np.where(up, eb - p_old, p_old - eb) % _M36
            hit_a = (da > done) & (da <= dist)
            hit_b = (db > done) & (db <= dist)
            hit = hit_a | hit_b
            if not hit.any():
                return
            at = np.minimum(np.where(hit_a, da, _M36), np.where(hit_b, db, _M36))
            hit_a &= da == at
            hit_b &= db == at
            self.equ[idx] ^= hit_a ^ hit_b
            step = self.cmp_inc[idx] * sign
            self.cmp_b[idx] = _s24(b + np.where(hit_a, step, 0))
            self.cmp_a[idx] = _s24(a + np.where(hit_b, step, 0))
            hit = hit_a | hit_b
            idx, ext, p_old, up, sign, dist = idx[hit], ext[hit], p_old[hit], up[hit], sign[hit], dist[hit]
            done = at[hit]

    def equ_outputs(self) -> np.ndarray:
        """The EQU output state per channel: channel 1 of an IC shows the OR of its own logic and
        that of the channels assigned to it by I7mn1 [A L776]."""
        out = self.equ.copy()
        assigned = self._not_first & (self._ivar(1) == 1) & self.equ
        for c in np.flatnonzero(assigned):
            out[self._first[c]] = True
        return out

    # -- hardware position capture [SRM I7mn2, I7mn3] ---------------------------------------------
    def _capture(self) -> None:
        """Level-triggered capture of armed channels: I7mn2 bit 0 use index (CHC), bit 1 use the
        flag chosen by I7mn3, bits 2/3 invert them; neither used = immediate capture."""
        self.materialize()
        idx = np.flatnonzero(self.cap_armed)
        ctl = self._ivar(2)[idx]
        sel = _CAPTURE_FLAG_SELECT[self._ivar(3)[idx] & 3]
        flags = self.flags[idx]
        index = ((flags >> ChannelFlag.CHC) & 1) ^ ((ctl >> 2) & 1)
        flag = ((flags >> sel) & 1) ^ ((ctl >> 3) & 1)
        trig = (((ctl & 1) == 0) | (index == 1)) & (((ctl & 2) == 0) | (flag == 1))
        hit = idx[trig]
        self.cap_pos[hit] = self._pos[hit]
        self.cap_flag[hit] = True
        self.cap_armed[hit] = False

    # -- MLDT [A L98-203, spec §1.1 "Emulator model"] --------------------------------------------
    def servo_period_s(self) -> float:
        """The servo period from I10 (1/8,388,608 ms)."""
        return float(self.ivars.values[10]) / 8_388_608 * 1e-3

    def _mldt(self, ch: np.ndarray) -> None:
        """Channels with I7mn0 = 12: the timer latches the echo time of the magnet's distance at the
        first output pulse of each PFM period, when the PFM output runs (I7mn6 = 2 or 3, Mxx07 != 0)
        and the echo returns before the next pulse [A L159, L187, L193-203]."""
        ic_global = self.ivars.values[self._i7m00[ch] + 3].astype(np.int64)
        pfmclk = MASTER_CLOCK_HZ / 2.0 ** ((ic_global >> 3) & 7)
        freq = self.y_regs[ch, 4] / 2.0**24 * pfmclk
        running = np.isin(self._ivar(6)[ch], (2, 3)) & (freq > 0)
        self._pfm_phase[ch] += np.where(running, freq * self.servo_period_s(), 0.0)
        pulsed = self._pfm_phase[ch] >= 1.0
        self._pfm_phase[ch] -= np.floor(self._pfm_phase[ch])
        lsb = self.mldt_base_mm[ch] * MLDT_US_PER_MM * MLDT_TIMER_HZ * 1e-6 + self._signed_count(ch)
        lsb = np.clip(np.floor(lsb + 0.5), 0, WORD)
        echo_s = lsb / MLDT_TIMER_HZ
        latch = pulsed & (echo_s * np.where(running, freq, 0.0) < 1.0)
        self.mldt_latch[ch[latch]] = lsb[latch].astype(np.int64)

    def _signed_count(self, ch: np.ndarray) -> np.ndarray:
        self.materialize()
        p = np.floor(self._pos[ch])
        return (p + (1 << 23)) % (1 << 24) - (1 << 23)

    # -- 1/T timers (synthesised from the sub-count position and the velocity) -------------------
    def _timers(self, c: int) -> tuple[int, int]:
        """("time between last two counts", "time since last count") in SCLK cycles."""
        sclk = MASTER_CLOCK_HZ / 2.0 ** (int(self.ivars.values[self._i7m00[c] + 3]) & 7)
        vel = (float(self._pos[c] - self._prev[c]) + (1 << 23)) % (1 << 24) - (1 << 23)
        if vel == 0:
            return WORD, WORD
        between = min(round(sclk * self.servo_period_s() / abs(vel)), WORD)
        p = float(self._pos[c])
        frac = p - math.floor(p) if vel > 0 else math.ceil(p) - p
        return between, min(round(frac * between), WORD)

    # -- what the ECT and the card read ----------------------------------------------------------
    def channel(self, addr: int) -> int | None:
        """The channel index (0-based) whose base address is `addr`, or None."""
        return self._channel_of.get(addr)

    def extended_position(self, addr: int, bits: int, hardware: bool) -> int | None:
        """The counter of the channel at base `addr` with `bits` fraction bits, 24-bit wrapped, for
        the ECT: software 1/T ($0, hardware False) needs I7mn9 = 0, hardware 1/T ($C mode 1) needs
        I7mn9 = 1; otherwise the fraction reads 0 [A L2435-2443, L2580-2590]. None: not ours."""
        c = self._channel_of.get(addr)
        if c is None:
            return None
        self.materialize()
        p = float(self._pos[c])
        if hardware != bool(self.ivars.values[self._i7mn0[c] + 9] == 1):
            return (math.floor(p) << bits) & WORD
        return math.floor(p * (1 << bits)) & WORD

    def counter(self, c: int) -> int:
        self.materialize()
        return math.floor(float(self._pos[c])) & WORD

    def dac(self) -> np.ndarray:
        """Output A (Y:b+2) per channel, signed 24-bit: what the servo wrote."""
        return _s24(self.y_regs[:, 2])

    def pfm(self) -> np.ndarray:
        """Output C / PFM command (Y:b+4, Mxx07 as a 24-bit value) per channel."""
        return self.y_regs[:, 4].copy()

    # -- backdoor --------------------------------------------------------------------------------
    def set_flag(self, c: int, flag: ChannelFlag, level: bool) -> None:
        """Drive input flag `flag` of channel c (0-based) as the IC reads it."""
        if not INPUT_FLAGS >> flag & 1:
            raise ValueError(f"{flag.name} is not an input flag")
        self.flags[c] = self.flags[c] | (1 << flag) if level else self.flags[c] & ~(1 << flag)
        self._cap_dirty = True

    def set_flag_levels(self, flag: ChannelFlag, levels: np.ndarray) -> None:
        """Drive input flag `flag` of the first len(levels) channels at once (the axis world)."""
        if not INPUT_FLAGS >> flag & 1:
            raise ValueError(f"{flag.name} is not an input flag")
        k = min(len(levels), self.n)
        bit = 1 << int(flag)
        now = self.flags[:k]
        new = np.where(levels[:k], now | bit, now & ~bit)
        if not np.array_equal(new, now):
            self.flags[:k] = new
            self._cap_dirty = True

    def set_mldt_base(self, c: int, mm: float) -> None:
        """Distance of the magnet from the MLDT head (mm) at encoder count 0 of channel c: one
        timer LSB is one count, ~0.024 mm [A L421-425]."""
        self.mldt_base_mm[c] = mm

    def set_adc(self, c: int, a: int, b: int) -> None:
        """The serial ADC words of channel c (Y:b+5, Y:b+6)."""
        self.y_regs[c, 5] = a & WORD
        self.y_regs[c, 6] = b & WORD

    # -- Device ----------------------------------------------------------------------------------
    def _locate(self, addr: int) -> tuple[int, int]:
        r = addr & 7
        return self._channel_of.get(addr - r, -1), r

    def read_word(self, space: str, addr: int) -> int:
        c, r = self._locate(addr)
        if c < 0:
            return self.plain.get((space, addr), 0)
        self.materialize()  # the counter, the 1/T timers, the sub-count bits
        if space == "X":
            return self._read_x(c, r, addr)
        return self._read_y(c, r, addr)

    def _read_x(self, c: int, r: int, addr: int) -> int:
        match r:
            case 0:
                return int(self.flags[c]) | int(self.equ_outputs()[c]) << 9 | int(self.cap_flag[c]) << 11
            case 1:
                return self.counter(c)
            case 3:
                self.cap_flag[c] = False
                self.cap_armed[c] = True
                self._cap_dirty = True
                return math.floor(float(self.cap_pos[c])) & WORD
            case 5:
                ext = int(self.ivars.values[self._i7mn0[c] + 9] == 1)
                return int(self.ctrl[c]) | ext << 18
            case 6:
                return int(self.cmp_inc[c]) & WORD
            case 7:
                return int(self.cmp_b[c]) & WORD
        return self.plain.get(("X", addr), 0)

    def _read_y(self, c: int, r: int, addr: int) -> int:
        if r >= 2:
            return int(self.cmp_a[c]) & WORD if r == 7 else int(self.y_regs[c, r])
        if self.ivars.values[self._i7mn0[c] + 9] == 1:
            # extended-count mode: high 12 bits hardware sub-count (capture / present), low 12 the
            # compare fraction [A L867-876]; the high halves are an ASSUMPTION
            p = float(self.cap_pos[c] if r == 0 else self._pos[c])
            hw = math.floor((p - math.floor(p)) * SUB)
            return hw << 12 | int(self.frac_a[c] if r == 0 else self.frac_b[c])
        if self.ivars.values[self._i7mn0[c]] == 12:
            return int(self.mldt_latch[c]) if r == 0 else 0
        return self._timers(c)[r]

    def write_word(self, space: str, addr: int, value: int) -> None:
        c, r = self._locate(addr)
        if c < 0:
            self.plain[(space, addr)] = value
        elif space == "X":
            self._write_x(c, r, addr, value)
        elif r >= 2:
            if r == 7:
                self.cmp_a[c] = _s24i(value)
                self._update_armed(c)
            else:
                self.y_regs[c, r] = value
        elif self.ivars.values[self._i7mn0[c] + 9] == 1:
            if r == 0:
                self.frac_a[c] = value & 0xFFF
            else:
                self.frac_b[c] = value & 0xFFF
            self._update_armed(c)

    def _write_x(self, c: int, r: int, addr: int, value: int) -> None:
        match r:
            case 0 | 1 | 3:
                return          # status, counter and capture registers are read-only
            case 5:
                if value & CTRL_WRITE_ENABLE:
                    self.equ[c] = bool(value & CTRL_DIRECT_VALUE)
                self.ivars.values[self._i7mn0[c] + 9] = float(bool(value & CTRL_EXTENDED))
                self.ctrl[c] = value & ~(CTRL_WRITE_ENABLE | CTRL_EXTENDED)
            case 6:
                self.cmp_inc[c] = _s24i(value)
                self._update_armed(c)
            case 7:
                self.cmp_b[c] = _s24i(value)
                self._update_armed(c)
            case _:
                self.plain[("X", addr)] = value
