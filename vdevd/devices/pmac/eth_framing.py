"""The framing an Ethernet connection keeps across a reset (`$$$`, `$$$***`) [spec pmac.md §3.2, §3.3].

The Ethernet protocol answers GETRESPONSE "exactly as a serial port would give it with I3=2"
(§3.2), and Ethernet clients set that framing once, when they connect: dls-pmaclib sends
`i6=1 i3=2 ver` in `connect()` and never again; every later reply must end in ACK (or be
`<BELL>ERRnnn<CR>`), else it reports "unexpected terminator" (§3.3 item 2). Its `sendCommand("$$$")`
(dls-pmaccontrol's reset button) goes through the same path, and nothing in the library reconnects
afterwards. A reset brings back the saved (or factory) I3 and I6, by default 1 and 1, which would
frame the reset's own reply and every later one with line feeds.

Rule (README "Ethernet after a reset"): every Ethernet connection open when the card resets (by a
line on any port, itself included) goes on framing its replies -- the resetting line's own reply
included -- with the I3/I6 it framed its last reply with, until the card's I3 or I6 changes again
(a client that writes I3 or I6 gets what it wrote). The card's I3 and I6 themselves are what the
reset made them (`I3` reads the saved value), and the DPRAM, the host port and connections opened
after the reset frame with them. The connections' `#`/`&` addressing starts afresh at #1 and &1,
as the other ports' does.
"""

from __future__ import annotations


class KeptFraming:
    """One Ethernet connection's framing (I3, I6) across resets; no I/O."""

    __slots__ = ("_after", "_kept", "_last")

    def __init__(self) -> None:
        self._kept: tuple[int, int] | None = None   # the framing kept over a reset
        self._after: tuple[int, int] = (0, 0)       # the card's I3/I6 right after that reset
        self._last: tuple[int, int] | None = None   # the framing of the connection's last reply

    @property
    def kept(self) -> tuple[int, int] | None:
        return self._kept

    def modes(self, i3: int, i6: int) -> tuple[int, int]:
        """The (I3, I6) that frame a reply while the card has (`i3`, `i6`)."""
        if self._kept is not None and (i3, i6) != self._after:
            self._kept = None  # I3 or I6 written since the reset: the card's own values rule
        self._last = (i3, i6) if self._kept is None else self._kept
        return self._last

    def reset(self, i3: int, i6: int) -> None:
        """The card was reset and now has (`i3`, `i6`)."""
        if self._last is not None:
            self._kept, self._after = self._last, (i3, i6)
