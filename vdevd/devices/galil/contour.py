"""Contour mode of the DMC-13X8 [M Ch6 §Contour Mode; spec §4.5].

`CM` puts axes in contour mode; `CD x,y,z,w` queues position increments (+-32000 counts) over the
interval `DT n`, 2^n samples (the manual's "2^n ms" at TM 1000); the card interpolates linearly,
one point a sample. With the buffer empty the axes wait where they are, no motion generated;
`DT 0` then `CD 0` leaves the mode once the buffer has run out, a limit switch the path heads
into at once (SC 2/3). `WC` waits until the interval before the last one given is complete,
`_CM` is 0 when the buffer is empty, else 1 [M Ch6].
"""

from __future__ import annotations

from collections import deque

import numpy as np

from vdevd.devices.galil.motion import GalilMotion, StopCode

CD_LIMIT = 32_000  # counts per interval [M Ch6 §Command Summary - Contour Mode]
DT_MAX = 8
#: segments the buffer holds (ASSUMPTION: the 511 of the DMC-1700/1800 family; the 13X8 manual
#: gives no size); a CD with the buffer full waits for space
BUFFER_SIZE = 511
SC_RUNNING, SC_STOPPED = 50, 51  # SC while and after contouring (spec §4.4)


class Contour:
    """The contour mode of one card: its axes, the interval, the buffer and the segment running."""

    def __init__(self, motion: GalilMotion) -> None:
        self.motion = motion
        self.on = False
        self.idx = np.zeros(0, dtype=np.int64)
        self.dt = 0  # DT n
        #: queued segments: (samples, increments of the contour axes); samples 0 ends the mode
        self.buffer: deque[tuple[int, np.ndarray]] = deque()
        self._start = np.zeros(0)  # where the running segment began
        self._inc = np.zeros(0)
        self._samples = 0  # of the running segment (0: none)
        self._k = 0
        self._holding = True

    @property
    def busy(self) -> bool:
        """_CM: a segment runs or waits in the buffer."""
        return bool(self._samples or self.buffer)

    @property
    def full(self) -> bool:
        return len(self.buffer) >= BUFFER_SIZE

    def begin(self, axes: list[int]) -> None:
        """CM axes: contour mode from the axes' commanded positions."""
        self.idx = np.asarray(sorted(axes), dtype=np.int64)
        self.on = True
        self._start = self.motion.core.axes.cmd_pos[self.idx].copy()
        self._samples, self._k, self._holding = 0, 0, True
        self.buffer.clear()
        self.motion.stop_code[self.idx] = SC_RUNNING

    def push(self, increments: np.ndarray) -> None:
        """CD: one segment over the present DT (DT 0 and all zero: the end of the mode)."""
        self.buffer.append((1 << self.dt if self.dt else 0, increments[self.idx].copy()))

    def leave(self, stop_code: int | None = SC_STOPPED) -> None:
        """Out of contour mode now (the end of the data, ST; AB with `stop_code` None: the
        abort's code stays): the axes hold where they are, their motion complete."""
        if not self.on:
            return
        self.on = False
        self.buffer.clear()
        self._samples = 0
        m = self.motion
        moving = self.idx[m.core.profile.moving[self.idx]]
        if stop_code is not None:
            m.stop_code[self.idx] = stop_code
            m.stop_reason[moving] = stop_code
        m.core.hold(moving)

    def step(self) -> None:
        """Before a sample: the next interpolated point of the running segment, the next segment
        when one ends, or (buffer empty) the axes hold where the last one ended."""
        if not self._samples:
            if not self.buffer:
                if not self._holding:
                    self.motion.core.track(self.idx, self._start)
                    self._holding = True
                return
            samples, inc = self.buffer.popleft()
            if not samples:
                self.leave()
                return
            if self._holding:
                self.motion.tracking(self.idx)
            self._samples, self._inc, self._k, self._holding = samples, inc, 0, False
        m = self.motion
        ahead = ((m.forward_limit[self.idx] & (self._inc > 0))
                 | (m.reverse_limit[self.idx] & (self._inc < 0)))
        if ahead.any():  # a limit switch in the way stops the contour [M Ch3 §Limit Switch Input]
            forward = bool((m.forward_limit[self.idx] & (self._inc > 0)).any())
            self.leave(StopCode.FORWARD_LIMIT if forward else StopCode.REVERSE_LIMIT)
            return
        self._k += 1
        k, n = self._k, self._samples
        self.motion.core.track(self.idx, self._start + self._inc * (k / n))
        if k == n:
            self._start = self._start + self._inc
            self._samples = 0
