"""Servo axes (PSM): the PID in DAC counts, open loop and KO, polarity, axis types and encoders
[S §2.9 "Connect and configure the motor/amplifier", §2.13 "Manual tuning", §2.14; spec oms.md
§4.3 "Servo (PSM) and position maintenance", §4.4, §5.3].

The card here has four servo axes (X..T, the card's default types) on the simulated motor of
vdevd/devices/oms/servo.py, updating at 1024 Hz unless told.
"""

from __future__ import annotations

import pytest
from vdevmaps.oms import Shm

from tests.devices.oms.conftest import Maxk, maxk_card

HZ = 1024  # the factory update rate [S §2.13]
DAC_W = Shm.WK_DAC
DAC_K = Shm.WK_DAC + 4
FULL_SCALE = 32767  # ±10 V [S §1.1]


def seconds(maxk: Maxk, s: float) -> None:
    maxk.step(round(s * HZ))


def positions(maxk: Maxk, axis: int = 0) -> tuple[int, int]:
    """(motor, encoder) of an axis X..S from the words the card updates every cycle."""
    return maxk.word(Shm.MOTOR_POSITION + 4 * axis), maxk.word(Shm.ENCODER_POSITION + 4 * axis)


def following_error(maxk: Maxk) -> int:
    motor, encoder = positions(maxk)
    return motor - encoder


