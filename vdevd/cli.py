"""`vdevd`: the daemon command.

`vdevd serve [--config FILE] [--clock realtime|lockstep] [--endpoint URL] [--events URL]
[--state-dir DIR] [--ready-file PATH] [--card-port CARD.KEY=VALUE] [--no-card-ports]`
"""

from __future__ import annotations

import argparse
import logging
import os
import sys
from importlib import metadata
from typing import NoReturn

from vdevd import card_ports
from vdevd import config as configmod
from vdevd.config import ConfigError


class _Parser(argparse.ArgumentParser):
    """A usage error is one line naming the argument, exit status 2 (no usage dump)."""

    def error(self, message: str) -> NoReturn:
        self.exit(2, f"{self.prog}: {message} (see {self.prog} --help)\n")


def parser() -> argparse.ArgumentParser:
    p = _Parser(
        prog="vdevd", description="virtual motion-control cards over ZeroMQ",
        epilog="exit status: 0 stopped by SIGINT/SIGTERM, 1 a ZeroMQ endpoint that cannot be "
               "bound, 2 a usage or configuration error, a card's own port that cannot be bound "
               "or a ready file that cannot be written")
    p.add_argument("--version", action="version", version=f"vdevd {_version()}")
    sub = p.add_subparsers(dest="command", required=True, metavar="COMMAND",
                           help="what to do (required; COMMAND --help for its arguments)")
    serve = sub.add_parser(
        "serve", help="run the rack (the embedded default rack without --config)",
        description="Run the rack until SIGINT or SIGTERM. Without --config: the embedded "
                    "default rack (one card of each type), requests on "
                    f"{configmod.DEFAULT_ENDPOINT}, events on {configmod.DEFAULT_EVENTS}, "
                    f"clock {_default_clock()}, PMAC Ethernet on {_default_pmac_port()}. "
                    "The options override the file.")
    serve.add_argument("--config", metavar="FILE",
                       help="rack configuration, TOML (default: the embedded default rack)")
    serve.add_argument("--clock", choices=configmod.CLOCK_MODES,
                       help="[clock] mode: realtime (locked to wall time) or lockstep (moves "
                            f"on sim step and waits) (default: {_default_clock()})")
    serve.add_argument("--endpoint", metavar="URL",
                       help="[server] endpoint, the ROUTER for requests: tcp://HOST:PORT "
                            "(loopback without CURVE; PORT * any free) or ipc://PATH "
                            f"(default: {configmod.DEFAULT_ENDPOINT})")
    serve.add_argument("--events", metavar="URL",
                       help="[server] events, the PUB for interrupts and heartbeats "
                            f"(default: {configmod.DEFAULT_EVENTS})")
    serve.add_argument("--state-dir", metavar="DIR",
                       help="[state] dir, where cards keep their flash (default: none, "
                            "nothing saved)")
    serve.add_argument("--ready-file", metavar="PATH",
                       help="write the bound endpoints as JSON to PATH (atomically) once all "
                            "listeners are up (default: none)")
    serve.add_argument("--card-port", action="append", default=[], metavar="CARD.KEY=VALUE",
                       help="move a card's own TCP port: VALUE a PORT (0: any free one), "
                            "tcp://HOST:PORT, or off; e.g. pmac0.ethernet=1026 (repeatable; "
                            "default: as configured)")
    serve.add_argument("--no-card-ports", action="store_true",
                       help="switch every card's own TCP port off, before any --card-port "
                            "(default: as configured)")
    serve.add_argument("--log-level", default="INFO", type=str.upper,
                       choices=("DEBUG", "INFO", "WARNING", "ERROR"),
                       help="log messages of this level and above, to stderr (default: INFO)")
    sub.add_parser("types", help="list the card types and their configuration keys")
    return p


def _default_pmac_port() -> str:
    """The default rack's PMAC Ethernet endpoint (the port `--card-port` moves)."""
    from vdevd.devices import card_class

    return str(card_class("pmac-turbo").options["ethernet"].default)


def _default_clock() -> str:
    """The clock of a configuration that names none (`[clock] mode`)."""
    return configmod.Config().clock


def _version() -> str:
    try:
        return metadata.version("vdevd")
    except metadata.PackageNotFoundError:  # run from a source tree that is not installed
        return "unknown (not installed)"


def main(argv: list[str] | None = None) -> int:
    try:
        return _main(argv)
    except BrokenPipeError:  # `vdevd types | head`: the reader has gone, stop quietly
        devnull = os.open(os.devnull, os.O_WRONLY)
        os.dup2(devnull, sys.stdout.fileno())
        return 141  # as a process killed by SIGPIPE


def _main(argv: list[str] | None) -> int:
    args = parser().parse_args(argv)
    if args.command == "types":
        return _types()
    logging.basicConfig(
        stream=sys.stderr,
        level=getattr(logging, str(args.log_level).upper(), logging.INFO),
        format="%(asctime)s %(levelname)s %(name)s: %(message)s",
    )
    try:
        cfg = configmod.load(args.config)
        if args.clock:
            cfg.clock = args.clock
        if args.endpoint:
            cfg.endpoint = args.endpoint
        if args.events:
            cfg.events = args.events
        if args.state_dir:
            cfg.state_dir = args.state_dir
        card_ports.apply(cfg, args.card_port, args.no_card_ports)
        configmod.check_endpoints(cfg)
    except ConfigError as exc:
        print(f"vdevd: configuration error: {exc}", file=sys.stderr)
        return 2
    from vdevd.daemon import run

    try:
        run(cfg, args.ready_file)
    except Exception as exc:  # bind failures and the like: one line, not a traceback
        import zmq

        from vdevd.errors import StartError

        if isinstance(exc, (StartError, zmq.ZMQError, OSError, ValueError)):
            print(f"vdevd: cannot start: {exc}", file=sys.stderr)
            return 2 if isinstance(exc, StartError) else 1  # 2: restarting cannot fix it
        raise
    return 0


def _types() -> int:
    """Each card type's options, printed from their declaration (vdevd/devices/options.py)."""
    from vdevd.config import PERIOD_NS
    from vdevd.devices import CARD_TYPES, card_class
    from vdevd.rt.world import AXIS_KEYS

    print(f"every card: [[card.axis]] tables, one per axis: {', '.join(AXIS_KEYS)}; period_ns "
          f"({PERIOD_NS[0]}..{PERIOD_NS[1]} ns, default the type's own) unless the type says "
          "what sets its period")
    for name in CARD_TYPES:
        cls = card_class(name)
        period = f"{float(cls.default_period_ns):.10g} ns"
        if cls.period_from:
            period += f": {cls.period_from}; no period_ns"
        print(f"{name} (period {period})")
        for key, opt in cls.options.items():
            print(f"  {key} = {opt.default!r}  {opt.describe()}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
