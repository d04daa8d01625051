"""`vdevctl`: the operator command (cards, lspci, peek, poke, irq, step, stats, control, now,
scope, dropin-path).

Endpoint rules as `vdevclient.connect`: --endpoint, else $VDEVD_ENDPOINT, else tcp://127.0.0.1:5555.
"""

from __future__ import annotations

import argparse
import json
import math
import os
import re
import sys
from importlib import metadata
from pathlib import Path
from typing import Any, NoReturn

import zmq
from vdevmaps.pci import IDENTITY_SIZE, lspci_line

from vdevclient import scope_cli, snapshot
from vdevclient.core import DEFAULT_ENDPOINT, connect
from vdevclient.errors import ConfigurationError, VdevClientError


class _Parser(argparse.ArgumentParser):
    """A usage error is one line naming the argument, exit status 2 (no usage dump)."""

    def error(self, message: str) -> NoReturn:
        self.exit(2, f"{self.prog}: {message} (see {self.prog} --help)\n")


def parser() -> argparse.ArgumentParser:
    p = _Parser(
        prog="vdevctl", description="operate a vdevd rack",
        epilog="exit status: 0 done, 1 an error (an error reply, no reply, a daemon gone), "
               "2 a usage or configuration error")
    p.add_argument("--version", action="version", version=f"vdevctl {_version()}")
    p.add_argument("--endpoint", metavar="URL", type=_endpoint,
                   help=f"request endpoint (default: $VDEVD_ENDPOINT, else {DEFAULT_ENDPOINT})")
    p.add_argument("--events", metavar="URL", type=_endpoint,
                   help="events endpoint (default: $VDEVD_EVENTS, else the one the daemon "
                        "reports in hello)")
    p.add_argument("--timeout", type=_seconds, default=10.0, metavar="S",
                   help="reply timeout, wall seconds (default: 10)")
    sub = p.add_subparsers(dest="command", required=True, metavar="COMMAND",
                           help="what to do (required; COMMAND --help for its arguments)")
    sub.add_parser("cards", help="list the cards, their regions and irq lines")
    sub.add_parser("lspci", help="list the PCI cards' IDs as lspci -n does")
    peek = sub.add_parser("peek", help="read a region: CARD REGION OFFSET [SIZE]")
    _access(peek)
    peek.add_argument("size", type=_int, nargs="?", default=4,
                      help="bytes to read, decimal or 0x hex (default: 4)")
    poke = sub.add_parser("poke", help="write a region: CARD REGION OFFSET HEXBYTES")
    _access(poke)
    poke.add_argument("data", type=_hexbytes, metavar="HEXBYTES",
                      help="bytes in bus order, e.g. 01000000 or 01:00:00:00 (required)")
    irq = sub.add_parser("irq", help="print interrupt events until interrupted")
    irq.add_argument("card", nargs="?", help="one card's name (default: every card)")
    irq.add_argument("--count", type=_count, default=0, metavar="N",
                     help="stop after N events (default: 0, no limit)")
    irq.add_argument("--timeout", dest="irq_timeout", type=_seconds, default=None, metavar="S",
                     help="stop after S wall seconds without an event (default: no limit; a "
                          "daemon silent for three heartbeats ends it anyway, exit 1)")
    step = sub.add_parser("step", help="advance the lockstep clock by SECONDS")
    step.add_argument("seconds", type=float,
                      help="simulated seconds, 0..86400 (required; rounded to ns)")
    sub.add_parser("now", help="print the simulated time and clock mode")
    sub.add_parser("stats", help="print the daemon's statistics (JSON)")
    ctl = sub.add_parser("control", help="backdoor: CARD ACTION [k=v ...]")
    ctl.add_argument("card", help="the card's name (required)")
    ctl.add_argument("action", help="the action, as `cards` lists them (required)")
    ctl.add_argument("params", nargs="*", type=_param, metavar="KEY=VALUE",
                     help="the action's parameters, VALUE parsed as JSON when it can be "
                          "(true, 3, 0.5), True/False as booleans, else a string (default: none)")
    scope_cli.add_parser(sub)
    sub.add_parser("dropin-path", help="print the directory of the drop-in vendor modules "
                   "(gclib): put it first on PYTHONPATH")
    snap = sub.add_parser("snapshot", help="save the rack (every card's state and the clock) "
                          "to FILE, or load FILE in its place")
    snap.add_argument("action", choices=("save", "load"), help="save or load (required)")
    snap.add_argument("file", type=Path, help="the snapshot file, on this machine (required)")
    return p


