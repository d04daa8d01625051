"""Acceptance of the Turbo PMAC card against the specification, end to end: a real daemon (lockstep
clock) and the card's two kinds of host, PComm32 over the DPRAM (`vdevclient.pcomm`, device 0) and
the Ethernet protocol (dls-pmaclib unmodified, or raw requests where dls-pmaclib cannot go) [issue 5
"Tests"].

Sources: [A Lnnn] = line of the seed addendum; §x = spec pmac.md; README = the card's README.
"""

from __future__ import annotations

import socket
import struct
from collections.abc import Iterator
from contextlib import contextmanager
from pathlib import Path
from typing import Any

import pytest
import vdevclient
from vdevclient import pcomm
from vdevmaps.pmac import BG_CS, BG_CS_COUNT, BG_READY, BG_STATUS, RT_MASK, RT_MOTORS, RT_READY

from tests.devices.pmac.conftest import Pmac, card_config
from vdevd.testing import DaemonThread

DEVICE = 0
ACK = "\x06"
BELL = "\x07"
# Ethernet requests [§3.2]
GETRESPONSE, GETBUFFER, READREADY = 0xBF, 0xC5, 0xC2


@contextmanager
def pmac_pcomm(state_dir: Path | None = None, **options: Any) -> Iterator[Pmac]:
    """A daemon of its own holding `pmac0` (device 0, plant `ideal` unless told), opened by PComm."""
    cfg = card_config(**{"plant": "ideal", **options})
    if state_dir is not None:
        cfg.state_dir = str(state_dir)
    with DaemonThread(cfg) as d, vdevclient.connect(d.endpoint, d.events, timeout=10) as rack:
        host = Pmac(rack)
        assert pcomm.OpenPmacDevice(DEVICE, endpoint=d.endpoint)
        try:
            yield host
        finally:
            pcomm.ClosePmacDevice(DEVICE)
            host.close()


@pytest.fixture
def card() -> Iterator[Pmac]:
    with pmac_pcomm() as host:
        yield host


@pytest.fixture
def servo_card() -> Iterator[Pmac]:
    with pmac_pcomm(plant="servo") as host:
        yield host


def pc(line: str) -> list[str]:
    """The data lines of a PComm response that ended with its ACK."""
    rc = pcomm.PmacGetResponseA(DEVICE, None, 0, line)
    assert pcomm.IS_COMM_EOT(rc), (line, rc.text)
    return rc.text.split("\r")[:-1]


def pc_error(line: str) -> str:
    rc = pcomm.PmacGetResponseA(DEVICE, None, 0, line)
    assert pcomm.IS_COMM_ERROR(rc), (line, rc.text)
    return rc.text


def words(status: str) -> tuple[int, ...]:
    """Status words from a hex status reply, six digits each."""
    return tuple(int(status[k:k + 6], 16) for k in range(0, len(status), 6))


def motor_words(motor: int) -> tuple[int, int]:
    (reply,) = pc(f"#{motor}?")
    assert len(reply) == 12
    w1, w2 = words(reply)
    return w1, w2


class Raw:
    """One Ethernet connection spoken by hand [§3.2]: GETRESPONSE, then GETBUFFER while output is
    pending (READREADY), so the whole byte stream of a reply is seen whatever I3 makes of it."""

    def __init__(self, pmac: Pmac) -> None:
        host, port = pmac.ethernet.removeprefix("tcp://").rsplit(":", 1)
        self.sock = socket.create_connection((host, int(port)), timeout=5)

    def request(self, request_type: int, request: int, data: bytes = b"", length: int = 0) -> bytes:
        self.sock.sendall(struct.pack(">BBHHH", request_type, request, 0, 0, len(data) or length) + data)
        return self.sock.recv(4096)

    def pieces(self, line: str) -> list[bytes]:
        out = [self.request(0x40, GETRESPONSE, line.encode("latin-1"))]
        while self.request(0xC0, READREADY, length=2)[0]:
            out.append(self.request(0xC0, GETBUFFER, length=2048))
        return out

    def reply(self, line: str) -> bytes:
        return b"".join(self.pieces(line))

    def close(self) -> None:
        self.sock.close()


@pytest.fixture
def raw(card: Pmac) -> Iterator[Raw]:
    r = Raw(card)
    yield r
    r.close()


