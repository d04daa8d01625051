"""Unipolar servo output (card option `servo_output`) [S §4.6 "The servo output may be either
unipolar analog (0/+10V) or bipolar analog (-10/+10 V)", §2.14 "Servo axis unipolar/bipolar
output; Factory Default = bipolar"; spec oms.md §5.3; README "Servo"].

A unipolar axis drives the magnitude of the servo law's output on its DAC (0..32767 = 0..+10 V)
and the sign on its direction output (backdoor `get_outputs()["direction"]`, True = positive);
the amplifier, so the motor, gets the signed command and the loop closes both ways. Here X is
bipolar and Y unipolar, both servos with the factory gains on the same simulated motor, so the
same commands give them the same signed output.
"""

from __future__ import annotations

from collections.abc import Iterator

import pytest
from vdevmaps.oms import Shm

from tests.devices.oms.conftest import Maxk, maxk_card

HZ = 1024
DAC_Y = Shm.DAC + 4
ENCODER_Y = Shm.ENCODER_POSITION + 4
FULL_SCALE = 32767
OUTPUTS = ["bipolar", "unipolar", "bipolar", "bipolar"]


@pytest.fixture
def card() -> Iterator[Maxk]:
    with maxk_card(servo_output=OUTPUTS) as maxk:
        maxk.send("AA VL20000,20000,20000,20000 AC200000,200000,200000,200000;")
        yield maxk


def direction(maxk: Maxk, axis: int) -> bool:
    return bool(maxk.control("get_outputs")["direction"][axis])


def run_together(maxk: Maxk, distance: int, ticks: int) -> list[tuple[int, int, bool]]:
    """X and Y move `distance` together (AA MR, GO); per update cycle (DAC X, DAC Y, Y's
    direction output)."""
    maxk.send(f"AA MR{distance},{distance} GO; AX;")
    seen = []
    for _ in range(ticks):
        maxk.step(1)
        seen.append((maxk.word(Shm.DAC), maxk.word(DAC_Y), direction(maxk, 1)))
    return seen


def test_a_unipolar_axis_moves_forward_and_back_to_its_targets(card: Maxk) -> None:
    card.send("AY MR6000 GO;")
    card.step(HZ)
    assert card.query("AY RP;") == "6000"
    assert card.query("AY RE;") == "6000"
    card.send("AY MR-9000 GO;")
    card.step(HZ)
    assert card.query("AY RP;") == "-3000"
    assert card.query("AY RE;") == "-3000"


def test_the_dac_word_is_the_magnitude_and_the_direction_output_the_sign(card: Maxk) -> None:
    """The same move on X (bipolar) and Y (unipolar): in every update cycle Y's word is
    |X's word|, never negative, and Y's direction output is X's sign; both drive both ways."""
    seen = run_together(card, 5000, HZ) + run_together(card, -8000, HZ)
    assert all(y == abs(x) for x, y, _ in seen)
    assert all(0 <= y <= FULL_SCALE for _, y, _ in seen)
    assert all(positive == (x >= 0) for x, _, positive in seen)
    assert min(x for x, _, _ in seen) < -1000 and max(x for x, _, _ in seen) > 1000
    assert any(not positive for _, _, positive in seen) and any(p for _, _, p in seen)
    assert card.query("AA RE;") == "-3000,-3000,0,0"


def test_open_loop_ko_below_zero_runs_the_motor_backwards(card: Maxk) -> None:
    """CL0: the output is KO alone [S §2.13]; KO-3277 is 1 V on the DAC and the direction
    output negative, and the motor runs backwards."""
    card.send("AY CL0; KO-3277;")
    card.step(HZ // 4)
    assert card.word(DAC_Y) == 3277
    assert card.control("get_outputs")["dac_volts"][1] == pytest.approx(1.0, abs=0.001)
    assert not direction(card, 1)
    assert card.word(ENCODER_Y) < -1000
    card.send("KO3277;")
    card.step(1)
    assert card.word(DAC_Y) == 3277
    assert direction(card, 1)


def test_svp_minus_inverts_the_direction_output_not_the_word(card: Maxk) -> None:
    """SVP− negates the output, KO included [S §2.9 step 5]: on a unipolar axis the word stays
    the magnitude, the direction output turns over, and the motor with it."""
    card.send("AY CL0; SVP-; KO2000;")
    card.step(HZ // 4)
    assert card.word(DAC_Y) == 2000
    assert not direction(card, 1)
    assert card.word(ENCODER_Y) < -500
    card.send("SVP+;")
    card.step(1)
    assert card.word(DAC_Y) == 2000
    assert direction(card, 1)


def test_a_unipolar_axis_made_a_stepper_drives_ao_both_ways(card: Maxk) -> None:
    """The option is the servo's output; the DAC of an axis that is not a servo is a ±10 V
    general-purpose output (AO, [S §4.5.2]) whatever the option, and PSM makes it unipolar
    again."""
    card.send("AY PSO; AO-2.5;")
    assert not card.command_error()
    card.step(1)
    assert card.word(DAC_Y) == round(-2.5 / 10 * FULL_SCALE)
    card.send("AY PSM; CL0; KO-500;")
    card.step(1)
    assert card.word(DAC_Y) == 500
    assert not direction(card, 1)


def test_bipolar_is_the_default_and_keeps_the_sign_on_the_word() -> None:
    """Factory default bipolar [S §2.14]: the word is signed; the direction output of a
    bipolar axis is the direction of its last motion command, as a stepper's."""
    with maxk_card() as maxk:
        maxk.send("AX CL0; KO-3277;")
        maxk.step(1)
        assert maxk.word(Shm.DAC) == -3277
        assert maxk.control("get_outputs")["dac_volts"][0] == pytest.approx(-1.0, abs=0.001)
        maxk.send("AX CL1; MR-100 GO;")
        maxk.step(1)
        assert maxk.control("get_outputs")["direction"][0] is False
