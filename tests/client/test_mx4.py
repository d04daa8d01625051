"""vdevclient.mx4, the Mx4 Octavia host library (spec octavia.md §8), against a real daemon holding
dspcg-octavia cards, lockstep. Every RTC's bytes are checked in test_mx4_codec.py; here what the
card does with them."""

from __future__ import annotations

import math
import struct
from collections.abc import Iterator
from typing import Any

import pytest
import vdevclient
from vdevclient import mx4
from vdevmaps.octavia import RING_SLOTS, SAMPLE_NS, Dpr, DspStat1, HostInt, Window

from tests.client.galil import card, rack_config, round_trips
from vdevd.testing import DaemonThread

OCT = "dspcg-octavia"
MOVE_MS = 30_000  # long enough for the moves here (card time)
#: the manual's example gains [Ch5 CTRL], for which the card's servo plant is tuned
GAINS = {"ki": 100, "kp": 4000, "kf": 3000, "kd": 2500}


def octavia(name: str = "oct0", **options: Any) -> Any:
    return card(OCT, name, **options)


@pytest.fixture
def daemon() -> Iterator[DaemonThread]:
    with DaemonThread(rack_config(octavia(plant="ideal"))) as d:
        yield d


@pytest.fixture
def h(daemon: DaemonThread) -> Iterator[mx4.Mx4]:
    with mx4.open(1, endpoint=daemon.endpoint) as handle:
        yield handle


@pytest.fixture
def rack(daemon: DaemonThread) -> Iterator[vdevclient.Rack]:
    with vdevclient.connect(daemon.endpoint, daemon.events) as r:
        yield r


def samples(h: mx4.Mx4) -> int:
    return h.rack.sim.now_ns() // SAMPLE_NS


def closed_form(acc: int, dist: int, vel: int) -> float:
    """The trapezoid's samples from rest [spec §5.3]: D/V + V/A, or 2 sqrt(D/A) for a triangle."""
    a, v = acc / 2**15, vel / 2**16
    return dist / v + v / a if dist >= v * v / a else 2 * math.sqrt(dist / a)


# -- opening ---------------------------------------------------------------------------------------------
def test_open_finds_a_card_by_its_number_else_by_its_place() -> None:
    """The card README's numbers: the `card` option (the PCI subsystem ID), else the place among
    the configuration's Octavias: here 5, 2, 3 (the generic card does not count)."""
    cfg = rack_config(octavia("oct0", card=5), card("generic-servo", "servo0"), octavia("oct1"),
                      octavia("oct2"))
    with DaemonThread(cfg) as d:
        for number, name in ((5, "oct0"), (2, "oct1"), (3, "oct2")):
            with mx4.open(number, endpoint=d.endpoint) as h:
                assert h.card == name
        with mx4.open(9, endpoint=d.endpoint, name="oct2") as h:  # a name wins
            assert h.card == "oct2"
        for number in (1, 4):  # the first Octavia is number 5
            with pytest.raises(mx4.Mx4Error,
                               match=f"no dspcg-octavia card number {number} .*oct0, oct1, oct2"):
                mx4.open(number, endpoint=d.endpoint)


def test_open_takes_the_endpoint_from_VDEVD_ENDPOINT(daemon: DaemonThread,
                                                     monkeypatch: pytest.MonkeyPatch) -> None:
    monkeypatch.setenv("VDEVD_ENDPOINT", daemon.endpoint)
    h = mx4.open()
    assert h.card == "oct0"
    mx4.close(h)
    mx4.close(h)  # again: nothing
    with pytest.raises(vdevclient.RackClosed):
        mx4.STOP(h, 0x01)


def test_open_clears_reset_finished_under_the_status_lock(daemon: DaemonThread,
                                                          rack: vdevclient.Rack) -> None:
    """Power-up init [Ch6 Power-Up/Reset Software Initialization]: the card comes up with 1FFEh
    b4 set; the first open clears it (locked write), and the lock is released."""
    dpr = rack.card("oct0").region("dpr")
    assert dpr.read8(Dpr.HOSTINT1) == HostInt.RESET_DONE
    with mx4.open(1, endpoint=daemon.endpoint) as h:
        assert mx4.read_int(h).hostint == 0
    assert dpr.read8(Dpr.HOSTACC_INT) == 0


def test_check_signature_reads_mx4_and_the_hardware_signature(h: mx4.Mx4) -> None:
    sig = mx4.check_signature(h)
    assert str(sig) == "MX4 4.0+4.0"
    assert (sig.bus, sig.option, sig.revision, sig.vx4) == ("P", "I", "A", None)


