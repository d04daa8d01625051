"""Real-time position capture [S §3.7, Tables 3-5/3-6; spec oms.md §2.8].

Each axis with an incremental encoder (PSE, PSM) can record its encoder position when its home
switch input has a rising (0x01) or falling (0x04) edge, at an "encoder home event" (0x02), and
when general-purpose input lines have a rising or falling edge. The update cycle that sees the
edges makes one entry per axis with every bit that triggered it; the card puts the entries in
the shared-memory ring and writes OMR1 = 2 (INTA).

The encoder home event is the home condition the firmware sees coming true (encoder.py): in HI
mode the axis's home truth table (HT/EH) [S §4.8], at the exact count where its encoder terms
begin to hold while the switch term holds in that cycle, or in the cycle the switch term comes
true where they hold; in HS mode, whose home condition is the switch alone (bits 0x01/0x04),
the encoder's own home signal, the index pulse.

Edges are of the raw input levels (a "positive edge" is TTL low to high, whatever HH/HL say).
A probe position of the axis world (`[[card.axis]] probe`) is a probe wired to input line IOa of
its axis a: crossing it pulses the line (both edges in one cycle), and axis a's entry holds the
encoder count at the probe position itself (`probe`).
The seed names no command for the triggers ("see the MAX family command reference"); the ones
this card takes (CPH, CPR, CPF) are proposed in cmd_motion.py and the README.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import TYPE_CHECKING

import numpy as np
from vdevmaps.oms import HomeEvent

from vdevd.devices.oms.encoder import switch_holds

if TYPE_CHECKING:
    from vdevd.devices.oms.firmware import Firmware

# Table 3-6 byte 5 as plain ints (an IntFlag costs a conversion in numpy arithmetic)
HOME_RISING = int(HomeEvent.SWITCH_RISING)
INDEX = int(HomeEvent.ENCODER_HOME)
HOME_FALLING = int(HomeEvent.SWITCH_FALLING)
HOME_EVENTS = HOME_RISING | INDEX | HOME_FALLING


@dataclass(frozen=True, slots=True)
class Entry:
    """One capture table entry (Table 3-6)."""

    position: int
    axis: int
    home: int
    rising: int
    falling: int


class Capture:
    """The capture triggers of every axis and the entries waiting for the card to post."""

    def __init__(self, n: int) -> None:
        self.home = np.zeros(n, dtype=np.int64)  # HOME_RISING | INDEX | HOME_FALLING per axis
        self.rising = np.zeros(n, dtype=np.int64)  # GP input lines, rising edges, per axis
        self.falling = np.zeros(n, dtype=np.int64)
        self.armed = False
        self.pending: list[Entry] = []
        self._inputs = 0
        self._home_level = np.ones(n, dtype=bool)
        self._index = np.zeros(n, dtype=bool)  # axes capturing encoder home events
        self._probe_lines = 0  # GP lines a probe pulsed in this cycle
        self._probe_past: dict[int, float] = {}  # axis -> encoder counts run past its probe

    def configure(self, fw: Firmware) -> None:
        """After a trigger changed: arm, watch index pulses where asked, take the levels now as
        the reference for edges."""
        self.armed = bool((self.home | self.rising | self.falling).any())
        self._index = (self.home & INDEX) != 0
        m = fw.motion
        for a, bits in enumerate(self.home.tolist()):
            if bool(bits & INDEX) != bool(m.index_capture[a]):
                m.set_index_capture(a, bool(bits & INDEX))
        self._inputs = self._input_levels(fw)
        self._home_level = m.home_level.copy()

    @staticmethod
    def _input_levels(fw: Firmware) -> int:
        return fw.gpio_levels() & ~fw.gpio_dir & 0xFFFF

    def probe(self, fw: Firmware, a: int, past: float) -> None:
        """Axis a crossed a probe position of the axis world `past` physical counts before
        where it stands: its probe, wired to input line IOa, pulses the line (a falling and a
        rising edge within this cycle, too short for the I/O word). Axis a's entry holds the
        encoder count at the probe position."""
        if self.armed and a < 16:
            self._probe_lines |= 1 << a
            self._probe_past[a] = past * float(fw.motion.core.encoder_scale[a])

    def cycle(self, fw: Firmware) -> None:
        """One update cycle: the edges since the last one make entries."""
        m = fw.motion
        inputs = self._input_levels(fw)
        rise, fall = inputs & ~self._inputs, self._inputs & ~inputs
        pulsed, past = self._probe_lines & ~fw.gpio_dir, self._probe_past
        if self._probe_lines:
            rise, fall = rise | pulsed, fall | pulsed
            self._probe_lines, self._probe_past = 0, {}
        level = m.home_level
        changed = level != self._home_level
        index, index_at = self._encoder_home_events(fw, changed)
        if not (rise or fall or changed.any() or index.any()):
            return
        home = (np.where(changed & level, HOME_RISING, 0) | np.where(index, INDEX, 0)
                | np.where(changed & ~level, HOME_FALLING, 0)) & self.home
        rising, falling = self.rising & rise, self.falling & fall
        self._inputs = inputs
        self._home_level = level.copy()
        hit = np.flatnonzero(home | rising | falling)
        if not len(hit):
            return
        enc = fw.encoder_position()
        raw = m.core.axes.encoder
        sign = np.where(fw.params.encoder_inverted, -1, 1)
        for a in hit.tolist():
            position = float(enc[a])
            if home[a] & INDEX:  # the count of the event itself, as the host counts
                position -= sign[a] * (float(raw[a]) - float(index_at[a]))
            elif a in past and (rising[a] | falling[a]) & pulsed & 1 << a:  # its own probe
                position -= sign[a] * round(past[a])
            self.pending.append(Entry(int(position), a, int(home[a]), int(rising[a]),
                                      int(falling[a])))

    def _encoder_home_events(self, fw: Firmware,
                             changed: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """Axes with an encoder home event in this cycle and its raw encoder count: in HI mode
        the home truth table coming true (at a count the axis passed, or where it stands when
        the switch term came true: `changed` are the switches that changed), in HS mode an
        index pulse."""
        m = fw.motion
        enc = m.encoders
        hi = self._index & m.home_index
        if not hi.any():
            return enc.index_hit, enc.index_at
        entry, active = fw.params.home_pattern[:, 3], m.home_active()
        switch = switch_holds(entry, active)
        rose, at = enc.home_rise(hi)
        event = rose & switch
        came = hi & changed & switch
        if came.any():  # the switch term came true where the encoder terms hold
            came &= ~event & ~switch_holds(entry, self._home_level == fw.params.home_high)
            came &= enc.home_condition(hi, active)
            at = np.where(came, enc.core.axes.encoder, at)
            event |= came
        return (enc.index_hit & ~m.home_index) | event, np.where(hi, at, enc.index_at)
