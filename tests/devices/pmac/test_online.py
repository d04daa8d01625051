"""The on-line command interpreter without sockets: a Firmware, a port, framed replies [spec pmac.md
§2.4, §2.5; the addendum's math section]. Integration through the daemon is in test_card.py."""

from __future__ import annotations

import pytest

from vdevd.devices.pmac.firmware import Firmware
from vdevd.devices.pmac.online import PortState
from vdevd.devices.pmac.reply import frame

PERIOD_NS = 442_710


class Card:
    """A firmware and one port, answering like a serial port with the current I3/I6."""

    def __init__(self, motors: int = 8, plant: str = "ideal") -> None:
        self.fw = Firmware(motors, PERIOD_NS, plant)
        self.fw.restore({})
        self.port = PortState()
        self.saved: list[dict] = []

    def raw(self, line: str) -> bytes:
        iv = self.fw.ivars.values
        return frame(self.fw.execute(self.port, line), int(iv[3]), int(iv[6]))

    def ask(self, line: str) -> str:
        """The reply with I3=2 framing stripped: data lines joined by CR, ACK required."""
        out = self.raw(line)
        assert out.endswith(b"\x06"), out
        return out[:-1].decode().rstrip("\r")

    def tick(self, n: int = 1) -> None:
        for _ in range(n):
            self.fw.tick(self.fw.now_ns + PERIOD_NS)


@pytest.fixture
def card() -> Card:
    c = Card()
    c.raw("I3=2")
    return c


# -- framing (I3, I6) [SRM p.37-38, UM p.384] ---------------------------------------------------
def test_i3_1_default_framing_uses_line_feeds() -> None:
    c = Card()
    assert c.fw.ivars[3] == 1
    assert c.raw("VER") == b"\n1.940\r\n"
    assert c.raw("I130=1000") == b"\n"


def test_i3_2_data_lines_then_ack(card: Card) -> None:
    assert card.raw("ver") == b"1.940\r\x06"
    assert card.raw("I130=1500") == b"\x06"
    assert card.raw("I130 I131") == b"1500\r1280\r\x06"


def test_i3_0_and_3() -> None:
    c = Card()
    c.raw("I3=0")
    assert c.raw("VER") == b"1.940\r"
    assert c.raw("I130=1") == b""
    c.raw("I3=3")
    assert c.raw("VER") == b"\n1.940\r\x06"


def test_dls_pmaclib_connect_line(card: Card) -> None:
    """dls-pmaclib connects with this line and wants ^\\d+\\.\\d+\\s*\\r\\x06$ [DLS-lib]."""
    assert card.raw("i6=1 i3=2 ver") == b"1.940\r\x06"


def test_error_reports_bell_errnnn_and_abandons_the_line(card: Card) -> None:
    assert card.raw("I99999") == b"\x07ERR003\r"
    assert card.raw("I130 XYZ I131=5") == b"2000\r\x07ERR003\r"
    assert card.fw.ivars[131] == 1280  # the rest of the line did not run


def test_i6_0_reports_a_bare_bell(card: Card) -> None:
    card.raw("I6=0")
    assert card.raw("XYZ") == b"\x07"


def test_comment_is_ignored_even_with_bytes_above_127(card: Card) -> None:
    """V1.939: characters > 127 are accepted inside comments [A L3311]; elsewhere one is ERR004
    (illegal character) [digest §2.4 error list]."""
    assert card.ask("I130 ; gain \xb5 ok") == "2000"
    assert card.raw("I130 \xb5") == b"2000\r\x07ERR004\r"


# -- identification --------------------------------------------------------------------------------
def test_identity(card: Card) -> None:
    assert card.ask("CID") == "603382"
    assert card.ask("VERSION") == "1.940"
    assert card.ask("cpu").startswith("DSP563")
    assert card.ask("DATE")


