"""The card contract (DESIGN.md "Card"): regions, interrupt lines, firmware ticks, backdoor.

A card package subclasses `Card`, declares its configuration keys in `options`, builds its
regions and lines in `__init__`, advances its firmware in `step()` (one servo tick), and marks
backdoor methods with `@control`. The rack owns the clock: it sets `now_ns` before every tick.
"""

from __future__ import annotations

import inspect
from collections.abc import Callable, Mapping
from dataclasses import dataclass, field
from typing import Any, ClassVar

from vdevd.errors import ErrorCode, VdevError
from vdevd.irq import IrqEvent, IrqLine
from vdevd.nvram import NvramStore
from vdevd.region import Region

EventSink = Callable[[IrqEvent], None]


@dataclass(frozen=True)
class Option:
    """A card configuration key: its type, default and allowed range or choices."""

    type: type | tuple[type, ...]
    default: Any = None
    min: float | None = None
    max: float | None = None
    choices: tuple[Any, ...] | None = None
    help: str = ""

    def check(self, key: str, value: Any) -> Any:
        """Return the value if valid, else raise ValueError naming `key`."""
        ok_type = isinstance(value, self.type) and not (
            isinstance(value, bool) and self.type in (int, float)
        )
        if not ok_type and self.type is float and isinstance(value, int):
            value, ok_type = float(value), not isinstance(value, bool)
        if not ok_type:
            raise ValueError(f"{key}: expected {_type_name(self.type)}, got {value!r}")
        if self.choices is not None:
            items = value if isinstance(value, list) else [value]
            bad = [v for v in items if v not in self.choices]
            if bad:
                raise ValueError(f"{key}: {bad[0]!r} is not one of {list(self.choices)}")
        if self.min is not None and value < self.min:
            raise ValueError(f"{key}: {value!r} is below the minimum {self.min:g}")
        if self.max is not None and value > self.max:
            raise ValueError(f"{key}: {value!r} is above the maximum {self.max:g}")
        return value


def _type_name(t: type | tuple[type, ...]) -> str:
    if isinstance(t, tuple):
        return " or ".join(x.__name__ for x in t)
    return t.__name__


@dataclass
class CardContext:
    """What the rack gives a card: where to emit interrupts and its non-volatile store."""

    emit: EventSink
    nvram: NvramStore | None = None
    extra: dict[str, Any] = field(default_factory=dict)


def control(name: str | None = None) -> Callable[[Callable[..., Any]], Callable[..., Any]]:
    """Mark a method as a backdoor action (`rack.control(card, action, **params)`)."""

    def mark(fn: Callable[..., Any]) -> Callable[..., Any]:
        fn.__vdev_control__ = name or fn.__name__  # type: ignore[attr-defined]
        return fn

    return mark


class Card:
    """Base of every virtual card."""

    type_name: ClassVar[str] = ""
    endian: ClassVar[str] = "little"
    options: ClassVar[Mapping[str, Option]] = {}
    #: the servo period in ns when the configuration gives none
    default_period_ns: ClassVar[int] = 1_000_000

    def __init__(self, name: str, config: Mapping[str, Any], ctx: CardContext) -> None:
        self.name = name
        self.config = dict(config)
        self.ctx = ctx
        self.period_ns = int(self.config.get("period_ns") or self.default_period_ns)
        self.now_ns = 0
        self.ticks = 0
        self.regions: dict[str, Region] = {}
        self.irq_lines: dict[str, IrqLine] = {}
        self.irq_seq = 0
        self.last_event: IrqEvent | None = None
        self.line_events: dict[str, IrqEvent] = {}
        #: set by an assertion so a batch of ticks stops at the tick that interrupted
        self.pause = False
        self._controls = self._collect_controls()

    # -- building ------------------------------------------------------------------------------
    def add_region(self, region: Region) -> Region:
        self.regions[region.name] = region
        return region

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

    # -- the firmware ----------------------------------------------------------------------------
    def step(self) -> None:
        """One servo tick of the firmware at `now_ns` (override)."""

    def tick(self, n: int) -> int:
        """Run up to n ticks; stop early after a tick that asserted an interrupt.

        Returns the number of ticks run. Cards may override for speed but must count `ticks` and keep
        `now_ns` (= ticks * period_ns) the time of the tick being run.
        """
        period = self.period_ns
        for i in range(n):
            self.ticks += 1
            self.now_ns = self.ticks * period
            self.step()
            if self.pause:
                self.pause = False
                return i + 1
        return n

    def reset(self) -> None:
        """Power-on reset of the firmware (override)."""

    async def open_services(self) -> None:
        """Start what the card serves beside its regions, on the daemon's loop (override: the
        PMAC's Ethernet protocol port). A failure is the card's to log; the daemon runs on."""

    async def close_services(self) -> None:
        """Stop what `open_services` started (override)."""

    def listeners(self) -> dict[str, str]:
        """The bound endpoints of what `open_services` started, by the name the card's config
        gives each (`vdevd serve --ready-file`); override with them."""
        return {}

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
        }

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
            inspect.signature(fn).bind(**params)
        except TypeError as exc:
            raise VdevError(ErrorCode.BAD_PARAM, f"{action}: {exc}") from None
        return fn

    def control(self, action: str, params: Mapping[str, Any]) -> Any:
        """Run a backdoor action; bad params become BAD_PARAM errors."""
        fn = self.check_control(action, params)
        try:
            return fn(**params)
        except (ValueError, TypeError, KeyError, IndexError) as exc:
            raise VdevError(ErrorCode.BAD_PARAM, f"{action}: {exc}") from None


def axis_number(axis: str | int, letters: str, n: int) -> int:
    """A backdoor's axis argument, a letter of `letters` (any case) or a number, as an index of
    one of the card's `n` axes; ValueError otherwise."""
    a = letters.index(axis.upper()) if isinstance(axis, str) else int(axis)
    if not 0 <= a < n:
        raise ValueError(f"no axis {axis!r} on this {n}-axis card")
    return a


def _signature(fn: Callable[..., Any]) -> dict[str, str]:
    doc = inspect.getdoc(fn) or ""
    return {"params": str(inspect.signature(fn)), "doc": doc.splitlines()[0] if doc else ""}
