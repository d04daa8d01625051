"""A DMC-13X8 firmware without card or daemon for the program tests: the A16 window, samples at
their time, an in-memory flash (what the card writes to its state directory)."""

from __future__ import annotations

from typing import Any

from vdevmaps.galil import A16Reg, ControlStatus

from vdevd.devices.galil.bus import A16Window
from vdevd.devices.galil.firmware import Firmware

PERIOD_NS = 1_000_000  # TM 1000
_UNMARK = bytes(range(128)) * 2


class Rig:
    """A firmware over a window; `flash` holds the last image it burned."""

    def __init__(self, plant: str = "ideal", flash: dict[str, Any] | None = None) -> None:
        self.bus = A16Window()
        self.now_ns = 0
        self.flash = flash
        self.fw = Firmware(4, PERIOD_NS, plant, 1000, self.bus, raise_irq=lambda code: None,
                           clear_irq=lambda: None, clock=lambda: self.now_ns,
                           save_flash=self._save, flash_image=flash)

    def _save(self, image: dict[str, Any]) -> None:
        self.flash = image

    def send(self, line: bytes) -> bytes:
        """Write a line to N+1 (the card decodes on arrival), read N+1 until empty."""
        for b in line:
            self.bus.write(A16Reg.DATA, b)
            if b in b"\r;\\":
                self.fw.serve()
        self.fw.serve()
        return self.receive()

    def receive(self, raw: bool = False) -> bytes:
        """What the card sent; a program's messages (bit 7 set, CW1) unmarked unless `raw`."""
        out = bytearray()
        while not self.bus.read(A16Reg.CONTROL) & ControlStatus.READ_EMPTY:
            out.append(self.bus.read(A16Reg.DATA))
            if not self.bus.read(A16Reg.CONTROL) & ControlStatus.READ_EMPTY:
                continue
            self.fw.serve()  # the card refills the response FIFO as the host empties it
        return bytes(out) if raw else bytes(out).translate(_UNMARK)

    def download(self, program: str) -> bytes:
        """DL, the lines (CR), `\\`: the card's answer."""
        return self.send(b"DL\r" + program.replace("\n", "\r").encode() + b"\\")

    def samples(self, k: int) -> bytes:
        """k samples; what the card sent meanwhile (program messages)."""
        out = bytearray()
        for _ in range(k):
            self.now_ns = (self.fw.ticks + 1) * PERIOD_NS
            self.fw.step()
            out += self.receive()
        return bytes(out)

    def until_halted(self, limit: int = 100_000) -> bytes:
        """Samples until every thread has ended (at most `limit`); what the card sent."""
        out = bytearray()
        for _ in range(limit):
            if not self.fw.threads.active:
                return bytes(out)
            out += self.samples(1)
        raise AssertionError(f"a thread still runs after {limit} samples")

    def tc(self) -> int:
        return int(self.send(b"TC\r").split(b"\r")[0])

    def value(self, expr: str) -> float:
        return float(self.send(f"MG {expr}\r".encode()).split(b"\r")[0])