# -- identification [§2.4 "Number formatting", README "Global"] ----------------------------------------
def test_both_clients_identify_the_card_alike(card: Pmac) -> None:
    expected = ["1.940", "603382", "TURBO2", "06/26/2003", "DSP56321", "1"]
    assert pc("VER CID TYPE DATE CPU VID") == expected
    reply, ok = card.dls().sendCommand("VERSION CID TYPE DATE CPU VID")
    assert ok and reply == "\r".join(expected) + "\r" + ACK


# -- the addendum's math examples [A "Turbo PMAC Mathematical Features", L944-1404] ---------------------
def test_division_examples_float_and_integer_destinations(card: Pmac) -> None:
    """'P1=10*2/3 -> 6.666666667', 'M1=10*2/3 -> 7', 'M1=10*(2/3) -> 7'; divide by zero saturates
    at +/-2^47 with no error [A L978-1002]."""
    pc("M1->* P1=10*2/3 P2=10*(2/3) M1=10*2/3")
    assert pc("P1 P2 M1") == ["6.666666667", "6.666666667", "7"]
    pc("M1=10*(2/3) P3=1/0 P4=-1/0")
    assert pc("M1 P3 P4") == ["7", str(2**47), str(-(2**47))]


def test_modulo_examples(card: Pmac) -> None:
    """The eight examples of [A L1004-1028]; a zero divisor gives 0."""
    pc("P1=11%4 P2=-11%4 P3=11%-4 P4=-11%-4 P5=3%2.5 P6=-3%2.5 P7=3%-2.5 P8=-3%-2.5 P9=5%0")
    assert pc("P1..9") == ["3", "1", "3", "-3", "0.5", "2", "-2", "2", "0"]


def test_bitwise_examples(card: Pmac) -> None:
    """& | ^ on integer and fractional bits [A L1030-1094] (0.875|-1.75 printed -0.375 is the
    digest's erratum 7: the other examples fix -1.125)."""
    pc("P1=3&1 P2=3&4 P3=3&-3 P4=0.875&1.75 P5=0.875&-1.75 P6=$F0|$4 P7=3|-3 P8=0.5|0.375")
    assert pc("P1..8") == ["1", "0", "1", "0.75", "0.25", "244", "-1", "0.875"]
    pc("P1=2^1 P2=2^2 P3=5^7 P4=$AA^$55 P5=3^-3 P6=0.5^0.875 P7=0.875|-1.75")
    assert pc("P1..7") == ["3", "0", "2", "255", "-2", "0.375", "-1.125"]


def test_function_examples_int_ln_and_atan2_with_q0(card: Pmac) -> None:
    """INT floors (INT(2.5)=2, INT(-2.5)=-3), LN of x <= 0 is 0, and the ATAN2 example
    Q30=-0.707 Q31=-0.707: ATAN(Q31/Q30)=45, Q0=Q30 ATAN2(Q31)=-135 [A L1216-1236, L1305-1320]."""
    pc("P1=INT(2.5) P2=INT(-2.5) P3=LN(0) P4=LN(-1)")
    assert pc("P1..4") == ["2", "-3", "0", "0"]
    pc("&1 Q30=-0.707 Q31=-0.707 Q32=ATAN(Q31/Q30) Q0=Q30 Q33=ATAN2(Q31)")
    assert pc("Q32 Q33") == ["45", "-135"]
    pc("I15=1 P5=SIN(ATAN(1)*2)")  # radians
    assert pc("P5") == ["1"]


def test_unary_plus_is_rejected_and_the_card_answers_on(card: Pmac) -> None:
    """'P1=+P2' is not accepted [A L956]."""
    assert pc_error("P1=+P2") == BELL + "ERR003\r"
    assert pc("P1") == ["0"]