# -- RTC posting -------------------------------------------------------------------------------------------
def test_an_rtc_is_one_round_trip_that_returns_once_the_card_took_it(
        h: mx4.Mx4, monkeypatch: pytest.MonkeyPatch) -> None:
    with round_trips(monkeypatch) as trips:
        mx4.MAXACC(h, 0x01, 0x150)
    assert trips.count == 1
    assert h.dpr.read8(Dpr.RTC) == 0 and h.dpr.read8(Dpr.HOSTACC_INT) == 0
    assert mx4.parread(h, 0x16)[:2] == b"\x50\x01"


def test_the_rtc_bytes_on_the_wire_are_ch6_example_2(h: mx4.Mx4,
                                                      monkeypatch: pytest.MonkeyPatch) -> None:
    with round_trips(monkeypatch) as trips:
        mx4.AXMOVE(h, 0x0A, 0x150, [0, 0x234567, 0, 0x112233], 0x200000)
    writes = [(op[3], op[4]) if isinstance(op, list) else (op["offset"], op["data"])
              for op in trips.sent[0]["ops"]
              if (op[0] == "w" if isinstance(op, list) else op["op"] == "write")]
    assert writes[:2] == [(0x3C3, bytes.fromhex("0a5001674523000000200050013322110000002000")),
                          (0x3C2, b"\x60")]


def test_an_8_axis_axmove_goes_as_two_rtcs_in_one_round_trip_and_moves_every_axis(
        h: mx4.Mx4, monkeypatch: pytest.MonkeyPatch) -> None:
    """81 argument bytes do not fit the 57-byte window (spec Q-3): axes 1-5, then 6-8, one
    sample apart."""
    targets = [1000 * (a + 1) * (-1) ** a for a in range(8)]
    mx4.EN_MOTCP(h, 0xFF)
    with round_trips(monkeypatch) as trips:
        mx4.AXMOVE(h, 0xFF, 0x2000, targets, mx4.vel_to_raw(8))
    assert trips.count == 1
    codes = [op[4] for op in trips.sent[0]["ops"] if isinstance(op, list) and op[3] == Dpr.RTC]
    assert codes == [b"\x60", b"\x60"]
    mx4.wait_int(h, dspstat1=DspStat1.MOTCP, axes=0xFF, timeout_ms=MOVE_MS)
    assert list(mx4.read_axes(h, Window.ACTPOS)) == targets


def test_a_command_the_card_ignores_while_halting_raises_its_report_and_clears_it(
        h: mx4.Mx4, monkeypatch: pytest.MonkeyPatch) -> None:
    """STOP in progress: AXMOVE for that axis is discarded with "RTC ignored" (DSPSTAT1 b7, the
    axis in 008h) [Ch5 STOP; Ch7 Table 7-1]: raised, in two round trips, and cleared."""
    mx4.MAXACC(h, 0x04, 0x10)
    mx4.VELMODE(h, 0x04, mx4.vel_to_raw(20))
    h.rack.sim.step(seconds=0.2)
    mx4.STOP(h, 0x04)
    with round_trips(monkeypatch) as trips, pytest.raises(mx4.Mx4Error) as err:
        mx4.AXMOVE(h, 0x05, 0x150, [1000, 0, 1000], 0x10000)
    assert trips.count == 2
    assert "AXMOVE: the card discarded the command: DSPSTAT1 b7 IGNORED (RTC ignored: STOP (halt) " \
           "in progress) on axis 3" in str(err.value)
    assert (err.value.ignored, err.value.conflict, err.value.rtc) == (0x04, 0, "AXMOVE")
    status = mx4.read_int(h)
    assert not status.dspstat1 & DspStat1.IGNORED and status.sources(DspStat1.IGNORED) == 0
    assert h.dpr.read8(Dpr.HOSTACC_INT) == 0
    assert mx4.read_axes(h)[0] == 0  # axis 1 was in the discarded command too


def test_motion_commands_are_ignored_while_estop_is_active(h: mx4.Mx4) -> None:
    """*ESTOP halts every axis and the card ignores motion commands while it is active (spec
    §5.3); the ESTOP interrupt is 1FFEh b2."""
    mx4.MAXACC(h, 0x03, 0x100)
    h.rack.control(h.card, "set_estop", active=True)
    with pytest.raises(mx4.Mx4Error, match=r"VELMODE: .* b7 IGNORED .* on axes 1, 2") as err:
        mx4.VELMODE(h, 0x03, mx4.vel_to_raw(1))
    assert err.value.ignored == 0x03
    assert mx4.read_int(h).hostint & HostInt.ESTOP
    h.rack.control(h.card, "set_estop", active=False)
    mx4.VELMODE(h, 0x03, mx4.vel_to_raw(1))  # taken again


