"""The card through a real daemon: dls-pmaclib over the Ethernet protocol, the DPRAM handshake,
the host port and its interrupts, SAVE across a restart, the backdoor [issue 5 "Tests"]."""

from __future__ import annotations

import socket
import struct
from pathlib import Path

import pytest

from tests.devices.pmac.conftest import PERIOD_NS, Pmac, pmac_card

ACK = "\x06"


def ask(pmac: Pmac, command: str) -> str:
    reply, ok = pmac.dls().sendCommand(command)
    assert ok, reply
    return reply


# -- dls-pmaclib, unmodified [DLS-lib; spec pmac.md §3.3] ------------------------------------------------
def test_dls_pmaclib_connects_and_identifies_the_card(pmac: Pmac) -> None:
    dls = pmac.dls()
    assert dls.getPmacModelCode() == 603382
    assert dls.isModelGeobrick()
    assert dls.getNumberOfAxes() == 8  # eight on-board axes, I20-I23 = $0: no MACRO IC


def test_dls_pmaclib_reads_and_writes_i_variables(pmac: Pmac) -> None:
    dls = pmac.dls()
    assert dls.sendCommand("i130")[0] == "2000\r" + ACK
    dls.setVar("i130", 1500)
    assert dls.sendCommand("i130")[0] == "1500\r" + ACK
    assert dls.getIVars(100, [30, 31, 32]) == ["1500", "1280", "1280"]


def test_dls_pmaclib_jogs_a_motor_and_reads_its_position(pmac: Pmac) -> None:
    dls = pmac.dls()
    dls.jogTo(1, 2000)
    pmac.step_ms(500)
    assert dls.sendCommand("#1P")[0] == "2000\r" + ACK
    dls.jogInc(1, "neg", 500)
    pmac.step_ms(500)
    assert dls.sendCommand("#1P")[0] == "1500\r" + ACK
    dls.jogContinous(1, "pos")
    pmac.step_ms(100)
    moving = int(dls.sendCommand("#1?")[0][:6], 16)
    assert not moving & (1 << 13)  # desired velocity is not zero while jogging
    dls.jogStop(1)
    pmac.step_ms(500)
    status = int(dls.sendCommand("#1?")[0][6:12], 16)
    assert status & 1  # in position


def test_dls_pmaclib_homes_a_motor_on_its_home_flag(pmac: Pmac) -> None:
    dls = pmac.dls()
    dls.sendCommand("I7012=2")  # capture on the home flag alone (the factory 1 is the index)
    dls.homeCommand(1)
    pmac.step_ms(100)
    w1 = int(dls.sendCommand("#1?")[0][:6], 16)
    assert w1 & (1 << 10)  # home search in progress
    pmac.control("set_home", motor=1, active=True)
    pmac.step_ms(1000)
    reply = dls.sendCommand("#1?")[0]
    w1, w2 = int(reply[:6], 16), int(reply[6:12], 16)
    assert not w1 & (1 << 10) and w2 & (1 << 10)  # search over, home complete
    assert dls.sendCommand("#1P")[0] == "0\r" + ACK


def test_dls_pmaclib_send_series_flags_the_failing_line(pmac: Pmac) -> None:
    dls = pmac.dls()
    lines = list(enumerate(["P1=1", "P2=2", "BADCMD", "P4=4"], start=1))
    results = list(dls.sendSeries(lines))
    assert [(n, cmd) for ok, n, cmd, _ in results if not ok] == [(3, "BADCMD")]
    assert dls.sendCommand("P1 P2 P4")[0] == "1\r2\r4\r" + ACK


def test_dls_pmaclib_disables_limits_through_ixx24(pmac: Pmac) -> None:
    dls = pmac.dls()
    dls.disableLimits(1, True)
    assert int(dls.sendCommand("i124")[0].strip("$\r\x06"), 16) & (1 << 17)


def test_ethernet_reply_longer_than_1400_bytes_arrives_whole(pmac: Pmac) -> None:
    """Three GETRESPONSE/GETBUFFER pieces (1400 + 1400 + 201 bytes). Values of three bytes keep a
    CR off the end of each 1400-byte piece: dls-pmaclib takes a piece ending in CR for an error."""
    dls = pmac.dls()
    dls.sendCommand("P0..999=10")
    reply = dls.sendCommand("P0..999")[0]
    assert reply == "10\r" * 1000 + ACK


def test_errors_follow_i6_and_the_card_keeps_serving(pmac: Pmac) -> None:
    dls = pmac.dls()
    assert dls.sendCommand("I99999")[0] == "\x07ERR003\r"
    assert dls.sendCommand("ver")[0] == "1.940\r" + ACK


def test_each_connection_addresses_its_own_motor(pmac: Pmac) -> None:
    a, b = pmac.dls(), pmac.dls()
    a.sendCommand("#3")
    assert a.sendCommand("#")[0] == "3\r" + ACK
    assert b.sendCommand("#")[0] == "1\r" + ACK


