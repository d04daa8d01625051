"""Manual chapter 4 "Interrupts": setting up (2, 4 to N+3), EI conditions and vectors, UI, the
8-deep queue and servicing (6 to N+3, read N+3), through the A16 window with `card.irq.wait`,
and through DMCOpen(hwnd) and DMCGetInterruptStatus.

An interrupt event's status is code | vector << 8 | IRQ level << 16 (the card's README); the
card runs at its default IRQ level 5, the level of the manual's example.
"""

from __future__ import annotations

import ctypes
from typing import Any

import vdevclient
from vdevclient import galil
from vdevmaps.galil import InterruptStatus

from tests.devices.galil.conftest import (
    CARD,
    CONTROL,
    LATENCY_S,
    MS,
    OpenDmc,
    host_command,
    host_receive,
    host_send,
    move_time,
)

IRQ_LEVEL = 5
# status codes [M Ch4 §Servicing Interrupts]
NO_INTERRUPT = int(InterruptStatus.NONE)
X_COMPLETE, Y_COMPLETE, Z_COMPLETE = (int(InterruptStatus.AXIS_COMPLETE) + a for a in range(3))
ALL_COMPLETE = int(InterruptStatus.ALL_COMPLETE)
EXCESS_ERROR = int(InterruptStatus.EXCESS_ERROR)
LIMIT_SWITCH = int(InterruptStatus.LIMIT_SWITCH)
COMMAND_DONE = int(InterruptStatus.COMMAND_DONE)
USER = int(InterruptStatus.USER)  # UI n -> F0 + n
INPUT = int(InterruptStatus.INPUT)  # input n -> E0 + n


def enable(a16: vdevclient.Region) -> None:
    """[M Ch4 §Setting up Interrupts]: "the data 2 and 4 should be written to the CONTROL register"."""
    a16.write8(CONTROL, 2)
    a16.write8(CONTROL, 4)


def service(a16: vdevclient.Region) -> int:
    """[M Ch4 §Servicing Interrupts]: write 6 to N+3, then read N+3."""
    a16.write8(CONTROL, 6)
    return a16.read8(CONTROL)


def status(code: int, vector: int) -> int:
    return code | vector << 8 | IRQ_LEVEL << 16


def mark(rack: vdevclient.Rack) -> None:
    """The next `wait` returns an interrupt asserted from now on, even one asserted before it is
    called (a command may run as soon as its terminator is written)."""
    rack.card(CARD).irq.last_seq = rack.stats()["cards"][CARD]["irq_seq"]


def wait(card: vdevclient.Card, timeout_s: float = 2.0) -> dict[str, Any]:
    event = card.irq.wait(timeout_s=timeout_s)
    assert event is not None, "no interrupt"
    return event


def toggle(rack: vdevclient.Rack, n: int) -> None:
    """Input n goes low then high again, 10 and 20 ms from now (during the next wait)."""
    rack.control(CARD, "set_input", input=n, level=0, after_ns=10 * MS)
    rack.control(CARD, "set_input", input=n, level=1, after_ns=20 * MS)


def test_example_y_motion_complete_on_irq5_vector_255(rack: vdevclient.Rack,
                                                      a16: vdevclient.Region) -> None:
    """[M Ch4 §Example - Interrupts] 1): write 2, 4 to N+3; EI 2,,255; PR,5000; BGY: when the
    motion is complete IRQ5 goes high with vector 255; write 6, read N+3 -> D1; then 00."""
    card = rack.card(CARD)
    enable(a16)
    assert host_command(a16, b"EI 2,,255\r") == b":"
    assert host_command(a16, b"PR,5000\r") == b":"
    speed, acc, dec = (float(host_command(a16, f"{c} ,?\r".encode())[:-3]) for c in ("SP", "AC", "DC"))
    start = rack.sim.now_ns()
    mark(rack)
    assert host_command(a16, b"BGY\r") == b":"
    event = wait(card)
    assert event["status"] == status(Y_COMPLETE, 255)
    expected = move_time(5000, speed, acc, dec)
    assert expected <= (event["sim_time_ns"] - start) / 1e9 <= expected + LATENCY_S
    assert service(a16) == Y_COMPLETE
    assert service(a16) == NO_INTERRUPT


def test_example_user_interrupt_ui1_reads_f1(rack: vdevclient.Rack, a16: vdevclient.Region) -> None:
    """[M Ch4 §Example - Interrupts] 2): UI1 sends an interrupt; "After a 6 is written to address
    N + 3, the data F1 will be read at address N + 3"."""
    enable(a16)
    assert host_command(a16, b"EI ,,255\r") == b":"  # the vector must be sent first
    mark(rack)
    host_send(a16, b"UI1\r")
    assert wait(rack.card(CARD))["status"] == status(USER + 1, 255)
    assert host_receive(a16) == b":"
    assert service(a16) == 0xF1


