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
