"""The addendum's I/O, position-compare and conversion-table examples, typed as on-line commands
with the M-variable definitions the addendum prints, against a real daemon (lockstep clock). The
backdoor plays the world: `set_input`/`get_outputs` on the JIO lines, `set_analog` on JANA,
`set_home` on the home flag; motion comes from jogs (plant `ideal`: actual = commanded).

Sources: [A Lnnn] = line of the seed addendum; §x = spec pmac.md.
"""

from __future__ import annotations

from collections.abc import Iterator

import pytest

from tests.devices.pmac.conftest import Pmac, pmac_card

ACK = "\x06"

# JIO suggested M-variables [A L504-539]: data, byte direction, buffer direction
JIO_DEFINITIONS = (
    "M0->Y:$078400,0 M1->Y:$078400,1 M3->Y:$078400,3 M8->Y:$078400,8 M23->Y:$078400,23 "
    "M24->Y:$078401,0 M30->Y:$078401,6 M31->Y:$078401,7 "
    "M32->X:$078400,0,8 M34->X:$078400,8,8 M36->X:$078400,16,8 M38->X:$078401,0,8 "
    "M33->Y:$070800,0 M35->Y:$070800,1 M37->Y:$070800,2 M39->Y:$070800,3"
)
# JTHW suggested M-variables [A L581-609]
JTHW_DEFINITIONS = (
    "M40->Y:$078402,8 M47->Y:$078402,15 M48->Y:$078402,8,8,U M50->Y:$078402,0 "
    "M57->Y:$078402,7 M58->Y:$078402,0,8,U M60->X:$078402,0,8 M62->X:$078402,8,8 "
    "M61->Y:$070800,4 M63->Y:$070800,5"
)
# PMAC2 compare registers of Servo IC 0 channel 1 as the addendum lists them [A L790-800]; the
# counter in X (the digest's CONFLICT resolution, §1.5: [A L792] prints Y:$078001)
COMPARE_DEFINITIONS = (
    "M101->X:$078001,0,24,S M108->Y:$078007,0,24,S M109->X:$078007,0,24,S "
    "M110->X:$078006,0,24,S M111->X:$078005,11 M112->X:$078005,12 M113->X:$078000,9"
)


class Online:
    """On-line commands over one dls-pmaclib connection: the data lines of an ACK-ed reply."""

    def __init__(self, pmac: Pmac) -> None:
        self.pmac = pmac
        self.dls = pmac.dls()

    def __call__(self, line: str) -> list[str]:
        reply, ok = self.dls.sendCommand(line)
        assert ok and reply.endswith(ACK), (line, reply)
        return reply[:-1].split("\r")[:-1]

    def define(self, definitions: str) -> None:
        """M-variable definitions in lines under dls-pmaclib's 255 characters (one length byte)."""
        chunk: list[str] = []
        for word in definitions.split():
            if sum(len(w) + 1 for w in chunk) + len(word) > 200:
                self(" ".join(chunk))
                chunk = []
            chunk.append(word)
        self(" ".join(chunk))

    def num(self, line: str) -> float:
        (value,) = self(line)
        return float(value)

    def jog_to(self, motor: int, position: int, ms: float = 600) -> None:
        self(f"#{motor}J={position}")
        self.pmac.step_ms(ms)
        assert self.num(f"#{motor}P") == position


@pytest.fixture
def io(pmac: Pmac) -> Iterator[Online]:
    yield Online(pmac)


# -- JIO [A L487-562] --------------------------------------------------------------------------------
def test_jio_power_up_all_inputs_pulled_high_non_inverting(io: Online) -> None:
    """'I/O00 to I/O31 are set up as inputs (M32 through M39 = 0)' [A L543]; an undriven line is
    biased high by its pull-up [A L493-495]; all non-inverting [A L556]."""
    io.define(JIO_DEFINITIONS)
    assert io("M32 M34 M36 M38 M33 M35 M37 M39") == ["0"] * 8
    assert io("M0 M3 M23 M24 M31") == ["1"] * 5
    assert io("RX:$078404 RX:$078405") == ["$000000", "$000000"]
    assert io.pmac.control("get_outputs") == 0xFFFFFFFF


