"""The host-visible DSPL surface on the card [Ch5 CHANGE_VAR, MONITOR_VAR, START_DSPL, STOP_DSPL,
SIGNAL_DSPL, CLEAR_DSPL, DSPL_AUTOSTART; Ch6 Tables 6-2, 6-3; spec octavia.md §7], driven
through the DPR as a host does, and the backdoor that stands in for a DSPL program."""

from __future__ import annotations

import asyncio
import struct
from pathlib import Path

import pytest
from vdevmaps.octavia import Dpr, DsplErr, DspStat1, DspStat2, HostInt

from tests.devices.octavia.cam_host import (
    AXMOVE,
    CHANGE_VAR,
    CLEAR_DSPL,
    DSPL_AUTOSTART,
    EN_MOTCP,
    MONITOR_VAR,
    RESET,
    SIGNAL_DSPL,
    START_DSPL,
    STOP_DSPL,
    Host,
    mask,
)
from vdevd.nvram import NvramStore

FIVE_MS = 25  # samples between two refreshes of the DSPL window
VALUES = {3: bytes.fromhex("010203040506"), 12: bytes.fromhex("A0A1A2A3A4A5"),
          15: bytes.fromhex("FFFFFFFFFFFF"), 55: bytes.fromhex("000000000080")}


def change_var(host: Host, values: dict[int, bytes]) -> None:
    host.rtc(CHANGE_VAR, bytes((len(values),)) + b"".join(
        bytes((var,)) + value for var, value in values.items()))


def slots(host: Host) -> list[bytes]:
    """The four monitor slots 066h..07Dh, read under 0D1h/0C9h [Table 6-3, 6-11]."""
    raw = host.locked(Dpr.HOSTACC_DSPL, Dpr.M4ACC_DSPL, Dpr.DSPLVAR, 24)
    return [raw[i:i + 6] for i in range(0, 24, 6)]


def test_monitor_var_example_shows_var3_12_15_55_within_5_ms() -> None:
    """[Ch5 MONITOR_VAR example] m=0Fh, varnums 03h, 0Ch, 0Fh, 37h; values set by CHANGE_VAR."""
    host = Host()
    change_var(host, VALUES)
    host.rtc(MONITOR_VAR, bytes.fromhex("0F 03 0C 0F 37"))
    host.tick(FIVE_MS)
    assert slots(host) == list(VALUES.values())


def test_change_var_of_a_monitored_variable_shows_in_its_slot() -> None:
    host = Host()
    host.rtc(MONITOR_VAR, bytes.fromhex("04 0C"))  # slot 3 shows VAR12
    host.tick(FIVE_MS)
    assert slots(host) == [bytes(6)] * 4
    change_var(host, {12: b"\x11" * 6, 13: b"\x22" * 6})
    host.tick(FIVE_MS)
    assert slots(host) == [bytes(6), bytes(6), b"\x11" * 6, bytes(6)]
    assert host.control("dspl_var", var=13) == 0x222222222222


def test_monitor_var_with_no_variable_stops_updating_its_slot() -> None:
    """A varnum outside 1..128 maps nothing: the slot keeps what it showed (README "DSPL")."""
    host = Host()
    change_var(host, {3: VALUES[3]})
    host.rtc(MONITOR_VAR, bytes.fromhex("02 03"))
    host.tick(FIVE_MS)
    host.rtc(MONITOR_VAR, bytes.fromhex("02 00"))
    change_var(host, {3: VALUES[12]})
    host.tick(FIVE_MS)
    assert slots(host)[1] == VALUES[3]
    assert host.control("get_dspl")["monitor"] == [0, 0, 0, 0]


def test_change_var_with_eight_pairs_fills_the_57_byte_window() -> None:
    """[Ch5 CHANGE_VAR] m at most 8: 1 + 8 x 7 = 57 bytes, 3C3h..3FBh."""
    host = Host()
    values = {var: bytes((var,)) * 6 for var in (1, 2, 64, 100, 125, 126, 127, 128)}
    args = bytes((8,)) + b"".join(bytes((v,)) + b for v, b in values.items())
    assert len(args) == 57
    host.rtc(CHANGE_VAR, args)
    for var, value in values.items():
        assert host.control("dspl_var", var=var) == int.from_bytes(value, "little")


