"""Typed exceptions of the client core."""

from __future__ import annotations


class VdevClientError(Exception):
    """Base of the client's exceptions."""


class RemoteError(VdevClientError):
    """The daemon answered with an error reply `{code, message}` (proto/PROTOCOL.md, Errors)."""

    def __init__(self, code: str, message: str) -> None:
        super().__init__(f"{code}: {message}")
        self.code = code
        self.message = message


class VdevTimeout(VdevClientError, TimeoutError):
    """No reply within the client's timeout."""


class ConfigurationError(VdevClientError, ValueError):
    """A client setting that cannot work (a CURVE key half given, a key file unusable); the
    message names the setting."""


class DaemonGone(VdevClientError):
    """A subscription heard no heartbeat for three of the daemon's heartbeat periods
    (proto/PROTOCOL.md, Heartbeat): the daemon has stopped, or its event loop is held."""


class RackClosed(VdevClientError):
    """A request on a `Rack` after its `close()`."""


class RequestTooLarge(VdevClientError):
    """A request the client refused to send: its packed body exceeds the daemon's `max_message`
    (proto/PROTOCOL.md, Size; the daemon's socket drops bodies over 4 MiB without a reply)."""

    code = "too_large"

    def __init__(self, op: str, size: int, limit: int) -> None:
        super().__init__(f"too_large: {op} request of {size} bytes exceeds the daemon's "
                         f"max_message of {limit} bytes; not sent")
        self.op = op
        self.size = size
        self.limit = limit
