"""How simulated time moves (DESIGN.md "Clock and scheduler", decision 0002): realtime pacing
to the wall clock and lockstep driving while someone waits.

`Pacer` owns the scheduler's advances: in realtime a waker (a thread sleeping to each deadline,
or a loop timer) hands a pass to the event loop, which runs every tick due by wall time and then
answers the waits; each request first catches up. In lockstep time moves only while a wait or a
`sim step` is pending, in chunks of LOCKSTEP_CHUNK_TICKS base ticks between looks at the sockets.
A card that raises in a tick is logged and counted; time goes on.
"""

from __future__ import annotations

import asyncio
import logging
import threading
import time
from collections.abc import Callable, Collection
from typing import Literal

from vdevd.metrics import Samples
from vdevd.rt.scheduler import Scheduler, Tickable
from vdevd.waits import Waits

log = logging.getLogger("vdevd.rack")

ClockMode = Literal["realtime", "lockstep"]
Waker = Literal["timer", "thread"]

#: lockstep: simulated ticks run between two looks at the socket while time is driven
LOCKSTEP_CHUNK_TICKS = 1000


class Pacer:
    """Moves the scheduler's time: paced to wall time (realtime) or driven by waits (lockstep)."""

    def __init__(self, sched: Scheduler, waits: Waits, mode: ClockMode, *, wake_ns: int,
                 waker: Waker, clock: Callable[[], int]) -> None:
        """`clock`: the monotonic wall clock in ns that realtime follows (a test may pass its own)."""
        self.sched = sched
        self.waits = waits
        self.mode: ClockMode = mode
        self.wake_ns = wake_ns
        self.waker: Waker = waker
        self._clock = clock
        self._loop: asyncio.AbstractEventLoop | None = None
        self._stop = threading.Event()
        self._thread: threading.Thread | None = None
        self.t0 = 0  # realtime: the wall clock reading at simulated time 0
        self.paced = False  # realtime and started: requests first run the ticks fallen due
        self._next_wake = 0
        self._driving = False
        # stats
        self.late = Samples()
        self.behind = Samples()
        self.passes = 0
        self.catch_ups = 0
        self.overruns = 0
        self.card_faults = 0

    # -- realtime ----------------------------------------------------------------------------------
    def start(self, loop: asyncio.AbstractEventLoop) -> None:
        """Attach to the event loop; in realtime start pacing simulated time to wall time."""
        self._loop = loop
        if self.mode != "realtime":
            return
        self.t0 = self._clock() - self.sched.now_ns
        self.paced = True
        self._next_wake = self.sched.now_ns + self.wake_ns
        if self.waker == "thread":
            self._thread = threading.Thread(target=self._wake_thread, name="vdevd-waker",
                                            daemon=True)
            self._thread.start()
        else:
            loop.call_later(self.wake_ns / 1e9, self._pass)

    def stop(self) -> None:
        self._stop.set()
        if self._thread is not None:
            self._thread.join(timeout=1.0)

    def _wake_thread(self) -> None:
        """Sleep to each wake deadline, then hand the pass to the event loop (no shared state)."""
        assert self._loop is not None
        loop, period, t0, clock = self._loop, self.wake_ns, self.t0, self._clock
        deadline = t0 + ((clock() - t0) // period + 1) * period
        while not self._stop.is_set():
            delay = deadline - clock()
            if delay > 0:
                time.sleep(delay / 1e9)
            try:
                loop.call_soon_threadsafe(self._pass)
            except RuntimeError:  # loop closed
                return
            deadline = t0 + ((clock() - t0) // period + 1) * period

    def _pass(self) -> None:
        """Realtime: run every tick due by wall time (a batch after a late wake), then waiters."""
        if self._stop.is_set():
            return
        wall = self._clock() - self.t0
        self.passes += 1
        self.late.add(wall - self._next_wake)
        self.behind.add(wall - self.sched.now_ns)
        if wall - self._next_wake >= self.wake_ns:
            self.overruns += 1
        self.advance(wall)
        self.waits.service(self.sched.now_ns)
        self._next_wake = wall - wall % self.wake_ns + self.wake_ns
        if self.waker == "timer" and self._loop is not None:
            delay = self._next_wake - (self._clock() - self.t0)
            self._loop.call_later(max(delay, 0) / 1e9, self._pass)

    def catch_up(self) -> None:
        """Realtime: run the ticks that fell due since the last pass, so that a request sees the
        hardware as it is at this wall time (within one servo period), not as at the last wake."""
        if self.paced:
            wall = self._clock() - self.t0
            if wall - self.sched.now_ns >= self.sched.tick_ns:
                self.catch_ups += 1
                self.advance(wall)
                self.waits.service(self.sched.now_ns)

    def advance(self, target_ns: int, stop: Callable[[], bool] | None = None,
                watched: Collection[Tickable] | None = None) -> int:
        """The scheduler's advance; a card bug must not stop the rack: logged, counted, and
        time moves on to the tick that raised."""
        try:
            return self.sched.advance(target_ns, stop, watched)
        except Exception:
            self.card_faults += 1
            log.exception("card raised during a tick; time continues")
            self.sched.settle(max(self.sched.now_ns, min(target_ns, self.sched.next_tick_ns())))
            return self.sched.now_ns

    # -- lockstep ----------------------------------------------------------------------------------
    def waiting(self) -> None:
        """A wait was left pending: in lockstep drive time until none is."""
        if self.mode != "lockstep" or self._driving:
            return
        self._driving = True
        if self._loop is None:
            self._drive_sync()
            return
        # The first chunk at once: a wait that resolves in it (a reply at the next tick)
        # costs no trip through the event loop; the rest runs as a task, between requests.
        try:
            self._drive_step()
        finally:
            if self.waits.pending:
                self._loop.create_task(self._drive())
            else:
                self._driving = False

    def _drive_step(self) -> None:
        """Advance to the earliest deadline or the end of one chunk, tick by tick (stopping at
        the tick a condition holds) when a waiter watches a condition."""
        target = self.waits.next_due_ns()
        chunk_end = self.sched.now_ns + LOCKSTEP_CHUNK_TICKS * self.sched.tick_ns
        target = chunk_end if target is None else min(target, chunk_end)
        fine = self.waits.needs_fine()
        stop = self.waits.any_fired if fine else None
        self.advance(max(target, self.sched.now_ns), stop, self.waits.watched() if fine else None)
        self.waits.service(self.sched.now_ns)

    async def _drive(self) -> None:
        """Lockstep: advance time while anyone waits, looking at the sockets between chunks."""
        try:
            while self.waits.pending:
                self._drive_step()
                await asyncio.sleep(0)
        finally:
            self._driving = False

    def _drive_sync(self) -> None:
        """Lockstep without an event loop (in-process use and tests)."""
        try:
            while self.waits.pending:
                self._drive_step()
        finally:
            self._driving = False