# -- the factory gains close the loop [S §2.14 "KP 10, KD 160, KI 1.00"; spec §5.3] -----------------
@pytest.mark.parametrize("update_hz", [1024, 2048, 4096, 8192])
def test_factory_gains_settle_a_move_at_every_update_rate(update_hz: int) -> None:
    with maxk_card(update_hz=update_hz) as maxk:
        maxk.send("AX MR6000; GO;")
        maxk.step(update_hz // 2)
        assert maxk.query("RP;") == "6000"
        assert maxk.query("RE;") == "6000"
        assert abs(maxk.word(Shm.DAC)) <= 20  # at rest the loop holds with next to no output
        maxk.step(update_hz)
        assert positions(maxk) == (6000, 6000)  # and stays there


def test_position_check_of_section_2_13_reads_re_equal_to_rp(maxk: Maxk) -> None:
    """[S §2.13]: "AC100000;VL5000;MR64000;GO;" (8 revolutions of a 2000-line encoder), then RE
    and RP: "If they are the same then you are on the right track"."""
    maxk.send("AX AC100000;VL5000;MR64000;GO;")
    seconds(maxk, 64000 / 5000 + 5000 / 100000 + 0.5)
    assert maxk.query("RP;") == "64000"
    assert maxk.query("RE;") == "64000"


def test_following_error_at_the_flat_spot_is_what_kp_leaves(maxk: Maxk) -> None:
    """[S §2.13]: KP sets the following error at peak velocity; a larger KP leaves less."""
    maxk.send("AX AC100000;VL5000;MR64000;GO;")
    seconds(maxk, 5.0)
    error_kp10 = following_error(maxk)
    maxk.send("KP40;")
    seconds(maxk, 0.5)
    error_kp40 = following_error(maxk)
    assert error_kp10 > 10
    assert error_kp40 == pytest.approx(error_kp10 / 4, abs=2)


@pytest.mark.parametrize("gains", ["KP1;", "KD0; KI0; KP1;"])
def test_manual_tuning_example_moves_6000_counts(maxk: Maxk, gains: str) -> None:
    """[S §2.13]: "LP0; KP1; CL1; MR6000; GO;" with the factory KD and KI, and as the text
    starts it: "Set the KD and KI variables to 0, and the KP variable to 1"."""
    maxk.send(f"AX LP0; {gains} CL1; MR6000; GO;")
    seconds(maxk, 4.0)
    assert maxk.query("RP;") == "6000"
    assert abs(int(maxk.query("RE;")) - 6000) <= 1


def test_appendix_c_example_1_gains_home_and_move() -> None:
    """[S App C] example 1 with its gains: "AX; VL5000; AC50000; KP20; KI1; KD45; CL1; HM0;
    MA10000; GO; ID;" (the home switch is found at once, it is active)."""
    with maxk_card() as maxk:
        maxk.control("set_home", axis="X", active=True)
        maxk.send("AX; VL5000; AC50000; KP20; KI1; KD45; CL1; HM0; MA10000; GO; ID;")
        seconds(maxk, 10000 / 5000 + 5000 / 50000 + 1.0)
        assert maxk.query("QA;")[1] == "D"
        assert maxk.query("RP;") == "10000"
        assert abs(int(maxk.query("RE;")) - 10000) <= 1


# -- KO: the DAC offset, and the open loop [S §2.9 steps 3-5, §2.13] -------------------------------
def test_ko_on_an_open_loop_servo_turns_the_motor(maxk: Maxk) -> None:
    """[S §2.13] "While still in open-loop mode (CL0;) use the KO command to zero the motor":
    open loop, the output is KO alone; KO2000 runs the motor forward, KO0 lets it stop."""
    maxk.send("AX CL0; LP0; KO2000;")
    seconds(maxk, 0.5)
    assert maxk.word(Shm.DAC) == 2000
    first = int(maxk.query("RE;"))
    seconds(maxk, 0.5)
    second = int(maxk.query("RE;"))
    assert 0 < first < second
    assert abs(int(maxk.query("RP;")) - second) <= 1  # open loop: the command follows the motor
    maxk.send("KO0;")
    seconds(maxk, 0.2)
    assert maxk.word(Shm.DAC) == 0
    rest = int(maxk.query("RE;"))
    seconds(maxk, 0.5)
    assert int(maxk.query("RE;")) == rest


def test_ko3277_puts_about_one_volt_on_the_dac(maxk: Maxk) -> None:
    """[S §2.9 step 4c]: "Send the KO3277; command ... The output of MAXk will be near 1VDC"."""
    maxk.send("AX CL0; KO3277;")
    maxk.step(1)
    assert maxk.word(Shm.DAC) == 3277
    assert maxk.control("get_outputs")["dac_volts"][0] == pytest.approx(1.0, abs=0.001)
    maxk.send("KO-3277;")
    maxk.step(1)
    assert maxk.word(Shm.DAC) == -3277


def test_open_loop_output_is_ko_whatever_the_position_error(maxk: Maxk) -> None:
    """CL0: no PID, however far the motor is from its last command [spec §5.3]."""
    maxk.send("AX CL0; KO500; KP100; KD0;")
    seconds(maxk, 1.0)
    assert maxk.word(Shm.DAC) == 500


def test_cl1_closes_the_loop_where_the_motor_is(maxk: Maxk) -> None:
    """After running open loop, CL1 holds the present position (no jump back) [S §2.13]."""
    maxk.send("AX CL0; LP0; KO2000;")
    seconds(maxk, 0.5)
    maxk.send("KO0; CL1;")
    seconds(maxk, 0.5)
    held = positions(maxk)
    assert held[0] > 5000
    assert abs(held[0] - held[1]) <= 1
    seconds(maxk, 0.5)
    assert positions(maxk) == held


def test_closed_loop_ko_is_an_offset_kp_holds_against_and_ki_ku_remove(maxk: Maxk) -> None:
    """CL1: KO is "a constant output that will compensate for torque offset" [S §2.13]. Without
    an integral the loop settles where KP·e cancels it; KI integrates the error away, but only
    as far as KU lets it ("The KU variable limits the amount the KI term can contribute")."""
    maxk.send("AX KO200;")
    seconds(maxk, 1.0)
    assert following_error(maxk) == -20  # KP 10 · 20 counts = 200; KU 0: no integral term
    maxk.send("KI1; KU100;")
    seconds(maxk, 2.0)
    assert following_error(maxk) == -10  # the integral gives 100 of the 200
    maxk.send("KU400;")
    seconds(maxk, 2.0)
    assert abs(following_error(maxk)) <= 1


def test_kv_velocity_feed_forward_removes_the_following_error_at_speed(maxk: Maxk) -> None:
    """[S §2.13] KV "is a gain applied to the current velocity"; here KV·v·T (spec §5.3)."""
    maxk.send("AX JG5000;")
    seconds(maxk, 1.0)
    without = following_error(maxk)
    maxk.send("KV84;")  # the motor's need: 200/s · 5000 counts/s / 2441 per count · 1024
    seconds(maxk, 1.0)
    assert without > 30
    assert abs(following_error(maxk)) <= 2


def test_ka_acceleration_feed_forward_removes_the_error_while_accelerating(maxk: Maxk) -> None:
    """[S §2.13] KA "compensates for inertia ... applied as a gain to the current acceleration";
    here KA·a·T² (spec §5.3). KV takes care of the velocity's share."""
    def error_while_accelerating(ka: int) -> int:
        maxk.send(f"AX KV84; KA{ka}; AC200000; VL200000; MR200000; GO;")
        seconds(maxk, 0.4)  # ramping up for 1 s
        error = following_error(maxk)
        maxk.send("ST;")
        seconds(maxk, 1.0)
        return error

    without = error_while_accelerating(0)
    assert without >= 6  # KP 10 gives the 82 DAC counts the acceleration needs
    assert abs(error_while_accelerating(430)) <= 2


def test_kf_friction_offset_acts_in_the_direction_of_motion(maxk: Maxk) -> None:
    """[S §2.13] KF "compensates for static friction ... applied to all commanded moves": at
    speed it takes over KF of the output the error had to give (KF/KP counts)."""
    maxk.send("AX VL5000; MR10000; GO;")
    seconds(maxk, 1.0)
    forward = following_error(maxk)
    maxk.send("KF300;")
    seconds(maxk, 0.5)
    assert following_error(maxk) == pytest.approx(forward - 30, abs=2)
    seconds(maxk, 1.0)
    assert positions(maxk) == (10000, 10000)
    assert abs(maxk.word(Shm.DAC)) <= 20  # at rest KF does nothing
    maxk.send("MR-10000; GO;")
    seconds(maxk, 1.0)
    assert following_error(maxk) == pytest.approx(-(forward - 30), abs=2)


def test_svp_minus_inverts_the_output_ko_included(maxk: Maxk) -> None:
    """[S §2.9 step 5]: "Use SVP-/SVP+ to invert/normalize PID analog output (inverts values of
    KO ...)": "LP0; KO2000;" then RE reads negative."""
    maxk.send("AX CL0; SVP-; LP0; KO2000;")
    seconds(maxk, 0.5)
    assert maxk.word(Shm.DAC) == -2000
    assert int(maxk.query("RE;")) < 0
    maxk.send("SVP+;")
    maxk.step(1)
    assert maxk.word(Shm.DAC) == 2000


def test_edi_inverts_the_encoder_direction(maxk: Maxk) -> None:
    """[S §2.9 step 5]: "LP0; KO2000;" and "RE;": positive; EDI inverts the encoder, EDN
    makes it normal again."""
    maxk.send("AX CL0; LP0; KO2000;")
    seconds(maxk, 0.5)
    maxk.send("KO0;")
    seconds(maxk, 0.2)
    counts = int(maxk.query("RE;"))
    assert counts > 0
    assert maxk.query("EDI; RE;") == str(-counts)
    maxk.step(1)
    assert maxk.word(Shm.ENCODER_POSITION) == -counts
    assert maxk.query("EDN; RE;") == str(counts)


# -- the DAC words [spec §2.2, §5.3] -----------------------------------------------------------------
def test_dac_words_of_every_axis_show_its_output() -> None:
    """X..S at 0x2E80 + 4·axis, W and K at 0x2EC8 and 0x2ECC, in DAC counts."""
    with maxk_card(axes=10, axis_types=["servo"] * 10) as maxk:
        for a, letter in enumerate("XYZTUVRSWK"):
            maxk.send(f"A{letter} CL0; KO{100 * (a + 1)};")
        maxk.step(1)
        assert [maxk.word(Shm.DAC + 4 * a) for a in range(8)] == [100 * (a + 1) for a in range(8)]
        assert (maxk.word(DAC_W), maxk.word(DAC_K)) == (900, 1000)


def test_output_is_clamped_to_the_dac_range(maxk: Maxk) -> None:
    """±32767 is ±10 V; the PID cannot ask for more (spec §5.3)."""
    maxk.send("AX KP32767; LP0; MR100000; GO;")
    maxk.step(5)
    assert maxk.word(Shm.DAC) == FULL_SCALE


# -- gains: queries and ranges [S §2.13; spec §4.2, §4.4] ------------------------------------------
def test_factory_gains_read_back(maxk: Maxk) -> None:
    """[S §2.14]: "KP 10, KD 160, KI 1.00, KO 0, KV 0, KA 0"; KP? replies `=`, ?KP (the older
    form EPICS sends) without."""
    replies = {g: maxk.query(f"AX {g}?;") for g in ("KP", "KD", "KI", "KO", "KV", "KA")}
    assert replies == {"KP": "=10.00", "KD": "=160.00", "KI": "=1.00", "KO": "=0.00",
                       "KV": "=0.00", "KA": "=0.00"}
    assert maxk.query("?KD;") == "160.00"


def test_gains_per_axis_in_aa_mode(maxk: Maxk) -> None:
    maxk.send("AA KP20,,30.5;")
    assert maxk.query("AA ?KP;") == "20.00,10.00,30.50,10.00"


@pytest.mark.parametrize("text", ["KP-1", "KP32767.5", "KI40000", "KD-0.01", "KU32768",
                                  "KV99999", "KA-1", "KF32768", "KO32768", "KO-32768", "KP",
                                  "KPx"])
def test_gain_out_of_range_is_a_command_error_and_changes_nothing(maxk: Maxk, text: str) -> None:
    """spec §4.4: KP..KF outside 0..32767, KO outside ±32767."""
    name = text[:2]
    before = maxk.query(f"AX ?{name};")
    maxk.send(f"{text};")
    assert maxk.command_error()
    assert maxk.query(f"?{name};") == before


@pytest.mark.parametrize("query", ["?KP", "?KA", "KP?", "KD?"])
def test_gain_query_on_a_stepper_axis_is_a_command_error(query: str) -> None:
    """[E-drvMAXv]: EPICS sends ?KA/?KP to find out whether an axis is a servo (spec §4.4)."""
    with maxk_card(axis_types=["servo", "stepper", "stepper_encoder", "servo"]) as maxk:
        for letter in "YZ":
            maxk.send(f"A{letter} {query};")
            assert maxk.command_error()
            assert maxk.reply() is None
        assert maxk.query(f"AT {query};").endswith("0.00")


# -- axis types at run time [S §2.9 step 3a, §4.1; spec §4.2-4.3] -----------------------------------
def test_ps_switches_the_axis_type_and_ps_query_reports_it(maxk: Maxk) -> None:
    assert maxk.query("AX PS?;") == "=M"
    assert maxk.query("PSO; PS?;") == "=O"
    assert maxk.query("PSE; PS?;") == "=E"
    assert maxk.query("PSM; PS?;") == "=M"
    assert maxk.query("?PS;") == "M"


def test_ps_per_axis_in_aa_mode(maxk: Maxk) -> None:
    maxk.send("AA PSO,E,,O;")
    assert maxk.query("AA PS?;") == "=O,=E,=M,=O"


def test_ps_with_an_unknown_type_is_a_command_error(maxk: Maxk) -> None:
    maxk.send("AX PSQ;")
    assert maxk.command_error()
    assert maxk.query("PS?;") == "=M"


def test_psm_makes_a_stepper_a_servo_with_its_loop_open() -> None:
    """[S §2.9 step 3]: "Configure the axis as a servo axis by sending the PSM command", then
    balance it with KO in open loop; CL1 closes the loop."""
    with maxk_card(axis_types=["stepper"] * 4) as maxk:
        assert maxk.query("AY PS?;") == "=O"
        assert maxk.query("PSM; CL?;") == "off"
        maxk.send("LP0; KO3277;")
        seconds(maxk, 0.2)
        assert maxk.word(Shm.DAC + 4) == 3277
        assert int(maxk.query("RE;")) > 0
        maxk.send("KO0; CL1;")
        seconds(maxk, 0.5)
        held = positions(maxk, 1)
        maxk.send("MR5000; GO;")
        seconds(maxk, 1.0)
        assert positions(maxk, 1) == (held[0] + 5000, held[0] + 5000)


def test_pso_axis_steps_and_has_no_dac_output(maxk: Maxk) -> None:
    maxk.send("AX PSO; MR1000; GO;")
    seconds(maxk, 0.5)
    assert maxk.query("RP;") == "1000"
    assert maxk.word(Shm.DAC) == 0


def test_ea_on_an_open_loop_stepper_is_a_command_error(maxk: Maxk) -> None:
    """[E-drvMAXv]; spec §4.4: EA needs an encoder."""
    maxk.send("AX PSO; EA;")
    assert maxk.command_error()
    assert maxk.reply() is None
    assert len(maxk.query("PSE; EA;")) == 5
    assert len(maxk.query("PSM; EA;")) == 5


def test_cl_query_hn_hf(maxk: Maxk) -> None:
    """CL1/CL0 and the older HN/HF [S §2.13]; CL? replies on/off [A-base]."""
    assert maxk.query("AX CL?;") == "on"
    assert maxk.query("CL0; CL?;") == "off"
    assert maxk.query("HN; CL?;") == "on"
    assert maxk.query("HF; CL?;") == "off"
    assert maxk.query("AA CL0,0,0,0; CL1,,1; CL?;") == "on,off,on,off"
    maxk.send("AX CL2;")
    assert maxk.command_error()


# -- the encoder ratio on PSE axes [spec §4.3 ER, §4.4] ---------------------------------------------
def test_er_is_refused_on_axes_that_are_not_pse(maxk: Maxk) -> None:
    maxk.send("AX ER4,1;")
    assert maxk.command_error()
    maxk.send("PSO; ER4,1;")
    assert maxk.command_error()


def test_er_makes_distances_encoder_counts_on_a_pse_axis() -> None:
    """ER a,b: a encoder counts per b motor steps; "results in all distance, velocity and
    acceleration parameters being input in encoder counts" [E-README]."""
    with maxk_card(axis_types=["stepper_encoder"] * 4) as maxk:
        maxk.send("AX ER4,1; MR1000; GO;")
        seconds(maxk, 0.5)
        assert positions(maxk) == (250, 1000)  # 250 steps made 1000 encoder counts
        assert maxk.query("RP;") == "1000"
        assert maxk.query("RE;") == "1000"
        maxk.send("ER0,1;")
        assert maxk.command_error()
