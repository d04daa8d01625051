"""The card contract (DESIGN.md "Card"): regions, interrupt lines, firmware ticks, backdoor.

A card package subclasses `Card`, declares its configuration keys in `options` (read back, checked
and defaulted, as `self.opts`), builds its regions and lines in `__init__`, advances its firmware
in `step()` (one servo tick), speaks the shared backdoor vocabulary (backdoor.py) over its axis
world and marks its own backdoor methods with `@control`. The rack owns the clock: it sets
`now_ns` before every tick.
"""

from __future__ import annotations

import importlib
import inspect
from collections.abc import Callable, Mapping
from dataclasses import dataclass, field
from fractions import Fraction
from typing import Any, ClassVar

from vdevd.devices.backdoor import WorldBackdoor, control, flag, flag_params
from vdevd.devices.options import CardOptions, Option, parse_options
from vdevd.errors import ErrorCode, VdevError
from vdevd.irq import IrqEvent, IrqLine
from vdevd.nvram import NvramStore
from vdevd.pci import ConfigSpace, PciIdentity
from vdevd.region import Backing, Region
from vdevd.rt.world import AxisWorld
from vdevd.scope.signals import Signals

__all__ = ["Card", "CardContext", "CardOptions", "Option", "control"]

EventSink = Callable[[IrqEvent], None]

#: a card that is moving looks whether it came to rest after 1, 2, 4, ... ticks, at most every
#: QUIET_CHECK ticks (two `rest_state` calls a look); a lockstep slice holds at least QUIET_MIN
#: ticks of every card
QUIET_CHECK = 64
QUIET_MIN = 16


@dataclass
class CardContext:
    """What the rack gives a card: where to emit interrupts, its non-volatile store, and the
    memory its regions with passive ranges take (`Region(..., memory=ctx.memory)`; None:
    private memory, as in-process racks and tests have)."""

    emit: EventSink
    nvram: NvramStore | None = None
    memory: Backing | None = None
    extra: dict[str, Any] = field(default_factory=dict)


