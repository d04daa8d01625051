"""The high-speed position compare trigger and timer 0 [M §4.9.2; spec adlink.md §2.16, §3.3]:
two linear comparators (LCMP0-1), two table comparators (TCMP0-1, the FIFO comparators FCMP),
the trigger outputs TRG0-3 (2 on the AMP-204C, spec Q25) with their pulse shapers, and the timer.

A comparator's source is an axis's encoder counter (raw counts) or the timer. The card compares
far faster than a motion cycle, so every cycle the source is taken to move linearly from its
last sample to this one, and every compare point crossed on the way fires, in order, stamped
with the time it was crossed (spec §2.16 "Emulation note", ASSUMPTION): counts are exact however
many points a cycle passes. The TRG outputs are an event count and a level, not a waveform.
"""

from __future__ import annotations

import struct
from typing import TYPE_CHECKING, Any

import numpy as np
from vdevmaps.adlink import Bar
from vdevmaps.aps_defs import (
    IFCF0,
    ILCF0,
    TGR_CMP_DIR_BIDIR,
    TGR_CMP_DIR_NEGATIVE,
    TGR_CMP_DIR_POSITIVE,
    TGR_CMP_SRC_DISABLED,
    TGR_CMP_SRC_TIMER0,
    TGR_LCMP0_SRC,
    TGR_SRC_FCMP0,
    TGR_SRC_FCMP1,
    TGR_SRC_LCMP0,
    TGR_SRC_LCMP1,
    TGR_SRC_MANUAL,
    TGR_TCMP0_DIR,
    TGR_TCMP0_SRC,
    TGR_TRG0_LOGIC,
    TGR_TRG0_PWD,
    TGR_TRG0_SRC,
    TGR_TRG0_TGL,
    TGR_TRG_EN,
    TIMR_DIR,
    TIMR_EN,
    TIMR_ITV,
    TIMR_RING_EN,
)

from vdevd.devices.adlink.errors import invalid
from vdevd.devices.adlink.params import image_entries

if TYPE_CHECKING:
    from vdevd.devices.adlink.kernel import Kernel

COMPARATORS = 2  # LCMP0-1 and TCMP0-1 [M §4.9.2.2]
HW_FIFO, CTRL_FIFO = 255, 999  # the two FIFO levels of a table comparator [M §4.9.2.2.2]
FIFO_DATA_MAX = HW_FIFO + CTRL_FIFO  # what APS_set_trigger_fifo_data may queue (ASSUMPTION)
TABLE_MAX = 1_000_000  # vdevd's bound on a streamed table ("limited by system memory")
TABLE_FIRST, TABLE_LAST = 1, 2  # set_trigger_table's flags: a new table; arm it
FIFO_EMPTY, FIFO_FULL, FIFO_ENABLED = 0x1, 0x2, 0x4  # APS_get_trigger_fifo_status (ASSUMPTION)
#: the TRGx_SRC bits the AMP has: manual, FCMP0-1, LCMP0-1 (bit 1 reserved, MCMP and
#: FCMP2-3/LCMP2-3 belong to other cards or later firmware, spec §2.16)
SRC_MASK = TGR_SRC_MANUAL | TGR_SRC_FCMP0 | TGR_SRC_FCMP1 | TGR_SRC_LCMP0 | TGR_SRC_LCMP1
LCMP_BITS = (TGR_SRC_LCMP0, TGR_SRC_LCMP1)
TCMP_BITS = (TGR_SRC_FCMP0, TGR_SRC_FCMP1)
PWD_MIN, PWD_MAX = 2, 0xFFFFFF  # (N - 1) x 20 ns [X7]; spec Q24
ITV_MAX = 536_870_911  # TIMR_ITV N x 100 ns [X7]
INTERVAL_MAX = 16_777_215  # linear compare interval, pulses [X7]
_MOD32, _RING = 1 << 32, 1 << 31
_WINDOW = 4096  # compare points examined per vectorised step
_U32X4 = struct.Struct("<4I")
_I32 = struct.Struct("<i")


def defaults() -> dict[int, int]:
    """The trigger parameters at power-up [spec §3.3 ASSUMPTION]."""
    p = {TGR_LCMP0_SRC + i: TGR_CMP_SRC_DISABLED for i in range(4)}
    p |= {TGR_TCMP0_DIR: TGR_CMP_DIR_BIDIR, TGR_TCMP0_DIR + 1: TGR_CMP_DIR_BIDIR, TGR_TRG_EN: 0}
    for ch in range(4):
        p |= {TGR_TRG0_SRC + ch: 0, TGR_TRG0_PWD + ch: 6, TGR_TRG0_LOGIC + ch: 0,
              TGR_TRG0_TGL + ch: 0}
    return p | {TIMR_ITV: 10_000, TIMR_DIR: 0, TIMR_RING_EN: 0, TIMR_EN: 0}