def test_jio_input_reads_the_line_and_x_078404_inverts_it(io: Online) -> None:
    """Input data follow the line; an inversion bit of X:$078404 makes 0 = +5 V [A L545-556]."""
    io.define(JIO_DEFINITIONS)
    io.pmac.control("set_input", line=3, level=False)
    assert io("M3 M1") == ["0", "1"]
    io("WX:$078404,8")  # bit 3: I/O03 inverting
    assert io("M3 M1") == ["1", "1"]
    io.pmac.control("set_input", line=3, level=True)
    assert io("M3") == ["0"]


def test_jio_output_byte_needs_the_asic_and_the_buffer_direction(io: Online) -> None:
    """'These control lines and bits must match the ASIC direction bits' [A L532-539]: M32=255
    alone leaves the buffer an input (the pull-up holds the line high); with M33=1 the latch drives
    I/O00-07 and I/O08 stays an input."""
    io.define(JIO_DEFINITIONS)
    io("M32=255 M0=0 M1=0")
    assert io.pmac.control("get_outputs") & 0x3 == 0x3
    io("M33=1")
    assert io.pmac.control("get_outputs") & 0x103 == 0x100
    io("M0=1")
    assert io.pmac.control("get_outputs") & 0x3 == 0x1
    assert io("M0 M1") == ["1", "0"]  # an output reads back its latch


def test_jio_inverting_output_drives_zero_volts_for_one(io: Online) -> None:
    """'inverting I/O point (0=+5V; 1=0V)' [A L547]."""
    io.define(JIO_DEFINITIONS)
    io("M32=255 M33=1 WX:$078404,1 M0=1 M1=1")
    assert io.pmac.control("get_outputs") & 0x3 == 0x2


def test_jio_top_byte_is_y_078401_and_its_direction_x_078401(io: Online) -> None:
    """I/O24-31 are Y:$078401 bits 0-7; 'the direction control bit for I/O30 is located at
    X:$078401,6' [A L504-526]; the buffer bit is Y:$070800 bit 3 (M39)."""
    io.define(JIO_DEFINITIONS + " M70->X:$078401,6")
    io("M38=255 M39=1 M31=0 M30=1 M24=0")
    assert io("M70") == ["1"]
    outputs = io.pmac.control("get_outputs")
    assert (outputs >> 24) & 0xC1 == 0x40
    assert outputs & 0xFFFFFF == 0xFFFFFF  # the three low bytes are still inputs


# -- JTHW [A L564-637] -------------------------------------------------------------------------------
def test_jthw_power_up_dat_inputs_sel_outputs_at_zero(io: Online) -> None:
    """'DAT0 to DAT7 are set up as non-inverting inputs; SEL0 to SEL7 ... as non-inverting outputs
    with a zero (low voltage) value' [A L593]; the PC-bus buffer bits are Y:$070800 bits 4-5."""
    io.define(JTHW_DEFINITIONS)
    assert io("M60 M62 M61 M63") == ["0", "255", "0", "1"]
    assert io("M48 M58") == ["0", "255"]
    io("M40=1 M47=1")
    assert io("M48 M40 M47") == ["129", "1", "1"]


# -- JANA [A L639-675] -------------------------------------------------------------------------------
def test_jana_pair_register_low_12_bits_anai00_07_high_12_bits_anai08_15(io: Online) -> None:
    """Writing Y:$078800 selects and starts: 0-7 unipolar 0..+5 V, 8-15 the same channel bipolar
    -2.5..+2.5 V; low 12 bits ANAI00-07, high 12 bits ANAI08-15 [A L649-655]."""
    io("M990->Y:$078800,0,24 M991->Y:$078800,0,12,U M992->Y:$078800,12,12,U "
       "M993->Y:$078800,0,12,S M994->Y:$078800,12,12,S")
    io.pmac.control("set_analog", channel=3, volts=2.5)
    io.pmac.control("set_analog", channel=11, volts=1.25)
    io("M990=$003003")  # ANAI03 and ANAI11, unipolar
    assert io("M991 M992") == ["2048", "1024"]
    io.pmac.control("set_analog", channel=3, volts=-1.25)
    io("M990=$00B00B")  # the same channels, bipolar
    assert io("M993 M994") == ["-1024", "1024"]


def test_jana_conversion_saturates_at_the_range_ends(io: Online) -> None:
    io("M990->Y:$078800,0,24 M991->Y:$078800,0,12,U M993->Y:$078800,0,12,S")
    io.pmac.control("set_analog", channel=0, volts=6.0)
    io("M990=0")
    assert io("M991") == ["4095"]
    io.pmac.control("set_analog", channel=0, volts=-3.0)
    io("M990=8")
    assert io("M993") == ["-2048"]


