"""The Octavia's interrupts [Ch6 Handling Interrupts, Ch7 Table 7-1; spec §3]: each source with
its status bits and source byte, the line and its acknowledge, the status lock."""

from __future__ import annotations

import struct

from vdevmaps.octavia import Dpr, DspStat1, DspStat2, HostInt, axis_offset

from tests.devices.octavia.host import Host

FAST = {"acc": 0x4000, "vel": 0x100000}  # 0.5 counts/sample^2, 16 counts/sample


def move(host: Host, mask: int, *targets: int, name: str = "AXMOVE") -> None:
    host.rtc(name, {"n": mask}, [{**FAST, "pos": t} for t in targets])


def test_motion_complete_posts_type_source_and_summary_and_the_host_read_ends_the_line() -> None:
    """Ch6 Handling Interrupts: motion complete of axis 2 sets 1FFEh b1, DSPSTAT1 b4 and bit 1
    of 005h; the line is asserted once (an event); reading 1FFEh deasserts it and the bits stay
    until the host clears them."""
    host = Host(plant="ideal")
    host.rtc("EN_MOTCP", {"n": 0x02})
    assert not host.card.inta.asserted
    move(host, 0x02, 3000)
    k = host.run_until(Dpr.INTAXIS_MOTCP, 0x02, 2000)
    assert k > 0
    assert host.u8(Dpr.DSPSTAT1) == DspStat1.MOTCP
    assert host.u8(Dpr.HOSTINT1) == HostInt.STAT1  # this read ends the interrupt
    assert not host.card.inta.asserted
    assert len(host.events) == 1 and host.events[0].line == "inta"
    host.run(10)
    assert host.u8(Dpr.DSPSTAT1) == DspStat1.MOTCP  # the card never clears them
    assert host.ack() == HostInt.STAT1
    assert host.u8(Dpr.DSPSTAT1) == 0 and host.u8(Dpr.HOSTINT1) == 0


def test_posts_wait_while_the_host_holds_the_status_window() -> None:
    """spec §2.5.1: while 3FDh is 01h the card posts nothing; the post comes once released."""
    host = Host(plant="ideal")
    host.rtc("EN_MOTCP", {"n": 0x01})
    host.write(Dpr.HOSTACC_INT, b"\x01")
    move(host, 0x01, 400)
    host.run(300)
    assert host.u8(Dpr.DSPSTAT1) == 0 and host.u8(Dpr.HOSTINT1) == 0 and not host.events
    host.write(Dpr.HOSTACC_INT, b"\x00")
    host.run(1)
    assert host.u8(Dpr.DSPSTAT1) == DspStat1.MOTCP and host.u8(Dpr.INTAXIS_MOTCP) == 0x01
    assert len(host.events) == 1


def test_following_error_interrupt_fires_on_the_rising_edge_and_stays_enabled() -> None:
    """EN_ERR: |FE| over the setpoint posts DSPSTAT1 b1 with the axis in 002h; it is not
    disabled after it fires [Ch5 EN_ERR] (again once back under and over, spec Q-7)."""
    host = Host()
    host.rtc("CTRL", {"n": 1}, [{"ki": 0, "kp": 4000, "kf": 3000, "kd": 2500}])
    host.rtc("EN_ERR", {"n": 1}, [{"fer": 50}])
    host.card.control("jam", {"axis": 1})
    move(host, 0x01, 400)
    assert host.run_until(Dpr.INTAXIS_ERR, 0x01, 500) > 0
    assert host.u8(Dpr.DSPSTAT1) & DspStat1.ERR
    host.ack()
    host.card.control("jam", {"axis": 1, "active": False})
    host.run(3000)  # the axis catches up: the error falls under the setpoint
    host.ack()
    host.run(100)
    assert host.u8(Dpr.DSPSTAT1) == 0 and abs(host.error(1)) < 50
    host.card.control("jam", {"axis": 1})
    move(host, 0x01, 0)
    assert host.run_until(Dpr.INTAXIS_ERR, 0x01, 500) > 0  # fires again


def test_following_error_halt_stops_the_axis_at_estop_acc_and_needs_it() -> None:
    """EN_ERRHLT: ignored while ESTOP_ACC is 0 (Note 1); armed, |FE| over it posts DSPSTAT1 b0
    with the axis in 001h and the axis halts at ESTOP_ACC."""
    host = Host()
    host.rtc("CTRL", {"n": 1}, [{"ki": 0, "kp": 4000, "kf": 3000, "kd": 2500}])
    host.rtc("EN_ERRHLT", {"n": 1}, [{"fer": 30}])
    assert not host.card.fw.params.errhlt_on[0]
    host.rtc("ESTOP_ACC", {"n": 1}, [{"acc": 0x2000}])
    host.rtc("EN_ERRHLT", {"n": 1}, [{"fer": 30}])
    host.rtc("AXMOVE", {"n": 1}, [{"acc": 0x100, "pos": 200_000, "vel": 0x80000}])
    host.run(500)
    host.card.control("jam", {"axis": 1})
    assert host.run_until(Dpr.INTAXIS_ERRHLT, 0x01, 500) > 0
    assert host.u8(Dpr.DSPSTAT1) & DspStat1.ERR_HALT
    host.card.control("jam", {"axis": 1, "active": False})
    host.run(2000)
    state = host.card.control("axis_state", {"axis": 1})
    assert state["cmd_vel"] == 0.0 and state["cmd_pos"] < 100_000  # halted, far from the target


