"""How simulated time moves (DESIGN.md "Clock and scheduler", decisions 0002 and 0009): realtime
pacing to the wall clock and lockstep driving while someone waits.

`Pacer` owns the scheduler's advances: in realtime a waker (a thread sleeping to each deadline,
or a loop timer) hands a pass to the event loop, which runs the ticks due by wall time and then
answers the waits; each request first catches up. No piece of that work holds the loop longer
than SLICE_BUDGET_NS: time advances in slices, and what is left goes on at the loop's next turn,
after the sockets and signals. A rack that cannot keep up is overloaded once simulated time is
more than OVERLOAD_BEHIND_NS behind; simulated time then slips (decision 0009). In lockstep time
moves only while a wait or a `sim step` is pending, in chunks of at most LOCKSTEP_CHUNK_TICKS
base ticks and LOCKSTEP_BUDGET_NS of wall time between looks at the sockets. A card that raises in
a tick is logged and counted; time goes on.
"""

from __future__ import annotations

import asyncio
import ctypes
import logging
import threading
import time
from collections.abc import Callable, Collection
from typing import Literal

from vdevd.devices.base import QUIET_MIN
from vdevd.metrics import Samples
from vdevd.rt.scheduler import Scheduler, Tickable
from vdevd.waits import Waits

log = logging.getLogger("vdevd.rack")

ClockMode = Literal["realtime", "lockstep"]
Waker = Literal["timer", "thread"]