class Card(WorldBackdoor):
    """Base of every virtual card."""

    type_name: ClassVar[str] = ""
    endian: ClassVar[str] = "little"
    options: ClassVar[Mapping[str, Option]] = {}
    #: the option that counts the card's axes: it bounds the `[[card.axis]]` tables and sets the
    #: length of the `per_axis` options
    axes_option: ClassVar[str] = "axes"
    #: the servo period in ns when the configuration gives none (exact: a Fraction may say it)
    default_period_ns: ClassVar[int | Fraction] = 1_000_000

    #: what sets the card's period instead of `period_ns` (which it then refuses), for
    #: `vdevd types`: "tm_us sets it"
    period_from: ClassVar[str | None] = None
    #: deprecated parameter names of actions: {action: {old name: name}} (kept for old scripts)
    control_params: ClassVar[Mapping[str, Mapping[str, str]]] = {}
    #: quiet ticks run in closed form (`tick`); the rack turns it off to tick every period
    #: (`[clock] skip_quiet = false`: the equality tests compare both)
    skip_quiet: bool = True
    #: the card runs stretches of its ticks itself between its looks for rest (`run`)
    runs_ticks: ClassVar[bool] = False

    def __init__(self, name: str, config: Mapping[str, Any], ctx: CardContext) -> None:
        """`config`: the card's options, as config loading checked them, or a plain mapping
        (checked here, ValueError naming the key)."""
        self.name = name
        self.opts: CardOptions = parse_options(self.options, config, name, self.axes_option)
        self.check_options(self.opts, name)
        self.config = dict(self.opts)
        self.ctx = ctx
        self.world = AxisWorld(0)
        self.now_ns = 0
        self.ticks = 0
        self.set_period(self.opts.period_ns or self.default_period_ns)
        self.regions: dict[str, Region] = {}
        self.irq_lines: dict[str, IrqLine] = {}
        self.irq_seq = 0
        self.last_event: IrqEvent | None = None
        self.line_events: dict[str, IrqEvent] = {}
        #: set by an assertion so a batch of ticks stops at the tick that interrupted
        self.pause = False
        #: ticks run in closed form at rest (stats)
        self.quiet_skipped = 0
        #: counts what may have changed the card's inputs (`touched`); the card is proven at rest
        #: while `_rest_epoch` equals it; it looks again at tick `_rest_due`, `_rest_wait` ticks
        #: after the last look that found it moving
        self.inputs_epoch = 0
        self._rest_epoch = -1
        self._rest_due = 0
        self._rest_wait = 1
        self._polled = b""  # `polled_state` when the card was proven at rest
        self._controls = self._collect_controls()

    @classmethod
    def check_options(cls, opts: CardOptions, where: str) -> None:
        """What one option cannot check alone: options that must agree (override; ValueError
        naming the key under `where`)."""

    # -- building ------------------------------------------------------------------------------
    def make_world(self, n: int) -> AxisWorld:
        """The axis world of the card's n axes from its `[[card.axis]]` tables."""
        self.world = AxisWorld(n, self.opts.axis)
        return self.world

    def add_region(self, region: Region) -> Region:
        """Add a region; the host's accesses to it touch the card (`touched`)."""
        self.regions[region.name] = region
        region.on_access = self.touched
        return region

    def add_config_space(self, identity: PciIdentity, irq: IrqLine | None) -> ConfigSpace:
        """A PCI card's `config` region: its type 0 header, status bit 3 following `irq`."""
        space = ConfigSpace(identity, irq)
        self.add_region(space.region)
        return space

    def add_irq(self, name: str) -> IrqLine:
        line = IrqLine(name, self._emit)
        self.irq_lines[name] = line
        return line

    def _emit(self, line: IrqLine, status: int) -> None:
        self.irq_seq += 1
        event = IrqEvent(self.name, line.name, self.irq_seq, self.now_ns, status)
        self.last_event = event
        self.line_events[line.name] = event
        self.pause = True
        self.ctx.emit(event)

    # -- the clock (DESIGN.md "Time that costs nothing", decision 0007) ---------------------------
    @property
    def period(self) -> Fraction:
        """The servo period in ns, exact."""
        return Fraction(self._period_num, self._period_den)

    @property
    def period_ns(self) -> int:
        """The servo period rounded to whole ns (describe, hello, stats)."""
        return self._period_ns

    @period_ns.setter
    def period_ns(self, value: int) -> None:
        self.set_period(value)

    def set_period(self, period: int | Fraction) -> None:
        """Change the servo period (ns, exact). Set at a tick (by its firmware, or right after
        it), the next tick comes one new period later; set between ticks, the cycle under way
        ends when it was due and the new period counts from there. Tick k is then at
        t + floor((k - n) x period) from that tick n at t, and `period_changed(period)` runs at
        the start of the first tick of the new length (`retimes`: each change still to come,
        so two changes before one tick each reach the tick whose length they set)."""
        exact = Fraction(period)
        if exact <= 0:
            raise ValueError(f"servo period {period} ns is not positive")
        if not hasattr(self, "_period_num"):  # being built: the clock starts at 0
            self._base_ns = self._base_ticks = self._last_tick_ns = 0
            #: told of every later change (the scheduler's base tick)
            self.on_period: Callable[[], None] | None = None
            self.retimes: list[tuple[int, Fraction]] = []  # no period_changed: built with it
            self._set_base(0, 0, exact)
            return
        if self.now_ns == self._last_tick_ns:
            base, base_ticks = self.now_ns, self.ticks
        else:
            base, base_ticks = self.time_of_tick(self.ticks + 1), self.ticks + 1
        self.retimes = [r for r in self.retimes if r[0] <= base_ticks]  # later ones superseded
        self.retimes.append((base_ticks + 1, exact))
        self._set_base(base, base_ticks, exact)
        self.touched()
        self.pause = True  # a batch of ticks under way stops here: the scheduler recounts
        if self.on_period is not None:
            self.on_period()

    def _set_base(self, base_ns: int, base_ticks: int, exact: Fraction) -> None:
        self._base_ns, self._base_ticks = base_ns, base_ticks
        self._period_num, self._period_den = exact.numerator, exact.denominator
        self._period_ns = round(exact)

    def period_changed(self, period: Fraction) -> None:
        """A tick of a new length `period` (ns, exact) begins: firmware and motion take it from
        here (override)."""

    def begin_tick(self) -> None:
        """Count the tick about to run and set its time; a new period takes effect here."""
        k = self.ticks = self.ticks + 1
        # time_of_tick(k), inlined: every tick of every card runs this
        self.now_ns = self._last_tick_ns = (self._base_ns + (k - self._base_ticks)
                                            * self._period_num // self._period_den)
        if self.retimes and self.retimes[0][0] == k:
            self.period_changed(self.retimes.pop(0)[1])

    def ticks_run(self, k: int) -> None:
        """A card that runs its ticks in batches (overriding `tick`) ran `k` more: count them
        and set the time of the last (the batch must stop before a tick in `retimes`)."""
        self.ticks += k
        self.now_ns = self._last_tick_ns = self.time_of_tick(self.ticks)

    def time_of_tick(self, k: int) -> int:
        """The simulated time of tick k (k >= the ticks run when the period was last set):
        floor of the exact time, so the long-run rate is the exact period's."""
        return (self._base_ns
                + (k - self._base_ticks) * self._period_num // self._period_den)

    def ticks_due(self, t: int) -> int:
        """The count of ticks whose time is at most `t` (before the tick a new period counts
        from, the ticks before it: they ran on the old period)."""
        if t < self._base_ns:
            return self._base_ticks - 1
        return (self._base_ticks
                + ((t - self._base_ns + 1) * self._period_den - 1) // self._period_num)

    # -- the firmware ----------------------------------------------------------------------------
    def step(self) -> None:
        """One servo tick of the firmware at `now_ns` (override)."""

    def tick(self, n: int) -> int:
        """Run up to n ticks; stop early after a tick that asserted an interrupt.

        Returns the number of ticks run. Cards may override for speed but must count `ticks` and keep
        `now_ns` (= `time_of_tick(ticks)`) the time of the tick being run. A card at rest runs
        its ticks in closed form (`rest_state`, `skip`; the steps of `rest_enter`,
        `rest_before`, `rest_after`, which an overriding card calls the same way).
        """
        begin, step, runs = self.begin_tick, self.step, self.runs_ticks
        i = self.rest_enter(n)
        while i < n:
            if runs:
                room = self._run_room(n - i)
                k = self.run(room) if room else 0
                if k:
                    i += k
                    if self.pause:
                        self.pause = False
                        self.batch_done()
                        return i
                    continue
            # rest_before's first test inlined: a card looks only at some ticks (None between)
            before = self.rest_before() if self.ticks >= self._rest_due else None
            begin()
            step()
            i += 1
            if self.pause:
                self.pause = False
                self.batch_done()
                return i
            if before is not None:
                i += self.rest_after(before, n - i)
        self.batch_done()
        return n

    def _run_room(self, room: int) -> int:
        """Of the next `room` ticks, those a `run` may take: none after an interrupt between
        batches (`pause`: the next tick ends the batch), none from the next look for rest or
        change of period on."""
        if self.pause:
            return 0
        if self.skip_quiet:
            room = min(room, self._rest_due - self.ticks)
        if self.retimes:
            room = min(room, self.retimes[0][0] - self.ticks - 1)
        return max(room, 0)

    def run(self, room: int) -> int:
        """Run up to `room` (> 0) of the next ticks at once when the card can (`runs_ticks`:
        ticks whose firmware does less than `step` checks for), leaving what `begin_tick` and
        `step` would: count them (`begin_tick` each, or `ticks_run`, with the time of a tick
        set before anything of it may read it; no look for rest and no change of period falls
        among them) and stop after one that asserted an interrupt. The count run; 0: the next
        tick runs through `step`. Override."""
        return 0

    # -- rest (DESIGN.md "Time that costs nothing", decision 0008) ---------------------------------
    def touched(self) -> None:
        """An input of the card may have changed (a host access, a backdoor action, a command on
        a port of its own, a new period): a card at rest looks again at its next tick."""
        self.inputs_epoch += 1
        self._rest_due = 0
        self._rest_wait = 1

    def rest_enter(self, n: int) -> int:
        """At the start of a batch of n ticks: a card proven at rest with nothing touched since
        skips them (up to its next periodic event or period change); the count skipped."""
        if not self.skip_quiet or self._rest_epoch != self.inputs_epoch:
            return 0
        if self.polled_state() != self._polled:  # written through the shared mapping: an input
            self.touched()  # changed, and the card proves rest again (once back to what it
            return 0  # was, the memory would not tell the card's work apart from rest)
        k = self.skip_quiet_ticks(n)
        if k < n:  # the tick ahead is an event of the card's own: look again after it
            self._rest_epoch = -1
            self._rest_due = self.ticks + 2
        return k

    def rest_before(self) -> bytes | None:
        """Before a tick: the state to compare after it, when the card is due to look whether it
        came to rest (None: not now)."""
        if not self.skip_quiet or self.ticks < self._rest_due:
            return None
        state = self.rest_state()
        if state is None:  # busy: look again in a while
            self._rest_due = self.ticks + QUIET_CHECK
        return state

    def rest_after(self, before: bytes, room: int) -> int:
        """After the tick `before` was taken for, with `room` ticks left in the batch: equal
        states prove the card at rest until an input changes, and it skips what it may of the
        room; else it looks again after twice as many ticks as last time (at most QUIET_CHECK).
        The count skipped."""
        if self.rest_state() != before:
            self._rest_wait = min(2 * self._rest_wait, QUIET_CHECK)
            self._rest_due = self.ticks + self._rest_wait
            return 0
        self._rest_epoch, self._rest_wait = self.inputs_epoch, 1
        self._polled = self.polled_state()
        return self.rest_enter(room) if room else 0

    def polled_state(self) -> bytes:
        """The passive memory the card's ticks read (decision 0010: a local client writes it
        through the shared mapping, touching nothing), as bytes: a card proven at rest compares
        it at every batch and looks again when it changed. Override (default: none)."""
        return b""

    def rest_state(self) -> bytes | None:
        """Everything a tick of the card may change, as bytes, except what `skip` advances in
        closed form (tick counters and the clocks derived from them); None while the card is
        busy (a command being served, a reply to send, a timer, a program). Two equal results
        around one tick prove the card at a fixed point: the next ticks change nothing until an
        input does (`touched`). Override (None: never at rest)."""
        return None

    def quiet_ticks(self) -> int:
        """At rest, how many of the next ticks may run in closed form at most: those before the
        card's next periodic event (a data record, a reporting buffer; override)."""
        return 1 << 62

    def skip(self, k: int) -> None:
        """Run k ticks at rest in closed form: what k calls of `begin_tick` and `step` would
        leave (override to advance the card's own counters, calling this one)."""
        self.ticks_run(k)

    def skip_quiet_ticks(self, room: int) -> int:
        """At rest with `room` ticks left in the batch: skip as many as the card and the next
        change of period allow; the count skipped."""
        k = min(room, self.quiet_ticks())
        if self.retimes:  # a new period takes effect at a tick: `begin_tick` runs that one
            k = min(k, self.retimes[0][0] - self.ticks - 1)
        if k <= 0:
            return 0
        self.skip(k)
        self.quiet_skipped += k
        return k

    def batch_done(self) -> None:
        """The last tick of a batch ran (or the batch stopped at an interrupt): publish what the
        host reads only between batches (override; a card whose memory must show every tick
        publishes in `step` instead)."""

    def reset(self) -> None:
        """Power-on reset of the firmware (override)."""

    async def open_services(self) -> None:
        """Start what the card serves beside its regions, on the daemon's loop (override: the
        PMAC's Ethernet protocol port). A listener that cannot start raises `StartError` naming
        the card and the endpoint: the daemon does not start (issue 16: ready only when every
        listener accepts)."""

    async def close_services(self) -> None:
        """Stop what `open_services` started (override)."""

    def listeners(self) -> dict[str, str]:
        """The bound endpoints of what `open_services` started, by the name the card's config
        gives each (`vdevd serve --ready-file`); override with them."""
        return {}

    def connections(self) -> int:
        """Open connections to what `open_services` started (the metrics endpoint); override."""
        return 0

    def nvram(self) -> dict[str, Any]:
        """What the card keeps in flash, to be saved atomically (override)."""
        return {}

    def describe(self) -> dict[str, Any]:
        return {
            "name": self.name,
            "type": self.type_name,
            "endian": self.endian,
            "period_ns": self.period_ns,
            "regions": [r.describe() for r in self.regions.values()],
            "irq": list(self.irq_lines),
            "controls": {k: _signature(fn) for k, fn in self._controls.items()},
            "deprecated": {k: getattr(fn, "__vdev_deprecated__", None) for k, fn in
                           self._controls.items() if getattr(fn, "__vdev_deprecated__", None)},
        }

    def scope_signals(self) -> type[Signals]:
        """How the scope reads this card (issue 23 §1; docs/card-pattern.md "Scope"): the
        `SIGNALS` class of the `scope` module of the card's package. LookupError: the card has
        none."""
        package = type(self).__module__.rpartition(".")[0]
        try:
            module = importlib.import_module(package + ".scope")
        except ModuleNotFoundError as exc:
            raise LookupError(f"{package} has no scope module") from exc
        signals: type[Signals] = module.SIGNALS
        return signals

    # -- backdoor ----------------------------------------------------------------------------------
    def _collect_controls(self) -> dict[str, Callable[..., Any]]:
        found: dict[str, Callable[..., Any]] = {}
        for klass in reversed(type(self).__mro__):
            for attr, fn in vars(klass).items():
                label = getattr(fn, "__vdev_control__", None)
                if label:
                    found[label] = getattr(self, attr)
        return found

    def check_control(self, action: str, params: Mapping[str, Any]) -> Callable[..., Any]:
        """The action's method if it exists and takes these params, else VdevError."""
        fn = self._controls.get(action)
        if fn is None:
            raise VdevError(
                ErrorCode.BAD_ACTION,
                f"card {self.name!r} has no control action {action!r} "
                f"(has: {', '.join(sorted(self._controls))})",
            )
        try:
            inspect.signature(fn).bind(**self._renamed(action, params))
        except TypeError as exc:
            raise VdevError(ErrorCode.BAD_PARAM,
                            f"{action}{inspect.signature(fn)}: {exc}") from None
        return fn

    def _renamed(self, action: str, params: Mapping[str, Any]) -> Mapping[str, Any]:
        """`params` with the deprecated names of `control_params` given their new names."""
        names = self.control_params.get(action)
        if not names or not any(k in names for k in params):
            return params
        both = [k for k in params if k in names and names[k] in params]
        if both:
            raise VdevError(ErrorCode.BAD_PARAM, f"{action}: {both[0]!r} is the old name of "
                            f"{names[both[0]]!r}: give one of them")
        return {names.get(k, k): v for k, v in params.items()}

    def control(self, action: str, params: Mapping[str, Any]) -> Any:
        """Run a backdoor action; bad params (a flag that is not true or false among them)
        become BAD_PARAM errors."""
        self.touched()
        fn = self.check_control(action, params)
        params = dict(self._renamed(action, params))
        try:
            for key, optional in flag_params(fn).items():
                if key in params:
                    params[key] = flag(key, params[key], optional)
            return fn(**params)
        except (ValueError, TypeError, KeyError, IndexError, ArithmeticError) as exc:
            raise VdevError(ErrorCode.BAD_PARAM, f"{action}: {exc}") from None


def _signature(fn: Callable[..., Any]) -> dict[str, str]:
    doc = inspect.getdoc(fn) or ""
    return {"params": str(inspect.signature(fn)), "doc": doc.splitlines()[0] if doc else ""}