def test_getmem_reads_the_dpram_over_ethernet(pmac: Pmac) -> None:
    pmac.card.region("dpram").write(0x2000, b"\x12\x34\x56\x78")
    host, port = pmac.ethernet.removeprefix("tcp://").rsplit(":", 1)
    with socket.create_connection((host, int(port)), timeout=5) as s:
        s.sendall(struct.pack(">BBHHH", 0xC0, 0xB4, 0x2000, 0, 4))
        assert s.recv(16) == b"\x12\x34\x56\x78"


# -- DPRAM ASCII handshake [spec pmac.md §2.10] --------------------------------------------------------
def test_dpram_handshake_posts_one_line_at_a_time_then_ack(pmac: Pmac) -> None:
    assert pmac.dpram_lines("I130 I131") == [(0x0D, "2000"), (0x0D, "1280"), (0x06, "")]


def test_dpram_error_word_is_bcd(pmac: Pmac) -> None:
    assert pmac.dpram_lines("I130 XYZ") == [(0x0D, "2000"), (0x8003, "")]
    assert pmac.dpram_lines("&1B1R") == [(0x8015, "")]


def test_dpram_ascii_ready_interrupt_when_enabled(pmac: Pmac) -> None:
    host = pmac.card.region("host")
    host.write(9, bytes([1 << 4]))  # IR4: ASCII response ready
    seq_before = pmac.card.region("host").read(8, 1)
    assert seq_before == b"\0"
    pmac.dpram_lines("VER")
    assert host.read(8, 1)[0] & (1 << 4)
    host.write(8, bytes([1 << 4]))  # write one to clear
    assert host.read(8, 1) == b"\0"


# -- host port [spec pmac.md §2.11] ----------------------------------------------------------------
def test_host_port_character_interface(pmac: Pmac) -> None:
    host = pmac.card.region("host")
    for ch in b"I3=2\rI130\r":
        host.write(7, bytes([ch]))
    out = bytearray()
    while host.read(2, 1)[0] & 1:
        out += host.read(7, 1)
    assert bytes(out) == b"\x06" + b"2000\r\x06"  # a reply is framed after its line ran


# -- SAVE survives a restart ------------------------------------------------------------------------
def test_save_survives_a_daemon_restart(tmp_path: Path) -> None:
    with pmac_card(tmp_path, plant="ideal") as pmac:
        dls = pmac.dls()
        dls.sendCommand("I130=1234 P5=5.5 M100->Y:$010000,0,8")
        reply, ok = dls.sendCommand("SAVE")
        assert ok
        dls.sendCommand("I131=1")  # not saved
    with pmac_card(tmp_path, plant="ideal") as pmac:
        dls = pmac.dls()
        assert dls.sendCommand("I130 I131 P5 M100->")[0] == \
            "1234\r1280\r5.5\rM100->Y:$010000,0,8,U\r" + ACK


# -- backdoor ------------------------------------------------------------------------------------------
def test_limit_stops_a_jog_with_the_limit_bit(pmac: Pmac) -> None:
    dls = pmac.dls()
    dls.jogContinous(1, "pos")
    pmac.step_ms(200)
    pmac.control("set_limits", motor=1, plus=True)
    pmac.step_ms(1000)
    reply = dls.sendCommand("#1?")[0]
    w1, w2 = int(reply[:6], 16), int(reply[6:12], 16)
    assert w1 & (1 << 21) and w2 & (1 << 11)
    assert dls.sendCommand("#1V")[0] == "0\r" + ACK


def test_amplifier_fault_kills_the_motor(pmac: Pmac) -> None:
    dls = pmac.dls()
    dls.sendCommand("#1J/")
    pmac.step(2)
    pmac.control("set_amp_fault", motor=1, active=True)
    pmac.step(2)
    reply = dls.sendCommand("#1?")[0]
    w1, w2 = int(reply[:6], 16), int(reply[6:12], 16)
    assert not w1 & (1 << 19) and w2 & (1 << 3)


def test_phase_clock_error_refuses_enabling_with_err018(pmac: Pmac) -> None:
    dls = pmac.dls()
    pmac.control("set_phase_clock_error", active=True)
    assert dls.sendCommand("#1J/")[0] == "\x07ERR018\r"
    assert int(dls.sendCommand("???")[0][:6], 16) & (1 << 3)


def test_unknown_backdoor_motor_is_a_parameter_error(pmac: Pmac) -> None:
    with pytest.raises(Exception, match="motor"):
        pmac.control("set_home", motor=9, active=True)