# -- I-variables -------------------------------------------------------------------------------------
def test_factory_defaults(card: Card) -> None:
    assert card.ask("I10") == "3713707"
    assert card.ask("I130 I131 I132 I133") == "2000\r1280\r1280\r0"
    assert card.ask("I111 I112 I128") == "32000\r16000\r160"
    assert card.ask("I119 I122 I123") == "0.15625\r32\r32"
    assert card.ask("I108 I109") == "96\r96"


def test_address_variables_print_in_hex_with_i9_2(card: Card) -> None:
    """getNumberOfAxes reads `i20 i21 i22 i23` and counts every value but `$0` [DLS-lib]."""
    assert card.ask("i20 i21 i22 i23 ") == "$0\r$0\r$0\r$0"
    assert card.ask("I124 I125 I225") == "$1\r$78000\r$78008"
    card.raw("I9=0")
    assert card.ask("I124 I125") == "1\r491520"


def test_i9_bit0_long_form(card: Card) -> None:
    card.raw("I9=3")
    assert card.ask("I130") == "I130=2000"
    assert card.ask("I125") == "I125=$78000"


def test_ranges_and_lists(card: Card) -> None:
    card.raw("P1=1 P2=2 P3=3 P5=5")
    assert card.ask("P1..3") == "1\r2\r3"
    assert card.ask("P1,3,2") == "1\r3\r5"
    card.raw("I130,8,100=1500")
    assert card.ask("I130,8,100") == "\r".join(["1500"] * 8)
    assert card.ask("I131") == "1280"
    assert card.raw("I133..134=2") == b"\x07ERR003\r"  # I134 (Ixx34) takes 0 or 1 only
    assert card.ask("I133") == "2"  # the range stopped at its first bad variable


def test_out_of_range_write_is_refused_and_nothing_changes(card: Card) -> None:
    assert card.raw("I130=99999999999") == b"\x07ERR003\r"
    assert card.ask("I130") == "2000"
    assert card.raw("I3=7") == b"\x07ERR003\r"


def test_default_and_address_of(card: Card) -> None:
    card.raw("I130=10")
    card.raw("I130=*")
    assert card.ask("I130") == "2000"
    card.raw("I103=@I8004")  # V1.937 [A L3266]
    assert card.ask("I103") == "$3505"


def test_ixx75_negative_values_are_converted(card: Card) -> None:
    """V1.939: -Ixx71 <= v <= 0 is stored as Ixx71 + v; below -Ixx71 is refused [A L2191]."""
    card.raw("I171=1000 I175=-200")
    assert card.ask("I175") == "800"
    assert card.raw("I175=-2000") == b"\x07ERR003\r"


def test_i44_cannot_leave_zero_on_standard_firmware(card: Card) -> None:
    assert card.raw("I44=1") == b"\x06"
    assert card.ask("I44") == "0"


# -- math [A "Turbo PMAC Mathematical Features"] ------------------------------------------------------
def test_division_float_and_integer_destinations(card: Card) -> None:
    card.raw("M1->* P1=10*2/3 M1=10*2/3 P2=10*(2/3) M2->* M2=10*(2/3)")
    assert card.ask("P1 P2") == "6.666666667\r6.666666667"
    assert card.ask("M1 M2") == "7\r7"


@pytest.mark.parametrize(("expression", "value"), [
    ("11%4", "3"), ("-11%4", "1"), ("11%-4", "3"), ("-11%-4", "-3"),
    ("3%2.5", "0.5"), ("-3%2.5", "2"), ("3%-2.5", "-2"), ("-3%-2.5", "2"),
    ("3&-3", "1"), ("0.875&1.75", "0.75"), ("$F0|$4", "244"), ("5^7", "2"),
    ("INT(2.5)", "2"), ("INT(-2.5)", "-3"), ("LN(0)", "0"), ("1/0", "140737488355328"),
])
def test_addendum_math_examples(card: Card, expression: str, value: str) -> None:
    card.raw(f"P10={expression}")
    assert card.ask("P10") == value