# -- I-variables: defaults and ranges [§2.2, §1.5] --------------------------------------------------
DEFAULTS = {  # §2.2 table, §1.5 (the addendum's new variables), README (I9, I6, Ixx24 PMAC2);
    # addresses and bit fields print in hex with I9 = 2
    "I3": "1", "I4": "1", "I6": "1", "I9": "2", "I10": "3713707", "I15": "0",
    "I20": "$0", "I21": "$0", "I22": "$0", "I23": "$0",
    "I108": "96", "I109": "96", "I111": "32000", "I112": "16000", "I113": "0", "I114": "0",
    "I115": "0.25", "I116": "32", "I119": "0.15625", "I120": "0", "I121": "50", "I122": "32",
    "I123": "32", "I124": "$1", "I126": "0", "I128": "160", "I130": "2000", "I131": "1280",
    "I132": "1280", "I133": "0", "I134": "1", "I135": "0", "I168": "0", "I169": "20480",
    "I171": "1000", "I192": "10", "I5194": "1644", "I5195": "1644",
    "I12": "0", "I30": "0", "I37": "$0", "I44": "0", "I7019": "0", "I142": "$0", "I143": "$0",
    "I175": "0", "I182": "$0", "I110": "$0",
}


def test_i_variable_factory_defaults(card: Pmac) -> None:
    names = list(DEFAULTS)
    got: list[str] = []
    for k in range(0, len(names), 16):
        got += pc(" ".join(names[k:k + 16]))
    assert dict(zip(names, got, strict=True)) == DEFAULTS


def test_per_channel_address_defaults_of_a_turbo_pmac2(card: Pmac) -> None:
    """Ixx02 = $078002 + 8(n-1) within an IC (I502 = $078102), Ixx25 = $078000 + 8(n-1), Ixx83 =
    $078001 + 8(n-1) [A L1462-1601, L1879-2032, L2317-2410]."""
    assert pc("I102 I202 I302 I402 I502 I802") == ["$78002", "$7800A", "$78012", "$7801A",
                                                    "$78102", "$7811A"]
    assert pc("I125 I225 I525") == ["$78000", "$78008", "$78100"]
    assert pc("I183 I283 I583") == ["$78001", "$78009", "$78101"]


@pytest.mark.parametrize(("write", "variable", "kept"), [
    ("I12=2", "I12", "0"),                 # 0-1 [A L1408]
    ("I30=2", "I30", "0"),                 # 0-1 [A L1420]
    ("I37=$032404", "I37", "$0"),           # $000000-$032403 [A L1432]
    ("I171=16777216", "I171", "1000"),     # 0-16,777,215 [A L2162]
    ("I7019=2", "I7019", "0"),             # 0-1 [A L2428]
    ("I15=2", "I15", "0"),                 # degrees or radians [A L1137]
])
def test_out_of_range_i_variable_is_refused_and_kept(card: Pmac, write: str, variable: str,
                                                     kept: str) -> None:
    assert pc_error(write) == BELL + "ERR003\r"
    assert pc(variable) == [kept]


def test_range_upper_ends_are_accepted(card: Pmac) -> None:
    pc("I37=$032403 I171=16777215 I7019=1")
    assert pc("I37 I171 I7019") == ["$32403", "16777215", "1"]


def test_i44_stays_zero_on_standard_firmware(card: Pmac) -> None:
    """'I44 cannot be changed from 0' without PMAC Ladder firmware [A L1452-1460]."""
    pc("I44=1")
    assert pc("I44") == ["0"]


def test_negative_ixx75_is_stored_as_ixx71_plus_value(card: Pmac) -> None:
    """'if a negative value for Ixx75 is specified (-Ixx71 <= Ixx75 <= 0), Turbo PMAC stores it as
    (Ixx71 + Ixx75)' [A L2222]."""
    pc("I175=-100")
    assert pc("I175") == ["900"]
    assert pc_error("I175=-1001") == BELL + "ERR003\r"


def test_ixx75_above_ixx71_is_rejected(card: Pmac) -> None:
    """'If a value for Ixx75 less than -Ixx71 or greater than Ixx71 is specified, Turbo PMAC will
    reject this with an error' [A L2222]; Ixx71 = 1000 (factory)."""
    assert pc_error("I175=1001") == BELL + "ERR003\r"
    assert pc("I175") == ["0"]


def test_address_of_a_conversion_table_line(card: Pmac) -> None:
    """'I{constant}=@I{constant}' gives the address of a table line: I103=@I8000 -> $3501
    [A L2549, L3266]."""
    pc("I103=@I8000 I5193=@I8009")
    assert pc("I103 I5193") == ["$3501", "$350A"]