def _access(sub: argparse.ArgumentParser) -> None:
    """The CARD REGION OFFSET of `peek` and `poke`."""
    sub.add_argument("card", help="the card's name (required)")
    sub.add_argument("region", help="the region's name, as `cards` lists them (required)")
    sub.add_argument("offset", type=_int, help="byte offset in the region, decimal or 0x hex "
                     "(required)")


def _version() -> str:
    try:
        return metadata.version("vdevd")
    except metadata.PackageNotFoundError:  # run from a source tree that is not installed
        return "unknown (not installed)"


def _param(text: str) -> tuple[str, Any]:
    """A `control` parameter KEY=VALUE (a usage error, before any request, when not one)."""
    key, sep, value = text.partition("=")
    if not sep or not key:
        raise argparse.ArgumentTypeError(f"parameter {text!r} is not KEY=VALUE")
    parsed = _value(value)
    if not _fits(parsed):
        raise argparse.ArgumentTypeError(f"parameter {key}: {value!r} holds an integer outside "
                                         f"{_INT_RANGE[0]}..{_INT_RANGE[1]}")
    return key, parsed


def _fits(value: Any) -> bool:
    """Whether every integer in `value` (a JSON value) fits a request (msgpack's range)."""
    if isinstance(value, int):
        return _INT_RANGE[0] <= value <= _INT_RANGE[1]
    if isinstance(value, list):
        return all(_fits(v) for v in value)
    if isinstance(value, dict):
        return all(_fits(v) for v in value.values())
    return True


def dropin_path() -> Path:
    """The directory of the drop-in modules (`import gclib` finds vdevclient's there)."""
    return Path(__file__).resolve().parent / "dropin"


#: what a client can connect to: tcp://HOST:PORT (HOST a name, an address or [IPv6]), ipc://,
#: inproc:// (ZeroMQ takes a tcp PORT modulo 65536: 65536 and more are refused here)
_ENDPOINT = re.compile(r"tcp://(\[[0-9A-Fa-f:.%\w]+\]|[\w.-]+):(\d{1,5})|(ipc|inproc)://.+")
#: the largest number of seconds a timeout takes (ZeroMQ's are int milliseconds)
MAX_SECONDS = 1_000_000.0
#: the integers a request can carry (msgpack's)
_INT_RANGE = (-(1 << 63), (1 << 64) - 1)


def _endpoint(text: str) -> str:
    match = _ENDPOINT.fullmatch(text)
    if match is None or (match[2] is not None and int(match[2]) > 65535):
        raise argparse.ArgumentTypeError(f"{text!r} is not an endpoint (tcp://HOST:PORT with PORT "
                                         "0..65535, tcp://[IPv6]:PORT, ipc://PATH)")
    return text


def _int(text: str) -> int:
    try:
        value = int(text, 0)
    except ValueError:
        raise argparse.ArgumentTypeError(f"{text!r} is not a number (decimal or 0x hex)") from None
    if not 0 <= value < 1 << 63:
        raise argparse.ArgumentTypeError(f"{text!r} is not a number in 0..2**63-1")
    return value


def _count(text: str) -> int:
    try:
        value = int(text)
    except ValueError:
        value = -1
    if value < 0:
        raise argparse.ArgumentTypeError(f"{text!r} is not a count >= 0")
    return value


def _seconds(text: str) -> float:
    try:
        value = float(text)
    except ValueError:
        value = math.nan
    if not 0 <= value <= MAX_SECONDS:  # also NaN and infinities
        raise argparse.ArgumentTypeError(f"{text!r} is not a number of seconds >= 0 (and at "
                                         f"most {MAX_SECONDS:.0f})")
    return value


def _hexbytes(text: str) -> bytes:
    try:
        return bytes.fromhex(text.replace(":", "").replace(" ", ""))
    except ValueError:
        raise argparse.ArgumentTypeError(f"{text!r} is not hex bytes") from None


#: Python's spellings of the booleans, which users type as readily as JSON's
_PYTHON_BOOLS = {"True": True, "False": False}


def _value(text: str) -> Any:
    """A `control` value: JSON when it parses (`true`, `3`, `0.5`), `True`/`False` as
    booleans, else the string."""
    if text in _PYTHON_BOOLS:
        return _PYTHON_BOOLS[text]
    try:
        return json.loads(text)
    except json.JSONDecodeError:
        return text


def main(argv: list[str] | None = None) -> int:
    args = parser().parse_args(argv)
    try:
        return _main(args)
    except BrokenPipeError:  # `vdevctl stats | head`: the reader has gone, stop quietly
        devnull = os.open(os.devnull, os.O_WRONLY)
        os.dup2(devnull, sys.stdout.fileno())
        return 141  # as a process killed by SIGPIPE