def test_servo_period_follows_i10(pmac: Pmac) -> None:
    """Servo cycle k at floor(k x I10 x 10^6 / 2^23) ns (I10 = 3,713,707: 442,708.37 ns)."""
    assert [pmac.step(1) for _ in range(3)] == [442_708, 885_416, 1_328_125]
    assert pmac.card.info.period_ns == PERIOD_NS


def test_backdoor_flags_show_in_the_servo_ic_flag_register(pmac: Pmac) -> None:
    """X:$078000 bits 16 HMFL, 17 PLIM, 18 MLIM, 15 FAULT of channel 1 [digest §1.5 table]."""
    dls = pmac.dls()
    dls.sendCommand("M120->X:$078000,15,4")
    assert dls.sendCommand("M120")[0] == "0\r" + ACK
    pmac.control("set_home", motor=1, active=True)
    pmac.control("set_limits", motor=1, minus=True)
    pmac.step(1)
    assert dls.sendCommand("M120")[0] == "10\r" + ACK  # HMFL (bit 16) and MLIM (bit 18)


def test_fatal_following_error_kills_every_motor(pmac_servo: Pmac) -> None:
    """Ixx11 exceeded: word 2 bit 2, and with Ixx24 bits 21-22 = 0 every motor is killed
    [§2.7; A L1863-1871]. Ixx12 sets the warning bit first."""
    dls = pmac_servo.dls()
    dls.sendCommand("#2J/ I111=160 I112=80 I122=100 I120=1 I121=0 I119=100")
    pmac_servo.step_ms(20)
    assert int(dls.sendCommand("#2?")[0][:6], 16) & (1 << 19)  # motor 2 enabled
    dls.sendCommand("#1J+")
    pmac_servo.step_ms(50)
    w1, w2 = (int(dls.sendCommand("#1?")[0][k:k + 6], 16) for k in (0, 6))
    assert w2 & (1 << 2) and w2 & (1 << 1)  # fatal and warning following error
    assert not w1 & (1 << 19)  # killed
    assert not int(dls.sendCommand("#2?")[0][:6], 16) & (1 << 19)  # motor 2 killed too


def test_following_error_report_while_jogging_with_the_servo_plant(pmac_servo: Pmac) -> None:
    dls = pmac_servo.dls()
    dls.sendCommand("#1J+")
    pmac_servo.step_ms(800)  # Ixx19 stretches the 100 ms S-curve to 410 ms; V averages 113 ms
    fe = float(dls.sendCommand("#1F")[0].rstrip("\r\x06"))
    assert 0 < abs(fe) < 16000 / 16  # below the factory warning limit Ixx12
    assert 13 < float(dls.sendCommand("#1V")[0].rstrip("\r\x06")) < 15.5  # 32 cts/ms x 0.4427 ms


def test_mldt_timer_reads_the_magnet_distance(pmac: Pmac) -> None:
    """I7mn0 = 12: the Y:b+0 timer latches distance x 0.35 us/mm x 117.96 MHz once per PFM period
    [A L94-435; digest §1.1 "Emulator model"]; the base distance comes from the backdoor."""
    dls = pmac.dls()
    pmac.control("set_mldt_base", motor=1, mm=100.0)
    dls.sendCommand("I7010=12 I7016=3 M107->Y:$078004,8,16,S M107=11 M100->Y:$078000,0,24")
    pmac.step_ms(10)
    expected = round(100.0 * 0.35e-6 * 117.96e6)  # about 4129 timer counts
    assert abs(int(dls.sendCommand("M100")[0].rstrip("\r\x06")) - expected) <= 1


def test_a_non_loopback_ethernet_endpoint_needs_an_allow_list() -> None:
    """The PMAC protocol has no authentication (README "Configuration")."""
    from vdevd.devices.base import CardContext
    from vdevd.devices.pmac.card import PmacCard

    with pytest.raises(ValueError, match="ethernet_allow"):
        PmacCard("pmac0", {"ethernet": "tcp://0.0.0.0:1025"}, CardContext(emit=lambda e: None))
    card = PmacCard("pmac0", {"ethernet": "tcp://0.0.0.0:1025", "ethernet_allow": ["10.0.0.0/8"]},
                    CardContext(emit=lambda e: None))
    assert card.allow == ["10.0.0.0/8"]


def test_ethernet_port_in_use_stops_the_daemon_from_starting() -> None:
    """Issue 16 §5: a listener that cannot bind is a start failure naming the card and the
    endpoint; DaemonThread raises it from start() as `vdevd serve` exits with it."""
    from vdevd.errors import StartError

    with socket.socket() as taken:
        taken.bind(("127.0.0.1", 0))
        taken.listen()
        port = taken.getsockname()[1]
        with pytest.raises(StartError, match=rf"^card\[0\] \(pmac0\) ethernet: 127.0.0.1:{port} "
                                              "already in use$"), \
                pmac_card(ethernet=f"tcp://127.0.0.1:{port}"):
            pass