def test_user_interrupts_0_to_15_read_f0_to_ff(rack: vdevclient.Rack, a16: vdevclient.Region) -> None:
    """"There are 16 of these User Interrupts"; F0 thru FF [M Ch4 §Servicing Interrupts]."""
    card = rack.card(CARD)
    enable(a16)
    host_command(a16, b"EI ,,64\r")
    for n in range(16):
        mark(rack)
        host_send(a16, f"UI{n}\r".encode())
        assert wait(card)["status"] == status(USER + n, 64)
        assert host_receive(a16) == b":"
        assert service(a16) == USER + n


def test_ei_517_x_and_z_complete_and_excess_error_with_vector_16(
        rack: vdevclient.Rack, a16: vdevclient.Region) -> None:
    """[M Ch4 §Configuring Interrupts]: X motion complete, Z motion complete and excess position
    error, vector 16: M = 2^9 + 2^2 + 2^0 = 517, EI 517,,16. Y completing does not interrupt."""
    card = rack.card(CARD)
    enable(a16)
    host_command(a16, b"EI 517,,16\r")
    host_command(a16, b"PR 1000,500,3000\r")
    host_command(a16, b"BG XYZ\r")
    first, second = wait(card), wait(card)
    assert (first["status"], second["status"]) == (status(X_COMPLETE, 16), status(Z_COMPLETE, 16))
    assert service(a16) == X_COMPLETE
    assert service(a16) == Z_COMPLETE
    assert service(a16) == NO_INTERRUPT
    # excess position error: the amplifier stops driving X, the error grows past ER
    host_command(a16, b"ER 100\r")
    rack.control(CARD, "set_amp_fault", axis="X", active=True)
    host_command(a16, b"JG 5000;BGX\r", replies=2)
    assert wait(card)["status"] == status(EXCESS_ERROR, 16)
    assert service(a16) == EXCESS_ERROR
    assert abs(float(host_command(a16, b"TEX\r")[:-3])) > 100


def test_excess_error_must_be_re_enabled_after_each_occurrence(
        rack: vdevclient.Rack, a16: vdevclient.Region) -> None:
    """"The * conditions must be re-enabled after each occurrence" (bit 9, excess position error)."""
    card = rack.card(CARD)
    enable(a16)
    host_command(a16, b"EI 512,,16;ER 100\r", replies=2)
    rack.control(CARD, "set_amp_fault", axis="X", active=True)
    host_command(a16, b"JG 5000;BGX\r", replies=2)
    wait(card)
    assert service(a16) == EXCESS_ERROR
    rack.control(CARD, "set_amp_fault", axis="Y", active=True)
    host_command(a16, b"JG ,5000;BGY\r", replies=2)
    assert card.irq.wait(timeout_s=0.5) is None
    assert abs(float(host_command(a16, b"TEY\r")[:-3])) > 100
    assert service(a16) == NO_INTERRUPT


def test_ei_32768_2_8_interrupts_on_input_2_only_and_must_be_re_enabled(
        rack: vdevclient.Rack, a16: vdevclient.Region) -> None:
    """[M Ch4 §Configuring Interrupts]: "an interrupt for Input 2 only with vector of 8": bit 15
    for m, bit 1 for n: EI 32768,2,8 -> E2. Inputs are a * condition: EI again to re-enable."""
    card = rack.card(CARD)
    enable(a16)
    host_command(a16, b"EI 32768,2,8\r")
    toggle(rack, 1)
    assert card.irq.wait(timeout_s=0.05) is None
    assert service(a16) == NO_INTERRUPT
    toggle(rack, 2)
    assert wait(card)["status"] == status(INPUT + 2, 8)
    assert service(a16) == 0xE2
    assert service(a16) == NO_INTERRUPT
    toggle(rack, 2)
    assert card.irq.wait(timeout_s=0.05) is None
    assert service(a16) == NO_INTERRUPT
    host_command(a16, b"EI 32768,2,8\r")
    toggle(rack, 2)
    assert wait(card)["status"] == status(INPUT + 2, 8)


def test_all_axes_complete_d8_when_the_last_axis_stops(rack: vdevclient.Rack,
                                                       a16: vdevclient.Region) -> None:
    """Bit 8, all axes motion complete -> D8 [M Ch4 §Configuring Interrupts]."""
    card = rack.card(CARD)
    enable(a16)
    host_command(a16, b"EI 256,,9\r")
    host_command(a16, b"PR 1000,3000\r")
    host_command(a16, b"BG XY\r")
    event = wait(card)
    assert event["status"] == status(ALL_COMPLETE, 9)
    assert host_command(a16, b"RP XY\r") == b"0000001000,0000003000\r\n:"
    assert service(a16) == ALL_COMPLETE