def test_a_conflict_left_by_another_program_is_raised_on_the_next_rtc_and_cleared(
        h: mx4.Mx4, rack: vdevclient.Rack) -> None:
    """A "conflicting commands" report (000h b6, the axes in 007h) nobody cleared, written here
    as the card leaves it: the next RTC raises it (decision 0012) and clears only it."""
    dpr = rack.card("oct0").region("dpr")
    dpr.write(Dpr.DSPSTAT1, bytes([DspStat1.CONFLICT | DspStat1.MOTCP, 0, 0, 0, 0, 0x01, 0, 0x06]))
    with pytest.raises(mx4.Mx4Error, match=r"b6 CONFLICT \(conflicting commands: the new motion "
                       r"command ignored\) on axes 2, 3") as err:
        mx4.MAXACC(h, 0x01, 0x100)
    assert err.value.conflict == 0x06
    assert dpr.read(Dpr.DSPSTAT1, 9) == bytes([DspStat1.MOTCP, 0, 0, 0, 0, 0x01, 0, 0, 0])  # the rest kept


def test_an_rtc_the_card_has_not_taken_raises_timeout(h: mx4.Mx4, rack: vdevclient.Rack) -> None:
    """With no time given, the card has no sample to take an RTC in: a pending code (here one
    written by another client) stops the post before it writes anything, and a post's own code
    is not acknowledged; the card takes both at its next sample."""
    dpr = rack.card("oct0").region("dpr")
    dpr.write(Dpr.ARGMNTS, b"\x01")
    dpr.write8(Dpr.RTC, 0x6E)
    with pytest.raises(mx4.Mx4Timeout, match="3C2h never read 00h: the card did not take the RTC "
                                             "before POS_PRESET"):
        h.send(mx4.encode("POS_PRESET", {"n": 1}, pset=5), timeout_ms=0)
    mx4.wait_rtc_idle(h)
    with pytest.raises(mx4.Mx4Timeout, match=r"POS_PRESET \(code 68h\) was not taken"):
        h.send(mx4.encode("POS_PRESET", {"n": 1}, pset=5), timeout_ms=0)
    mx4.wait_rtc_idle(h)
    assert mx4.read_axes(h)[0] == 5
    mx4.rtc(h, 0x6E, b"\x01")
    with pytest.raises(ValueError, match="57"):
        mx4.rtc(h, 0x60, bytes(58))


# -- motion [Ch5 AXMOVE, REL_AXMOVE, VELMODE, STOP; spec §5.3] -----------------------------------------
def test_axmove_example_1_completes_at_the_closed_form_time_with_motion_complete(h: mx4.Mx4) -> None:
    """[Ch5 AXMOVE] Example 1 after the listing's command sequence (MAXACC, CTRL, KILIMIT, AXMOVE,
    EN_MOTCP): axis 2 completes after D/V + V/A samples, then axis 1 (spec §5.3, +-2 samples)."""
    mx4.MAXACC(h, 0x03, 0x150)
    mx4.CTRL(h, 0x03, **GAINS)
    mx4.KILIMIT(h, 0x03, 0)
    mx4.EN_MOTCP(h, 0x03)
    mx4.AXMOVE(h, 0x03, 0x0150, [0x00234567, 0x00112233], 0x00200000)
    start = samples(h)
    status = mx4.wait_int(h, dspstat1=DspStat1.MOTCP, axes=0x02, timeout_ms=MOVE_MS)
    assert status.sources(DspStat1.MOTCP) == 0x02 and status.hostint is not None
    assert abs(samples(h) - start - closed_form(0x150, 0x112233, 0x200000)) <= 2
    mx4.wait_int(h, dspstat1=DspStat1.MOTCP, axes=0x01, timeout_ms=MOVE_MS)
    assert abs(samples(h) - start - closed_form(0x150, 0x234567, 0x200000)) <= 2
    assert mx4.read_axes(h, Window.ACTPOS)[:2] == (0x234567, 0x112233)
    status = mx4.read_int(h)  # both acknowledged: nothing left
    assert not status.dspstat1 and status.hostint == 0


def test_rel_axmove_example_moves_axis_2_back_8000_counts(h: mx4.Mx4) -> None:
    """[Ch5 REL_AXMOVE] n=02h, acc 8000h (1.0), pos FFFFE0C0h (-8000), vel 00038000h (3.5)."""
    mx4.POS_PRESET(h, 0x02, [0, 50_000])
    mx4.EN_MOTCP(h, 0x02)
    mx4.REL_AXMOVE(h, 0x02, 0x8000, [0, 0xFFFFE0C0], 0x00038000)
    start = samples(h)
    mx4.wait_int(h, dspstat1=DspStat1.MOTCP, axes=0x02, timeout_ms=MOVE_MS)
    assert abs(samples(h) - start - closed_form(0x8000, 8000, 0x38000)) <= 2
    assert mx4.read_axes(h)[1] == 42_000