#: lockstep: base ticks run at most between two looks at the sockets while time is driven
LOCKSTEP_CHUNK_TICKS = 1000
#: lockstep: a chunk runs in slices of this many base ticks, the wall clock looked at between two
LOCKSTEP_SLICE_TICKS = 32
#: the wall time one turn of ticking may hold the event loop (a realtime pass, continuation or
#: request's catch-up, a lockstep chunk), give or take a slice; a request waits about this long
#: at most behind the clock's work
SLICE_BUDGET_NS = 2_000_000
#: lockstep: the wall time a chunk may hold the event loop (give or take a slice): a lockstep
#: client waits for its step anyway, and a longer turn lets cards at rest skip whole chunks
LOCKSTEP_BUDGET_NS = 10_000_000
#: realtime: simulated time further behind wall time than this is an overload; simulated time
#: then slips so that it stays this far behind (decision 0009)
OVERLOAD_BEHIND_NS = 100_000_000
#: an overload episode ends once simulated time has stayed at most CALM_BEHIND_NS behind for
#: CALM_HOLD_NS of wall time
CALM_BEHIND_NS = 10_000_000
CALM_HOLD_NS = 1_000_000_000
#: realtime: a request catches up once simulated time is this far behind (or a base tick)
CATCH_UP_NS = 100_000
#: a card that raises at every tick is logged at most once in this much wall time (with the
#: count of the faults in between; `stats` counts every one in `card_faults`)
FAULT_LOG_NS = 10_000_000_000
#: realtime: a pass of the scheduler later than this is a stall (issue 22): counted in `stats`
#: `scheduler.stalls` and logged once each
STALL_NS = 100_000_000
#: the waker thread's timer slack (Linux PR_SET_TIMERSLACK; the default is 50 us)
WAKER_SLACK_NS = 1_000


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
        #: realtime: the wall clock reading at simulated time 0; moves on when time slips
        self.t0 = 0
        self.paced = False  # realtime and started: requests first run the ticks fallen due
        self._next_wake = 0
        self._due = 0  # the clock's reading when the next pass is due (`_next_wake`, unslipped)
        self._posted = False  # the waker thread's pass is queued on the loop, not yet run
        self._continuing = False  # ticks still due are queued on the loop (`_work`)
        self._cost = 0.0  # wall ns per simulated ns of the last slice
        self._lock_span = 0  # lockstep: the simulated ns of the last slice of a chunk
        self._lock_wall = 0  # lockstep: and its wall ns
        self._driving = False
        # overload (decision 0009)
        self.overloaded = False
        self.episodes = 0
        self.slipped_ns = 0
        self._episode_start = 0  # wall clock at the episode's start
        self._episode_slip = 0  # slipped_ns at the episode's start
        self._calm_since: int | None = None
        # stats
        self.late = Samples()
        self.behind = Samples()
        #: how far simulated time is behind wall time as each request is answered
        self.answered_behind = Samples()
        self.passes = 0
        self.catch_ups = 0
        self.continuations = 0
        self.overruns = 0
        self.card_faults = 0
        #: passes more than STALL_NS late: how many, the longest and the sum of their lateness
        self.stalls = {"count": 0, "longest_ns": 0, "total_ns": 0}
        self._faults_logged = 0  # card_faults at the last one logged
        self._fault_logged_ns = -FAULT_LOG_NS

    # -- realtime ----------------------------------------------------------------------------------
    @property
    def clock(self) -> Callable[[], int]:
        """The wall clock it paces to (ns)."""
        return self._clock

    def start(self, loop: asyncio.AbstractEventLoop) -> None:
        """Attach to the event loop; in realtime start pacing simulated time to wall time."""
        self._loop = loop
        if self.mode != "realtime":
            return
        self.t0 = self._clock() - self.sched.now_ns
        self.paced = True
        self._next_wake = self.sched.now_ns + self.wake_ns
        self._due = self.t0 + self._next_wake
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

    def behind_ns(self) -> int:
        """Realtime: how far simulated time is behind wall time now (0 when not paced)."""
        return max(0, self._clock() - self.t0 - self.sched.now_ns) if self.paced else 0

    def _wake_thread(self) -> None:
        """Sleep to each wake deadline, then hand the pass to the event loop. Shares two plain
        attributes with the loop, no lock: the epoch, and a flag that keeps one pass queued at a
        time (a busy loop gets no backlog of passes)."""
        assert self._loop is not None
        _set_timer_slack(WAKER_SLACK_NS)
        loop, period, clock, stopped = self._loop, self.wake_ns, self._clock, self._stop.is_set
        pass_ = self._pass
        while not stopped():
            t0 = self.t0  # read at every deadline: it moves on when simulated time slips
            deadline = t0 + ((clock() - t0) // period + 1) * period
            delay = deadline - clock()
            if delay > 0:
                time.sleep(delay / 1e9)
            if self._posted:
                continue
            self._posted = True
            try:
                loop.call_soon_threadsafe(pass_)
            except RuntimeError:  # loop closed
                return

    def _pass(self) -> None:
        """Realtime: a wake; run the ticks due by wall time (`_work`) unless that work is
        already under way, then arm the next wake (timer waker)."""
        self._posted = False
        if self._stop.is_set():
            return
        wall = self._clock() - self.t0
        self.passes += 1
        late = wall - self._next_wake
        self.late.add(late)
        self.behind.add(wall - self.sched.now_ns)
        if late >= self.wake_ns:
            self.overruns += 1
        if wall + self.t0 - self._due > STALL_NS:  # on the clock: a slip meanwhile hides none
            self._stalled(wall + self.t0 - self._due)
        self._next_wake = wall - wall % self.wake_ns + self.wake_ns
        self._due = self.t0 + self._next_wake
        if not self._continuing:
            self._work()
        if self.waker == "timer" and self._loop is not None:
            # uvloop's timers count whole ms and fire at once below 1 ms: round up, never spin
            delay = self._due - self._clock()  # on the clock: a slip in `_work` moved t0
            self._loop.call_later(-(-max(delay, 1) // 1_000_000) / 1e3, self._pass)

    def _stalled(self, late: int) -> None:
        """A pass `late` ns late, more than STALL_NS: the event loop was held (a blocking call,
        a suspended process, a starved machine). Counted, and logged once."""
        stalls = self.stalls
        stalls["count"] += 1
        stalls["longest_ns"] = max(stalls["longest_ns"], late)
        stalls["total_ns"] += late
        log.warning("stall: a scheduler pass ran %.0f ms late (more than %.0f ms; stall %d): "
                    "the event loop was held", late / 1e6, STALL_NS / 1e6, stalls["count"])

    def _work(self) -> None:
        """Realtime: run the ticks due by wall time for at most SLICE_BUDGET_NS; what is left
        goes on at the loop's next turn, after the sockets. Then look at the overload."""
        self._continuing = False
        if self._stop.is_set():
            return
        start = self._clock()
        if not self._run(start - self.t0, start + SLICE_BUDGET_NS) and self._loop is not None:
            self._continuing = True
            self.continuations += 1
            self._loop.call_soon(self._work)
        self._check_overload()

    def _run(self, target: int, until: int) -> bool:
        """Advance towards `target` in slices, answering the waits after each, until the wall
        clock reads `until`; whether `target` was reached. A slice is at most one wake period
        of simulated time, less when the last slice says it would not fit the budget left, and
        at least one base tick."""
        sched, clock = self.sched, self._clock
        while sched.now_ns < target:
            t = clock()
            if t >= until:
                return False
            span = self.wake_ns
            if self._cost > 0.0:
                span = min(span, max(sched.tick_ns, int((until - t) / self._cost)))
            begin = sched.now_ns
            self.advance(min(target, begin + span))
            self.waits.service(sched.now_ns)
            if sched.now_ns == begin:  # a card raised and time could not move: the next pass
                return True
            self._cost = (clock() - t) / (sched.now_ns - begin)
        return True

    def _check_overload(self) -> None:
        """Overload episodes (decision 0009): beyond OVERLOAD_BEHIND_NS simulated time slips to
        stay that far behind; the episode ends once it stays within CALM_BEHIND_NS for
        CALM_HOLD_NS. Logged once at each start and end."""
        now = self._clock()
        behind = now - self.t0 - self.sched.now_ns
        if behind > OVERLOAD_BEHIND_NS:
            if not self.overloaded:
                self.overloaded = True
                self.episodes += 1
                self._episode_start, self._episode_slip = now, self.slipped_ns
                log.warning("overload: simulated time is %.0f ms behind wall time, more than "
                            "%.0f ms; it slips from now on, the rack runs slower than real time "
                            "(episode %d)", behind / 1e6, OVERLOAD_BEHIND_NS / 1e6, self.episodes)
            slip = behind - OVERLOAD_BEHIND_NS
            self.t0 += slip
            self.slipped_ns += slip
            self._calm_since = None
        elif self.overloaded:
            if behind > CALM_BEHIND_NS:
                self._calm_since = None
            elif self._calm_since is None:
                self._calm_since = now
            elif now - self._calm_since >= CALM_HOLD_NS:
                self.overloaded = False
                self._calm_since = None
                log.warning("overload over after %.1f s: simulated time slipped %.0f ms in the "
                            "episode (%.0f ms in all)", (now - self._episode_start) / 1e9,
                            (self.slipped_ns - self._episode_slip) / 1e6, self.slipped_ns / 1e6)

    def catch_up(self) -> None:
        """Realtime: run the ticks that fell due since the last pass, so that a request sees the
        hardware as it is at this wall time (within CATCH_UP_NS or a base tick), not as at the
        last wake; at most SLICE_BUDGET_NS of it, and none while a continuation is queued (the
        request is then answered from where simulated time is). Counts how far behind that is."""
        if not self.paced:
            return
        behind = self._clock() - self.t0 - self.sched.now_ns
        if not self._continuing and (behind >= CATCH_UP_NS or behind >= self.sched.tick_ns):
            self.catch_ups += 1
            self._work()
            behind = self._clock() - self.t0 - self.sched.now_ns
        self.answered_behind.add(behind)

    def overload_stats(self) -> dict[str, int | bool]:
        """The `stats` `overload` map (PROTOCOL.md)."""
        return {"active": self.overloaded, "episodes": self.episodes,
                "behind_ns": self.behind_ns(), "slipped_ns": self.slipped_ns,
                "threshold_ns": OVERLOAD_BEHIND_NS}

    def advance(self, target_ns: int, stop: Callable[[], bool] | None = None,
                watched: Collection[Tickable] | None = None) -> int:
        """The scheduler's advance; a card bug must not stop the rack: logged, counted, and
        time moves on to the tick that raised."""
        try:
            return self.sched.advance(target_ns, stop, watched)
        except Exception:
            self.card_faults += 1
            now = self._clock()
            if now - self._fault_logged_ns >= FAULT_LOG_NS:  # once a while, not once a tick
                more = self.card_faults - self._faults_logged - 1
                log.exception("card raised during a tick; time continues%s",
                              f" ({more} more since the last report)" if more else "")
                self._fault_logged_ns, self._faults_logged = now, self.card_faults
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
        the tick a condition holds) when a waiter watches a condition. The chunk runs in slices
        sized by what the last slices cost, to fill LOCKSTEP_BUDGET_NS of wall time (at least
        LOCKSTEP_SLICE_TICKS base ticks and QUIET_MIN ticks of the slowest card, at most 8
        times the last slice: a rack that starts
        moving overruns the budget by one slice at most), and ends at the slice that used the
        budget up. Where slices end changes no result (every advance is exact); a rack at rest
        runs whole chunks in one slice, which its cards run in closed form (decision 0008)."""
        sched, clock = self.sched, self._clock
        target, watched = self.waits.outlook()
        chunk_end = sched.now_ns + LOCKSTEP_CHUNK_TICKS * sched.tick_ns
        target = max(sched.now_ns, chunk_end if target is None else min(target, chunk_end))
        stop = self.waits.any_fired if watched is not None else None
        until = clock() + LOCKSTEP_BUDGET_NS
        # a slice holds enough ticks of every card for one at rest to skip the rest of them
        least = max(LOCKSTEP_SLICE_TICKS * sched.tick_ns, QUIET_MIN * sched.longest_ns)
        while True:
            t = clock()
            span = least
            if self._lock_span:
                grow = 8 * self._lock_span
                # a slice that cost little (cards at rest: a fixed cost, whatever its length)
                # grows 8 times; else it gets what its cost per simulated ns says fits
                fit = grow if self._lock_wall * 4 < LOCKSTEP_BUDGET_NS else (
                    (until - t) * self._lock_span // self._lock_wall)
                span = min(grow, max(least, fit))
            begin = sched.now_ns
            end = min(target, begin + span)
            reached = self.advance(end, stop, watched)
            if reached > begin:
                self._lock_span, self._lock_wall = reached - begin, max(1, clock() - t)
            if (reached >= target or reached < end or reached == begin
                    or (stop is not None and stop()) or clock() >= until):
                break
        self.waits.service(sched.now_ns)

    async def _drive(self) -> None:
        """Lockstep: advance time while anyone waits, looking at the sockets between chunks."""
        try:
            while self.waits.pending and not self._stop.is_set():
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


def _set_timer_slack(ns: int) -> None:
    """Ask Linux to wake the calling thread within `ns` of its deadlines (prctl
    PR_SET_TIMERSLACK); elsewhere, or if refused, the default slack stays."""
    try:
        libc = ctypes.CDLL(None, use_errno=True)
        libc.prctl(29, ctypes.c_ulong(ns), 0, 0, 0)  # 29: PR_SET_TIMERSLACK
    except (OSError, AttributeError):
        pass