def test_limit_switch_interrupt_c0(rack: vdevclient.Rack, a16: vdevclient.Region) -> None:
    """Bit 10, limit switch -> C0 [M Ch4 §Configuring Interrupts, §Servicing Interrupts]."""
    card = rack.card(CARD)
    enable(a16)
    host_command(a16, b"EI 1024,,32\r")
    host_command(a16, b"JG 5000;BGX\r", replies=2)
    rack.control(CARD, "set_switches", axis="X", forward_limit=True, after_ns=100 * MS)
    event = wait(card)
    assert event["status"] == status(LIMIT_SWITCH, 32)
    assert service(a16) == LIMIT_SWITCH


def test_command_done_interrupt_da(rack: vdevclient.Rack, a16: vdevclient.Region) -> None:
    """Bit 14, command done -> DA [M Ch4 §Configuring Interrupts, §Servicing Interrupts]."""
    card = rack.card(CARD)
    enable(a16)
    host_command(a16, b"EI 16384,,33\r")
    while service(a16) != NO_INTERRUPT:  # EI's own completion, if the condition counts it
        pass
    mark(rack)
    host_send(a16, b"TPX\r")
    assert wait(card)["status"] == status(COMMAND_DONE, 33)
    assert host_receive(a16) == b"0000000000\r\n:"
    assert service(a16) == COMMAND_DONE


def test_queue_is_eight_deep_in_order_of_occurrence(rack: vdevclient.Rack,
                                                    a16: vdevclient.Region) -> None:
    """"an interrupt buffer that is eight levels deep. This allows for multiple interrupt
    conditions to be stored in sequence of occurrence without loss of data" [M Ch4 §Interrupts]."""
    enable(a16)
    host_command(a16, b"EI ,,200\r")
    host_command(a16, b"UI1;UI2;UI3;UI4;UI5;UI6;UI7;UI8\r", replies=8)
    assert [service(a16) for _ in range(8)] == [USER + n for n in range(1, 9)]
    assert service(a16) == NO_INTERRUPT


def test_ei0_clears_the_queue(rack: vdevclient.Rack, a16: vdevclient.Region) -> None:
    """"The EI0 clears the interrupt queue" [M Ch4 §Interrupts]."""
    enable(a16)
    host_command(a16, b"EI ,,200\r")
    host_command(a16, b"UI3;UI4\r", replies=2)
    host_command(a16, b"EI0\r")
    assert service(a16) == NO_INTERRUPT


def test_no_interrupt_reaches_the_host_before_2_and_4_are_written(
        rack: vdevclient.Rack, a16: vdevclient.Region) -> None:
    """The host enables the card's interrupts by writing 2 then 4 [M Ch4 §Setting up Interrupts]."""
    card = rack.card(CARD)
    host_command(a16, b"EI 1,,99\r")
    host_command(a16, b"PR 100;BGX\r", replies=2)
    assert card.irq.wait(timeout_s=0.2) is None


# -- through the DMC library ----------------------------------------------------------------------
def test_dmc_open_with_a_window_enables_interrupts_and_get_status_reads_d1(
        rack: vdevclient.Rack, open_dmc: OpenDmc) -> None:
    """DMCOpen with a window handle writes 2, 4; DMCGetInterruptStatus writes 6 and reads N+3."""
    dmc = open_dmc(hwnd=1)
    card = rack.card(CARD)
    dmc.cmd("EI 2,,255")
    dmc.cmd("PR,5000")
    dmc.cmd("BGY")
    assert wait(card)["status"] == status(Y_COMPLETE, 255)
    code = ctypes.c_ushort()
    assert galil.DMCGetInterruptStatus(dmc.handle, ctypes.byref(code)) == galil.DMCNOERROR
    assert code.value == Y_COMPLETE
    assert galil.DMCGetInterruptStatus(dmc.handle, ctypes.byref(code)) == galil.DMCNOERROR
    assert code.value == NO_INTERRUPT


def test_dmc_ei_517_codes_in_the_order_the_axes_finish(rack: vdevclient.Rack, open_dmc: OpenDmc) -> None:
    """EI 517,,16 with X finishing after Z: the queue keeps the order of occurrence."""
    dmc = open_dmc(hwnd=1)
    card = rack.card(CARD)
    dmc.cmd("EI 517,,16")
    dmc.cmd("PR 4000,1000,300")
    dmc.cmd("BG XYZ")
    assert [wait(card)["status"] for _ in range(2)] == [status(Z_COMPLETE, 16), status(X_COMPLETE, 16)]
    codes = []
    for _ in range(3):
        code = ctypes.c_ushort()
        galil.DMCGetInterruptStatus(dmc.handle, ctypes.byref(code))
        codes.append(code.value)
    assert codes == [Z_COMPLETE, X_COMPLETE, NO_INTERRUPT]