def test_velmode_runs_at_its_velocity_and_stop_brings_motion_complete(h: mx4.Mx4) -> None:
    """[Ch5 VELMODE] n=42h, 0003B5C3h (3.71 counts/sample) on axes 2 and 7, after MAXACC; PARREAD
    18h shows them in velocity mode; STOP decelerates them at MAXACC to motion complete."""
    mx4.MAXACC(h, 0x42, 0x2000)
    mx4.EN_MOTCP(h, 0x42)
    mx4.VELMODE(h, 0x42, 0x0003B5C3)
    h.rack.sim.step(seconds=0.1)
    vel = mx4.read_axes(h, Window.ACTVEL)
    assert vel[1] / mx4.ACTVEL_SCALE == pytest.approx(3.71, abs=0.01) and vel[6] == vel[1]
    modes = mx4.parread(h, 0x18)
    assert modes[2] == 0x02 and modes[8 + 2] == 0x04  # velmode: axis 2 in bank 1, axis 7 in bank 2
    mx4.STOP(h, 0x42)
    assert mx4.parread(h, 0x18)[1] == 0x02  # halting
    mx4.wait_int(h, dspstat1=DspStat1.MOTCP, axes=0x42, timeout_ms=MOVE_MS)
    assert mx4.read_axes(h, Window.ACTVEL) == (0,) * 8
    assert mx4.parread(h, 0x18) == bytes(16)


def test_ddac_puts_the_example_voltage_on_the_dac(h: mx4.Mx4) -> None:
    """[Ch5 DDAC] n=10h, +3.7 V = 2F5Ch on DAC 5 (open loop), seen through the backdoor."""
    mx4.DDAC(h, 0x10, [0, 0, 0, 0, mx4.volts_to_dac(3.7)])
    h.rack.sim.step(ticks=2)
    out = h.rack.control(h.card, "get_outputs")
    assert out["dac"][4] == 0x2F5C and out["dac_volts"][4] == pytest.approx(3.7, abs=1e-3)


# -- PARREAD and I/O [Ch5 PARREAD, OUTP_ON, OUTP_OFF, INP_STATE] -------------------------------------
def test_parread_reads_back_the_ctrl_example_gains_from_both_banks(
        h: mx4.Mx4, monkeypatch: pytest.MonkeyPatch) -> None:
    mx4.CTRL(h, 0x28, ki=[0, 0, 0, 100, 0, 20], kp=[0, 0, 0, 4000, 0, 8000],
             kf=[0, 0, 0, 3000, 0, 5500], kd=[0, 0, 0, 2500, 0, 7000])
    with round_trips(monkeypatch) as trips:
        axis_4 = mx4.PARREAD(h, 0x13)  # axis 4 at 0B8h, axis 8 at 8B8h
    assert trips.count == 1
    assert struct.unpack("<8H", axis_4) == (100, 4000, 3000, 2500, 0, 0, 0, 0)
    assert struct.unpack("<8H", mx4.parread(h, 0x11)) == (0, 0, 0, 0, 20, 8000, 5500, 7000)
    with pytest.raises(ValueError, match="10h..27h"):
        mx4.parread(h, 0x28)


def test_outp_on_and_off_show_in_parread_22h_and_on_the_outputs(h: mx4.Mx4) -> None:
    """[Ch5 OUTP_ON] OUT1, OUT11, OUT12, OUT22 -> outp1 1802h, outp2 0040h; [OUTP_OFF] OUT0, OUT5,
    OUT6, OUT12 -> 1061h."""
    mx4.OUTP_ON(h, 0x1802, 0x0040)
    on = 1 << 1 | 1 << 11 | 1 << 12 | 1 << 22
    assert mx4.parread(h, 0x22)[:4] == on.to_bytes(4, "little")
    assert h.rack.control(h.card, "get_outputs")["outputs"] == on
    mx4.OUTP_OFF(h, 0x1061, 0x0000)
    assert h.rack.control(h.card, "get_outputs")["outputs"] == on & ~(1 << 12)
    assert mx4.parread(h, 0x22)[:4] == (on & ~(1 << 12)).to_bytes(4, "little")


def test_inp_state_sets_the_polarity_input_shows(h: mx4.Mx4) -> None:
    """[Ch5 INP_STATE] 000Fh: IN0..IN3 active high; the inputs float high (pulled up), so those
    four read active in INPUT (094h), and an active-low input pulled low does too."""
    assert mx4.read_inputs(h) == 0
    mx4.INP_STATE(h, 0x000F, 0x0000)
    h.rack.control(h.card, "set_input", line=20, level=False)
    h.rack.sim.step(ticks=1)
    assert mx4.read_inputs(h) == 0x0000000F | 1 << 20
    assert mx4.parread(h, 0x23)[:4] == b"\x0f\x00\x00\x00"


