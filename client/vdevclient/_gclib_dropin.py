"""gclib's `py` opened by the controller's address, for the drop-in `gclib` module (dropin/gclib.py).

Third-party code opens a controller by its IP address, `g.GOpen("192.168.0.42 --direct -s ALL")`.
A `galil-dmc13x8` card declares the address it stands for (its `address` option, in the card info
of `hello`); `py.GOpen` finds the card that declares the address on the daemon at $VDEVD_ENDPOINT
(or `--endpoint URL`) and opens it as `vdevclient.gclib.py` opens a card by name. Everything else
is `vdevclient.gclib.py`'s: a method added there is the drop-in's too.

gclib's address flags [gclib GOpen]: `--address`/`-a` ADDRESS (or the first bare word),
`--timeout`/`-t` ms, `--baud`/`-b` rate, `--subscribe`/`-s` MG|DR|EI|ALL|NONE, `--direct`/`-d`;
vdevd's own `--endpoint URL`, `--events URL`. Baud, subscriptions and --direct change nothing
here (the card's unsolicited output comes through GMessage whatever -s says); another flag is
taken as a switch and ignored.
"""

from __future__ import annotations

import shlex
from typing import Any, NoReturn

from vdevclient import galil, gclib
from vdevclient._galil_bus import CARD_TYPE
from vdevclient.core import Rack, connect
from vdevclient.errors import VdevClientError
from vdevclient.gclib import (
    _BUF_SIZE,
    DEFAULT_TIMEOUT_MS,
    G_BAD_ADDRESS,
    G_GCLIB_NON_BLOCKING_READ_EMPTY,
    G_OPEN_ERROR,
    G_TIMEOUT,
    _rc,
)


def _fail(code: int) -> NoReturn:
    """Raise GclibError with gclib's text for `code` (non-zero)."""
    _rc(code)
    raise AssertionError(code)  # _rc raises for every non-zero code


#: flags that take a value, by the name the value is kept under
_VALUED = {"--address": "address", "-a": "address", "--timeout": "timeout", "-t": "timeout",
           "--baud": "baud", "-b": "baud", "--subscribe": "subscribe", "-s": "subscribe",
           "--endpoint": "endpoint", "--events": "events"}


def parse_address(address: str) -> dict[str, str]:
    """gclib's address string as {"address": ..., "timeout": ..., ...}; GclibError "a bad
    address was specified in open" (G_BAD_ADDRESS) when it names no address, two, or a flag
    lacks its value."""
    try:
        words = shlex.split(address)
    except ValueError:
        _fail(G_BAD_ADDRESS)
    flags: dict[str, str] = {}
    i = 0
    while i < len(words):
        word = words[i]
        key = _VALUED.get(word)
        if key is not None:
            if i + 1 >= len(words) or key in flags:
                _fail(G_BAD_ADDRESS)
            flags[key] = words[i + 1]
            i += 2
            continue
        if not word.startswith("-"):
            if "address" in flags:
                _fail(G_BAD_ADDRESS)
            flags["address"] = word
        i += 1
    if not flags.get("address") or not flags.get("timeout", "0").isdigit():
        _fail(G_BAD_ADDRESS)
    return flags


#: the least wall time the daemon gets to answer the look-up (a short gclib --timeout is for
#: the card's replies, not for finding it)
LOOKUP_MIN_MS = 1000


def _lookup(endpoint: str | None, events: str | None, timeout_ms: int) -> Rack:
    """The daemon's rack; GclibError "device failed to open" when it does not answer within the
    timeout (wall time, at least LOOKUP_MIN_MS)."""
    try:
        return connect(endpoint, events, timeout=max(timeout_ms, LOOKUP_MIN_MS) / 1000)
    except VdevClientError:
        _fail(G_OPEN_ERROR)


def galil_cards(rack: Rack) -> list[dict[str, Any]]:
    """The card info (`hello`) of the rack's galil-dmc13x8 cards, in order."""
    return [c for c in rack.info["cards"] if c["type"] == CARD_TYPE]


def find_card(cards: list[dict[str, Any]], address: str) -> dict[str, Any] | None:
    """The card that declares `address`; else the card named so (vdevclient.gclib's form)."""
    for c in cards:
        if c.get("address") == address:
            return c
    return next((c for c in cards if c["name"] == address), None)


class py(gclib.py):
    """A Python connection to a Galil controller: here the galil-dmc13x8 card declaring its
    address (`vdevclient.gclib.py` for everything but opening and the address reports)."""

    def __init__(self) -> None:
        super().__init__()
        self._shown = ""  # the address GInfo reports
        self._serial = 0

    def GOpen(self, address: str) -> None:
        """Open the card that declares the address of gclib's address string (see the module
        docstring); GclibError "device failed to open" when no card declares it (as gclib
        fails for a controller that does not answer)."""
        flags = parse_address(address)
        timeout = int(flags.get("timeout", DEFAULT_TIMEOUT_MS))
        rack = _lookup(flags.get("endpoint"), flags.get("events"), timeout)
        try:
            found = find_card(galil_cards(rack), flags["address"])
            endpoint = rack.endpoint
        finally:
            rack.close()
        if found is None:
            _fail(G_OPEN_ERROR)
        words = [found["name"], "--timeout", str(timeout), "--endpoint", endpoint]
        if flags.get("events"):
            words += ["--events", flags["events"]]
        super().GOpen(shlex.join(words))
        self._shown = flags["address"]
        self._serial = int(found.get("serial") or 0)

    def GInfo(self) -> str:
        """gclib's connection string, "address, revision report, serial number":
        "192.168.0.42, DMC1348 Rev 1.1a, 0" (the revision report is the card's ^R^V)."""
        self._cc()
        _rc(galil.DMCVersion(self._gcon, self._buf, _BUF_SIZE))
        return f"{self._shown}, {self._buf.value.decode('latin-1')}, {self._serial}"

    def GMessage(self) -> str:
        """The card's unsolicited output (vdevclient.gclib's); with none pending, gclib's: wait
        up to the timeout (card time) for some, then GclibError "device timed out" (timeout 0:
        "data was not waiting for a zero-timeout read") [gclib.h GMessage, x_gmessage.cpp]."""
        text = super().GMessage()
        if text:
            return text
        wait_ms = self._initial_timeout if self._timeout == -1 else self._timeout
        if not wait_ms:
            _fail(G_GCLIB_NON_BLOCKING_READ_EMPTY)
        self._cc().pause(wait_ms)
        text = super().GMessage()
        if not text:
            _fail(G_TIMEOUT)
        return text

    def GAddresses(self) -> dict[str, str]:
        """The addresses the daemon's cards declare, each with its revision report
        ({"192.168.0.42": "DMC1348 Rev 1.1a"}), as gclib.py maps its listing."""
        bus = galil.bus_of(self._gcon) if self._gcon.value else None
        rack = _lookup(bus.rack.endpoint if bus is not None else None, None, DEFAULT_TIMEOUT_MS)
        try:
            cards = galil_cards(rack)
        finally:
            rack.close()
        return {c["address"]: c.get("revision", "") for c in cards if c.get("address")}
