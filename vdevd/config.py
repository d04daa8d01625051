"""The rack configuration: a TOML file, or the embedded default rack (one card of each type).

Every check names the key it rejects (`card[2].axes: 99 is above the maximum 16`; cards count
from 0), so a bad file
fails at start with one clear message (`ConfigError`).
"""

from __future__ import annotations

import re
import tomllib
from collections.abc import Mapping
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any, Literal

from vdevd.bounds import MAX_SCHEDULED, MAX_SCHEDULED_PER_CLIENT
from vdevd.devices import CARD_TYPES, DEFAULT_NAMES, card_class
from vdevd.devices.options import CardOptions, parse_options
from vdevd.heartbeat import PERIOD_NS as HEARTBEAT_NS
from vdevd.http_health import MetricsConfig, parse_metrics
from vdevd.security import CurveConfig, check_curve, is_local, parse_networks
from vdevd.web.config import WebConfig, parse_web

DEFAULT_ENDPOINT = "tcp://127.0.0.1:5555"
DEFAULT_EVENTS = "tcp://127.0.0.1:5556"
DEFAULT_SHM_DIR = "/dev/shm"
CLOCK_MODES = ("realtime", "lockstep")
_NAME = re.compile(r"[A-Za-z0-9_-]+")  # a card name: ASCII letters, digits, - and _
#: what `check_endpoints` takes: tcp://HOST:PORT (HOST a name, an IPv4 address, [IPv6] or *;
#: PORT 0..65535 or *), ipc://PATH, inproc://NAME
_ENDPOINT = re.compile(r"tcp://(\[[0-9A-Fa-f:.%\w]+\]|[\w.*-]+):(\*|\d{1,5})|(ipc|inproc)://.+")
WAKERS = ("thread", "timer")
#: the servo periods a configuration may ask for, ns (a card built in code may use any)
PERIOD_NS = (10_000, 1_000_000_000)
#: the events socket's heartbeat period, wall seconds (default, bounds): subscribers call a
#: daemon gone after three periods without one (PROTOCOL.md "Heartbeat")
HEARTBEAT_S = HEARTBEAT_NS / 1e9
HEARTBEAT_RANGE_S = (0.01, 3.0)


class ConfigError(ValueError):
    """A configuration that cannot start a rack; the message names the key."""


@dataclass(frozen=True)
class CardSpec:
    """One [[card]]: its type, name and options (checked by the card when built from a plain
    mapping)."""

    type: str
    name: str
    options: Mapping[str, Any]


@dataclass
class Config:
    endpoint: str = DEFAULT_ENDPOINT
    events: str = DEFAULT_EVENTS
    clock: Literal["realtime", "lockstep"] = "realtime"
    wake_us: int = 1000
    waker: Literal["thread", "timer"] = "thread"
    #: cards at rest run their quiet ticks in closed form (false: every tick runs in full)
    skip_quiet: bool = True
    state_dir: str | None = None
    #: where the shared memory of local clients is created ("": none; decision 0010)
    shm_dir: str = DEFAULT_SHM_DIR
    #: scheduled `control` actions one client, and all clients, may have pending
    max_scheduled_per_client: int = MAX_SCHEDULED_PER_CLIENT
    max_scheduled: int = MAX_SCHEDULED
    #: the heartbeat period on the events socket, wall seconds
    heartbeat_s: float = HEARTBEAT_S
    curve: CurveConfig | None = None
    #: `[security] allow_unauthenticated_networks`: serve these networks without CURVE
    open_networks: tuple[str, ...] = ()
    #: `[metrics]`: the HTTP metrics and health endpoint (None: off)
    metrics: MetricsConfig | None = None
    #: `[web]`: the live web view (None: off)
    web: WebConfig | None = None
    cards: list[CardSpec] = field(default_factory=list)


_SECTIONS = {"server", "clock", "state", "security", "metrics", "card", "web"}


