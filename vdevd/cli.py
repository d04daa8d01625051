"""`vdevd`: the daemon command.

`vdevd serve [--config FILE] [--clock realtime|lockstep] [--endpoint URL] [--events URL]
[--state-dir DIR] [--ready-file PATH]`
"""

from __future__ import annotations

import argparse
import logging
import sys

from vdevd import config as configmod
from vdevd.config import ConfigError


def parser() -> argparse.ArgumentParser:
    p = argparse.ArgumentParser(prog="vdevd", description="virtual motion-control cards over ZeroMQ")
    sub = p.add_subparsers(dest="command", required=True)
    serve = sub.add_parser("serve", help="run the rack (the embedded default rack without --config)")
    serve.add_argument("--config", metavar="FILE", help="rack configuration (TOML)")
    serve.add_argument("--clock", choices=configmod.CLOCK_MODES, help="override [clock] mode")
    serve.add_argument("--endpoint", metavar="URL", help="override [server] endpoint")
    serve.add_argument("--events", metavar="URL", help="override [server] events")
    serve.add_argument("--state-dir", metavar="DIR", help="override [state] dir")
    serve.add_argument("--ready-file", metavar="PATH",
                       help="write the bound endpoints as JSON to PATH (atomically) once all "
                            "listeners are up")
    serve.add_argument("--log-level", default="INFO", type=str.upper,
                       choices=("DEBUG", "INFO", "WARNING", "ERROR"), help="default INFO")
    sub.add_parser("types", help="list the card types and their configuration keys")
    return p


def main(argv: list[str] | None = None) -> int:
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