# -- interrupts [Ch6 Handling Interrupts] --------------------------------------------------------------
def test_wait_irq_read_int_and_ack_int_handle_motion_complete(h: mx4.Mx4, rack: vdevclient.Rack,
                                                              monkeypatch: pytest.MonkeyPatch) -> None:
    mx4.EN_MOTCP(h, 0x01)
    mx4.AXMOVE(h, 0x01, 0x4000, 100, mx4.vel_to_raw(2))
    status = mx4.wait_irq(h, timeout_ms=MOVE_MS)
    assert status.hostint == HostInt.STAT1 and status.dspstat1 == DspStat1.MOTCP
    assert status.sources(DspStat1.MOTCP) == 0x01
    assert rack.card("oct0").irq.wait(0.0) is None  # no other assertion
    with round_trips(monkeypatch) as trips:
        found = mx4.ack_int(h, dspstat1_bits=DspStat1.MOTCP)
    assert trips.count == 1  # the registers as read_int left them: one locked round trip
    assert found.dspstat1 == DspStat1.MOTCP
    after = mx4.read_int(h)
    assert after.hostint == 0 and after.raw == bytes(16)


def test_ack_int_after_a_change_takes_two_round_trips_and_loses_nothing(
        h: mx4.Mx4, monkeypatch: pytest.MonkeyPatch) -> None:
    mx4.EN_MOTCP(h, 0x03)
    mx4.AXMOVE(h, 0x01, 0x4000, 100, mx4.vel_to_raw(2))
    status = mx4.wait_int(h, dspstat1=DspStat1.MOTCP, axes=0x01, ack=False, timeout_ms=MOVE_MS)
    assert status.sources(DspStat1.MOTCP) == 0x01
    mx4.AXMOVE(h, 0x02, 0x4000, [0, 100], mx4.vel_to_raw(2))
    h.rack.sim.step(seconds=0.1)  # axis 2 completes too: the registers changed since
    with round_trips(monkeypatch) as trips:
        found = mx4.ack_int(h, dspstat1_bits=DspStat1.MOTCP, src_clear=0x01)
    assert trips.count == 2
    assert found.sources(DspStat1.MOTCP) == 0x03
    left = mx4.read_int(h)
    assert left.dspstat1 == DspStat1.MOTCP and left.sources(DspStat1.MOTCP) == 0x02
    assert left.hostint == HostInt.STAT1


def test_wait_int_gives_up_after_its_time_out_in_card_time(h: mx4.Mx4) -> None:
    before = h.rack.sim.now_ns()
    with pytest.raises(mx4.Mx4Timeout, match="no DSPSTAT1 b4 MOTCP .* of axis 1 within 50 ms"):
        mx4.wait_int(h, dspstat1=DspStat1.MOTCP, axes=0x01, timeout_ms=50)
    assert h.rack.sim.now_ns() - before == 50_000_000
    with pytest.raises(ValueError, match="one of"):
        mx4.wait_int(h, hostint=1, dspstat1=1)


def test_read_window_and_lock_follow_the_access_bytes(h: mx4.Mx4, rack: vdevclient.Rack) -> None:
    mx4.POS_PRESET(h, 0xFF, list(range(-4, 4)))
    h.rack.sim.step(ticks=1)
    assert mx4.read_axes(h, Window.ACTPOS) == tuple(range(-4, 4))
    mx4.lock(h, Window.ACTPOS)  # the card leaves the window alone while the host holds it
    mx4.POS_PRESET(h, 0x01, 1000)
    h.rack.sim.step(ticks=3)
    dpr = rack.card("oct0").region("dpr")
    assert dpr.read8(Window.ACTPOS.host_flag) == 1
    assert struct.unpack_from("<i", dpr.read(Dpr.ACTPOS, 4))[0] == -4
    mx4.unlock(h, Window.ACTPOS)
    h.rack.sim.step(ticks=1)
    assert mx4.read_axes(h, Window.ACTPOS)[0] == 1000
    with pytest.raises(ValueError, match="per-axis"):
        mx4.read_axes(h, Window.STATUS)


# -- procedures ---------------------------------------------------------------------------------------------
def test_reset_clears_the_parameters_and_comes_back_initialized(h: mx4.Mx4,
                                                               monkeypatch: pytest.MonkeyPatch) -> None:
    mx4.CTRL(h, 0x01, **GAINS)
    mx4.OUTP_ON(h, 0xFFFF, 0)
    with round_trips(monkeypatch) as trips:
        sig = mx4.reset(h)
    assert trips.count == 1 and str(sig) == "MX4 4.0+4.0"
    assert mx4.parread(h, 0x10) == bytes(16) and mx4.parread(h, 0x22) == bytes(16)
    assert mx4.read_int(h).hostint == 0  # "reset finished" acknowledged


