"""The `scope` request (proto/PROTOCOL.md "Scope"): arm, status, read and clear the recorder of
a card. Checks every field (`bad_param`, `no_region`, `no_irq`, `out_of_range` as the protocol
names them) before anything changes; keeps one `Probe` per card (`Scopes`, held by the rack).
"""

from __future__ import annotations

import math
from collections.abc import Mapping
from fractions import Fraction
from typing import Any

from vdevd.errors import ErrorCode, VdevError
from vdevd.protocol import MAX_MESSAGE
from vdevd.scope.probe import Probe
from vdevd.scope.recorder import ARMED
from vdevd.scope.signals import SIGNALS, Signals
from vdevd.scope.trigger import DIRECTIONS, KINDS, Trigger

#: the most values (samples x axes x signals) one card's recorder holds (8 bytes each)
MAX_VALUES = 2_000_000
#: the longest sampling interval, in ticks
MAX_EVERY = 1_000_000
#: the signals recorded when a request names none
DEFAULT_SIGNALS = ("position", "command", "error")
ACTIONS = ("arm", "status", "read", "clear")
#: bytes a read reply holds beside its samples (the map's keys and small fields), and per column
_READ_OVERHEAD, _COLUMN_OVERHEAD = 1024, 96


def _bad(message: str) -> VdevError:
    return VdevError(ErrorCode.BAD_PARAM, f"scope: {message}")


def _int(args: Mapping[str, Any], key: str, default: int, low: int, high: int) -> int:
    value = args.get(key, default)
    if not isinstance(value, int) or isinstance(value, bool) or not low <= value <= high:
        raise _bad(f"{key} {value!r} is not an integer in {low}..{high:,}")
    return value