def test_demultiplexing_ring_results_in_y_003400_bits_12_to_23(io: Online) -> None:
    """I5060 pairs, I5061+ addresses (0 still means $078800 [A L3249]), I5081+ = $00m00n with
    m = ANAI#-8 unipolar / ANAI# bipolar (high converter), n = ANAI# unipolar / ANAI#+8 bipolar
    (low); low converter to the even address, high to the odd one [A L657-675]."""
    pmac = io.pmac
    for channel, volts in ((3, 1.25), (10, 2.5), (5, -0.625), (13, 0.625)):
        pmac.control("set_analog", channel=channel, volts=volts)
    io("M5061->Y:$003400,12,12,U M5062->Y:$003401,12,12,U "
       "M5063->Y:$003402,12,12,S M5064->Y:$003403,12,12,S")
    io("I5060=2 I5061=$078800 I5062=0 I5081=$002003 I5082=$00D00D I5080=1")
    pmac.step(4)
    assert io("M5061 M5062 M5063 M5064") == ["1024", "2048", "-512", "512"]


def test_i5080_zero_disables_demultiplexing(io: Online) -> None:
    """'I5080=0 disables A/D de-multiplexing' (V1.937) [A L3257]."""
    pmac = io.pmac
    io("M5061->Y:$003400,12,12,U I5060=1 I5061=$078800 I5081=$000001 I5080=1")
    pmac.control("set_analog", channel=1, volts=2.5)
    pmac.step(2)
    assert io("M5061") == ["2048"]
    io("I5080=0")
    pmac.control("set_analog", channel=1, volts=1.25)
    pmac.step(4)
    assert io("M5061") == ["2048"]


# -- position compare, PMAC2-style Servo IC [A L750-894] -------------------------------------------
def test_single_pulse_example_output_on_between_1000_and_1010(io: Online) -> None:
    """'With the axis sitting still at about encoder position 100, and a 1 value of position compare
    desired between encoder positions 1000 and 1010' [A L805-829]; the output toggles when the
    counter leaves equality [A L766]; the write enable clears itself [A L786]."""
    io.define(COMPARE_DEFINITIONS)
    io.jog_to(1, 100)
    io("M108=1000 M109=1010 M110=0 M112=0 M111=1")
    assert io("M111 M113 M101") == ["0", "0", "100"]
    io.jog_to(1, 1005)
    assert io("M113") == ["1"]
    io.jog_to(1, 1020)
    assert io("M113") == ["0"]
    io.jog_to(1, 1005)  # back through 1010: leaving B downwards toggles again
    assert io("M113") == ["1"]


def test_multiple_pulse_example_auto_increment_2000(io: Online) -> None:
    """M110=2000 M108=1000 M109=1010-M110: on between 1000 and 1010, 3000 and 3010, ...; each
    register moves the other by the auto-increment in the direction of motion [A L831-851, L768]."""
    io.define(COMPARE_DEFINITIONS)
    io.jog_to(1, 100)
    io("M110=2000 M108=1000 M109=1010-M110 M112=0 M111=1")
    assert io("M109") == ["-990"]
    io.jog_to(1, 1005)
    assert io("M113 M109") == ["1", "1010"]
    io.jog_to(1, 1015)
    assert io("M113 M108") == ["0", "3000"]
    io.jog_to(1, 3005, ms=800)
    assert io("M113 M109") == ["1", "3010"]
    io.jog_to(1, 3015)
    assert io("M113") == ["0"]


def test_extended_count_example_edges_at_fractional_counts(io: Online) -> None:
    """Extended-count mode (I7mn9=1): write n-1 to the integer register and the fraction in 1/4096
    count: 'to get a compare edge at 743.25 counts ... write 742 ... and 1024' [A L853-894],
    using the addendum's own program lines."""
    io.define(COMPARE_DEFINITIONS + " M188->Y:$078000,0,12,U M189->Y:$078001,0,12,U")
    io("I7019=1 P108=743.25 P109=753.5 P110=2000")
    io("M110=P110 M108=INT(P108)-1 M188=(P108-(M108+1))*4096 "
       "M109=INT(P109)-1-M110 M189=(P109-(M109+1+M110))*4096 M112=0 M111=1")
    assert io("M108 M188 M109 M189") == ["742", "1024", "-1248", "2048"]
    io.jog_to(1, 743)
    assert io("M113") == ["0"]
    io.jog_to(1, 744)
    assert io("M113") == ["1"]
    io.jog_to(1, 753)
    assert io("M113") == ["1"]
    io.jog_to(1, 754)
    assert io("M113") == ["0"]


