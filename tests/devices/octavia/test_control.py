"""The Octavia's control law, open loop, position bookkeeping, I/O and PARREAD [Ch5; spec §4.3,
§5.2]."""

from __future__ import annotations

import struct

import pytest
from vdevmaps.octavia import BANK2, Dpr, axis_offset

from tests.devices.octavia.host import Host

DAC = 32767 / 10.0  # codes per volt


def parread(host: Host, m: int) -> bytes:
    """The manual's PARREAD handshake: 0B7h := 0, post 5Eh, wait for the echo, read both banks."""
    host.write(Dpr.PARACC, b"\x00")
    host.rtc("PARREAD", {"m": m})
    for _ in range(30):
        if host.u8(Dpr.PARACC) == m:
            return host.read(Dpr.PARRDBK, 8) + host.read(Dpr.PARRDBK + BANK2, 8)
        host.run(1)
    raise AssertionError(f"no PARREAD echo of {m:02X}h within 30 samples")


def jammed_error(host: Host, counts: int) -> None:
    """Axis 1 blocked, commanded `counts` away: a steady following error of `counts`."""
    host.card.control("jam", {"axis": 1})
    host.rtc("AXMOVE", {"n": 1}, [{"acc": 0x4000, "pos": counts, "vel": 0x100000}])
    host.run(100)
    assert host.error(1) == counts


def volts(host: Host, axis: int = 1) -> float:
    return float(host.card.control("get_outputs", {})["dac_volts"][axis - 1])


def test_ctrl_example_gains_read_back_by_parread_with_the_manuals_erratum() -> None:
    """CTRL example n=28h: axis 4 Ki 100, Kp 4000, Kf 3000, Kd 2500; axis 6 Ki 20, Kp 8000, Kf
    5500, Kd 7000 = 1B58h (the manual prints 1658h, spec Q-30.1); PARREAD 13h reads axis 4 and
    11h axis 6 in bank 2 [Ch5 CTRL, PARREAD]."""
    host = Host()
    host.rtc("CTRL", {"n": 0x28}, [dict(ki=100, kp=4000, kf=3000, kd=2500),
                                   dict(ki=0x14, kp=0x1F40, kf=0x157C, kd=0x1B58)])
    assert struct.unpack("<4H", parread(host, 0x13)[:8]) == (100, 4000, 3000, 2500)
    assert struct.unpack("<4H", parread(host, 0x11)[8:]) == (20, 8000, 5500, 7000)


def test_parread_echoes_at_the_next_5ms_boundary_data_first() -> None:
    """The data are in 0B8h.. when the echo comes, "may take more than 5 ms" [Ch5 PARREAD];
    a code outside 10h..27h gets no echo."""
    host = Host()
    host.write(Dpr.PARACC, b"\x00")
    host.rtc("PARREAD", {"m": 0x27})
    assert host.read(Dpr.PARRDBK, 2) == b"\xff\x7f"  # TRQ_LIMIT defaults to full swing
    k = host.run_until(Dpr.PARACC, 0xFF, 30)
    assert 0 < k <= 25 and host.u8(Dpr.PARACC) == 0x27
    host.write(Dpr.PARACC, b"\x00")
    host.rtc("PARREAD", {"m": 0x30})
    host.run(60)
    assert host.u8(Dpr.PARACC) == 0


