"""Fixtures of the OMS MAXk tests: a real daemon (lockstep clock) holding one `oms-maxk` card
`maxk0` (board 1, 4 axes, every other option at its default), and `Maxk`, a host that talks to
the card the raw way, through the shared-memory rings and the message unit (spec oms.md
§2.4-2.5, §2.9).

    def test_wy(maxk: Maxk) -> None:
        assert maxk.query("WY;").startswith("MAXk-4000")

Text goes to the card as it is: end it with `;` as EPICS does, since a trailing command without
its terminator waits in the card for the next write (spec §2.4, §4.1).
"""

from __future__ import annotations

from collections.abc import Iterator
from contextlib import contextmanager
from pathlib import Path
from typing import Any

import pytest
import vdevclient
from vdevmaps.oms import RING_SIZE, MaxkDoorbell, Mu, Omisr, Shm

from vdevd.config import CardSpec, Config
from vdevd.devices import card_class
from vdevd.testing import DaemonThread

CARD = "maxk0"
CARD_TYPE = "oms-maxk"
AXES = 4
LOOPBACK = "tcp://127.0.0.1:*"



def card_config(**options: Any) -> Config:
    """One oms-maxk card `maxk0`, board 1, 4 axes, its defaults unless told, on free loopback
    ports, lockstep clock."""
    defaults = {key: opt.default for key, opt in card_class(CARD_TYPE).options.items()}
    return Config(endpoint=LOOPBACK, events=LOOPBACK, clock="lockstep",
                  cards=[CardSpec(CARD_TYPE, CARD,
                                  {**defaults, "board": 1, "axes": AXES, **options})])


@pytest.fixture
def maxk_daemon() -> Iterator[DaemonThread]:
    with DaemonThread(card_config()) as d:
        yield d


@pytest.fixture
def rack(maxk_daemon: DaemonThread) -> Iterator[vdevclient.Rack]:
    """The backdoor (`rack.control`) and the clock (`rack.sim`) of the card's daemon."""
    with vdevclient.connect(maxk_daemon.endpoint, maxk_daemon.events, timeout=10) as r:
        yield r