def test_power_up_init_resets_a_card_without_its_signature(h: mx4.Mx4, rack: vdevclient.Rack) -> None:
    mx4.OUTP_ON(h, 0x0001, 0)
    rack.card("oct0").region("dpr").write(Dpr.SIGNATURE, b"MX?")
    assert str(mx4.power_up_init(h)) == "MX4 4.0+4.0"
    assert mx4.parread(h, 0x22) == bytes(16)  # a RESET ran
    rack.card("oct0").region("dpr").write(Dpr.SIGNATURE, b"XX")
    with pytest.raises(mx4.Mx4Error, match="no signature"):
        mx4.check_signature(h)


def test_home_on_index_shifts_the_axis_so_the_index_reads_position(h: mx4.Mx4) -> None:
    """EN_INDEX, VELMODE, the index interrupt, INDPOS, POS_SHIFT [Ch5 EN_INDEX, POS_SHIFT]: axis 3's
    index pulses every 4000 counts from 250; homed there as 0, its next index reads 4000."""
    h.rack.control(h.card, "set_index", axis=3, period=4000, phase=250)
    mx4.MAXACC(h, 0x04, 0x4000)
    assert mx4.home_on_index(h, 3, mx4.vel_to_raw(10)) == pytest.approx(250, abs=1)
    h.rack.sim.step(seconds=0.1)
    assert mx4.home_on_index(h, 3, mx4.vel_to_raw(10)) == pytest.approx(4000, abs=1)
    status = mx4.read_int(h)
    assert not status.dspstat1 & DspStat1.INDEX
    h.rack.control(h.card, "set_index", axis=4, period=0, phase=0)  # axis 4 has no index
    mx4.MAXACC(h, 0x08, 0x4000)
    with pytest.raises(mx4.Mx4Timeout, match="no index pulse of axis 4"):
        mx4.home_on_index(h, 4, mx4.vel_to_raw(10), timeout_ms=100)
    h.rack.sim.step(seconds=0.1)
    assert mx4.read_axes(h, Window.ACTVEL)[3] == 0  # stopped, not running on


def test_calibrate_offset_cancels_the_amplifier_offset() -> None:
    """[Ch5 OFFSET] on the servo plant: with +0.2 V at the amplifier's input (the backdoor's
    set_amp_offset), the axis holding with Ki != 0, OFFSET reports "offset cancel finished"
    (DSPSTAT2 b2, axis 1 in 00Ch) and the DAC then holds -0.2 V; the report is acknowledged."""
    with DaemonThread(rack_config(octavia())) as d, mx4.open(1, endpoint=d.endpoint) as h:
        h.rack.control(h.card, "set_amp_offset", axis=1, volts=0.2)
        mx4.CTRL(h, 0x01, **GAINS)
        h.rack.sim.step(seconds=0.5)
        status = mx4.calibrate_offset(h, 1, timeout_ms=5_000)
        assert status.dspstat2 & mx4.DspStat2.OFFSET and status.sources(mx4.DspStat2.OFFSET) == 0x01
        assert h.rack.control(h.card, "get_outputs")["dac_volts"][0] == pytest.approx(-0.2, abs=0.01)
        left = mx4.read_int(h)
        assert not left.dspstat2 and not left.hostint


def test_load_table_stages_the_manual_cam_table_as_its_10_byte_points(
        h: mx4.Mx4, monkeypatch: pytest.MonkeyPatch) -> None:
    """[Ch5 LOAD_CAM_TABLE] master i32, slave i32, ratio i16 (x128), LSB first."""
    cam = [(0, 0, 0x100), (100, 200, 0x20), (500, 300, -26), (1000, 200, 0)]  # the manual's table
    with round_trips(monkeypatch) as trips:
        mx4.load_table(h, "cam", 0, cam)
    staged = [op[4] for op in trips.sent[0]["ops"] if isinstance(op, list) and op[3] == 0x120]
    assert staged == [bytes.fromhex("00000000" "00000000" "0001" "64000000" "c8000000" "2000"
                                    "f4010000" "2c010000" "e6ff" "e8030000" "c8000000" "0000")]