def wrap_i32(v: int) -> int:
    return (v + _RING) % _MOD32 - _RING


def crossed(points: np.ndarray, a: int, step: int, mod: int, direction: int, start: int,
            inclusive: bool) -> tuple[int, np.ndarray]:
    """How many of `points` (in order) the source passes moving from `a` by `step` (mod `mod`),
    and their distances from `a`. A point fires when the source reaches or passes it in the
    compare direction, from `start` along the move on (where the last point fired; the cycle's
    start is exclusive unless the comparator was just armed: a point equal to the value at arm
    time fires at the next update, spec §2.16 and Q21 ASSUMPTION)."""
    if not len(points):
        return 0, points
    sign = -1 if step < 0 else 1
    allowed = (direction == TGR_CMP_DIR_BIDIR or step == 0
               or (direction == TGR_CMP_DIR_POSITIVE) == (step > 0))
    reach = abs(step) if allowed else 0
    dist = ((points - a) * sign) % mod
    ok = dist <= reach
    ok[0] &= dist[0] >= (start if inclusive else start + 1)
    ok[1:] &= dist[1:] >= dist[:-1]
    n = len(ok) if ok.all() else int(np.argmin(ok))
    return n, dist[:n]


class Comparator:
    """One comparator's compare points: a linear sequence or a table (FIFO); the next pending
    point is `pending()`, fired points advance `fired`."""

    def __init__(self, linear: bool) -> None:
        self.linear = linear
        self.armed = False  # comparing (a table comparator: enabled)
        self.fresh = False  # armed since the last update (Q21)
        self.fired = 0  # points fired of this sequence / table
        self.last = 0  # the last compare value fired (0 before any)
        self.start = self.repeat = self.interval = 0  # a linear sequence
        self.points = np.zeros(0, dtype=np.int64)  # a table (the library's, controller's, FIFO's)
        self.staging: list[int] | None = None  # a table being streamed in

    def remaining(self) -> int:
        if self.linear:
            return self.repeat - self.fired if self.armed else 0
        return len(self.points) - self.fired

    def window(self, count: int) -> np.ndarray:
        """The next `count` pending points (I32 values)."""
        if self.linear:
            idx = np.arange(self.fired, self.fired + count, dtype=np.int64)
            return (self.start + idx * self.interval + _RING) % _MOD32 - _RING
        return self.points[self.fired:self.fired + count]

    def pending(self) -> int:
        """APS_get_trigger_linear_cmp / _table_cmp: the next compare value, the last one when
        none is pending (ASSUMPTION)."""
        return int(self.window(1)[0]) if self.remaining() > 0 else self.last

    def direction(self, table_dir: int) -> int:
        """The compare direction: the sign of the interval (linear; 0 compares both ways), the
        TCMPx_DIR parameter (table) [M §4.9.2.2]."""
        if not self.linear:
            return table_dir
        if self.interval == 0:
            return TGR_CMP_DIR_BIDIR
        return TGR_CMP_DIR_POSITIVE if self.interval > 0 else TGR_CMP_DIR_NEGATIVE

    def run(self, a: int, step: int, mod: int, direction: int) -> list[int]:
        """The distances along this move (from `a`) of the points it fires."""
        out: list[int] = []
        at, inclusive = 0, self.fresh
        while self.remaining() > 0:
            pts = self.window(min(self.remaining(), _WINDOW))
            n, dist = crossed(pts, a, step, mod, direction, at, inclusive)
            if n == 0:
                break
            out.extend(dist.tolist())
            self.last = int(pts[n - 1])
            self.fired += n
            at, inclusive = int(dist[-1]), True
            if n < len(pts):
                break
        self.fresh = False
        return out