def test_compare_from_motor_coordinates_after_homing(io: Online) -> None:
    """EncoderPosition = MotorPosition + HomeCaptureOffset + Ixx26/16, with M173->Y:$0000CE,0,24,S;
    'M108=1500+M173+I126/16' triggers at motor position +1500 [A L896-914]."""
    pmac = io.pmac
    io.define(COMPARE_DEFINITIONS + " M173->Y:$0000CE,0,24,S")
    io("I7012=2 I126=1600 #1HM")  # capture on the home flag; home offset 100 counts
    pmac.step_ms(60)
    pmac.control("set_home", motor=1, active=True)
    pmac.step_ms(1500)
    pmac.control("set_home", motor=1, active=False)
    assert io("#1P") == ["0"]
    capture = int(io.num("M173"))
    assert capture > 0 and io.num("M101") == capture + 100
    io("M108=1500+M173+I126/16 M109=M108+200 M110=0 M112=0 M111=1")
    assert io.num("M108") == 1500 + capture + 100
    io.jog_to(1, 1499, ms=1000)
    assert io("M113") == ["0"]
    io.jog_to(1, 1502)
    assert io("M113") == ["1"]


def test_writing_past_the_24_bit_range_wraps_the_compare_register(io: Online) -> None:
    """'If you attempted to write a value of +9,388,608 ... the resulting value would be
    -7,388,608' [A L942]."""
    io.define(COMPARE_DEFINITIONS)
    io("M108=9388608")
    assert io("M108") == ["-7388608"]


def test_channel_select_puts_channel_2_compare_on_channel_1_output(io: Online) -> None:
    """I7mn1=1: channel 2's compare acts on channel 1's encoder, and channel 1's output is the OR
    of the compare logics assigned to it [A L774-776]. Motor 2 does not move."""
    io.define(COMPARE_DEFINITIONS + " M208->Y:$07800F,0,24,S M209->X:$07800F,0,24,S "
       "M210->X:$07800E,0,24,S M211->X:$07800D,11 M212->X:$07800D,12")
    io("I7021=1 M208=500 M209=600 M210=0 M212=0 M211=1")
    io.jog_to(1, 550)
    assert io("M113 #2P") == ["1", "0"]
    io.jog_to(1, 700)
    assert io("M113") == ["0"]


def test_compare_output_equ1_interrupts_the_host(io: Online) -> None:
    """'the compare outputs for Channel 1 and Channel 5 ... can also be used to interrupt the host'
    [A L754]: IR5 (EQU1) on the line `inta` when its mask bit is set (README, host region)."""
    pmac = io.pmac
    io.define(COMPARE_DEFINITIONS)
    io("M108=300 M109=400 M110=0 M112=0 M111=1")
    host = pmac.card.region("host")
    host.write8(9, 1 << 5)
    pmac.card.irq.last_seq = pmac.rack.stats()["cards"]["pmac0"]["irq_seq"]
    io.jog_to(1, 350)
    event = pmac.card.irq.wait(timeout_s=2.0)
    assert event is not None and event["line"] == "inta" and event["status"] & (1 << 5)
    assert host.read8(8) & (1 << 5)


def test_home_flag_capture_latches_the_counter(io: Online) -> None:
    """Hardware capture at X:b+3 on the I7mn2/I7mn3 trigger (I7mn2=2 flag, I7mn3=0 HMFL), the
    capture flag in X:b+0 bit 11 (§1.5 register table, [A L2863])."""
    io("M101->X:$078001,0,24,S M103->X:$078003,0,24,S M117->X:$078000,11 I7012=2 I7013=0")
    io.jog_to(1, 250)
    assert io("M117") == ["0"]
    io.pmac.control("set_home", motor=1, active=True)
    io.pmac.step(2)
    assert io("M117 M103") == ["1", "250"]