# -- status words during and after a jog and a home [§2.6, §2.7] ------------------------------------
ACTIVATED, AMP_ENABLED, OPEN_LOOP, MOVE_TIMER = 1 << 23, 1 << 19, 1 << 18, 1 << 17
INTEGRATION, DESIRED_VEL_ZERO, HOME_SEARCH = 1 << 16, 1 << 13, 1 << 10
POS_LIMIT, NEG_LIMIT = 1 << 21, 1 << 22
HOME_COMPLETE, STOPPED_ON_LIMIT, FATAL_FE, WARNING_FE, IN_POSITION = (1 << 10, 1 << 11, 1 << 2,
                                                                      1 << 1, 1 << 0)


def test_status_words_at_power_up_during_and_after_a_jog(card: Pmac) -> None:
    assert motor_words(1) == (ACTIVATED | OPEN_LOOP | INTEGRATION, 0)  # killed at power-up
    pc("#1J/")
    card.step(5)
    assert motor_words(1) == (ACTIVATED | AMP_ENABLED | INTEGRATION | DESIRED_VEL_ZERO, IN_POSITION)
    pc("#1J+")
    card.step_ms(100)
    w1, w2 = motor_words(1)
    assert w1 & AMP_ENABLED and not w1 & DESIRED_VEL_ZERO and not w2 & IN_POSITION
    pc("#1J/")
    card.step_ms(1000)
    w1, w2 = motor_words(1)
    assert w1 & DESIRED_VEL_ZERO and w2 & IN_POSITION


def test_jog_to_position_runs_the_move_timer_then_reports_in_position(card: Pmac) -> None:
    pc("#1J=1000")
    card.step_ms(50)
    w1, w2 = motor_words(1)
    assert w1 & MOVE_TIMER and not w2 & IN_POSITION
    card.step_ms(1000)
    w1, w2 = motor_words(1)
    assert not w1 & MOVE_TIMER and w2 & IN_POSITION
    assert pc("#1P V F") == ["1000", "0", "0"]


def test_status_words_during_and_after_a_home_search(card: Pmac) -> None:
    """HM: word 1 bit 10 set and word 2 bit 10 (home complete) cleared at the start; at the trigger
    home complete is set; the motor ends at its new zero [§2.7 "Homing", SRM p.283]."""
    pc("#1HMZ")
    card.step(2)
    assert motor_words(1)[1] & HOME_COMPLETE
    pc("I7012=2 #1HM")  # capture on the home flag alone
    card.step_ms(50)
    w1, w2 = motor_words(1)
    assert w1 & HOME_SEARCH and not w2 & HOME_COMPLETE and not w1 & DESIRED_VEL_ZERO
    card.control("set_home", motor=1, active=True)
    card.step(3)
    w1, w2 = motor_words(1)
    assert not w1 & HOME_SEARCH and w2 & HOME_COMPLETE
    card.step_ms(1500)
    w1, w2 = motor_words(1)
    assert w2 & (HOME_COMPLETE | IN_POSITION) == HOME_COMPLETE | IN_POSITION
    assert pc("#1P") == ["0"]


# -- limits and following error [§2.7] -----------------------------------------------------------------
def test_hardware_limit_stops_motion_toward_it_and_allows_motion_away(card: Pmac) -> None:
    pc("#1J+")
    card.step_ms(200)
    card.control("set_limits", motor=1, plus=True)
    card.step_ms(3000)
    w1, w2 = motor_words(1)
    assert w1 & POS_LIMIT and w2 & STOPPED_ON_LIMIT
    stopped = float(pc("#1P")[0])
    pc("#1J+")
    card.step_ms(200)
    assert float(pc("#1P")[0]) == stopped
    pc("#1J-")
    card.step_ms(300)
    assert float(pc("#1P")[0]) < stopped


def test_minus_limit_sets_word_1_bit_22(card: Pmac) -> None:
    pc("#2J/")
    card.step(2)
    card.control("set_limits", motor=2, minus=True)
    card.step(2)
    assert motor_words(2)[0] & NEG_LIMIT


def test_software_limit_ixx13_stops_a_jog_beyond_it(card: Pmac) -> None:
    """Ixx13 (+ software limit, counts from motor zero) acts on the actual position: the motor
    stops beyond it with word 1 bit 21 and word 2 bit 11 [§2.7 "Software limits"]."""
    pc("I113=500 #1J+")
    card.step_ms(2000)
    w1, w2 = motor_words(1)
    assert w1 & POS_LIMIT and w2 & STOPPED_ON_LIMIT and w1 & DESIRED_VEL_ZERO
    assert float(pc("#1P")[0]) > 500


