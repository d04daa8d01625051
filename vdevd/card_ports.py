"""The cards' own TCP ports moved or switched off from the command line (`vdevd serve
--card-port CARD.KEY=VALUE`, `--no-card-ports`): the default rack's PMAC port 1025 collides on a
shared machine, and a test harness wants free ports without writing a file.

VALUE is an endpoint `tcp://HOST:PORT`, a bare PORT (on the host the card was configured with,
loopback when its port was off; 0: any free port, which `--ready-file` reports), or `off`. Each
change is checked as the card checks its configuration; an error names the argument.
"""

from __future__ import annotations

import re
from dataclasses import replace

from vdevd.config import Config, ConfigError
from vdevd.devices import card_class
from vdevd.devices.options import CardOptions

#: the card options that open a TCP port of the card's own (Galil DMC, PMAC Ethernet)
PORT_KEYS = ("ethernet",)
_HOST = re.compile(r"tcp://(?P<host>\[[^\]]+\]|[^:/\[\]]+):")


def parse(text: str) -> tuple[str, str, str]:
    """`CARD.KEY=VALUE` -> (card, key, value)."""
    target, sep, value = text.partition("=")
    card, dot, key = target.partition(".")
    if not sep or not dot or not card or not key:
        raise ConfigError(f"--card-port {text}: not CARD.KEY=VALUE (e.g. pmac0.ethernet=1026, "
                          "pmac0.ethernet=off)")
    return card, key, value.strip()


def apply(cfg: Config, changes: list[str], all_off: bool = False) -> None:
    """Switch every card port off (`all_off`), then apply each `CARD.KEY=VALUE` of `changes`."""
    specs = {spec.name: i for i, spec in enumerate(cfg.cards)}
    if all_off:
        for i, spec in enumerate(cfg.cards):
            keys = {k: "" for k in PORT_KEYS if spec.options.get(k)}
            if keys:
                cfg.cards[i] = replace(spec, options=CardOptions({**spec.options, **keys}))
    for text in changes:
        card, key, value = parse(text)
        where = f"--card-port {text}"
        if card not in specs:
            raise ConfigError(f"{where}: no card {card!r} (cards: {', '.join(specs) or 'none'})")
        spec = cfg.cards[specs[card]]
        if key not in PORT_KEYS or key not in card_class(spec.type).options:
            ports = [k for k in PORT_KEYS if k in card_class(spec.type).options]
            raise ConfigError(f"{where}: {card} ({spec.type}) has no port key {key!r} "
                              f"(port keys: {', '.join(ports) or 'none'})")
        endpoint = _endpoint(str(spec.options.get(key) or ""), value, where)
        options = CardOptions({**spec.options, key: endpoint})
        try:
            card_class(spec.type).check_options(options, f"--card-port {card}")
        except ValueError as exc:
            raise ConfigError(str(exc)) from None
        cfg.cards[specs[card]] = replace(spec, options=options)


def _endpoint(current: str, value: str, where: str) -> str:
    """The option's new value: "" for off, an endpoint as given, a bare port on the current
    host (loopback if none)."""
    if value.lower() in ("off", ""):
        return ""
    if value.startswith("tcp://"):
        return value
    if not value.isdigit() or int(value) > 65535:
        raise ConfigError(f"{where}: {value!r} is not a port (0..65535), tcp://HOST:PORT or off")
    match = _HOST.match(current)
    host = match["host"] if match else "127.0.0.1"
    return f"tcp://{host}:{int(value)}"
