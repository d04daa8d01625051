"""`[web]`: where the web view listens and who may connect (issue 23 §3).

The same rules as `[metrics]` (vdevd/http_health.py): loopback unless `allow` names the
networks that may connect (loopback always may); a non-loopback `listen` needs `allow`.
"""

from __future__ import annotations

import ipaddress
from dataclasses import dataclass
from typing import Any

from vdevd.http_health import parse_listener
from vdevd.security import IPNetwork

DEFAULT_LISTEN = "127.0.0.1:8080"
_KEYS = ("listen", "allow")


@dataclass(frozen=True)
class WebConfig:
    """`[web]`: the page's `host:port` and the networks besides loopback that may connect."""

    listen: str = DEFAULT_LISTEN
    allow: tuple[str, ...] = ()

    @property
    def networks(self) -> tuple[IPNetwork, ...]:
        return tuple(ipaddress.ip_network(a, strict=False) for a in self.allow)


def parse_web(table: Any, where: str = "web") -> WebConfig:
    """`[web]` checked (ValueError naming the key): `listen` host:port, `allow` a list of IP
    networks (required when `listen` is not loopback), as `[metrics]` checks them."""
    return WebConfig(*parse_listener(table, where, _KEYS, DEFAULT_LISTEN))
