"""CUBIC_INT: cubic-spline contouring from the internal table in board RAM [Ch5 CUBIC_INT,
CUBIC_RATE, CUBIC_SCALE, LOAD_CUBIC_TABLE; Ch6 Table 6-10 ICUBCOUNT; spec octavia.md §5.4].

m table entries from index si, interleaved per axis in increasing axis order (m / k points for k
axes), scaled per axis by CUBIC_SCALE when the command runs; the velocities at the points come
from the C² spline through them (periodic when the run loops, natural for one pass); one point
every CUBIC_RATE samples, Hermite between points (the `Segments` of contour.py). The first
interval runs from the present commanded state; the run starts once the card interpreted the
command ("approximately 5 ms"). NOTES-contour.md lists the assumptions.
"""

from __future__ import annotations

from typing import TYPE_CHECKING

import numpy as np
from vdevmaps.octavia import Dpr, DspStat1, Window

from vdevd.devices.octavia.contour import Segments
from vdevd.devices.octavia.ram import CUBIC_POINTS
from vdevd.devices.octavia.spline import cubic_scale, spline_velocities
from vdevd.devices.octavia.state import Mode, axes_bits

if TYPE_CHECKING:
    from vdevd.devices.octavia.firmware import Firmware

MAX_ENTRIES = 2000  # "The maximum number of points is 2,000" [Ch5 CUBIC_INT]
INTERPRET_SAMPLES = 25  # "approximately 5 ms to interpret this command" [Ch5 CUBIC_INT]


class CubicInt(Segments):
    """One CUBIC_INT run: `points` (P, k) scaled positions and `vels` their velocities
    (counts/sample), `passes` passes (0: for ever) of P intervals of `samples` samples; `index`
    counts the intervals fetched. `delay` counts the interpretation samples left."""

    mode = Mode.CUBIC

    def __init__(self, fw: Firmware) -> None:
        super().__init__(fw)
        self.points = np.zeros((0, 0))
        self.vels = np.zeros((0, 0))
        self.first = 0  # the table index of the run's first entry (si)
        self.passes = 0
        self.samples = 0
        self.index = 0
        self.delay = 0
        self.count: int | None = None  # an ICUBCOUNT value the host's access byte deferred

    def reset(self) -> None:
        super().reset()
        self.delay = 0
        self.count = None

    def start(self, axes: list[int], entries: int, first: int, passes: int) -> None:
        """CUBIC_INT m=`entries`, si=`first`, n=`passes` on `axes` (0-based): the run starts
        after the interpretation time. ValueError (nothing done) when the entries are more than
        2000, fewer than the axes, or past the table's end."""
        if not 1 <= entries <= MAX_ENTRIES:
            raise ValueError(f"CUBIC_INT m={entries}: 1..{MAX_ENTRIES} table entries")
        if first + entries > CUBIC_POINTS:
            raise ValueError(f"CUBIC_INT si={first} m={entries}: past the {CUBIC_POINTS}-point table")
        k = len(axes)
        count = entries // k
        if not count:
            raise ValueError(f"CUBIC_INT m={entries}: fewer entries than its {k} axes")
        fw, p = self.fw, self.fw.params
        table = fw.ram.cubic_points(first, count * k).reshape(count, k)
        scaled = np.stack([cubic_scale(table[:, j], int(p.cubic_mult[a]), int(p.cubic_shift[a]))
                           for j, a in enumerate(axes)], axis=1).astype(np.float64)
        self.samples = int(p.cubic_rate)
        self.points = scaled
        self.vels = spline_velocities(scaled, self.samples, periodic=passes != 1)
        self.first, self.passes, self.index = first, passes, 0
        self.axes = np.array(axes, dtype=np.intp)
        self.path = np.zeros((0, k))
        self.t = 0
        self.fw.close_loop(self.axes)
        fw.mode[self.axes] = Mode.CUBIC
        self.delay = INTERPRET_SAMPLES
        self.count = None  # a count the last run could not publish is lost (README)
        self.running = True

    def redefined(self, axis: int, shift: float) -> None:
        """POS_SHIFT of a CUBIC_INT axis: its points and path move with its counter."""
        super().redefined(axis, shift)
        cols = np.flatnonzero(self.axes == axis)
        if self.running and len(cols):
            self.points[:, cols] += shift

    # -- the sample ------------------------------------------------------------------------------
    def step(self) -> None:
        """One sample while running (the firmware calls it before the core's tick)."""
        if self.count is not None:
            self.put_count(self.count)
        if self.released():  # STOP (*ESTOP, EN_ERRHLT) took axes: the others run on
            keep = self.fw.mode[self.axes] == Mode.CUBIC
            self.axes, self.path = self.axes[keep], self.path[:, keep]
            self.points, self.vels = self.points[:, keep], self.vels[:, keep]
            if not len(self.axes):
                self.running = False
                return
        if self.delay:  # interpreting: the run starts at the next sample
            self.delay -= 1
            if not self.delay:
                self.join(self.axes)
            return
        if self.t == len(self.path):
            if self.passes and self.index == self.passes * len(self.points):
                self.complete()
                return
            self.fetch()
        self.follow()

    def fetch(self) -> None:
        """The next interval: to the next point (the first again after the last, when looping);
        the run's last point is reached at rest. ICUBCOUNT shows the point's table index."""
        size = len(self.points)
        i = self.index % size
        self.index += 1
        v1 = self.vels[i]
        if self.passes and self.index == self.passes * size:
            v1 = np.zeros_like(v1)
        self.plan(self.points[i], v1, self.samples, cubic=True)
        self.put_count(self.first + i * len(self.axes))

    def complete(self) -> None:
        """The last interval ran: the axes hold, motion complete where enabled [Ch5 EN_MOTCP]."""
        fw, axes = self.fw, self.axes
        self.finish(axes)
        self.running = False
        done = np.zeros(fw.n, dtype=bool)
        done[axes] = fw.params.motcp_on[axes]
        if done.any():
            fw.post_stat1(DspStat1.MOTCP, axes_bits(done))

    def put_count(self, value: int) -> None:
        """ICUBCOUNT (482h, u16) under the 480h/481h access bytes: deferred while the host holds
        the window, written at the next sample it does not [Ch6 Table 6-10, Table 6-11]."""
        data = (value & 0xFFFF).to_bytes(2, "little")
        written = self.fw.windows.put_bytes(Window.COUNTERS, int(Dpr.ICUBCOUNT), data)
        self.count = None if written else value