def test_parread_reports_each_parameter_it_defines() -> None:
    """PARREAD 14h-16h, 19h, 1Bh, 1Dh, 20h-24h, 26h, 27h after the RTCs that set them."""
    host = Host(plant="ideal")
    host.rtc("KILIMIT", {"n": 0x81}, [{"val": 3}, {"val": 14}])
    host.rtc("OUTGAIN", {"n": 0x02}, [{"m": 2}])
    host.rtc("MAXACC", {"n": 0x11}, [{"acc": 0x150}, {"acc": 0x200}])
    host.rtc("ESTOP_ACC", {"n": 0x04}, [{"acc": 0x7FF}])
    host.rtc("EN_ERRHLT", {"n": 0x04}, [{"fer": 0x64}])
    host.rtc("EN_POSBRK", {"n": 0x11}, [{"pos": 0xEA60}, {"pos": 0x7A120}])
    host.rtc("EN_BUFBRK", {"buffbrk": 0x1E})
    host.rtc("SYNC", {"m": 1})
    host.rtc("OUTP_ON", {"outp1": 0x1802, "outp2": 0x0040})
    host.rtc("INP_STATE", {"inp1": 0x000F, "inp2": 0x0000})
    host.rtc("EN_ENCFLT", {"m": 0x0C, "n": 0x0C}, [{"fer": 0x1F4}, {"fer": 0x1F4}])
    host.rtc("CTRL_KA", {"n": 0x84}, [{"ka": 0x1388}, {"ka": 0x1388}])
    host.rtc("TRQ_LIMIT", {"n": 0x01}, [{"val": 0x4000}])
    assert parread(host, 0x14) == bytes((3, 0, 0, 0, 0, 0, 0, 0, 0, 0, 0, 14, 0, 0, 0, 0))
    assert parread(host, 0x15)[1] == 2
    assert struct.unpack("<8H", parread(host, 0x16)) == (0x150, 0, 0, 0, 0x200, 0, 0, 0)
    assert struct.unpack("<8H", parread(host, 0x19))[2] == 0x64
    assert struct.unpack("<2i", parread(host, 0x1B)[:8]) == (0xEA60, 0)
    assert struct.unpack("<2i", parread(host, 0x1B)[8:]) == (0x7A120, 0)
    assert parread(host, 0x1D)[:4] == bytes((0x1E, 0, 0, 0))  # 2nd order, BTRATE m 0
    assert struct.unpack("<8H", parread(host, 0x20))[2] == 0x7FF
    assert parread(host, 0x21)[0] == 0x11
    assert parread(host, 0x22)[:4] == (0x1802 | 0x0040 << 16).to_bytes(4, "little")
    assert parread(host, 0x23)[:4] == bytes((0x0F, 0, 0, 0))
    assert struct.unpack("<8H", parread(host, 0x24))[2:4] == (0x1F4, 0x1F4)
    assert struct.unpack("<8H", parread(host, 0x26))[2::5] == (0x1388, 0x1388)
    assert struct.unpack("<8H", parread(host, 0x27))[:2] == (0x4000, 0x7FFF)
    report = parread(host, 0x17)  # enabled: FE-halt axis 3, breakpoints axes 1 and 5, bufbrk
    assert report[0] == 1 and report[1] == 0x04 and report[2] == 0x10 and report[10] == 0x10


def test_ctrl_dac_scaling_100_counts_at_kp_1000_is_59_5_mv() -> None:
    """The manual's check [Ch5 CTRL]: 100 counts of error with Kp = 1000 give 100 x 1000 x
    0.595E-06 = 59.5 mV."""
    host = Host()
    host.rtc("CTRL", {"n": 1}, [dict(ki=0, kp=1000, kf=0, kd=0)])
    jammed_error(host, 100)
    assert volts(host) == pytest.approx(0.0595, abs=1 / DAC)


def test_outgain_multiplies_by_2_to_the_m() -> None:
    """OUTGAIN m = 2: the output loop gain x4 [Ch5 OUTGAIN]."""
    host = Host()
    host.rtc("CTRL", {"n": 1}, [dict(ki=0, kp=1000, kf=0, kd=0)])
    host.rtc("OUTGAIN", {"n": 1}, [{"m": 2}])
    jammed_error(host, 100)
    assert volts(host) == pytest.approx(4 * 0.0595, abs=1 / DAC)


