"""A host on an in-process Octavia card, the raw way: RTCs posted at 3C2h/3C3h, the ring buffer
written at INPTR, the interrupt registers read at 1FFEh and 000h.. (spec octavia.md §2.5), time
run sample by sample (no daemon: the card's `tick`, as the scheduler runs it)."""

from __future__ import annotations

import struct
from collections.abc import Mapping, Sequence
from typing import Any

from vdevmaps.octavia import (
    BANK2,
    BY_NAME,
    DPR,
    RING_SLOTS,
    Dpr,
    axis_offset,
    pack,
    slot_offset,
)

from vdevd.devices.base import CardContext
from vdevd.devices.octavia.card import OctaviaCard

RTC_SAMPLES = 40  # an RTC not taken within this many samples fails the test


def vel_word(counts_per_sample: float) -> int:
    """A velocity as the card's 16.16 word (int32)."""
    return round(counts_per_sample * 65536)


class Host:
    """The card `oct0` (8 axes, an ideal plant unless told: ACTPOS then shows the commanded
    position, in counts) and the host's accesses to its DPR."""

    def __init__(self, axes: int = 8, plant: str = "ideal", **options: Any) -> None:
        self.events: list[Any] = []
        self.card = OctaviaCard("oct0", {"axes": axes, "plant": plant, **options},
                                CardContext(emit=self.events.append))
        self.dpr = self.card.regions[DPR]
        self.fw = self.card.fw

    # -- time ------------------------------------------------------------------------------------
    def run(self, samples: int) -> None:
        """Exactly `samples` samples (a batch stops at an interrupt: run on)."""
        left = samples
        while left > 0:
            left -= self.card.tick(left)

    # -- memory ----------------------------------------------------------------------------------
    def read(self, offset: int, size: int) -> bytes:
        return self.dpr.read(offset, size)

    def write(self, offset: int, data: bytes) -> None:
        self.dpr.write(offset, data)

    def u8(self, offset: int) -> int:
        return self.read(offset, 1)[0]

    def i32(self, offset: int) -> int:
        return int(struct.unpack("<i", self.read(offset, 4))[0])

    def actpos(self, axis: int) -> int:
        """ACTPOS of axis 1..8 (published after every batch of samples)."""
        return self.i32(axis_offset(Dpr.ACTPOS, axis))

    # -- RTCs [Ch6 Real-Time Commands] -----------------------------------------------------------
    def rtc(self, name: str, head: Mapping[str, Any] | None = None,
            groups: Sequence[Mapping[str, Any]] = ()) -> None:
        """Post an RTC (arguments, then the code) and run until the card cleared 3C2h."""
        rtc = BY_NAME[name]
        assert self.u8(Dpr.RTC) == 0, "the card still runs the last RTC"
        self.write(Dpr.ARGMNTS, pack(rtc, head or {}, groups))
        self.write(Dpr.RTC, bytes((rtc.code,)))
        for _ in range(RTC_SAMPLES):
            self.run(1)
            if self.u8(Dpr.RTC) == 0:
                return
        raise AssertionError(f"{name} not taken in {RTC_SAMPLES} samples")

    def parread(self, m: int) -> bytes:
        """PARREAD m: clear the echo, post, wait for 0B7h = m, read both banks' 8 bytes [Ch5
        PARREAD]."""
        self.write(Dpr.PARACC, b"\x00")
        self.rtc("PARREAD", {"m": m})
        for _ in range(2 * RTC_SAMPLES):
            if self.u8(Dpr.PARACC) == m:
                return self.read(Dpr.PARRDBK, 8) + self.read(Dpr.PARRDBK + BANK2, 8)
            self.run(1)
        raise AssertionError(f"PARREAD {m:02X}h not echoed")

    # -- interrupts [Ch6 Handling Interrupts] ----------------------------------------------------
    def hostint(self) -> int:
        return self.u8(Dpr.HOSTINT1)

    def stat1(self) -> int:
        return self.u8(Dpr.DSPSTAT1)

    def acknowledge(self) -> None:
        """Clear 1FFEh and the status block's bits (the host's side of the protocol)."""
        self.write(Dpr.HOSTACC_INT, b"\x01")
        self.write(Dpr.DSPSTAT1, bytes(Dpr.STATUS_END - Dpr.DSPSTAT1))
        self.write(Dpr.HOSTINT1, b"\x00")
        self.write(Dpr.HOSTACC_INT, b"\x00")

    # -- the ring buffer [Ch6 Contouring] ----------------------------------------------------------
    def inptr(self) -> int:
        return self.u8(Dpr.INPTR)

    def outptr(self) -> int:
        return self.u8(Dpr.OUTPTR)

    def free_slots(self) -> int:
        """Slots the host may write: all but one empty slot (full = INPTR + 1 == OUTPTR)."""
        return (self.outptr() - self.inptr() - 1) % RING_SLOTS

    def put(self, entries: Sequence[tuple[int, int]]) -> None:
        """Write {pos, vel word} entries from INPTR on (rolling over from slot 83 to 0), then
        INPTR := the slot after the last (rules 1-5)."""
        assert len(entries) <= self.free_slots(), "the ring has no room for them"
        slot = self.inptr()
        for pos, vel in entries:
            self.write(slot_offset(slot), struct.pack("<iI", pos, vel & 0xFFFFFFFF))
            slot = (slot + 1) % RING_SLOTS
        self.write(Dpr.INPTR, bytes((slot,)))

    def slot(self, index: int) -> tuple[int, int]:
        pos, vel = struct.unpack("<ii", self.read(slot_offset(index), 8))
        return int(pos), int(vel)