def _main(args: argparse.Namespace) -> int:
    if args.command == "dropin-path":  # no daemon needed
        print(dropin_path())
        return 0
    for name in ("VDEVD_ENDPOINT", "VDEVD_EVENTS"):  # used when the option is not given
        value = os.environ.get(name)
        if value and not getattr(args, name.removeprefix("VDEVD_").lower()):
            try:
                _endpoint(value)
            except argparse.ArgumentTypeError as exc:
                print(f"vdevctl: ${name}: {exc}", file=sys.stderr)
                return 2
    try:
        with connect(args.endpoint, args.events, timeout=args.timeout) as rack:
            return _run(rack, args)
    except ConfigurationError as exc:
        print(f"vdevctl: {exc}", file=sys.stderr)
        return 2
    except VdevClientError as exc:
        print(f"vdevctl: {exc}", file=sys.stderr)
        return 1
    except KeyError as exc:
        print(f"vdevctl: {exc.args[0]}", file=sys.stderr)
        return 1
    except (zmq.ZMQError, OSError) as exc:  # a bad endpoint, an unreadable key file
        print(f"vdevctl: {exc}", file=sys.stderr)
        return 1
    except KeyboardInterrupt:
        return 130


def _run(rack: Any, args: argparse.Namespace) -> int:
    out = sys.stdout
    if args.command == "cards":
        for c in rack.cards():
            print(f"{c.name}  {c.type}  period {c.period_ns} ns  {c.endian}-endian", file=out)
            for r in c.regions:
                widths = "/".join(str(w) for w in r.widths)
                print(f"  region {r.name}  {r.size:#x} bytes  widths {widths}", file=out)
            print(f"  irq {', '.join(c.irq) or '-'}", file=out)
            if c.controls:
                print(f"  controls {', '.join(c.controls)}", file=out)
    elif args.command == "lspci":
        for c in rack.cards():
            if any(r.name == "config" for r in c.regions):
                header = rack.card(c.name).region("config").read(0, IDENTITY_SIZE)
                print(f"{c.name} {lspci_line(header)}", file=out)
    elif args.command == "peek":
        data = rack.card(args.card).region(args.region).read(args.offset, args.size)
        for i in range(0, len(data), 16):
            chunk = data[i : i + 16]
            print(f"{args.offset + i:08x}  {chunk.hex(' ')}", file=out)
    elif args.command == "poke":
        rack.card(args.card).region(args.region).write(args.offset, args.data)
    elif args.command == "irq":
        return _watch(rack, args)
    elif args.command == "step":
        print(rack.sim.step(seconds=args.seconds), file=out)
    elif args.command == "now":
        info = rack.request("sim", action="now")
        print(f"{info['now_ns']} ns ({info['mode']}, tick {info['tick_ns']} ns)", file=out)
    elif args.command == "stats":
        print(json.dumps(rack.stats(), indent=2), file=out)
    elif args.command == "scope":
        return scope_cli.run(rack, args)
    elif args.command == "control":
        result = rack.control(args.card, args.action, **dict(args.params))
        if result is not None:
            print(json.dumps(result), file=out)
    elif args.command == "snapshot":
        print(snapshot.run(rack, args.action, args.file), file=out)
    return 0


def _watch(rack: Any, args: argparse.Namespace) -> int:
    import msgpack

    names = [args.card] if args.card else [c.name for c in rack.cards()]
    if not names:
        print(f"vdevctl: no cards to watch: the rack at {rack.endpoint} has none", file=sys.stderr)
        return 1
    for name in names:
        rack.card(name)  # KeyError for an unknown card
    sub, liveness = rack.subscriber(names)
    try:
        for _ in range(100):  # until the subscription is live (PROTOCOL.md, sync)
            # the daemon takes subscriptions in order: once the last one is live, all are
            rack.request("sync", card=names[-1])
            if sub.poll(50):
                break
        else:
            print(f"vdevctl: no events from {rack.events_endpoint}", file=sys.stderr)
            return 1
        print(f"vdevctl: watching {', '.join(names)} on {rack.events_endpoint}; Ctrl-C stops",
              file=sys.stderr, flush=True)
        seen = 0
        while not args.count or seen < args.count:
            got = liveness.receive(args.irq_timeout)  # DaemonGone once the daemon is silent
            if got is None:
                break
            topic, body = got
            if topic.decode() not in names:
                continue
            ev = msgpack.unpackb(body, raw=False)
            if ev.get("kind") != "irq":
                continue
            print(f"{ev['sim_time_ns']:>15} {ev['card']} {ev['line']} seq={ev['seq']} "
                  f"status={ev['status']:#x}", flush=True)
            seen += 1
    finally:
        sub.close()
    return 0


if __name__ == "__main__":
    sys.exit(main())
