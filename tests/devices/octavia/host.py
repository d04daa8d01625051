"""A host driving an in-process Octavia card through its DPR, as a driver would: bus accesses
through the region (hooks included), RTCs posted by the manual's procedure [Ch6 Real-Time
Commands], time advanced in samples."""

from __future__ import annotations

import struct
from collections.abc import Mapping, Sequence
from typing import Any

from vdevmaps.octavia import BY_NAME, Dpr, axis_offset, pack

from vdevd.devices.base import CardContext
from vdevd.devices.octavia.card import OctaviaCard
from vdevd.irq import IrqEvent


class Host:
    def __init__(self, **options: Any) -> None:
        self.events: list[IrqEvent] = []
        self.card = OctaviaCard("octavia0", options, CardContext(emit=self.events.append))
        self.dpr = self.card.dpr
        assert self.ack() == 0x10  # power-up: "reset finished" [Ch6 Power-Up/Reset]
        self.events.clear()

    # -- bus accesses ---------------------------------------------------------------------------
    def read(self, offset: int, size: int) -> bytes:
        return self.dpr.read(offset, size)

    def u8(self, offset: int) -> int:
        return self.read(offset, 1)[0]

    def i32(self, offset: int) -> int:
        return int(struct.unpack("<i", self.read(offset, 4))[0])

    def write(self, offset: int, data: bytes) -> None:
        self.dpr.write(offset, data)

    def position(self, axis: int) -> int:
        return self.i32(axis_offset(Dpr.ACTPOS, axis))

    def error(self, axis: int) -> int:
        return self.i32(axis_offset(Dpr.ERROR, axis))

    # -- time -----------------------------------------------------------------------------------
    def run(self, samples: int) -> None:
        """Advance `samples` samples (batches stop at interrupts: run on to the count)."""
        done = 0
        while done < samples:
            done += self.card.tick(samples - done)

    def run_until(self, offset: int, mask: int, limit: int) -> int:
        """Samples until (DPR byte at `offset` & mask) != 0, at most `limit`; -1 if never."""
        for k in range(1, limit + 1):
            self.card.tick(1)
            if self.dpr.buf[offset] & mask:
                return k
        return -1

    # -- RTCs [Ch6 Real-Time Commands] ----------------------------------------------------------
    def raw_rtc(self, code: int, args: bytes = b"") -> None:
        """Poll 3C2h for 00h, write the arguments from 3C3h, then the code; the card takes it
        at its next sample."""
        assert self.u8(Dpr.RTC) == 0, "the previous RTC is still pending"
        if args:
            self.write(Dpr.ARGMNTS, args)
        self.write(Dpr.RTC, bytes((code,)))
        self.run(1)

    def rtc(self, name: str, head: Mapping[str, Any] | None = None,
            groups: Sequence[Mapping[str, Any]] = ()) -> None:
        r = BY_NAME[name]
        self.raw_rtc(r.code, pack(r, head or {}, groups))
        assert self.u8(Dpr.RTC) == 0, f"{name}: the card did not clear 3C2h"

    def ack(self) -> int:
        """The interrupt service of [Ch6 Handling Interrupts]: read 1FFEh (ends the line), then
        under the status lock clear every bit it reported; the 1FFEh value read."""
        hostint = self.u8(Dpr.HOSTINT1)
        self.write(Dpr.HOSTACC_INT, b"\x01")
        assert self.u8(Dpr.MINTACC) == 0
        self.write(0x000, bytes(0x10))
        self.write(Dpr.HOSTINT1, b"\x00")
        self.write(Dpr.HOSTACC_INT, b"\x00")
        return hostint