# -- encoder conversion table [A L2445-3116] -------------------------------------------------------
def test_default_table_converts_the_eight_encoders_in_1_32_count(io: Online) -> None:
    """Turbo PMAC2 defaults I8000-I8007 = $078000, $078008 ... $078118 (1/T of encoders 1-8), results
    in X:$003501-$003508 in 1/32 count [A L2445-2483, L2578-2582]."""
    assert io("I8000..8007") == ["$78000", "$78008", "$78010", "$78018",
                                 "$78100", "$78108", "$78110", "$78118"]
    io("M1001->X:$003501,0,24,S M1008->X:$003508,0,24,S")
    io.jog_to(1, 1000)
    io.jog_to(8, -250)
    assert io("M1001 M1008") == ["32000", "-8000"]


def test_sum_and_difference_entries_of_the_addendum(io: Online) -> None:
    """$E00100 = I8000+I8001, $E20100 = I8000-I8001, bit 16 negates the first source and bit 18
    drops the second ($E50013 inverts I8019; here $E50001 inverts I8001) [A L2953-2975]."""
    io("I8008=$E00100 I8009=$E20100 I8010=$E50001 "
       "M1009->X:$003509,0,24,S M1010->X:$00350A,0,24,S M1011->X:$00350B,0,24,S")
    io.jog_to(1, 1000)
    io.jog_to(2, 250)
    assert io("M1009 M1010 M1011") == ["40000", "24000", "-8000"]


def test_time_base_example_at_the_real_time_input_frequency_is_i10(io: Online) -> None:
    """I8008=$403504 I8009=512 (TBSF = 131072/256 for 256 cts/ms) I5193=@I8009 [A L2825-2846]: with
    encoder 4 at the real-time input frequency the result is 100 % of the time base, i.e. I10."""
    io("I8003=$078018 I8008=$403504 I8009=512 I5193=@I8009")
    assert io("I5193") == ["$350A"]
    io("M1010->X:$00350A,0,24,S I422=256 I419=10 I420=10 I421=0 #4J+")  # at speed in 25 ms
    io.pmac.step_ms(200)
    assert io.num("M1010") == pytest.approx(io.num("I10"), rel=0.01)


def test_one_over_t_entry_has_a_fraction_while_the_encoder_moves(io: Online) -> None:
    """$0: result = counter*32 + fraction, fraction = 'time since last count' / 'time between last
    two counts' [A L2578-2582]: at 10 cts/ms (4.43 counts per servo cycle) the servo samples fall
    between counts, so the 5 fraction bits cannot all stay 0."""
    io("M1001->X:$003501,0,24,S M1->Y:$078001,0,24 I122=10 I119=10 I120=10 I121=0 #1J+")
    io.pmac.step_ms(50)
    samples, since = [], []
    for _ in range(12):
        io.pmac.step(3)
        value, timer = io("M1001 M1")
        samples.append(int(value) % 32)
        since.append(int(timer))
    assert any(samples) and any(since)


def test_exponential_filter_seven_cycle_time_constant_and_max_change(io: Online) -> None:
    """$D: Out += K/2^23 (In - Out), the step limited to max change; K = 2^23/(Tf+1) = 1,048,576 for
    Tf = 7, max change 2048 = 64 counts in 1/32 count [A L2929-2951]. The source is an X word."""
    io("I8008=$D10000 I8009=1048576 I8010=2048 M1011->X:$00350B,0,24,S")
    io.pmac.step(2)
    assert io("M1011") == ["0"]
    io("WX:$010000,65536")
    io.pmac.step(1)
    assert io("M1011") == ["2048"]  # K/2^23 * 65536 = 8192, limited to 2048
    io.pmac.step(200)
    assert io.num("M1011") == pytest.approx(65536, abs=8)


def test_mldt_direct_entry_result_in_the_third_line() -> None:
    """MLDT on IC 0 channel 1 (I7010=12, PFM on C with I7016=3, Mxx07 = 11 ~ 1.667 kHz at 9.83 MHz
    [A L132-203]) read by the addendum's entry I8000=$378000 I8001=$013000 I8002=32: the result is
    in X:$003503 [A L336-365]; one count is one timer LSB (card README, MLDT)."""
    with pmac_card(plant="ideal") as pmac:
        io = Online(pmac)
        io.jog_to(1, 20)
        io("I7010=12 I7016=3 M107->Y:$078004,8,16,S M107=11 M100->Y:$078000,0,24")
        io("I8000=$378000 I8001=$013000 I8002=32 M1003->X:$003503,0,24,S")
        pmac.step_ms(10)
        assert io("M100") == ["20"]
        assert io("M1003") == [str(20 * 32)]