@pytest.mark.parametrize("limit", ["software", "hardware"])
def test_limit_stop_decelerates_at_ixx15(card: Pmac, limit: str) -> None:
    """'Actual position beyond a limit ... stops motion toward it at the Ixx15 rate' [§2.7], 'the
    stop decelerates at Ixx15' (README "Limits"): Ixx15 = 0.25 cts/ms^2 from at most 32 cts/ms
    stops within 32^2/(2 x 0.25) = 2048 counts, and the speed never grows after the trip."""
    pc("M161->D:$000088 #1J+" if limit == "hardware" else "M161->D:$000088 I113=500 #1J+")
    if limit == "hardware":
        card.step_ms(165)
        card.control("set_limits", motor=1, plus=True)
    trip, speeds, last = None, [], 0.0
    for _ in range(300):
        card.step(22)  # about 10 ms
        position = float(pc("M161")[0]) / (96 * 32)
        if trip is None and motor_words(1)[0] & POS_LIMIT:
            trip = position
        elif trip is not None:
            speeds.append(position - last)
        last = position
    assert trip is not None
    assert last - trip < 2048
    assert all(b <= a + 1e-6 for a, b in zip(speeds, speeds[1:], strict=False))


def test_fatal_following_error_kills_only_its_motor_with_ixx24_bit_22(servo_card: Pmac) -> None:
    """Ixx24 bits 21-22 = 10: 'kill only this motor' [A L1863-1871]; Ixx12 warns and Ixx11 kills,
    word 2 bits 1 and 2; the host sees IR3 then IR2 on `inta` (README host region)."""
    card = servo_card
    host = card.card.region("host")
    host.write8(9, (1 << 2) | (1 << 3))
    card.card.irq.last_seq = card.rack.stats()["cards"]["pmac0"]["irq_seq"]
    pc("#2J/ I124=$400001 I111=160 I112=80 I122=100 I120=1 I121=0 I119=100")
    card.step_ms(20)
    pc("#1J+")
    card.step_ms(50)
    w1, w2 = motor_words(1)
    assert w2 & (FATAL_FE | WARNING_FE) == FATAL_FE | WARNING_FE and not w1 & AMP_ENABLED
    assert motor_words(2)[0] & AMP_ENABLED
    statuses = []
    while (event := card.card.irq.wait(timeout_s=0.5)) is not None:
        statuses.append(event["status"])
    assert statuses and statuses[-1] & 0x0C == 0x0C


def test_in_position_interrupt_when_a_jog_ends(card: Pmac) -> None:
    """IR0 in-position: word 2 bit 0 rising (README host region)."""
    pc("#1J/")
    card.step(5)
    host = card.card.region("host")
    pc("#1J=200")
    card.step(2)
    host.write8(9, 1)
    card.card.irq.last_seq = card.rack.stats()["cards"]["pmac0"]["irq_seq"]
    card.step_ms(800)
    event = card.card.irq.wait(timeout_s=1.0)
    assert event is not None and event["status"] & 1


def test_enabling_in_position_interrupt_does_not_fire_without_an_edge(card: Pmac) -> None:
    """IR0 is 'a motor's word-2 bit 0 rising' (README host region); motor 1 has been in position
    for a while and nothing moves."""
    pc("#1J/")
    card.step(20)
    host = card.card.region("host")
    card.card.irq.last_seq = card.rack.stats()["cards"]["pmac0"]["irq_seq"]
    host.write8(9, 1)
    card.step(20)
    assert host.read8(8) & 1 == 0
    assert card.card.irq.wait(timeout_s=0.2) is None


# -- memory and M-variables see the servo loop's memory [§2.1 motor block, §2.3] ---------------------
def test_m_variables_read_the_motor_block_the_servo_loop_writes(card: Pmac) -> None:
    pc("M101->X:$078001,0,24,S M161->D:$000088 M162->D:$00008B M130->X:$0000B0,0,24 "
       "M140->Y:$0000C0,0,24")
    pc("#1J=1000")
    card.step_ms(1000)
    assert pc("M161 M162 M101") == [str(1000 * 96 * 32)] * 2 + ["1000"]
    (status,) = pc("#1?")
    assert [int(v) for v in pc("M130 M140")] == list(words(status))