def test_unary_plus_is_rejected(card: Card) -> None:
    assert card.raw("P1=+P2") == b"\x07ERR003\r"


def test_atan2_uses_q0_of_the_addressed_cs(card: Card) -> None:
    card.raw("&1 Q30=-0.707 Q31=-0.707 Q32=ATAN(Q31/Q30) Q0=Q30 Q33=ATAN2(Q31)")
    assert card.ask("Q32 Q33") == "45\r-135"
    assert card.ask("&2 Q33") == "0"  # Q-variables belong to the coordinate system


def test_i15_switches_to_radians(card: Card) -> None:
    card.raw("I15=1 P1=SIN(0.5)")
    assert card.ask("P1").startswith("0.479425538")


# -- M-variables [spec pmac.md §2.3] -------------------------------------------------------------------
def test_m_variable_bit_fields_share_memory(card: Card) -> None:
    card.raw("M100->X:$010000,0,24,S M101->X:$010000,8,8,U M102->Y:$010000,0")
    card.raw("M100=$001234")
    assert card.ask("M101") == "18"
    card.raw("M101=255")
    assert card.ask("M100") == str(0xFF34)
    assert card.ask("RX:$010000") == "$00FF34"


def test_24_bit_wrap_example(card: Card) -> None:
    """Writing +9,388,608 to a 24-bit signed M-variable stores -7,388,608 [A L942]."""
    card.raw("M108->Y:$010001,0,24,S M108=9388608")
    assert card.ask("M108") == "-7388608"


def test_m_definition_query_and_bad_definitions(card: Card) -> None:
    card.raw("M162->D:$00008B M1->Y:$010002,8")
    assert card.ask("M162->") == "M162->D:$00008B"
    assert card.ask("M1->") == "M1->Y:$010002,8"
    assert card.raw("M2->X:$010000,20,8") == b"\x07ERR003\r"  # does not fit a word
    assert card.raw("M3->Z:$0") == b"\x07ERR003\r"


def test_p_variables_through_l_m_variables(card: Card) -> None:
    """P0 is at L:$6000 [M-vars "M11->L:$6000"]."""
    card.raw("M11->L:$6005 P5=2.5")
    assert card.ask("M11") == "2.5"
    card.raw("M11=-7.25")
    assert card.ask("P5") == "-7.25"


def test_motor_registers_through_m_variables(card: Card) -> None:
    card.raw("M162->D:$00008B M130->X:$0000B0,0,24,U")
    card.raw("#1J=100")
    card.tick(2000)
    assert card.ask("#1P") == "100"
    assert card.ask("M162") == str(100 * 96 * 32)
    w1 = int(card.ask("#1?")[:6], 16)
    assert card.ask("M130") == str(w1)


# -- addressing, status, reports ----------------------------------------------------------------------
def test_addressing_is_per_port(card: Card) -> None:
    assert card.ask("#") == "1"
    assert card.ask("#3#") == "3"
    other = PortState()
    assert card.fw.execute(other, "#").lines == ["1"]
    assert card.raw("#40") == b"\x07ERR003\r"
    assert card.ask("&2&") == "2"


def test_status_words_are_hex(card: Card) -> None:
    motor = card.ask("#1?")
    cs = card.ask("&1??")
    glob = card.ask("???")
    assert len(motor) == 12 and int(motor, 16) >> 47 & 1  # word 1 bit 23: activated
    assert len(cs) == 18 and len(glob) == 12


def test_dls_control_poll_line(card: Card) -> None:
    """dls-pmac-control polls with one line of twelve commands and splits the reply into I65,
    ???, &1??, %, then six values per motor [DLS-ctl commsThread.py]."""
    reply = card.ask("i65???&1??%#1?PVF m190 p99").split("\r")
    assert len(reply) == 10
    assert reply[0] == "0" and reply[3] == "100"
    assert len(reply[1]) == 12 and len(reply[2]) == 18 and len(reply[4]) == 12