def test_ring_put_wraps_from_slot_83_to_0_and_moves_inptr(h: mx4.Mx4, rack: vdevclient.Rack) -> None:
    """[Ch6 Contouring] with both pointers at slot 80 (OUTPTR written as the card leaves it after
    a contour), ten slots go to 80..83 and 0..5, INPTR becomes 6."""
    dpr = rack.card("oct0").region("dpr")
    dpr.write(Dpr.INPTR, bytes([80, 80]))
    assert mx4.ring_free(h) == RING_SLOTS - 1
    slots = [(1 + i % 2, 1000 * i, -i) for i in range(10)]
    assert mx4.ring_put(h, slots) == 10
    assert dpr.read8(Dpr.INPTR) == 6 and mx4.ring_free(h) == RING_SLOTS - 11
    ring = dpr.read(Dpr.RINGBUF, 84 * 8)
    got = [struct.unpack_from("<ii", ring, 8 * s) for s in [80, 81, 82, 83, 0, 1, 2, 3, 4, 5]]
    assert got == [(pos, vel) for _, pos, vel in slots]
    assert mx4.ring_put(h, [(1, 0, 0)] * 100) == RING_SLOTS - 11  # as many as fit
    assert mx4.ring_free(h) == 0


# -- contouring, tables, cam, gearing, DSPL [Ch4-Ch6, Ch8; the card README] ------------------------------
def second_order(v: float, n: int, points: int) -> list[int]:
    """Positions of a 2nd-order contour (BTRATE 0: 25 samples an interval) that accelerates to v
    counts/sample over the first interval, cruises, and stops over the last: each interval
    covers N (V0 + V1) / 2 [spec §5.4]."""
    step = n * v
    return [round(step / 2 + step * (i - 1) + (step / 2 if i == points else 0))
            for i in range(1, points + 1)]


def test_contour_streams_200_points_refilling_at_each_buffer_breakpoint(
        h: mx4.Mx4, monkeypatch: pytest.MonkeyPatch) -> None:
    """[Ch6 Contouring, Fig. 6-5] 2nd order, axes 1 and 3 (400 slots: the ring wraps almost five
    times), EN_BUFBRK 20: preloaded with START in one batch, then one batch per buffer
    breakpoint; the axes end on the last point, the breakpoints acknowledged."""
    pos = second_order(2.0, 25, 200)
    vel = [mx4.vel_to_raw(2.0)] * 199 + [0]
    points = [[(p, v), (-p, -v & 0xFFFFFFFF)] for p, v in zip(pos, vel, strict=True)]
    with round_trips(monkeypatch) as trips:
        assert mx4.contour(h, 0x05, points, btrate=0, bufbrk=20) == 200
    # the preload (41 points), a refill at each breakpoint (41 points read, 18 slots left: 32
    # points fit), the last points with the wait for the ring to drain
    assert trips.count == 1 + 5 + 1
    h.rack.sim.step(ticks=30)  # the last interval
    assert mx4.read_axes(h)[0] == pos[-1] == 10_000 and mx4.read_axes(h)[2] == -10_000
    # the ring holds the last 84 slots written, the oldest at INPTR (400 mod 84 = 64)
    slots = [slot for point in points for slot in point]
    ring = h.dpr.read(Dpr.RINGBUF, RING_SLOTS * 8)
    assert h.dpr.read(Dpr.INPTR, 2) == bytes([64, 64])
    assert [struct.unpack_from("<ii", ring, 8 * ((64 + i) % RING_SLOTS)) for i in range(RING_SLOTS)] \
        == [(p, v - (1 << 32) if v >= 1 << 31 else v) for p, v in slots[-RING_SLOTS:]]
    assert mx4.read_int(h).hostint == 0
    with pytest.raises(mx4.Mx4Error, match="not empty"):
        h.dpr.write(Dpr.INPTR, b"\x05")
        mx4.contour(h, 0x05, points, btrate=0)


def test_a_move_for_a_contouring_axis_is_a_conflict(h: mx4.Mx4) -> None:
    """[Ch6 Contouring, Ch7 Table 7-1] AXMOVE naming an axis that contours is discarded with
    "conflicting commands" (000h b6, 007h); the contour goes on."""
    pos = second_order(1.0, 25, 40)
    mx4.ring_put(h, [(2, p, mx4.vel_to_raw(1.0) if i < 39 else 0) for i, p in enumerate(pos)])
    mx4.BTRATE(h, 0)
    mx4.START(h, 0x02)
    with pytest.raises(mx4.Mx4Error, match=r"AXMOVE: .* b6 CONFLICT \(conflicting commands: the "
                                           r"new motion command ignored\) on axis 2") as err:
        mx4.AXMOVE(h, 0x03, 0x150, [0, 0], 0x10000)
    assert err.value.conflict == 0x02
    assert mx4.parread(h, 0x18)[3] == 0x02  # contouring
    h.rack.sim.step(seconds=0.25)
    assert mx4.read_axes(h)[1] == pos[-1]