class Scopes:
    """The recorder of each card of a rack (at most one a card)."""

    def __init__(self) -> None:
        self.probes: dict[str, Probe] = {}

    def op(self, card: Any, args: Mapping[str, Any]) -> dict[str, Any] | None:
        """Serve one `scope` request on `card`."""
        action = args["action"]
        if action == "arm":
            return self.arm(card, args)
        if action == "status":
            return self.status(card)
        if action == "read":
            return self.read(card, args)
        if action == "clear":
            probe = self.probes.pop(card.name, None)
            if probe is not None:
                probe.detach()
            return None
        raise _bad(f"action {action!r} is not one of {', '.join(ACTIONS)}")

    # -- arm -------------------------------------------------------------------------------------------
    def arm(self, card: Any, args: Mapping[str, Any]) -> dict[str, Any]:
        """A new recording on `card`, replacing any it had."""
        try:
            signals: type[Signals] = card.scope_signals()
        except LookupError:
            raise _bad(f"card {card.name!r} ({card.type_name}) has no scope") from None
        all_names = signals.axis_names(card)
        axes = [_axis(a, all_names) for a in _list(args, "axes", all_names)]
        if len(set(axes)) != len(axes):
            raise _bad("an axis is named twice")
        wanted = [str(s) for s in _list(args, "signals", list(DEFAULT_SIGNALS))]
        for s in wanted:
            if s not in SIGNALS:
                raise _bad(f"no signal {s!r} (signals: {', '.join(SIGNALS)})")
        if len(set(wanted)) != len(wanted):
            raise _bad("a signal is named twice")
        every = _int(args, "every", 1, 1, MAX_EVERY)
        cols = len(axes) * len(wanted)
        samples = self._samples(card, args, every, cols)
        pre = _int(args, "pre", 0, 0, samples - 1)
        trigger = _trigger(card, args.get("trigger"), all_names)
        if pre and trigger.kind == "now":
            raise _bad("pre-trigger samples need a trigger other than now")
        old = self.probes.pop(card.name, None)
        if old is not None:
            old.detach()
        self.probes[card.name] = Probe(card, signals, axes, [all_names[a] for a in axes], wanted,
                                       every, samples, pre, trigger)
        return self.status(card)

    @staticmethod
    def _samples(card: Any, args: Mapping[str, Any], every: int, cols: int) -> int:
        """`samples`, or the samples of `seconds` of ticks; at most MAX_VALUES values."""
        if ("samples" in args) == ("seconds" in args):
            raise _bad("give exactly one of samples and seconds")
        if "samples" in args:
            samples = args["samples"]
            if not isinstance(samples, int) or samples < 1:
                raise _bad(f"samples {samples!r} is not a positive integer")
        else:
            seconds = args["seconds"]
            if not isinstance(seconds, int | float) or not 0 < seconds < 1e6 \
                    or not math.isfinite(seconds):
                raise _bad(f"seconds {seconds!r} is not in (0, 1e6)")
            samples = max(1, int(Fraction(round(seconds * 1e9)) / card.period) // every)
        if samples * cols > MAX_VALUES:
            raise _bad(f"{samples:,} samples x {cols} columns = {samples * cols:,} values "
                       f"exceed the limit of {MAX_VALUES:,} values a card")
        return samples

    # -- status and read ---------------------------------------------------------------------------
    def _probe(self, card: Any) -> Probe | None:
        probe = self.probes.get(card.name)
        if probe is not None:
            probe.status()  # the staged samples written
        return probe

    def status(self, card: Any) -> dict[str, Any]:
        probe = self._probe(card)
        if probe is None:
            return {"state": "idle", "card": card.name}
        rec = probe.rec
        fired = rec.state != ARMED
        return {
            "state": rec.state, "card": card.name, "axes": probe.axis_names,
            "signals": sorted({c[0].split(".", 1)[1] for c in probe.columns},
                              key=SIGNALS.index),
            "columns": [c[0] for c in probe.columns], "every": probe.every,
            "samples": rec.capacity, "pre": rec.pre, "period_ns": card.period_ns,
            "trigger": probe.trigger.describe(), "taken": rec.written,
            "available": rec.available,
            "trigger_index": rec.trigger_index - rec.start if fired else None,
            "trigger_ns": _trigger_ns(probe) if fired and rec.trigger_index < rec.written
            else None,
        }

    def read(self, card: Any, args: Mapping[str, Any]) -> dict[str, Any]:
        """Samples `start` .. of the kept window, as many as fit a reply (`count` at most)."""
        probe = self._probe(card)
        if probe is None:
            raise _bad(f"card {card.name!r} has no recording (arm one first)")
        rec = probe.rec
        start = _int(args, "start", 0, 0, 1 << 62)
        ncols = len(probe.columns)
        fit = max(1, (MAX_MESSAGE - _READ_OVERHEAD - _COLUMN_OVERHEAD * ncols) // (8 * (1 + ncols)))
        count = _int(args, "count", fit, 0, 1 << 62)
        times, floats, words = rec.window(start, min(count, fit))
        n = len(times)
        columns: dict[str, bytes] = {}
        fi = wi = 0
        for name, kind in probe.columns:
            if kind == "f":
                columns[name] = floats[:, fi].astype("<f8").tobytes()
                fi += 1
            else:
                columns[name] = words[:, wi].astype("<i8").tobytes()
                wi += 1
        end = start + n
        return {
            "state": rec.state, "start": start, "count": n, "available": rec.available,
            "next": end if end < rec.available or rec.state != "done" else None,
            "time_ns": times.astype("<i8").tobytes(), "columns": columns,
            "types": {name: "f8" if kind == "f" else "i8" for name, kind in probe.columns},
        }


def _trigger_ns(probe: Probe) -> int:
    rec = probe.rec
    return int(rec.times[rec.trigger_index % rec.capacity])


def _list(args: Mapping[str, Any], key: str, default: list[Any]) -> list[Any]:
    value = args.get(key)
    if value is None:
        return list(default)
    if not isinstance(value, list) or not value or len(value) > 1024:
        raise _bad(f"{key} must be a non-empty list")
    return value


def _axis(axis: Any, names: list[str]) -> int:
    """The index of an axis named as the card names it (a letter in any case, or a number)."""
    text = str(axis).upper() if isinstance(axis, str | int) and not isinstance(axis, bool) else ""
    if text in names:
        return names.index(text)
    raise _bad(f"no axis {axis!r} (axes: {', '.join(names)})")


def _trigger(card: Any, spec: Any, names: list[str]) -> Trigger:
    """The `trigger` field: a map with `kind` and its fields (PROTOCOL.md "Scope")."""
    if spec is None:
        return Trigger()
    if not isinstance(spec, dict):
        raise _bad("trigger must be a map")
    kind = spec.get("kind", "now")
    if kind not in KINDS:
        raise _bad(f"trigger kind {kind!r} is not one of {', '.join(KINDS)}")
    allowed = {"now": set(), "register": {"region", "offset", "width", "mask", "value"},
               "irq": {"line"}, "position": {"axis", "level", "direction"}}[kind]
    extra = set(spec) - allowed - {"kind"}
    if extra:
        raise _bad(f"trigger {kind}: unknown field {sorted(extra)[0]!r}")
    t = Trigger(kind)
    if kind == "register":
        region = spec.get("region")
        if not isinstance(region, str) or region not in card.regions:
            raise VdevError(ErrorCode.NO_REGION, f"scope: card {card.name!r} has no region "
                            f"{region!r} (regions: {', '.join(card.regions)})")
        t.region = region
        t.width = _int(spec, "width", 4, 1, 8)
        if t.width not in (1, 2, 4, 8):
            raise VdevError(ErrorCode.BAD_WIDTH, f"scope: trigger width {t.width} not 1/2/4/8")
        t.offset = _int(spec, "offset", -1, 0, 1 << 62) if "offset" in spec else _missing("offset")
        card.regions[region].get_peek(t.offset, t.width)  # out_of_range now, not at a tick
        full = (1 << (8 * t.width)) - 1
        t.mask = _int(spec, "mask", full, 1, full)
        if "value" in spec:
            t.value = _int(spec, "value", 0, 0, full)
            if t.value & ~t.mask:
                raise _bad(f"trigger value {t.value:#x} has bits outside the mask {t.mask:#x}")
    elif kind == "irq":
        line = spec.get("line")
        if line is not None and line not in card.irq_lines:
            raise VdevError(ErrorCode.NO_IRQ, f"scope: card {card.name!r} has no irq line "
                            f"{line!r} (lines: {', '.join(card.irq_lines)})")
        t.line = line
    elif kind == "position":
        if "axis" not in spec:
            _missing("axis")
        t.axis = _axis(spec["axis"], names)
        t.axis_name = names[t.axis]
        level = spec.get("level")
        if not isinstance(level, int | float) or isinstance(level, bool) \
                or not math.isfinite(level):
            raise _bad(f"trigger level {level!r} is not a finite number")
        t.level = float(level)
        t.direction = spec.get("direction", "rising")
        if t.direction not in DIRECTIONS:
            raise _bad(f"trigger direction {t.direction!r} is not one of {', '.join(DIRECTIONS)}")
    return t


def _missing(key: str) -> Any:
    raise _bad(f"trigger: missing field {key!r}")