class TriggerUnit:
    """The compare trigger of one card: comparators, TRG outputs, timer 0."""

    def __init__(self, k: Kernel) -> None:
        self.k = k
        self.channels = 2 if k.n == 4 else 4  # TRG0-1 / TRG0-3 (spec Q25)
        self.params = defaults()
        self.reset()

    def reset(self) -> None:
        """Power-up: comparators disarmed, counts 0, the timer stopped at 0; the parameters
        are kept (flash image, like the board's)."""
        self.params[TIMR_EN] = 0
        self.lcmp = [Comparator(linear=True) for _ in range(COMPARATORS)]
        self.tcmp = [Comparator(linear=False) for _ in range(COMPARATORS)]
        self.count = [0] * 4  # pulses output on TRG0-3 (U32)
        self.level = [0] * 4  # TRG output level (toggle mode; after TRGx_LOGIC)
        self.last_event = [-1.0] * 4  # when TRG0-3 last fired, s of the kernel clock
        self.timer = 0  # timer 0's counter (I32; 0 ... 0x7FFFFFFF in ring mode)
        self.timer_phase = 0  # 100 ns units toward the next count
        self.prev_enc = self.k.core.axes.encoder.copy()

    # -- the cycle ---------------------------------------------------------------------------
    def before_motion(self, t: float) -> None:
        pass

    def busy(self) -> bool:
        """The timer counts, or a comparator waits for its first update."""
        return bool(self.params[TIMR_EN]) or any(c.fresh for c in self.lcmp + self.tcmp)

    def motion_only(self) -> bool:
        """Nothing counts or compares: the cycle's after-motion work only takes the encoder
        (runs.py)."""
        return not self.busy() and not any(c.armed and c.remaining() > 0
                                           for c in self.lcmp + self.tcmp)

    def after_motion(self, t: float) -> None:
        """Advance the timer, then run every armed comparator over the cycle's move."""
        enc = self.k.core.axes.encoder.copy()
        t_before, t_step = self.advance_timer()
        dt = self.k.dt
        for ch in range(COMPARATORS):
            for cmp, bits, src_no, done in (
                    (self.lcmp[ch], LCMP_BITS, TGR_LCMP0_SRC, ILCF0),
                    (self.tcmp[ch], TCMP_BITS, TGR_TCMP0_SRC, IFCF0)):
                if not cmp.armed or cmp.remaining() <= 0:
                    continue
                src = self.params[src_no + ch]
                if src == TGR_CMP_SRC_DISABLED:
                    continue
                if src == TGR_CMP_SRC_TIMER0:
                    a, step = t_before, t_step
                    mod = _RING if self.params[TIMR_RING_EN] else _MOD32
                else:
                    a, step, mod = int(self.prev_enc[src]), int(enc[src] - self.prev_enc[src]), _MOD32
                dists = cmp.run(a, step, mod, cmp.direction(self.params[TGR_TCMP0_DIR + ch]))
                if dists:
                    span = abs(step) or 1
                    self.fire(bits[ch], len(dists), t - dt + dists[-1] / span * dt)
                if cmp.remaining() == 0:
                    self.k.sys_events |= 1 << (done + ch)  # ILCFn / IFCFn [M §4.11]
        self.prev_enc = enc

    def advance_timer(self) -> tuple[int, int]:
        """Timer 0 over one cycle: (its value before, the counts it moved, signed)."""
        before = self.timer
        if not self.params[TIMR_EN]:
            return before, 0
        self.timer_phase += self.k.cycle_us * 10
        ticks, self.timer_phase = divmod(self.timer_phase, self.params[TIMR_ITV])
        step = -ticks if self.params[TIMR_DIR] else ticks
        self.timer = self.timer_value(before + step)
        return before, step

    def timer_value(self, v: int) -> int:
        """Counting past the end: a ring counter within 0 ... 0x7FFFFFFF, else I32 two's
        complement [X7 TIMR_RING_EN]."""
        return v % _RING if self.params[TIMR_RING_EN] else wrap_i32(v)

    def fire(self, source_bit: int, n: int, when: float) -> None:
        """`n` events of one trigger source: every enabled TRG output routed to it pulses
        (pulse mode) or toggles its level (toggle mode) n times [M §4.9.2]."""
        p = self.params
        for ch in range(self.channels):
            if not p[TGR_TRG0_SRC + ch] & source_bit or not p[TGR_TRG_EN] >> ch & 1:
                continue
            self.count[ch] = (self.count[ch] + n) & 0xFFFFFFFF
            if p[TGR_TRG0_TGL + ch]:
                self.level[ch] ^= n & 1
            self.last_event[ch] = when

    def publish(self) -> None:
        _U32X4.pack_into(self.k.buf, Bar.TRG_COUNT, *self.count)
        _I32.pack_into(self.k.buf, Bar.TIMER, wrap_i32(self.timer))

    def image(self) -> dict[str, int]:
        return {f"{no:#x}": v for no, v in self.params.items() if no != TIMR_EN}

    def restore(self, image: Any) -> int:
        """Take a saved image's legal parameters (TIMR_EN is no parameter: the timer starts
        stopped); the count of entries left out."""
        entries, dropped = image_entries(image)
        for no, v in entries:
            if (no in self.params and no != TIMR_EN and isinstance(v, int)
                    and not isinstance(v, bool) and self.legal(no, v)):
                self.params[no] = v
            else:
                dropped += 1
        return dropped

    # -- parameters ---------------------------------------------------------------------------
    def legal(self, no: int, v: int) -> bool:
        """A trigger parameter's value is in its range [spec §2.16 table]; a parameter of TRG2-3
        on the AMP-204C or of an axis it lacks is not."""
        ch = (no - TGR_TRG0_SRC) % 4
        if TGR_TRG0_SRC <= no <= TGR_TRG0_TGL + 3 and ch >= self.channels:
            return False
        if TGR_LCMP0_SRC <= no <= TGR_TCMP0_SRC + 1:
            return 0 <= v < self.k.n or v in (TGR_CMP_SRC_TIMER0, TGR_CMP_SRC_DISABLED)
        if no in (TGR_TCMP0_DIR, TGR_TCMP0_DIR + 1):
            return v in (TGR_CMP_DIR_NEGATIVE, TGR_CMP_DIR_POSITIVE, TGR_CMP_DIR_BIDIR)
        if no == TGR_TRG_EN:
            return 0 <= v < 1 << self.channels
        if TGR_TRG0_SRC <= no < TGR_TRG0_PWD:
            return v & ~SRC_MASK == 0
        if TGR_TRG0_PWD <= no < TGR_TRG0_LOGIC:
            return PWD_MIN <= v <= PWD_MAX
        if no == TIMR_ITV:
            return 1 <= v <= ITV_MAX
        return no in self.params and v in (0, 1)

    def channel(self, ch: int) -> int:
        if not 0 <= ch < self.channels:
            raise invalid(f"TRG channel {ch} outside 0..{self.channels - 1}")
        return ch

    def outputs(self) -> dict[str, Any]:
        """The backdoor's view: what TRG0-n output (count, level, pulse width) and the timer."""
        p = self.params
        n = self.channels
        return {
            "trg_count": self.count[:n],
            "trg_level": [self.level[c] ^ p[TGR_TRG0_LOGIC + c] for c in range(n)],
            "trg_width_ns": [(p[TGR_TRG0_PWD + c] - 1) * 20 for c in range(n)],
            "trg_last_s": self.last_event[:n],
            "timer": wrap_i32(self.timer),
        }


