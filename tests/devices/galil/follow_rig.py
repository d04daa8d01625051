"""A DMC-13X8 firmware without a card for the tests of gearing, ECAM, contour, SPM, loop polarity
and commutation: commands in, replies out, samples one by one (STYLE.md §1)."""

from __future__ import annotations

from vdevmaps.galil import A16Reg, ControlStatus

from vdevd.devices.galil.bus import A16Window
from vdevd.devices.galil.firmware import Firmware

PERIOD_NS = 1_000_000  # TM 1000: one sample a millisecond


class Rig:
    """One firmware (4 axes, `plant`) over its A16 window."""

    def __init__(self, plant: str = "ideal") -> None:
        self.bus = A16Window()
        self.fw = Firmware(4, PERIOD_NS, plant, 1000, self.bus, raise_irq=lambda code: None,
                           clear_irq=lambda: None)

    def send(self, line: str) -> bytes:
        """A command line through the command FIFO; what the card has answered so far."""
        for b in line.encode() + b"\r":
            self.bus.write(A16Reg.DATA, b)
        self.fw.serve()
        return self.receive()

    def receive(self) -> bytes:
        out = bytearray()
        while not self.bus.read(A16Reg.CONTROL) & ControlStatus.READ_EMPTY:
            out.append(self.bus.read(A16Reg.DATA))
        return bytes(out)

    def cmd(self, line: str) -> str:
        """A line whose every statement is accepted: its data without the colons."""
        reply = self.send(line)
        assert b"?" not in reply, f"{line!r} refused: TC {self.tc()}"
        return reply.decode().replace("\r\n:", "\n").strip(":").strip()

    def tc(self) -> int:
        return self.fw.error_code

    def refused(self, line: str) -> int:
        """A statement the card answers `?`: its TC code."""
        assert self.send(line) == b"?"
        return self.tc()

    def ints(self, line: str) -> list[int]:
        """A report (`RP`, `TP X`) as integers."""
        return [int(float(v)) for v in self.cmd(line).replace("\n", ",").split(",")]

    def value(self, expr: str) -> float:
        return float(self.cmd(f"MG {expr}"))

    def run(self, samples: int) -> None:
        for _ in range(samples):
            self.fw.step()

    def run_until_stopped(self, limit: int = 20_000) -> int:
        """Samples until no axis moves (and one more), at most `limit`."""
        moving = self.fw.motion.core.profile.moving
        for k in range(limit):
            self.fw.step()
            if not moving.any():
                self.fw.step()
                return k + 2
        raise AssertionError("still moving")
