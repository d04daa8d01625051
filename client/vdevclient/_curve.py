"""The CURVE key files of a client (`connect(server_key=, client_key=)`, $VDEVD_SERVER_KEY and
$VDEVD_CLIENT_KEY), checked before a socket exists: a half-given pair or an unusable file is a
`ConfigurationError` naming the setting, never a silent fall back to no CURVE (which a CURVE
daemon answers with nothing: `hello: no reply`)."""

from __future__ import annotations

import zmq.auth

from vdevclient.errors import ConfigurationError


def curve_keys(server_key: tuple[str, str | None], client_key: tuple[str, str | None]
               ) -> tuple[str, str] | None:
    """`server_key`, `client_key`: (the setting's name, its file or None). The two files when
    both are given, None when neither is."""
    (server_name, server_file), (client_name, client_file) = server_key, client_key
    if not server_file and not client_file:
        return None
    if not server_file or not client_file:
        given, missing = ((server_name, client_name) if server_file
                          else (client_name, server_name))
        raise ConfigurationError(f"{given} is set but {missing} is not: CURVE needs both, the "
                                 "server's public key file and this client's secret key file")
    _load(server_name, server_file)
    if _load(client_name, client_file) is None:
        raise ConfigurationError(f"{client_name}: {client_file} holds no secret key (a public "
                                 "key file? give this client's .key_secret file)")
    return server_file, client_file


def _load(name: str, path: str) -> bytes | None:
    """The secret key of the certificate file at `path` (None for a public one)."""
    try:
        _, secret = zmq.auth.load_certificate(path)
    except (OSError, ValueError) as exc:
        reason = exc.strerror if isinstance(exc, OSError) and exc.strerror else str(exc)
        raise ConfigurationError(f"{name}: {path}: {reason}") from None
    return secret