def load(path: str | Path | None) -> Config:
    """Read and validate a configuration file; None gives the embedded default rack."""
    if path is None:
        return default_config()
    try:
        with open(path, "rb") as f:
            data = tomllib.load(f)
    except OSError as exc:
        raise ConfigError(f"{path}: {exc.strerror}") from None
    except tomllib.TOMLDecodeError as exc:
        raise ConfigError(f"{path}: not valid TOML: {exc}") from None
    except UnicodeDecodeError as exc:
        raise ConfigError(f"{path}: not valid TOML: not UTF-8 (byte {exc.start})") from None
    return parse(data)


def default_config() -> Config:
    """One card of each registered type, loopback endpoints, realtime clock."""
    cfg = Config()
    cfg.cards = [
        CardSpec(t, f"{DEFAULT_NAMES.get(t, t.split('-')[0])}0", _card_defaults(t, {}, "card"))
        for t in CARD_TYPES
    ]
    return cfg


def parse(data: dict[str, Any]) -> Config:
    unknown = sorted(set(data) - _SECTIONS)
    if unknown:
        raise ConfigError(f"{unknown[0]}: unknown section (sections: {', '.join(sorted(_SECTIONS))})")
    cfg = Config()
    server = _table(data, "server")
    _only(server, "server", ("endpoint", "events", "shm_dir", "max_scheduled_per_client",
                             "max_scheduled", "heartbeat_s"))
    cfg.endpoint = _str(server, "server", "endpoint", cfg.endpoint)
    cfg.events = _str(server, "server", "events", cfg.events)
    cfg.shm_dir = _str(server, "server", "shm_dir", cfg.shm_dir)
    for key in ("max_scheduled_per_client", "max_scheduled"):
        value = server.get(key, getattr(cfg, key))
        if not isinstance(value, int) or isinstance(value, bool) or not 0 <= value <= 10**6:
            raise ConfigError(f"server.{key}: {value!r} is not an integer in 0..1000000")
        setattr(cfg, key, value)
    beat = server.get("heartbeat_s", cfg.heartbeat_s)
    low, high = HEARTBEAT_RANGE_S
    if isinstance(beat, bool) or not isinstance(beat, (int, float)) or not low <= beat <= high:
        raise ConfigError(f"server.heartbeat_s: {beat!r} is not a number of seconds in "
                          f"{low}..{high}")
    cfg.heartbeat_s = float(beat)
    clock = _table(data, "clock")
    _only(clock, "clock", ("mode", "wake_us", "waker", "skip_quiet"))
    cfg.clock = _choice(clock, "clock", "mode", CLOCK_MODES, cfg.clock)  # type: ignore[assignment]
    cfg.waker = _choice(clock, "clock", "waker", WAKERS, cfg.waker)  # type: ignore[assignment]
    wake = clock.get("wake_us", cfg.wake_us)
    if not isinstance(wake, int) or isinstance(wake, bool) or not 100 <= wake <= 100_000:
        raise ConfigError(f"clock.wake_us: {wake!r} is not an integer in 100..100000")
    cfg.wake_us = wake
    skip = clock.get("skip_quiet", cfg.skip_quiet)
    if not isinstance(skip, bool):
        raise ConfigError(f"clock.skip_quiet: {skip!r} is not true or false")
    cfg.skip_quiet = skip
    state = _table(data, "state")
    _only(state, "state", ("dir",))
    cfg.state_dir = _str(state, "state", "dir", None)
    security = _table(data, "security")
    if "allow_unauthenticated_networks" in security:
        _only(security, "security", ("server_secret_key", "client_keys_dir",
                                     "allow_unauthenticated_networks"))
        keys = [k for k in ("server_secret_key", "client_keys_dir") if k in security]
        if keys:
            raise ConfigError(f"security.allow_unauthenticated_networks: serves without CURVE, "
                              f"so security.{keys[0]} cannot be set too")
        try:
            cfg.open_networks = parse_networks(security["allow_unauthenticated_networks"],
                                               "security.allow_unauthenticated_networks")
        except ValueError as exc:
            raise ConfigError(str(exc)) from None
    elif "security" in data:
        _only(security, "security", ("server_secret_key", "client_keys_dir",
                                     "allow_unauthenticated_networks"))
        cfg.curve = CurveConfig(
            _required(security, "security", "server_secret_key"),
            _required(security, "security", "client_keys_dir"),
        )
        try:
            check_curve(cfg.curve)
        except ValueError as exc:
            raise ConfigError(str(exc)) from None
    if "metrics" in data:
        try:
            cfg.metrics = parse_metrics(data["metrics"])
        except ValueError as exc:
            raise ConfigError(str(exc)) from None
    if "web" in data:
        try:
            cfg.web = parse_web(data["web"])
        except ValueError as exc:
            raise ConfigError(str(exc)) from None
    cards = data.get("card", [])
    if not isinstance(cards, list):
        raise ConfigError("card: use [[card]] tables, one per card")
    seen: set[str] = set()
    for i, table in enumerate(cards):
        where = f"card[{i}]"
        if not isinstance(table, dict):
            raise ConfigError(f"{where}: must be a table")
        ctype = table.get("type")
        if not isinstance(ctype, str) or ctype not in CARD_TYPES:
            raise ConfigError(
                f"{where}.type: unknown card type {ctype!r} (types: {', '.join(CARD_TYPES)})"
            )
        name = table.get("name")
        if not isinstance(name, str) or not _NAME.fullmatch(name):
            raise ConfigError(f"{where}.name: {name!r} is not a name (letters, digits, - and _)")
        if name in seen:
            raise ConfigError(f"{where}.name: duplicate card name {name!r}")
        seen.add(name)
        cfg.cards.append(CardSpec(ctype, name, _card_defaults(ctype, table, where)))
    check_endpoints(cfg)
    return cfg


