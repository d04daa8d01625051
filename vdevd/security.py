"""Endpoint safety (DESIGN.md "Security"): loopback by default, CURVE for anything else."""

from __future__ import annotations

import ipaddress
from dataclasses import dataclass
from pathlib import Path

import zmq
import zmq.auth
from zmq.auth.thread import ThreadAuthenticator


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
    host = rest.rsplit(":", 1)[0].strip("[]")
    if host == "localhost":
        return True
    try:
        return ipaddress.ip_address(host).is_loopback
    except ValueError:
        return False


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