@pytest.mark.parametrize("args", [b"\x00", b"\x09" + b"\x01" * 63, b"\x01\x00" + bytes(6),
                                  b"\x01\x81" + bytes(6)])
def test_change_var_with_no_variable_changes_nothing(args: bytes) -> None:
    host = Host()
    host.control("dspl_var", var=1, value=0x0102)
    host.rtc(CHANGE_VAR, args)
    assert host.control("dspl_var", var=1) == 0x0102


def test_the_dspl_window_waits_while_the_host_holds_0d1h() -> None:
    host = Host()
    change_var(host, {3: VALUES[3]})
    host.dpr.write(Dpr.HOSTACC_DSPL, b"\x01")
    host.rtc(MONITOR_VAR, bytes.fromhex("01 03"))
    host.tick(4 * FIVE_MS)
    assert host.dpr.read(Dpr.DSPLVAR, 6) == bytes(6)
    host.dpr.write(Dpr.HOSTACC_DSPL, b"\x00")
    host.tick(FIVE_MS)
    assert slots(host)[0] == VALUES[3]


def test_start_dspl_runs_a_loaded_program_only() -> None:
    """[Ch5 START_DSPL] starts a program "previously downloaded"; with none, nothing."""
    host = Host()
    host.rtc(START_DSPL)
    assert host.control("get_dspl")["running"] is False
    host.control("dspl_load")
    host.rtc(START_DSPL)
    state = host.control("get_dspl")
    assert (state["loaded"], state["running"]) == (True, True)
    host.rtc(SIGNAL_DSPL)
    host.rtc(SIGNAL_DSPL)
    assert host.control("get_dspl")["signals"] == 2
    host.rtc(STOP_DSPL)
    assert host.control("get_dspl")["running"] is False
    host.rtc(CLEAR_DSPL)
    host.rtc(START_DSPL)
    state = host.control("get_dspl")
    assert (state["loaded"], state["running"]) == (False, False)


def test_stop_dspl_halts_every_axis_at_its_maxacc() -> None:
    """[Ch5 STOP_DSPL] "will also halt the motion (if any) of all axes with the programmed
    MAXACC": axes 1 and 2 decelerate at 0.125 / 0.25 counts/sample^2 with motion complete; an
    axis without MAXACC is left alone, as STOP leaves it."""
    host = Host()
    host.maxacc(0x1000, 1)
    host.maxacc(0x2000, 2)
    host.rtc(EN_MOTCP, b"\xff")
    host.velmode(1, 0x40000)
    host.velmode(2, -0x40000)
    host.rtc(AXMOVE, bytes((mask(3),)) + struct.pack("<HiI", 0x1000, 3000, 0x40000))
    host.tick(100)
    host.ack()
    host.rtc(STOP_DSPL)
    host.tick(20)
    v1, v2 = host.axis(1)["cmd_vel"] * 200e-6, host.axis(2)["cmd_vel"] * 200e-6
    assert abs(v1 - (4 - 0.125 * 21)) <= 0.125 + 1e-9  # 20 or 21 samples of braking
    assert v2 == 0  # 16 samples at 0.25
    host.settle(1, 2, 3)
    assert host.actpos(3) == 3000
    status = host.status()
    assert status["dspstat1"] & DspStat1.MOTCP and status["src5"] == mask(1, 2, 3)


def test_dspl_host_interrupt_reports_dspstat2_b4_and_its_value_at_00eh() -> None:
    """[Table 6-2] DSPL INT_HOST: 009h b4, 00Eh, 1FFEh b6 and the interrupt line."""
    host = Host()
    host.ack()
    host.card.inta.clear()
    host.control("dspl_host_interrupt", value=0x5A)
    assert host.card.inta.asserted
    status = host.status()
    assert status["hostint"] & HostInt.STAT2
    assert status["dspstat2"] == DspStat2.DSPL_INT and status["dspl_int"] == 0x5A


def test_dspl_error_reports_dspstat2_b5_and_00fh() -> None:
    host = Host()
    host.ack()
    host.control("dspl_error", not_found=True)
    status = host.status()
    assert status["dspstat2"] == DspStat2.DSPL_ERR and status["dsplerr"] == DsplErr.NOT_FOUND
    host.control("dspl_error", too_many=True)
    assert host.status()["dsplerr"] == DsplErr.TOO_MANY | DsplErr.NOT_FOUND
    with pytest.raises(Exception, match="too_many or not_found"):
        host.control("dspl_error")