def test_position_breakpoint_is_one_shot_and_applies_its_output_masks() -> None:
    """EN_POSBRK + POSBRK_OUT: axis 1 travelling 1000 counts posts DSPSTAT1 b3 with 004h b0
    once; its ON mask (OUT0-3) and OFF mask (OUT4) apply [Ch5 EN_POSBRK, POSBRK_OUT example]."""
    host = Host(plant="ideal")
    host.rtc("OUTP_ON", {"outp1": 0x0010, "outp2": 0})
    host.rtc("POSBRK_OUT", {"n": 0x03}, [{"on1": 0x000F, "on2": 0, "off1": 0x0010, "off2": 0},
                                          {"on1": 0, "on2": 0, "off1": 0xFFFF, "off2": 0xFFFF}])
    host.rtc("EN_POSBRK", {"n": 0x01}, [{"pos": 1000}])
    move(host, 0x01, 2000)
    k = host.run_until(Dpr.INTAXIS_POSBRK, 0x01, 1000)
    assert k > 0 and 1000 <= host.card.fw.core.axes.encoder[0] <= 1016
    assert host.card.control("get_outputs", {})["outputs"] == 0x0F
    host.ack()
    move(host, 0x01, 0)
    host.run(600)
    assert host.u8(Dpr.DSPSTAT1) == 0  # one-shot


def test_index_interrupt_latches_every_axis_at_the_edge() -> None:
    """EN_INDEX n=02h: the first index edge of axis 2 latches the actual positions of all axes
    to INDPOS and posts DSPSTAT1 b2 with 003h = 02h [Ch5 EN_INDEX]; SERVOCHK shows the index
    seen in the 5 ms window [Table 6-5]."""
    host = Host(plant="ideal")
    host.card.control("set_index", {"axis": 2, "period": 4096, "phase": 1500})
    host.rtc("EN_INDEX", {"n": 0x02})
    move(host, 0x03, 3000, 3000)
    assert host.run_until(Dpr.INTAXIS_INDEX, 0x02, 2000) > 0
    assert host.u8(Dpr.DSPSTAT1) & DspStat1.INDEX
    host.run(1)
    indpos = [host.i32(axis_offset(Dpr.INDPOS, a)) for a in (1, 2)]
    assert abs(indpos[1] - 1500) <= 1 and abs(indpos[0] - 1500) <= 1  # both axes moved alike
    assert host.u8(Dpr.SERVOCHK) & 0x02 or host.run_until(Dpr.SERVOCHK, 0x02, 25) > 0


def test_probe_interrupt_on_ext4_latches_every_axis() -> None:
    """EN_PROBE 08h (EXT4): its active edge latches the positions to PRB and posts DSPSTAT1 b5
    with 006h = 08h [Ch5 EN_PROBE]; one-shot."""
    host = Host(plant="ideal")
    host.rtc("POS_PRESET", {"n": 0x05}, [{"pset": 1234}, {"pset": -55}])
    host.rtc("EN_PROBE", {"m": 0x08})
    host.card.control("set_probe", {"input": 3})
    host.run(2)
    assert host.u8(Dpr.DSPSTAT1) == 0
    host.card.control("set_probe", {"input": 4})
    host.run(2)
    assert host.u8(Dpr.DSPSTAT1) & DspStat1.PROBE and host.u8(Dpr.INTAXIS_PROBE) == 0x08
    assert struct.unpack("<3i", host.read(Dpr.PRB, 12)) == (1234, 0, -55)
    host.ack()
    host.card.control("set_probe", {"input": 4, "active": False})
    host.card.control("set_probe", {"input": 4})
    host.run(2)
    assert host.u8(Dpr.DSPSTAT1) == 0


def test_estop_halts_every_axis_reports_and_ignores_motion_while_active() -> None:
    """*ESTOP: 1FFEh b2 on going active, the axes halt at ESTOP_ACC; AXMOVE meanwhile is "RTC
    ignored" (DSPSTAT1 b7, 008h) [Ch7 Table 7-1; spec §5.3]."""
    host = Host(plant="ideal")
    host.rtc("ESTOP_ACC", {"n": 0x03}, [{"acc": 0x1000}, {"acc": 0x1000}])
    move(host, 0x03, 100_000, -100_000)
    host.run(100)
    host.card.control("set_estop", {"active": True})
    host.run(1)
    assert host.u8(Dpr.HOSTINT1) & HostInt.ESTOP
    host.run(400)
    vel = host.card.fw.core.axes.cmd_vel[:2].tolist()
    assert vel == [0.0, 0.0]
    host.ack()
    move(host, 0x01, 5)
    assert host.u8(Dpr.DSPSTAT1) & DspStat1.IGNORED and host.u8(Dpr.INTAXIS_IGNORED) == 0x01


