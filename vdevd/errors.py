"""Error codes of wire protocol v1 (proto/PROTOCOL.md, "Errors") and the exception that carries them."""

from __future__ import annotations

import enum


class ErrorCode(enum.StrEnum):
    """The `code` of an error reply. Stable strings: clients switch on them."""

    MALFORMED = "malformed"  # not msgpack, not a map, wrong field types, missing fields
    TOO_LARGE = "too_large"  # message over the maximum size
    BAD_VERSION = "bad_version"  # protocol version not supported
    UNKNOWN_OP = "unknown_op"
    NO_CARD = "no_card"
    NO_REGION = "no_region"
    NO_IRQ = "no_irq"
    OUT_OF_RANGE = "out_of_range"  # offset/size outside the region
    BAD_WIDTH = "bad_width"  # access width or alignment the bus forbids
    BAD_ACTION = "bad_action"  # unknown control action
    BAD_PARAM = "bad_param"  # a value out of range or of the wrong kind
    WRONG_MODE = "wrong_mode"  # e.g. `sim step` while the clock is realtime
    BUSY = "busy"  # too many pending waits
    BAD_SNAPSHOT = "bad_snapshot"  # a snapshot of another version or layout, or damaged
    INTERNAL = "internal"  # a bug in a card; the daemon keeps serving


class VdevError(Exception):
    """A request that cannot be served; becomes an error reply `{code, message}`."""

    def __init__(self, code: ErrorCode, message: str) -> None:
        super().__init__(message)
        self.code = code
        self.message = message


class StartError(Exception):
    """A listener the configuration asks for cannot be opened (a card's port in use, a ready
    file that cannot be written): the daemon does not start. The message names what failed."""