def test_program_status_words_are_published_every_5_ms() -> None:
    """[Table 6-3] PRG1STAT 07Eh, PRG2STAT 080h, PLCSTAT 084h: line numbers, u16."""
    host = Host()
    host.control("dspl_status", prg1=0x1234, plc=7)
    host.tick(FIVE_MS)
    raw = host.locked(Dpr.HOSTACC_DSPL, Dpr.M4ACC_DSPL, Dpr.PRG1STAT, 8)
    assert struct.unpack("<4H", raw) == (0x1234, 0, 0, 7)
    host.rtc(STOP_DSPL)
    host.tick(FIVE_MS)
    assert host.dpr.read(Dpr.PRG1STAT, 8) == bytes(8)


def test_variables_survive_reset_and_the_monitor_mapping_does_not() -> None:
    host = Host()
    change_var(host, {3: VALUES[3]})
    host.rtc(MONITOR_VAR, bytes.fromhex("01 03"))
    host.tick(FIVE_MS)
    host.rtc(RESET, b"\xaa\xaa")
    host.tick(FIVE_MS)
    assert slots(host)[0] == bytes(6)
    assert host.control("dspl_var", var=3) == int.from_bytes(VALUES[3], "little")
    assert host.control("get_dspl")["monitor"] == [0, 0, 0, 0]


def test_reset_restarts_the_program_only_with_autostart() -> None:
    """Power-up is RESET's sequence [Ch7]: a loaded program runs after it with autostart."""
    host = Host()
    host.control("dspl_load")
    host.rtc(START_DSPL)
    host.rtc(RESET, b"\xaa\xaa")
    assert host.control("get_dspl")["running"] is False
    host.rtc(DSPL_AUTOSTART, b"\x55")
    host.rtc(RESET, b"\xaa\xaa")
    assert host.control("get_dspl")["running"] is True


def close(host: Host) -> None:
    asyncio.run(host.card.close_services())


def test_dspl_autostart_55h_survives_a_power_cycle_and_starts_the_program(tmp_path: Path
                                                                          ) -> None:
    """[Ch5 DSPL_AUTOSTART] x=55h enables; it stays "even after power-down"; any other x
    disables."""
    store = NvramStore(tmp_path)
    host = Host(store)
    host.control("dspl_load")
    host.rtc(DSPL_AUTOSTART, b"\x55")
    change_var(host, {128: VALUES[55]})
    close(host)
    again = Host(store)
    state = again.control("get_dspl")
    assert (state["autostart"], state["loaded"], state["running"]) == (True, True, True)
    assert again.control("dspl_var", var=128) == int.from_bytes(VALUES[55], "little")
    again.rtc(DSPL_AUTOSTART, b"\x54")
    close(again)
    state = Host(store).control("get_dspl")
    assert (state["autostart"], state["loaded"], state["running"]) == (False, True, False)


def test_autostart_without_a_program_runs_nothing(tmp_path: Path) -> None:
    store = NvramStore(tmp_path)
    host = Host(store)
    host.rtc(DSPL_AUTOSTART, b"\x55")
    host.rtc(CLEAR_DSPL)
    close(host)
    state = Host(store).control("get_dspl")
    assert (state["autostart"], state["loaded"], state["running"]) == (True, False, False)


def test_stop_dspl_keeps_engaged_slaves_behind_their_halting_master() -> None:
    """README "DSPL": STOP_DSPL halts masters at MAXACC; their slaves follow, engaged."""
    host = Host()
    host.maxacc(0x1000, 1, 2)
    host.rtc(0x9C, bytes((mask(1), mask(2))) + struct.pack("<h", 0x100))  # GEAR 2.0
    host.velmode(1, 0x20000)
    host.tick(100)
    host.rtc(STOP_DSPL)
    host.settle(1, 2)
    assert host.actpos(2) == 2 * host.actpos(1)
    host.axmove(1, host.actpos(1) + 50)
    host.settle(1, 2)
    assert host.actpos(2) == 2 * host.actpos(1)


def test_the_reset_finished_bit_is_all_a_fresh_card_reports() -> None:
    host = Host()
    status = host.status()
    assert status["hostint"] == HostInt.RESET_DONE and status["dspstat2"] == 0