def test_load_table_stages_672_byte_chunks_and_cubic_int_runs_them(
        h: mx4.Mx4, monkeypatch: pytest.MonkeyPatch) -> None:
    """[Ch5 LOAD_CUBIC_TABLE] 400 points go as 168 + 168 + 64, each staged at 120h then loaded,
    in one batch; CUBIC_INT over entries 350 and 351 (in the third chunk) ends axis 1 on
    entry 351 [Ch5 CUBIC_INT]."""
    points = [10 * i for i in range(400)]
    with round_trips(monkeypatch) as trips:
        mx4.load_table(h, "cubic", 0, points)
    assert trips.count == 1
    writes = [(op[3], op[4]) for op in trips.sent[0]["ops"] if isinstance(op, list) and op[0] == "w"]
    assert writes == [
        (0x120, struct.pack("<168i", *points[:168])), (0x3C3, struct.pack("<HH", 0, 168)), (0x3C2, b"\xaf"),
        (0x120, struct.pack("<168i", *points[168:336])), (0x3C3, struct.pack("<HH", 168, 168)),
        (0x3C2, b"\xaf"),
        (0x120, struct.pack("<64i", *points[336:])), (0x3C3, struct.pack("<HH", 336, 64)), (0x3C2, b"\xaf")]
    mx4.EN_MOTCP(h, 0x01)
    mx4.CUBIC_RATE(h, 25)
    mx4.CUBIC_INT(h, 2, 350, 1, 0x01)
    mx4.wait_int(h, dspstat1=DspStat1.MOTCP, axes=0x01, timeout_ms=MOVE_MS)
    assert mx4.read_axes(h)[0] == points[351]


def test_a_cam_slave_follows_the_manual_table_loaded_with_load_table(h: mx4.Mx4) -> None:
    """[Ch5 LOAD_CAM_TABLE] the manual's table (master 0, 100, 500, 1000; slave 0, 200, 300,
    200), CAM with axis 1 as master and axis 2 as slave: the master at 500 puts the slave at
    300 [Ch5 CAM]; CAM_OFF leaves it there."""
    cam = [(0, 0, mx4.ratio_to_raw(2.0)), (100, 200, mx4.ratio_to_raw(0.25)),
           (500, 300, mx4.ratio_to_raw(-0.2)), (1000, 200, 0)]
    mx4.load_table(h, "cam", 0, cam)
    mx4.CAM(h, 0x01, 0x02, 0, [0, 4])
    mx4.EN_MOTCP(h, 0x01)
    mx4.AXMOVE(h, 0x01, 0x4000, 500, mx4.vel_to_raw(10))
    mx4.wait_int(h, dspstat1=DspStat1.MOTCP, axes=0x01, timeout_ms=MOVE_MS)
    h.rack.sim.step(ticks=2)  # the slave follows one sample behind
    assert mx4.read_axes(h)[:2] == (500, 300)
    assert h.dpr.read(Dpr.CAMCOUNT + 2, 2) == b"\x02\x00"  # slave axis 2 in segment 2
    mx4.CAM_OFF(h, 0x02)
    mx4.AXMOVE(h, 0x01, 0x4000, 0, mx4.vel_to_raw(10))
    mx4.wait_int(h, dspstat1=DspStat1.MOTCP, axes=0x01, timeout_ms=MOVE_MS)
    assert mx4.read_axes(h)[:2] == (0, 300)


def test_a_geared_follower_moves_at_its_ratio(h: mx4.Mx4) -> None:
    """[Ch5 GEAR] axis 5 follows axis 1 at 2.0 (1.8.7, the card's default `gear_ratio_bits`)."""
    mx4.GEAR(h, 0x01, 0x10, [0, 0, 0, 0, mx4.ratio_to_raw(2.0)])
    mx4.EN_MOTCP(h, 0x01)
    mx4.AXMOVE(h, 0x01, 0x4000, 1000, mx4.vel_to_raw(10))
    mx4.wait_int(h, dspstat1=DspStat1.MOTCP, axes=0x01, timeout_ms=MOVE_MS)
    h.rack.sim.step(ticks=2)
    assert mx4.read_axes(h)[0] == 1000 and mx4.read_axes(h)[4] == 2000
    mx4.GEAR_OFF(h, 0x10)


def test_change_var_shows_in_its_monitor_slot(h: mx4.Mx4) -> None:
    """[Ch5 CHANGE_VAR, MONITOR_VAR] VAR3's six bytes in the first monitor slot (066h, the DSPL
    window read under 0C9h/0D1h)."""
    mx4.CHANGE_VAR(h, [(3, b"\x01\x02\x03\x04\x05\x06"), (12, b"\xaa" * 6)])
    mx4.MONITOR_VAR(h, 0x03, [3, 12])
    h.rack.sim.step(seconds=0.01)
    window = mx4.read_window(h, Window.DSPL)
    assert window[:12] == b"\x01\x02\x03\x04\x05\x06" + b"\xaa" * 6