def test_variable_jog_register_mxx72_drives_j_equals_star(card: Pmac) -> None:
    """Mxx72 = L:$0000D7, the variable jog position used by J=* (§2.1, README "Jog")."""
    pc("M172->L:$0000D7 M172=250 #1J=*")
    card.step_ms(800)
    assert pc("#1P") == ["250"]


def test_p_variables_are_memory_at_l_006000(card: Pmac) -> None:
    """'M11->L:$6000 ;address of P0' [M-vars]: P5 is L:$006005."""
    pc("M11->L:$006005 M11=3.25")
    assert pc("P5") == ["3.25"]
    pc("P5=-7.5")
    assert pc("M11 RL:$006005") == ["-7.5", "-7.5"]


def test_memory_commands_write_and_read_words(card: Pmac) -> None:
    pc("WY:$010000,5,$12 WX:$010000,$ABCDEF")
    assert pc("RY:$010000,2 RX:$010000") == ["$000005", "$000012", "$ABCDEF"]
    assert pc_error("RX:$080000") == BELL + "ERR003\r"  # above $07FFFF (README "Memory")


def test_global_and_coordinate_system_status_words(card: Pmac) -> None:
    """??? is global word 1 (X:$000006) then word 2; &n?? three words [§2.6]; the phase-clock
    error is bit 3 [A L3267, L3320]."""
    (status,) = pc("???")
    assert len(status) == 12 and words(status) == (0, 0)
    assert len(pc("&1??")[0]) == 18
    card.control("set_phase_clock_error", active=True)
    (status,) = pc("???")
    assert words(status)[0] == 1 << 3
    assert pc("RX:$000006") == ["$000008"]
    assert pc_error("#1J/") == BELL + "ERR018\r"


def test_v_reports_counts_per_servo_cycle_while_jogging(card: Pmac) -> None:
    """V in counts per servo cycle rounded to 0.1: 32 cts/ms x 0.44271 ms = 14.2 [§2.4]."""
    pc("I119=10 I120=10 I121=0 #1J+")
    card.step_ms(300)
    assert pc("#1V") == ["14.2"]


# -- DEFINE COMP [A L3118-3219] -------------------------------------------------------------------------
def test_define_comp_addendum_example_twelve_by_ten(card: Pmac) -> None:
    """'#1 DEFINE COMP 12.10,#4,1280,1200': #4 row source, #1 column source and target, 142 entries
    [A L3214-3219]; LIST COMP prints a row per line (E0 implied); I51=1 turns it on: ??? bit 14
    (README)."""
    pc("#1 DEFINE COMP 12.10,#4,1280,1200")
    entries = [str(k) for k in range(1, 143)]
    for k in range(0, 142, 20):
        pc(" ".join(entries[k:k + 20]))
    assert pc("LIST COMP DEF") == ["DEFINE COMP 12.10,#4,#1,#1,1280,1200"]
    rows = pc("LIST COMP")
    assert len(rows) == 13 and rows[0] == "1 2 3 4 5 6 7 8 9 10"
    assert rows[1].split() == [str(k) for k in range(11, 22)]
    assert words(pc("???")[0])[0] & (1 << 14) == 0
    pc("I51=1")
    assert words(pc("???")[0])[0] & (1 << 14)


def test_define_comp_order_high_to_low_and_err007(card: Pmac) -> None:
    """Tables are DEFINEd from high to low motor number and DELETEd from low to high; otherwise
    ERR007 (the example's number) [A L3139, L3179-3190]."""
    pc("#3 DEFINE COMP 1.1,#1,#2,100,100")
    pc("0 0 0")
    assert pc_error("#4 DEFINE COMP 1.1,#1,#2,100,100") == BELL + "ERR007\r"
    pc("#2 DEFINE COMP 1.1,#1,#3,100,100")
    pc("0 0 0")
    assert pc_error("#3 DELETE COMP") == BELL + "ERR007\r"
    pc("#2 DELETE COMP #3 DELETE COMP")
    pc("#4 DEFINE COMP 1.1,#1,#2,100,100")


