"""The DMC-13X8 firmware on its own (vdevd/devices/galil/firmware.py): an A16 window, samples and
callbacks, no card, no daemon, no ZeroMQ (STYLE.md §1)."""

from __future__ import annotations

from vdevmaps.galil import IRQ_ENABLE_SEQUENCE, A16Reg, ControlStatus, InterruptStatus

from vdevd.devices.galil.bus import A16Window
from vdevd.devices.galil.firmware import Firmware

PERIOD_NS = 1_000_000  # TM 1000


class Rig:
    """A firmware over a window, with the interrupt callbacks and the clock recorded."""

    def __init__(self) -> None:
        self.bus = A16Window()
        self.raised: list[int] = []
        self.cleared = 0
        self.now_ns = 0
        self.fw = Firmware(4, PERIOD_NS, "ideal", 1000, self.bus, raise_irq=self.raised.append,
                           clear_irq=self._clear, clock=lambda: self.now_ns)

    def _clear(self) -> None:
        self.cleared += 1

    def send(self, line: bytes) -> bytes:
        """Write a line to N+1, let the firmware serve it, read N+1 until bit 5 says empty."""
        for b in line:
            self.bus.write(A16Reg.DATA, b)
        self.fw.serve()
        return self.receive()

    def receive(self) -> bytes:
        out = bytearray()
        while not self.bus.read(A16Reg.CONTROL) & ControlStatus.READ_EMPTY:
            out.append(self.bus.read(A16Reg.DATA))
        return bytes(out)

    def sample(self) -> None:
        """The next sample, at its time (as the rack runs a card's tick)."""
        self.now_ns = (self.fw.ticks + 1) * PERIOD_NS
        self.fw.step()


def test_a_command_written_to_the_window_is_answered_in_the_response_fifo() -> None:
    rig = Rig()
    assert rig.send(b"KP 10;KP ?\r") == b":0010.00\r\n:"


def test_ui_raises_the_line_with_the_ei_vector_once_the_host_enabled_it() -> None:
    rig = Rig()
    assert rig.send(b"EI ,,200;UI 3\r") == b"::"
    assert rig.raised == []  # queued; the host has not written 2, 4 to N+3
    for b in IRQ_ENABLE_SEQUENCE:
        rig.bus.write(A16Reg.CONTROL, b)
    assert rig.raised == [(InterruptStatus.USER + 3) | 200 << 8]


def test_ei0_clears_the_queue_and_drops_the_line() -> None:
    rig = Rig()
    rig.send(b"UI 1\r")
    assert rig.bus.pending_interrupts == (InterruptStatus.USER + 1,)
    rig.send(b"EI 0\r")
    assert rig.bus.pending_interrupts == ()
    assert rig.cleared == 1


def test_wt_holds_the_reply_until_the_clock_has_run_its_time() -> None:
    rig = Rig()
    rig.now_ns = PERIOD_NS // 2  # the rack's clock may stand between two samples: WT ends at 3.5 ms
    assert rig.send(b"WT 3\r") == b""
    for _ in range(3):
        rig.sample()
        assert rig.receive() == b""
    rig.sample()
    assert rig.receive() == b":"


def test_rs_forgets_the_variables_and_restores_the_defaults() -> None:
    rig = Rig()
    assert rig.send(b"V1=5;KP 10\r") == b"::"
    assert rig.send(b"RS\r") == b":"
    assert rig.send(b"KP ?\r") == b"0006.00\r\n:"
    assert rig.send(b"V1=\r") == b"?"
    assert rig.send(b"TC\r") == b"009\r\n:"  # TC 9: variable error