def unit(k: Kernel) -> TriggerUnit:
    return next(u for u in k.units if isinstance(u, TriggerUnit))


def _comparator_channel(ch: int) -> int:
    if not 0 <= ch < COMPARATORS:
        raise invalid(f"comparator {ch} outside 0..{COMPARATORS - 1}")
    return ch


# -- kernel commands [spec §4.8] ---------------------------------------------------------------

def set_trigger_param(k: Kernel, no: int, value: int) -> None:
    """APS_set_trigger_param [M §4.9.2]."""
    u = unit(k)
    if not u.legal(no, value):
        raise invalid(f"trigger parameter {no:#x} = {value}")
    u.params[no] = value


def get_trigger_param(k: Kernel, no: int) -> int:
    u = unit(k)
    if not u.legal(no, u.params.get(no, -1)):
        raise invalid(f"trigger parameter {no:#x}")
    return u.params[no]


def set_trigger_manual(k: Kernel, mask: int) -> None:
    """APS_set_trigger_manual(_s) [M §4.9.2.1]: one pulse on each TRG of `mask` whose source
    has the manual bit (and whose output is enabled, spec §2.16 ASSUMPTION)."""
    u = unit(k)
    if not 0 < mask < 1 << u.channels:
        raise invalid(f"TRG channels {mask:#x}")
    p = u.params
    for ch in range(u.channels):
        if mask >> ch & 1 and p[TGR_TRG0_SRC + ch] & TGR_SRC_MANUAL and p[TGR_TRG_EN] >> ch & 1:
            u.count[ch] = (u.count[ch] + 1) & 0xFFFFFFFF
            if p[TGR_TRG0_TGL + ch]:
                u.level[ch] ^= 1
            u.last_event[ch] = k.t


def set_trigger_linear(k: Kernel, ch: int, start: int, repeat: int, interval: int) -> None:
    """APS_set_trigger_linear [M §4.9.2.2.1]: points start + i x interval, i < repeat; the
    interval's sign is the compare direction. Re-arms the comparator."""
    _comparator_channel(ch)
    if repeat < 1 or abs(interval) > INTERVAL_MAX:
        raise invalid(f"RepeatTimes {repeat}, Interval {interval}")
    c = unit(k).lcmp[ch]
    c.start, c.repeat, c.interval = start, repeat, interval
    c.fired, c.armed, c.fresh = 0, True, True