def test_jog_to_and_position_report(card: Card) -> None:
    card.raw("#2J=1000")
    card.tick(3000)
    assert card.ask("#2P") == "1000"
    assert card.ask("#2F") == "0"


# -- memory words ------------------------------------------------------------------------------------
def test_write_and_read_memory_words(card: Card) -> None:
    card.raw("WY:$010010,$123456,7")
    assert card.ask("RY:$010010,2") == "$123456\r$000007"
    assert card.raw("RX:$900000") == b"\x07ERR003\r"


# -- control characters [digest §2.4] ----------------------------------------------------------------
def test_control_characters(card: Card) -> None:
    assert card.fw.control(card.port, 0x10) == " ".join(["0"] * 8)  # ^P
    assert len(card.fw.control(card.port, 0x02).split()) == 8       # ^B
    card.raw("I63=1")
    assert card.fw.control(card.port, 0x18) == "\x18"               # ^X echoed with I63=1


# -- not yet (README "Not yet") -----------------------------------------------------------------------
@pytest.mark.parametrize(("line", "error"), [
    ("OPEN PROG 0", b"ERR003"), ("&1B1R", b"ERR015"), ("MS0,I910", b"ERR008"),
    ("LIST PLCC 1", b"ERR003"),
    ("LEARN", b"ERR005"), ("#1J+^100", b"ERR003"), ("^5", b"ERR003"),
])
def test_later_issue_commands_answer_an_error(card: Card, line: str, error: bytes) -> None:
    assert card.raw(line) == b"\x07" + error + b"\r"
    assert card.ask("VER") == "1.940"


# -- process locks [A L3264] ----------------------------------------------------------------------------
def test_lock_and_unlock(card: Card) -> None:
    card.raw("LOCK0,P1 LOCK0,P2")
    assert card.ask("P1 P2") == "0\r1"
    card.raw("UNLOCK0 LOCK0,P3")
    assert card.ask("P3") == "0"


# -- reset ------------------------------------------------------------------------------------------
def test_save_then_power_on_reset_and_factory_reset(card: Card) -> None:
    card.raw("I130=1234 P7=7 M5->Y:$010000,0,8")
    card.raw("SAVE")
    card.raw("I130=1 P7=0")
    card.raw("$$$")
    card.raw("I3=2")  # I3 was not saved: $$$ brought back the factory 1
    assert card.ask("I130 P7 M5->") == "1234\r7\rM5->Y:$010000,0,8,U"
    card.raw("$$$***")
    card.raw("I3=2")
    assert card.ask("I130 P7") == "2000\r0"
    card.raw("$$$")  # the saved image is untouched by $$$***
    card.raw("I3=2")
    assert card.ask("I130") == "1234"


def test_cs_block_time_base_is_the_feed_rate(card: Card) -> None:
    """X:$002000 holds the host-commanded time base, I10·%/100 [M-vars; digest §2.8]."""
    card.raw("M5197->X:$002000,0,24 &1%50")
    assert card.ask("M5197") == str(round(3713707 / 2))
    card.raw("M5197=3713707")
    assert card.ask("&1%") == "100"
    assert card.ask("&2%") == "100"


def test_v1937_v1938_additions_without_programs(card: Card) -> None:
    """MOVETIME reports 0 with no move running; UNDEFINE and SETPHASE are accepted [A L3262-3284]."""
    assert card.ask("MOVETIME") == "0"
    assert card.raw("UNDEFINE ALL &2 UNDEFINE #1 SETPHASE") == b"\x06"


