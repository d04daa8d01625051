"""`vdevctl scope CARD ...` (issue 23 §1): arm a card's recorder, step the lockstep clock the
recording's length (unless --no-step), read the trace, write it as CSV and/or PNG."""

from __future__ import annotations

import argparse
import sys
from typing import Any

from vdevclient.scope import SIGNALS, parse_trigger, record

#: the longest recording the command asks for, simulated seconds (the daemon bounds the values)
MAX_SECONDS = 86_400.0


def _names(text: str) -> list[str]:
    names = [t.strip() for t in text.split(",") if t.strip()]
    if not names:
        raise argparse.ArgumentTypeError(f"{text!r} names nothing (a comma-separated list)")
    return names


def _signals(text: str) -> list[str]:
    names = _names(text)
    for s in names:
        if s not in SIGNALS:
            raise argparse.ArgumentTypeError(f"no signal {s!r} (signals: {', '.join(SIGNALS)})")
    return names


def _seconds(text: str) -> float:
    try:
        value = float(text)
    except ValueError:
        value = float("nan")
    if not 0 < value <= MAX_SECONDS:
        raise argparse.ArgumentTypeError(f"{text!r} is not a number of seconds in (0, {MAX_SECONDS:g}]")
    return value


def _positive(text: str) -> int:
    try:
        value = int(text, 0)
    except ValueError:
        value = 0
    if value < 1:
        raise argparse.ArgumentTypeError(f"{text!r} is not a positive integer")
    return value


def _count(text: str) -> int:
    try:
        value = int(text, 0)
    except ValueError:
        value = -1
    if value < 0:
        raise argparse.ArgumentTypeError(f"{text!r} is not a count (0 or more)")
    return value


def _trigger(text: str) -> dict[str, Any]:
    try:
        return parse_trigger(text)
    except ValueError as exc:
        raise argparse.ArgumentTypeError(str(exc)) from None


def add_parser(sub: Any) -> None:
    """The `scope` subcommand's arguments."""
    p = sub.add_parser("scope", help="record signals of a card's axes: CARD --seconds S "
                       "[--csv FILE] [--png FILE]")
    p.add_argument("card", help="the card's name (required)")
    p.add_argument("--axes", type=_names, metavar="A,B,...",
                   help="axes as the card names them (default: every axis)")
    p.add_argument("--signals", type=_signals, metavar="S,...",
                   help=f"of {', '.join(SIGNALS)} (default: position,command,error)")
    p.add_argument("--seconds", type=_seconds, required=True, metavar="S",
                   help="simulated seconds to record (required)")
    p.add_argument("--every", type=_positive, default=1, metavar="N",
                   help="sample every N ticks (default: 1)")
    p.add_argument("--trigger", type=_trigger, metavar="SPEC",
                   help="now (default), irq[:LINE], position:AXIS:LEVEL[:rising|falling|either] "
                        "or register:REGION:OFFSET[:WIDTH[:MASK[:VALUE]]]")
    p.add_argument("--pre", type=_count, default=0, metavar="N",
                   help="samples kept before the trigger (default: 0)")
    p.add_argument("--trigger-wait", type=_seconds, default=10.0, metavar="S",
                   help="with a trigger, simulated seconds the command steps on at most for "
                        "it to fire and the recording to end (default: 10)")
    p.add_argument("--csv", metavar="FILE",
                   help="write the trace as CSV (time_s, AXIS.signal...) (default: none)")
    p.add_argument("--png", metavar="FILE",
                   help="plot one panel per signal (needs matplotlib: vdevd[plot]) (default: none)")
    p.add_argument("--title", default="", help="the plot's title (default: none)")
    p.add_argument("--no-step", action="store_true",
                   help="do not step the lockstep clock: wait for someone else to (or realtime) "
                        "(default: step it)")


def run(rack: Any, args: argparse.Namespace) -> int:
    card = rack.card(args.card)
    trace = record(card, args.axes, args.signals, seconds=args.seconds, every=args.every,
                   trigger=args.trigger, pre=args.pre, step=not args.no_step,
                   trigger_s=args.trigger_wait,
                   wait_s=max(args.timeout, 2 * args.seconds + 1) if args.no_step else None)
    if trace.state != "done":
        waited = args.seconds + (args.trigger_wait if args.trigger else 0.0)
        print(f"vdevctl: scope on {card.name}: the recording is {trace.state} after "
              f"{waited:g} s ({len(trace)} samples)", file=sys.stderr)
        if not len(trace):
            return 1
    written = []
    if args.csv:
        trace.to_csv(args.csv)
        written.append(args.csv)
    if args.png:
        try:
            trace.to_png(args.png, title=args.title)
        except ImportError as exc:
            print(f"vdevctl: {exc}", file=sys.stderr)
            return 1
        written.append(args.png)
    t = trace.time
    span = f", {t[0]:.6f}..{t[-1]:.6f} s" if len(t) else ""
    print(f"{card.name}: {len(trace)} samples of {len(trace.columns)} columns{span} "
          f"({trace.state}){' -> ' + ', '.join(written) if written else ''}")
    return 0