def test_stop_needs_maxacc_and_a_halting_axis_ignores_motion() -> None:
    """STOP is ignored while MAXACC is 0 (Note 2); while an axis halts under STOP, AXMOVE for
    it is discarded with "RTC ignored" [Ch5 STOP]; the stop completes with motion complete."""
    host = Host(plant="ideal")
    host.rtc("EN_MOTCP", {"n": 0x01})
    host.rtc("AXMOVE", {"n": 1}, [{"acc": 0x400, "pos": 500_000, "vel": 0x200000}])
    host.run(200)
    host.rtc("STOP", {"n": 1})
    host.run(5)
    assert host.card.fw.core.axes.cmd_vel[0] > 0  # no MAXACC: ignored
    host.rtc("MAXACC", {"n": 1}, [{"acc": 0x80}])
    host.rtc("STOP", {"n": 1})
    move(host, 0x01, 7)
    assert host.u8(Dpr.DSPSTAT1) == DspStat1.IGNORED
    assert host.run_until(Dpr.INTAXIS_MOTCP, 0x01, 20_000) > 0
    assert host.card.fw.core.axes.cmd_vel[0] == 0.0


def test_encoder_fault_opens_the_loop_at_zero_volts() -> None:
    """EN_ENCFLT m bit 1 (following error alone): over the setpoint the axis goes open loop at
    0 V and DSPSTAT2 b0 with 00Ah reports it [Ch5 EN_ENCFLT; spec Q-9, Q-10]."""
    host = Host()
    host.rtc("CTRL", {"n": 1}, [{"ki": 0, "kp": 4000, "kf": 3000, "kd": 2500}])
    host.rtc("EN_ENCFLT", {"m": 0x02, "n": 0x01}, [{"fer": 40}])
    host.card.control("jam", {"axis": 1})
    move(host, 0x01, 5000)
    assert host.run_until(Dpr.INTAXIS_ENCFLT, 0x01, 500) > 0
    assert host.u8(Dpr.DSPSTAT2) & DspStat2.ENCFLT
    assert host.u8(Dpr.HOSTINT1) & HostInt.STAT2
    host.run(2)
    assert host.card.control("get_outputs", {})["dac"][0] == 0


def test_int5ms_every_25_samples_in_its_firmware_only() -> None:
    """INT5MS m=1: DSPSTAT2 b6 every 5 ms [Ch5 INT5MS]; the standard firmware has no 8Eh: the
    code is cleared and ignored."""
    host = Host(firmware="int5ms")
    host.rtc("INT5MS", {"m": 1})
    host.ack()
    assert host.run_until(Dpr.DSPSTAT2, DspStat2.INT5MS, 26) > 0
    host.ack()
    assert 20 <= host.run_until(Dpr.DSPSTAT2, DspStat2.INT5MS, 26) <= 25
    standard = Host()
    standard.raw_rtc(0x8E, b"\x01")
    standard.run(60)
    assert standard.u8(Dpr.DSPSTAT2) == 0 and standard.u8(Dpr.RTC) == 0


def test_the_line_shows_in_the_pci_status_register_and_interrupt_disable_masks_it() -> None:
    """INTA# as bit 3 (Interrupt Status) of the PCI status register; the command register's
    Interrupt Disable (bit 10) keeps assertions from the host (no event) [PCI 2.3 §6.2]."""
    from vdevmaps.pci import COMMAND, COMMAND_INTX_DISABLE, STATUS, STATUS_INTERRUPT

    host = Host(plant="ideal")
    config = host.card.regions["config"]
    host.rtc("EN_MOTCP", {"n": 0x01})
    move(host, 0x01, 100)
    assert host.run_until(Dpr.INTAXIS_MOTCP, 0x01, 500) > 0
    assert int.from_bytes(config.read(STATUS, 2), "little") & STATUS_INTERRUPT
    host.u8(Dpr.HOSTINT1)
    assert not int.from_bytes(config.read(STATUS, 2), "little") & STATUS_INTERRUPT
    host.ack()
    config.write(COMMAND, (COMMAND_INTX_DISABLE | 0x0002).to_bytes(2, "little"))
    events = len(host.events)
    move(host, 0x01, 0)
    assert host.run_until(Dpr.INTAXIS_MOTCP, 0x01, 500) > 0
    assert len(host.events) == events  # masked: nothing reaches the host