def check_endpoints(cfg: Config) -> None:
    """Non-loopback endpoints need CURVE keys (DESIGN.md "Security")."""
    for key, ep in (("server.endpoint", cfg.endpoint), ("server.events", cfg.events)):
        match = _ENDPOINT.fullmatch(ep)
        if not match or match[2] not in (None, "*") and int(match[2]) > 65535:
            raise ConfigError(f"{key}: {ep!r} is not a ZeroMQ endpoint (tcp://HOST:PORT with "
                              "PORT 0..65535 or *, [IPv6]:PORT, ipc://PATH)")
        if not is_local(ep) and cfg.curve is None and not cfg.open_networks:
            raise ConfigError(
                f"{key}: {ep!r} is not loopback; add a [security] section "
                "(server_secret_key, client_keys_dir) to serve it with CURVE, or name a "
                "private network in [security] allow_unauthenticated_networks"
            )


def _card_defaults(ctype: str, table: dict[str, Any], where: str) -> CardOptions:
    """The card's options: its declared keys checked and defaulted, unknown keys rejected, one
    frozen object the card reads (vdevd/devices/options.py)."""
    try:
        cls = card_class(ctype)
        options = parse_options(cls.options, table, where, cls.axes_option)
        cls.check_options(options, where)
    except ValueError as exc:
        raise ConfigError(str(exc)) from None
    period = options.period_ns
    if period is not None and not PERIOD_NS[0] <= period <= PERIOD_NS[1]:
        raise ConfigError(f"{where}.period_ns: {period!r} is not an integer in 10000..1e9")
    return options


def _table(data: dict[str, Any], key: str) -> dict[str, Any]:
    value = data.get(key, {})
    if not isinstance(value, dict):
        raise ConfigError(f"{key}: must be a table")
    return value


def _only(table: dict[str, Any], section: str, keys: tuple[str, ...]) -> None:
    for key in table:
        if key not in keys:
            raise ConfigError(f"{section}.{key}: unknown key (keys: {', '.join(keys)})")


def _str(table: dict[str, Any], section: str, key: str, default: str | None) -> Any:
    value = table.get(key, default)
    if value is not None and not isinstance(value, str):
        raise ConfigError(f"{section}.{key}: expected a string, got {value!r}")
    return value


def _choice(table: dict[str, Any], section: str, key: str, choices: tuple[str, ...], default: str) -> str:
    value = table.get(key, default)
    if value not in choices:
        raise ConfigError(f"{section}.{key}: {value!r} is not one of {', '.join(choices)}")
    return str(value)


def _required(table: dict[str, Any], section: str, key: str) -> str:
    value = _str(table, section, key, None)
    if not value:
        raise ConfigError(f"{section}.{key}: missing")
    return str(value)