# -- SAVE, $$$, $$$*** [README "Non-volatile memory"] ------------------------------------------------
def test_save_survives_a_restart_with_q_variables_and_comp_tables(tmp_path: Path) -> None:
    with pmac_pcomm(tmp_path) as card:
        pc("&2 I130=1234 P5=5.5 Q7=-2.25 M100->Y:$010000,0,8 #1 DEFINE COMP 1.1,#2,100,100")
        pc("1 2 3")
        pc("SAVE")
        pc("I131=1 P6=6")  # after the SAVE: lost
        card.step(1)
    with pmac_pcomm(tmp_path):
        assert pc("I130 I131 P5 P6 &2 Q7 M100->") == ["1234", "1280", "5.5", "0", "-2.25",
                                                      "M100->Y:$010000,0,8,U"]
        assert pc("#1 LIST COMP") == ["1", "2 3"]


def test_reset_reloads_the_saved_image_and_kills_the_motors(card: Pmac) -> None:
    pc("I130=1500 P1=1 SAVE")
    pc("I130=1700 P1=2 #1J=300")
    card.step_ms(800)
    pc("$$$")
    card.step(2)
    assert pc("I130 P1 #1P") == ["1500", "1", "0"]
    assert motor_words(1)[0] & (AMP_ENABLED | OPEN_LOOP) == OPEN_LOOP


def test_factory_reset_keeps_the_saved_image_until_the_next_save(tmp_path: Path) -> None:
    with pmac_pcomm(tmp_path):
        pc("I130=1500 P1=1 M100->Y:$010000,0,8 SAVE")
        pc("$$$***")
        assert pc("I130 P1 M100->") == ["2000", "0", "M100->*"]
        pc("$$$")
        assert pc("I130 P1") == ["1500", "1"]
        pc("$$$***")
    with pmac_pcomm(tmp_path):
        assert pc("I130 P1 M100->") == ["1500", "1", "M100->Y:$010000,0,8,U"]


# -- the DPRAM and Ethernet paths [§2.10, §3.2] -----------------------------------------------------
def test_a_long_reply_is_the_same_through_the_dpram_and_in_1400_byte_ethernet_pieces(
        card: Pmac, raw: Raw) -> None:
    """GETRESPONSE answers exactly 1400 bytes when more follows, GETBUFFER the rest [§3.2]; the
    DPRAM posts the same lines one at a time [§2.10]."""
    raw.reply("I3=2")
    pieces = raw.pieces("I0..1000")
    assert len(pieces) > 1 and len(pieces[0]) == 1400
    assert all(len(p) <= 1400 for p in pieces)
    text = b"".join(pieces).decode("latin-1")
    assert text.endswith(ACK) and text.count(ACK) == 1
    dpram = pc("I0..1000")
    assert len(dpram) == 1001 and text == "\r".join(dpram) + "\r" + ACK


@pytest.mark.parametrize(("i6", "error"), [(0, b"\x07"), (1, b"\x07ERR003\r"), (2, b"\x07"),
                                           (3, b"\x07ERR003\r")])
def test_errors_as_i6_sets_them_and_the_card_answers_on(card: Pmac, raw: Raw, i6: int,
                                                          error: bytes) -> None:
    """I6 = 1 or 3: <BELL>ERRnnn<CR>, 0 or 2: a bare <BELL> (README "Ports and framing"); no ACK after
    an error; data before the error are still sent [§2.4]."""
    raw.reply(f"I3=2 I6={i6}")
    assert raw.reply("XYZ") == error
    assert raw.reply("I130 XYZ P1") == b"2000\r" + error
    assert raw.reply("VER") == b"1.940\r\x06"


@pytest.mark.parametrize(("i3", "with_data", "without"), [
    (0, b"2000\r1280\r", b"\x00"),        # nothing for a valid command: the Ethernet NUL
    (1, b"\n2000\r\n1280\r\n", b"\n"),
    (2, b"2000\r1280\r\x06", b"\x06"),
    (3, b"\n2000\r\n1280\r\x06", b"\x06"),
])
def test_reply_framing_follows_i3(card: Pmac, raw: Raw, i3: int, with_data: bytes,
                                  without: bytes) -> None:
    """The I3 table [§2.4, SRM p.37]: 1 = <LF>DATA<CR> per line then <LF>; 3 = <LF>DATA<CR> per line
    then <ACK>."""
    raw.reply(f"I3={i3}")
    assert raw.reply("I130 I131") == with_data
    assert raw.reply("P1=1") == without


@pytest.mark.parametrize(("i9", "reply"), [(0, ["1", "491520"]), (1, ["I124=1", "I125=491520"]),
                                           (2, ["$1", "$78000"]), (3, ["I124=$1", "I125=$78000"])])