def test_kilimit_clamps_the_integral_action_at_10v_over_2_to_the_val() -> None:
    """KILIMIT 4: the integral channel stops at 10/16 = 0.625 V [Ch5 KILIMIT]."""
    host = Host()
    host.rtc("CTRL", {"n": 1}, [dict(ki=1000, kp=0, kf=0, kd=0)])
    host.rtc("KILIMIT", {"n": 1}, [{"val": 4}])
    jammed_error(host, 100)
    rate = 1000 * 3.308e-5 * 200e-6 * 100  # volts per sample
    host.run(int(0.625 / rate) // 2)
    assert 0.1 < volts(host) < 0.6
    host.run(int(0.625 / rate))
    assert volts(host) == pytest.approx(0.625, abs=1 / DAC)


def test_trq_limit_clamps_the_output() -> None:
    """TRQ_LIMIT 1000h: at most 4096/32767 x 10 V = 1.25 V either way [Ch5 TRQ_LIMIT]."""
    host = Host()
    host.rtc("CTRL", {"n": 1}, [dict(ki=0, kp=30000, kf=0, kd=0)])
    host.rtc("TRQ_LIMIT", {"n": 1}, [{"val": 0x1000}])
    jammed_error(host, 1000)
    assert volts(host) == pytest.approx(4096 / DAC, abs=1 / DAC)
    host.rtc("AXMOVE", {"n": 1}, [{"acc": 0x4000, "pos": -1000, "vel": 0x100000}])
    host.run(300)
    assert volts(host) == pytest.approx(-4096 / DAC, abs=1 / DAC)


def test_ddac_example_opens_the_loop_and_axmove_closes_it() -> None:
    """DDAC example: axis 5 at 2F5Ch = +3.7 V, open loop [Ch5 DDAC]; the recommended way back:
    DDAC 0 V, POS_PRESET, AXMOVE to the preset position."""
    host = Host()
    host.rtc("CTRL", {"n": 0x10}, [dict(ki=100, kp=4000, kf=3000, kd=2500)])
    host.rtc("DDAC", {"n": 0x10}, [{"val": 0x2F5C}])
    host.run(10)
    out = host.card.control("get_outputs", {})
    assert out["dac"][4] == 0x2F5C and out["dac_volts"][4] == pytest.approx(3.7, abs=1e-3)
    assert host.position(5) > 5  # the motor runs away, open loop
    host.rtc("DDAC", {"n": 0x10}, [{"val": 0}])
    host.run(5000)
    host.rtc("POS_PRESET", {"n": 0x10}, [{"pset": 0}])
    host.rtc("AXMOVE", {"n": 0x10}, [{"acc": 0x100, "pos": 0, "vel": 0x10000}])
    host.run(5000)
    assert abs(host.position(5)) <= 2 and host.card.fw.mode[4] == 0


def test_pos_shift_example_with_the_manuals_erratum() -> None:
    """POS_SHIFT example n=25h: axis 1 100h -> 20100h (+20000h), axis 3 1010h -> 1000h (-10h),
    axis 6 36F3h -> F5D0h, which takes BEDDh (the manual prints 00006EDDh, spec Q-30.2); the
    following error is kept [Ch5 POS_SHIFT]."""
    host = Host(plant="ideal")
    host.rtc("POS_PRESET", {"n": 0x25}, [{"pset": 0x100}, {"pset": 0x1010}, {"pset": 0x36F3}])
    host.rtc("POS_SHIFT", {"n": 0x25}, [{"psft": 0x20000}, {"psft": -0x10}, {"psft": 0xBEDD}])
    host.run(1)
    assert [host.position(a) for a in (1, 3, 6)] == [0x20100, 0x1000, 0xF5D0]
    assert [host.error(a) for a in (1, 3, 6)] == [0, 0, 0]


def test_pos_shift_keeps_a_move_under_way() -> None:
    """A shift while moving: the motion goes on to the shifted target."""
    host = Host(plant="ideal")
    host.rtc("AXMOVE", {"n": 1}, [{"acc": 0x200, "pos": 10_000, "vel": 0x80000}])
    host.run(300)
    host.rtc("POS_SHIFT", {"n": 1}, [{"psft": 5000}])
    host.run(5000)
    assert host.position(1) == 15_000


def test_inputs_follow_inp_state_polarity_and_outputs_the_examples() -> None:
    """INP_STATE example 000Fh: IN0-3 active high; the rest active low [Ch5 INP_STATE]; INPUT
    (094h) shows set = active. OUTP_ON example (OUT1, 11, 12, 22 -> 1802h, 0040h) and OUTP_OFF
    example (OUT0, 5, 6, 12 -> 1061h) [Ch5 OUTP_ON, OUTP_OFF]."""
    host = Host()
    assert host.read(Dpr.INPUT, 4) == bytes(4)  # pulled up, active low: none active
    host.card.control("set_input", {"line": 5, "level": False})
    host.run(1)
    assert host.read(Dpr.INPUT, 4) == (1 << 5).to_bytes(4, "little")
    host.rtc("INP_STATE", {"inp1": 0x000F, "inp2": 0x0000})
    assert host.read(Dpr.INPUT, 4) == (0x0F | 1 << 5).to_bytes(4, "little")
    host.rtc("OUTP_ON", {"outp1": 0x1802, "outp2": 0x0040})
    assert host.card.control("get_outputs", {})["outputs"] == 1 << 1 | 1 << 11 | 1 << 12 | 1 << 22
    host.rtc("OUTP_OFF", {"outp1": 0x1061, "outp2": 0})
    assert host.card.control("get_outputs", {})["outputs"] == 1 << 1 | 1 << 11 | 1 << 22


def test_the_state_windows_are_not_updated_while_the_host_holds_them() -> None:
    """spec §2.5.1: HOSTACC 0CBh = 01h holds ACTPOS: the card does not write it until it is
    released; ERROR (another window) goes on."""
    host = Host(plant="ideal")
    host.write(Dpr.HOSTACC_ACTPOS, b"\x01")
    host.rtc("AXMOVE", {"n": 1}, [{"acc": 0x4000, "pos": 300, "vel": 0x100000}])
    host.run(100)
    assert host.position(1) == 0 and host.card.fw.core.axes.encoder[0] == 300
    host.write(Dpr.HOSTACC_ACTPOS, b"\x00")
    host.run(1)
    assert host.position(1) == 300
    assert host.i32(axis_offset(Dpr.ACTPOS, 5)) == 0


def test_analog_inputs_adc1_to_4_under_their_access_bytes() -> None:
    """set_analog drives ADC1-4 (int16 at 502h.., 7FFFh = +10 V) [Table 6-10]; while the host
    holds 501h the card does not update them."""
    host = Host()
    host.card.control("set_analog", {"channel": 2, "volts": 2.5})
    host.run(1)
    assert struct.unpack("<4h", host.read(Dpr.ADC, 8)) == (0, 8192, 0, 0)
    host.write(Dpr.HOSTACC_ADC, b"\x01")
    host.card.control("set_analog", {"channel": 4, "volts": -20.0})
    host.run(2)
    assert struct.unpack("<4h", host.read(Dpr.ADC, 8))[3] == 0
    host.write(Dpr.HOSTACC_ADC, b"\x00")
    host.run(1)
    assert struct.unpack("<4h", host.read(Dpr.ADC, 8)) == (0, 8192, 0, -32768)
    with pytest.raises(Exception, match="outside 1..4"):
        host.card.control("set_analog", {"channel": 5, "volts": 1.0})


def test_a_host_write_into_a_window_the_card_owns_is_overwritten_at_the_next_sample() -> None:
    """The access codes are a convention the hardware does not enforce [Ch6 Communication
    Protocols]: a host that writes ACTPOS or the signature stores its bytes, and the card
    rewrites ACTPOS from its counters after its next sample (the signature only at RESET)."""
    host = Host(plant="ideal")
    host.rtc("POS_PRESET", {"n": 0x01}, [{"pset": 4321}])
    host.run(3)
    host.write(axis_offset(Dpr.ACTPOS, 1), b"\xff\xff\xff\x7f")
    assert host.position(1) == 0x7FFFFFFF
    host.run(1)
    assert host.position(1) == 4321
    host.run(500)  # at rest, skipping: nothing to rewrite
    assert host.position(1) == 4321 and host.card.quiet_skipped > 0
    host.write(axis_offset(Dpr.ACTPOS, 1), b"\x00\x00\x00\x00")
    host.run(1)
    assert host.position(1) == 4321


def test_parread_18h_reports_an_axis_halting_under_estop_as_stopping() -> None:
    """PARREAD 18h 0B9h: the axes halting, under STOP and under *ESTOP alike (both make motion
    RTCs "ignored", [Ch5 STOP]); 0BAh the VELMODE axes."""
    host = Host(plant="ideal")
    host.rtc("MAXACC", {"n": 0x03}, [{"acc": 0x100}, {"acc": 0x100}])
    host.rtc("ESTOP_ACC", {"n": 0x03}, [{"acc": 0x10}, {"acc": 0x10}])
    host.rtc("VELMODE", {"n": 0x03}, [{"vel": 20 << 16}, {"vel": -(20 << 16)}])
    host.run(2500)
    assert parread(host, 0x18)[2] == 0x03
    host.card.control("set_estop", {"active": True})
    host.run(10)
    assert parread(host, 0x18)[1] == 0x03