def test_comp_table_moves_its_target_motor_when_i51_is_set() -> None:
    """A 1x1 table on motor 1 driven by motor 2: the correction (1/16 count entries) moves motor
    1's loop by that much; P keeps the commanded frame; Mxx69 shows it [A L3118-3219]. The
    servo plant: an ideal plant follows its command whatever the loop sees."""
    card = Card(plant="servo")
    card.raw("I3=2")
    card.raw("#1 DEFINE COMP 1.1,#2,#2,#1,1000,1000")
    card.raw("1600 1600 1600")  # E1 E2 E3 of the 2x2 grid (E0 = 0): 100 counts at the far corner
    card.raw("#2J=500 #1J/")
    card.tick(2000)
    base = int(card.ask("RX:$078001")[1:], 16)  # motor 1's encoder counter
    card.raw("M169->D:$000090 I51=1")
    card.tick(500)
    moved = int(card.ask("RX:$078001")[1:], 16) - base
    correction = int(card.ask("M169")) / (96 * 32)
    assert moved == round(correction) and 30 < moved < 100  # bilinear between 0 and 100
    assert abs(float(card.ask("#1P"))) <= 1
    card.raw("I51=0")
    card.tick(500)
    assert int(card.ask("RX:$078001")[1:], 16) == base


def test_motors_above_the_card_count_are_deactivated() -> None:
    """A 4-motor card: #5 exists in the firmware (32 motors) but is not processed: commands are
    ignored, reports read 0, its status words 0 [digest §2.6 word 1 bit 23]."""
    c = Card(motors=4)
    c.raw("I3=2")
    assert c.ask("#5J+ #5P #5V #5F #5?") == "0\r0\r0\r000000000000"
    assert c.ask("I500 I400") == "0\r1"


def test_ixx03_closes_the_loop_on_an_mldt_conversion_table_entry() -> None:
    """MLDT feedback [A L336-365, L301-335]: a direct MLDT entry ($378000, $013000, max change)
    puts the timer into X:$3503 and I103 points the motor there. A jump of the magnet reading
    (the base distance moved 10 mm) is a position change the loop corrects: the motor moves back
    by the same count while P returns to the commanded 0."""
    card = Card(plant="servo")
    card.raw("I3=2")
    card.fw.servo_ic.set_mldt_base(0, 100.0)
    card.raw("I7010=12 I7016=3 M107->Y:$078004,8,16,S M107=11")
    card.raw("I8000=$378000 I8001=$013000 I8002=100000 #1J/")
    card.tick(200)
    card.raw("I103=$3503")
    card.tick(200)
    assert abs(float(card.ask("#1P"))) <= 1
    counter = int(card.ask("RX:$078001")[1:], 16)
    card.fw.servo_ic.set_mldt_base(0, 110.0)  # 10 mm = 413 timer counts
    jump = round(10.0 * 0.35e-6 * 117.96e6)
    card.tick(3000)
    moved = (int(card.ask("RX:$078001")[1:], 16) - counter + (1 << 23)) % (1 << 24) - (1 << 23)
    assert abs(moved + jump) <= 2
    assert abs(float(card.ask("#1P"))) <= 1


def test_jog_to_position_saturates_at_768m_over_ixx08_counts_per_second(card: Card) -> None:
    """V1.938: jog-to-position velocity saturates at 768M/Ixx08 counts/s [A L3286]; an
    indefinite jog (J+) runs at Ixx22 as set."""
    card.raw("I122=100000 I119=1000 I120=1 I121=0 #1J=100000000")
    card.tick(700)  # 300 ms
    per_cycle = 768e6 / 96 * PERIOD_NS * 1e-9  # 8000 counts/ms x 0.44271 ms
    assert abs(float(card.ask("#1V")) - per_cycle) < 0.2
    card.raw("I222=100000 I219=1000 I220=1 I221=0 #2J+")
    card.tick(700)
    assert float(card.ask("#2V")) > 2 * per_cycle


def test_axis_definition_query_answers_none_yet(card: Card) -> None:
    """EPICS pmac asks `&1#1->` for each motor's axis [EPICS-HW]; with no axis definitions
    (a later issue) the card answers 0."""
    assert card.ask("&1#1->") == "0"
    assert card.ask("#2-> #3->#") == "0\r0\r3"