def set_trigger_table(k: Kernel, ch: int, flags: int, points: list[int]) -> None:
    """APS_set_trigger_table [M §4.9.2.2.2], one part of a streamed table: the library loads a
    table of any size in parts; the last part arms it (the FIFOs then refill from it)."""
    _comparator_channel(ch)
    c = unit(k).tcmp[ch]
    if flags & ~(TABLE_FIRST | TABLE_LAST):
        raise invalid(f"table flags {flags}")
    staged = [] if flags & TABLE_FIRST else c.staging
    if staged is None:
        raise invalid("a table part with no first part")
    if len(staged) + len(points) > TABLE_MAX:
        raise invalid(f"a table over {TABLE_MAX} points")
    if flags & TABLE_LAST and not staged and not points:
        raise invalid("an empty table")
    staged = staged + points
    if flags & TABLE_LAST:
        c.points = np.asarray(staged, dtype=np.int64)
        c.fired, c.armed, c.fresh, c.staging = 0, True, True, None
    else:
        c.staging = staged


def get_trigger_linear_cmp(k: Kernel, ch: int) -> int:
    return unit(k).lcmp[_comparator_channel(ch)].pending()


def get_trigger_table_cmp(k: Kernel, ch: int) -> int:
    return unit(k).tcmp[_comparator_channel(ch)].pending()


def get_trigger_count(k: Kernel, ch: int) -> int:
    u = unit(k)
    return wrap_i32(u.count[u.channel(ch)])


def reset_trigger_count(k: Kernel, ch: int) -> None:
    u = unit(k)
    u.count[u.channel(ch)] = 0


def enable_trigger_fifo_cmp(k: Kernel, ch: int, enable: int) -> None:
    """APS_enable_trigger_fifo_cmp: start (1) or pause (0) table comparator `ch`, its points
    kept (spec §4.8 ASSUMPTION)."""
    c = unit(k).tcmp[_comparator_channel(ch)]
    if enable not in (0, 1):
        raise invalid(f"Enable {enable}")
    if enable and not c.armed:
        c.fresh = True
    c.armed = bool(enable)


def get_trigger_fifo_status(k: Kernel, ch: int) -> int:
    """Bit 0 empty, bit 1 hardware FIFO full, bit 2 enabled; bits 16-23 the hardware FIFO's
    usage (0-255) (vdevd's encoding, spec §4.8 ASSUMPTION)."""
    c = unit(k).tcmp[_comparator_channel(ch)]
    used = min(c.remaining(), HW_FIFO)
    return ((FIFO_EMPTY if used == 0 else 0) | (FIFO_FULL if used == HW_FIFO else 0)
            | (FIFO_ENABLED if c.armed else 0) | used << 16)


def set_trigger_fifo_data(k: Kernel, ch: int, shift: int, points: list[int]) -> None:
    """APS_set_trigger_fifo_data: queue points on table comparator `ch` (ShiftFlag 1 empties it
    first, spec §4.8 ASSUMPTION), at most the two FIFO levels (255 + 999) pending."""
    c = unit(k).tcmp[_comparator_channel(ch)]
    if shift not in (0, 1) or not points:
        raise invalid(f"ShiftFlag {shift}, {len(points)} points")
    kept = np.zeros(0, dtype=np.int64) if shift else c.points[c.fired:]
    if len(kept) + len(points) > FIFO_DATA_MAX:
        raise invalid(f"{len(points)} points: the FIFO holds {FIFO_DATA_MAX}")
    c.points = np.concatenate([kept, np.asarray(points, dtype=np.int64)])
    c.fired = 0


def _timer(ch: int) -> None:
    if ch != 0:
        raise invalid(f"timer {ch}: the card has timer 0")


def get_timer_counter(k: Kernel, ch: int) -> int:
    _timer(ch)
    return wrap_i32(unit(k).timer)


def set_timer_counter(k: Kernel, ch: int, value: int) -> None:
    """APS_set_timer_counter [M §4.9.2]; in ring mode the counter holds 0 ... 0x7FFFFFFF."""
    _timer(ch)
    u = unit(k)
    if u.params[TIMR_RING_EN] and value < 0:
        raise invalid(f"ring timer value {value}")
    u.timer = value


def start_timer(k: Kernel, ch: int, start: int) -> None:
    """APS_start_timer: TIMR_EN [spec §4.8]."""
    _timer(ch)
    if start not in (0, 1):
        raise invalid(f"Start {start}")
    unit(k).params[TIMR_EN] = start
