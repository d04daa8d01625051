"""`[web]`: where the web view listens and who may connect (issue 23 §3).

The same rules as `[metrics]` (vdevd/http_health.py): loopback unless `allow` names the
networks that may connect (loopback always may); a non-loopback `listen` needs `allow`.
"""

from __future__ import annotations

import ipaddress
from dataclasses import dataclass
from typing import Any

from vdevd.http_health import split_listen
from vdevd.security import IPNetwork, is_loopback_host

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
    networks (required when `listen` is not loopback)."""
    if not isinstance(table, dict):
        raise ValueError(f"{where}: must be a table")
    for key in table:
        if key not in _KEYS:
            raise ValueError(f"{where}.{key}: unknown key (keys: {', '.join(_KEYS)})")
    listen = table.get("listen", DEFAULT_LISTEN)
    if not isinstance(listen, str):
        raise ValueError(f"{where}.listen: expected a string, got {listen!r}")
    host, _ = split_listen(listen, f"{where}.listen")
    allow = table.get("allow", [])
    if not isinstance(allow, list) or not all(isinstance(a, str) for a in allow):
        raise ValueError(f"{where}.allow: expected a list of networks, got {allow!r}")
    for a in allow:
        try:
            ipaddress.ip_network(a, strict=False)
        except ValueError:
            raise ValueError(f"{where}.allow: {a!r} is not an IP network (\"10.0.0.0/8\")") from None
    if not is_loopback_host(host) and not allow:
        raise ValueError(f"{where}.listen: {listen!r} is not loopback; name the networks that may "
                         f"connect in {where}.allow (e.g. [\"10.0.0.0/8\"])")
    return WebConfig(listen, tuple(allow))