class Maxk:
    """A host on the card's two windows, doing what the EPICS MAXv driver does by hand.

    `send` puts bytes in the command ring and writes the insert index (the text channel's only
    doorbell, spec §2.4); `pending`/`release`/`reply` take one reply from the response ring and
    hand it back (0x0FC := 0x0F8, OMISR bit 0 W1C, semaphore 0, spec §2.5); `query` is both.
    """

    def __init__(self, rack: vdevclient.Rack, card: str = CARD) -> None:
        self.rack = rack
        self.card = rack.card(card)
        self.shm = self.card.region("shm")
        self.mu = self.card.region("mu")

    # -- the command ring ---------------------------------------------------------------------
    def send(self, text: str | bytes) -> None:
        """Write `text` as it is at 0x100 + put (wrapping at 1024), then put := the new index
        (spec §2.4 steps 2-3)."""
        data = text.encode("latin-1") if isinstance(text, str) else bytes(text)
        assert len(data) < RING_SIZE, "the host must not write more than 1023 bytes at once"
        put = self.shm.read32(Shm.COMMAND_INSERT)
        first = data[: RING_SIZE - put]
        self._write_bytes(Shm.COMMAND_RING + put, first)
        self._write_bytes(Shm.COMMAND_RING, data[len(first):])
        self.shm.write32(Shm.COMMAND_INSERT, (put + len(data)) % RING_SIZE)

    # -- the response ring --------------------------------------------------------------------
    def pending(self) -> bytes:
        """The bytes between 0x0FC and 0x0F8 (one posted reply, LF included), left in place."""
        start, end = self.shm.read32(Shm.RESPONSE_PROCESS), self.shm.read32(Shm.RESPONSE_INSERT)
        if end >= start:
            return self._read_bytes(Shm.RESPONSE_RING + start, end - start)
        return (self._read_bytes(Shm.RESPONSE_RING + start, RING_SIZE - start)
                + self._read_bytes(Shm.RESPONSE_RING, end))

    def release(self) -> None:
        """Hand the reply back: 0x0FC := 0x0F8, clear OM0I, semaphore := 0 (the card may then
        post the next reply, so OM0I is cleared before the semaphore)."""
        self.shm.write32(Shm.RESPONSE_PROCESS, self.shm.read32(Shm.RESPONSE_INSERT))
        self.mu.write32(Mu.OMISR, Omisr.OM0I)
        self.shm.write32(Shm.MESSAGE_SEMAPHORE, 0)

    def reply(self) -> str | None:
        """The posted reply without its LF (and released), or None when none is posted."""
        data = self.pending()
        if not data:
            return None
        self.release()
        assert data.endswith(b"\n"), f"a reply ends with one LF (spec §2.5): {data!r}"
        return data[:-1].decode("latin-1")

    def query(self, text: str | bytes, ticks: int = 4) -> str:
        """Send, then the reply, waiting up to `ticks` update cycles of lockstep time."""
        self.send(text)
        for _ in range(ticks + 1):
            got = self.reply()
            if got is not None:
                return got
            self.step(1)
        raise AssertionError(f"no reply to {text!r} within {ticks} update cycles")

    def _read_bytes(self, offset: int, size: int) -> bytes:
        """A byte string from plain memory, as bus accesses the region takes (a 2- or 4-byte
        access must be aligned; longer blocks go at any offset)."""
        if size == 0:
            return b""
        if size in (2, 4) and offset % size:
            return self.shm.read(offset, 1) + self.shm.read(offset + 1, size - 1)
        return self.shm.read(offset, size)

    def _write_bytes(self, offset: int, data: bytes) -> None:
        if not data:
            return
        if len(data) in (2, 4) and offset % len(data):
            self.shm.write(offset, data[:1])
            self.shm.write(offset + 1, data[1:])
        else:
            self.shm.write(offset, data)

    # -- the message unit ---------------------------------------------------------------------
    def odbr(self) -> int:
        """The outbound doorbell (done, over-travel, slip, command error) [S §3.4]."""
        return self.mu.read32(Mu.ODBR)

    def clear_odbr(self, bits: int = 0xFFFFFFFF) -> None:
        """Clear doorbell bits by writing ones [S §3.4.1]."""
        self.mu.write32(Mu.ODBR, bits)

    def command_error(self) -> bool:
        """ODBR bit 24, then cleared [S §3.4.4]."""
        raised = bool(self.odbr() & MaxkDoorbell.COMMAND_ERROR)
        self.clear_odbr(MaxkDoorbell.COMMAND_ERROR)
        return raised

    # -- the shared memory ---------------------------------------------------------------------
    def word(self, offset: int) -> int:
        """A signed 32-bit word of the shared memory."""
        value = self.shm.read32(offset)
        return value - (1 << 32) if value & 1 << 31 else value

    # -- the daemon ----------------------------------------------------------------------------
    def step(self, ticks: int) -> int:
        """Advance lockstep time by `ticks` update cycles; the new time in ns."""
        return self.rack.sim.step(ticks=ticks, card=self.card.name)

    def control(self, action: str, **params: Any) -> Any:
        """A backdoor action on the card (`set_home`, `set_limits`, `set_input` ...)."""
        return self.card.control(action, **params)


@pytest.fixture
def maxk(rack: vdevclient.Rack) -> Maxk:
    return Maxk(rack)


@contextmanager
def maxk_card(state_dir: Path | None = None, **options: Any) -> Iterator[Maxk]:
    """A daemon of its own with the card `maxk0` configured by `options` (`axes`, `axis_types`,
    `update_hz` ...), its flash kept in `state_dir` if given; a host on it. Two of these on the
    same `state_dir`, one after the other, are a power cycle."""
    cfg = card_config(**options)
    if state_dir is not None:
        cfg.state_dir = str(state_dir)
    with DaemonThread(cfg) as d, vdevclient.connect(d.endpoint, d.events, timeout=10) as rack:
        yield Maxk(rack)
