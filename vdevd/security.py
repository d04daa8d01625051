"""Endpoint safety (DESIGN.md "Security"): loopback by default, CURVE for anything else."""

from __future__ import annotations

import ipaddress
import logging
from dataclasses import dataclass
from pathlib import Path

import zmq
import zmq.auth
from zmq.auth.thread import ThreadAuthenticator

log = logging.getLogger("vdevd.security")

IPNetwork = ipaddress.IPv4Network | ipaddress.IPv6Network
IPAddress = ipaddress.IPv4Address | ipaddress.IPv6Address


def peer_ip(address: str) -> IPAddress:
    """A peer's address without its IPv6 scope; an IPv4-mapped IPv6 address as IPv4 (ValueError
    when it is no IP address)."""
    ip = ipaddress.ip_address(address.split("%", 1)[0])
    if isinstance(ip, ipaddress.IPv6Address) and ip.ipv4_mapped is not None:
        return ip.ipv4_mapped
    return ip


def loopback_or_in(address: object, networks: tuple[IPNetwork, ...]) -> bool:
    """A peer address that is loopback or in one of `networks` (False when it is no IP)."""
    try:
        ip = peer_ip(str(address))
    except ValueError:
        return False
    return ip.is_loopback or any(ip in net for net in networks)


def is_loopback_host(host: str) -> bool:
    """`localhost` or a loopback IP address."""
    if host == "localhost":
        return True
    try:
        return ipaddress.ip_address(host).is_loopback
    except ValueError:
        return False


@dataclass(frozen=True)
class CurveConfig:
    """`[security]`: the server's secret key file and the directory of allowed client keys."""

    server_secret_key: str
    client_keys_dir: str


def is_local(endpoint: str) -> bool:
    """True for ipc://, inproc:// and tcp:// endpoints bound to a loopback address."""
    scheme, _, rest = endpoint.partition("://")
    if scheme in ("ipc", "inproc"):
        return True
    if scheme != "tcp":
        return False
    return is_loopback_host(rest.rsplit(":", 1)[0].strip("[]"))


def check_curve(curve: CurveConfig) -> tuple[bytes, bytes]:
    """The server's (public, secret) key; ValueError naming the key when a file is unusable."""
    try:
        public, secret = zmq.auth.load_certificate(curve.server_secret_key)
    except (OSError, ValueError) as exc:
        raise ValueError(f"security.server_secret_key: {exc}") from None
    if secret is None:
        raise ValueError(f"security.server_secret_key: {curve.server_secret_key} has no secret key")
    if not Path(curve.client_keys_dir).is_dir():
        raise ValueError(f"security.client_keys_dir: {curve.client_keys_dir} is not a directory")
    return public, secret


def secure(ctx: zmq.Context, sockets: list[zmq.Socket], curve: CurveConfig) -> ThreadAuthenticator:
    """Make `sockets` CURVE servers that accept only the clients whose keys are allowed."""
    public, secret = check_curve(curve)
    auth = ThreadAuthenticator(ctx)
    auth.start()
    auth.configure_curve(domain="*", location=curve.client_keys_dir)
    for sock in sockets:
        sock.curve_secretkey = secret
        sock.curve_publickey = public
        sock.curve_server = True
    return auth


class _Networks(set[str]):
    """The addresses a NULL-mechanism ZAP handler lets in: any in `networks` or loopback
    (pyzmq's `Authenticator` asks `address in allowed`)."""

    def __init__(self, networks: tuple[IPNetwork, ...]) -> None:
        super().__init__()
        self.networks = networks

    def __contains__(self, address: object) -> bool:
        return loopback_or_in(address, self.networks)

    def __len__(self) -> int:
        return 1  # never empty: the authenticator then checks every address


def parse_networks(value: object, key: str) -> tuple[str, ...]:
    """A list of IP networks ("10.0.0.0/8", "192.168.5.7"); ValueError naming `key`."""
    if not isinstance(value, list) or not value or not all(isinstance(v, str) for v in value):
        raise ValueError(f"{key}: expected a non-empty list of networks (e.g. [\"10.0.0.0/8\"]), "
                         f"got {value!r}")
    for v in value:
        try:
            ipaddress.ip_network(v, strict=False)
        except ValueError:
            raise ValueError(f"{key}: {v!r} is not an IP network (e.g. \"10.0.0.0/8\")") from None
    return tuple(value)


def allow_networks(ctx: zmq.Context, sockets: list[zmq.Socket],
                   networks: tuple[str, ...]) -> ThreadAuthenticator:
    """Serve `sockets` without CURVE to peers in `networks` (and loopback) only, refusing every
    other peer at the handshake (ZAP): `[security] allow_unauthenticated_networks`, for a
    private network such as a CI cluster's. Logged as a warning."""
    nets = tuple(ipaddress.ip_network(n, strict=False) for n in networks)
    auth = ThreadAuthenticator(ctx)
    auth._allowed = _Networks(nets)  # pyzmq's address allow-list, by network instead of address
    auth.start()
    for sock in sockets:
        sock.zap_domain = b"vdevd"  # a NULL-mechanism socket asks ZAP only with a domain set
    log.warning("serving WITHOUT CURVE (no encryption, no client keys) to %s and loopback "
                "([security] allow_unauthenticated_networks)", ", ".join(networks))
    return auth