def test_i9_hex_and_long_forms(card: Pmac, i9: int, reply: list[str]) -> None:
    """I9 bit 1: address I-variables and Ixx24 in hex; bit 0: the long form [§2.4]."""
    pc(f"I9={i9}")
    assert pc("I124 I125") == reply


def test_comment_with_characters_above_127_is_accepted(card: Pmac, raw: Raw) -> None:
    """V1.939: characters > 127 accepted inside comments [A L3311]."""
    raw.reply("I3=2")
    assert raw.reply("P1=5 ;\xe9t\xe9 \xff") == b"\x06"
    assert pc("P1") == ["5"]


def test_ports_address_their_own_motor_and_share_i_variables(card: Pmac, raw: Raw) -> None:
    """Each port has its own #n and &n; I-variables are card wide (README "Ports and framing")."""
    raw.reply("I3=2")
    pc("#3 &2")
    assert raw.reply("# &") == b"1\r1\r\x06"
    raw.reply("I130=1600")
    assert pc("# & I130") == ["3", "2", "1600"]


def test_host_port_frames_its_replies_by_i3(card: Pmac) -> None:
    """The host port is a serial-style port: I3 = 1 gives <LF>DATA<CR><LF> (README host region)."""
    host = card.card.region("host")
    for ch in b"I130\r":
        host.write8(7, ch)
    out = bytearray()
    while host.read8(2) & 1:
        out.append(host.read8(7))
    assert bytes(out) == b"\n2000\r\n"


def test_dpram_error_word_is_bcd_and_the_control_character_slot_works(card: Pmac) -> None:
    """ERRnnn posts 0x80|hundreds, BCD tens/units (ERR015 = 0x8015) [§2.10]; a control character at
    0x0E9E answers its text: ^P the eight positions (README)."""
    assert card.dpram_lines("&1B1R") == [(0x8015, "")]
    pc("#2J=40")
    card.step_ms(500)
    rc = pcomm.PmacGetControlResponseA(DEVICE, None, 256, "\x10")
    assert pcomm.IS_COMM_EOT(rc) and rc.text == "0 40 0 0 0 0 0 0\r"


# -- DPRAM reporting buffers, I47-I50 (README "Region dpram") ----------------------------------------
def test_realtime_buffer_layout_period_and_handshake(card: Pmac) -> None:
    dpram = card.card.region("dpram")
    pc("#1J=100")
    card.step_ms(800)
    dpram.write(RT_MASK, struct.pack("<I", 1))
    pc("I47=10 I48=1")
    card.step(20)
    timer_lo, timer_hi = struct.unpack("<HH", dpram.read(RT_READY - 2, 4))
    cycle = timer_lo | (timer_hi & 0xFF) << 16
    assert timer_hi & 0x8000 and cycle % 10 == 0
    rec = struct.unpack("<12i", dpram.read(RT_MOTORS, 48))
    assert (rec[3] & 0xFFFFFF, rec[4] & 0xFFFFFF) == motor_words(1)
    assert (rec[0], rec[1], rec[10], rec[11]) == (0, 0, 100 * 96 * 32, 0)  # FE, actual position
    card.step(25)
    assert struct.unpack("<H", dpram.read(RT_READY - 2, 2))[0] == timer_lo  # held until cleared
    dpram.write16(RT_READY, 0)
    card.step(10)
    later, ready = struct.unpack("<HH", dpram.read(RT_READY - 2, 4))
    assert ready & 0x8000 and later > timer_lo and later % 10 == 0


def test_background_buffer_global_status_and_time_base(card: Pmac) -> None:
    dpram = card.card.region("dpram")
    card.control("set_phase_clock_error", active=True)
    dpram.write16(BG_CS_COUNT, 2)
    pc("&2%50 I50=1 I49=1")
    card.step(2)
    assert dpram.read16(BG_READY) & 0x8000
    y_word, x_word = struct.unpack("<ii", dpram.read(BG_STATUS, 8))
    assert (x_word & 0xFFFFFF, y_word & 0xFFFFFF) == words(pc("???")[0])
    cs2 = struct.unpack("<32i", dpram.read(BG_CS + 128, 128))
    assert cs2[2] == round(3713707 * 0.5)  # time base at 50 %, I10 units
