"""APS_home_move and APS_jog_start through the client against a lockstep daemon [M §4.3, §4.5;
spec adlink.md §2.6, §2.8, §2.14].

The stage (physical counts; unit factor 1): limits at -60 000 and +60 000, the home switch on
from 20 000 to 30 000. Where the axis came to rest is read from the stage itself: the backdoor
moves a probe switch (the home window) until it finds the physical position (`physical`).
"""

from __future__ import annotations

import contextlib
from collections.abc import Iterator
from typing import Any

import pytest
import vdevclient
from vdevclient import aps

from tests.client.aps_rack import amp, aps_session, f64, i32, step_ms

STAGE = {"limits": [-60_000, 60_000], "home": [20_000, 30_000]}
LOW, HIGH = 20_000, 30_000  # the home switch's edges
VO_CYCLE = 50  # counts one 1 ms cycle runs at PRA_HOME_VO 5e4 (the edge's resolution)


@contextlib.contextmanager
def stage(axis: dict[str, Any] | None = None, **params: float) -> Iterator[vdevclient.Rack]:
    """An AMP-208C whose axis 0 has the stage, servo on, `params` (PRA_* names) set."""
    with aps_session(amp(axis=[STAGE if axis is None else axis])) as (_, rack):
        assert aps.APS_set_servo_on(0, 1) == 0
        for name, value in params.items():
            setp(getattr(aps, name), value)
        yield rack


def setp(no: int, value: float, a: int = 0) -> None:
    assert aps.APS_set_axis_param_f(a, no, value) == aps.ERR_NoError


def status(a: int = 0) -> int:
    return aps.APS_motion_status(a)


def bit(word: int, n: int) -> int:
    return word >> n & 1


def move_to(rack: vdevclient.Rack, pos: float) -> None:
    """A fast PTP to `pos` (the start condition of a home move)."""
    assert aps.APS_ptp_all(0, 0, pos, 0, 1e6, 0, 1e7, 1e7, 0) == 0
    step_ms(rack, 200)
    assert bit(status(), aps.MTS_MDN)


def home(rack: vdevclient.Rack, limit_ms: int = 6000, every_ms: int = 10) -> int:
    """APS_home_move, then the manual's wait loop (with MDN's sense as §4.8.1 gives it, spec
    MANUAL-DEFECT) looking every `every_ms`: HMV 1 and MDN 0 on every look until done. The time
    it took (ms)."""
    assert aps.APS_home_move(0) == aps.ERR_NoError
    return wait_home(rack, limit_ms, every_ms)


def wait_home(rack: vdevclient.Rack, limit_ms: int = 6000, every_ms: int = 10) -> int:
    ms = 0
    while not bit(status(), aps.MTS_MDN):
        assert bit(status(), aps.MTS_HMV)
        assert ms < limit_ms
        step_ms(rack, every_ms)
        ms += every_ms
    return ms


def physical(rack: vdevclient.Rack, lo: int = -70_000, hi: int = 70_000) -> int:
    """The stage's physical position at rest (whole counts): the home window moved to
    [x, far] until its edge meets the stage (bisection)."""
    card = rack.card("amp0")
    while hi - lo > 1:
        mid = (lo + hi) // 2
        card.control("set_home_window", axis=0, low=mid, high=1e9)
        step_ms(rack, 1)
        if bit(aps.APS_motion_io_status(0), aps.MIO_ORG):
            lo = mid
        else:
            hi = mid
    return lo


def assert_homed(home_pos: float = 0.0) -> None:
    st = status()
    assert bit(st, aps.MTS_MDN) and not bit(st, aps.MTS_HMV) and not bit(st, aps.MTS_ASTP)
    assert i32(aps.APS_get_stop_code, 0) == aps.STOP_NORMAL
    assert f64(aps.APS_get_command_f, 0) == home_pos
    assert f64(aps.APS_get_position_f, 0) == home_pos


def assert_aborted(code: int) -> None:
    st = status()
    assert bit(st, aps.MTS_MDN) and bit(st, aps.MTS_ASTP) and not bit(st, aps.MTS_HMV)
    assert i32(aps.APS_get_stop_code, 0) == code


# -- mode 0: ORG --------------------------------------------------------------------------------

def test_m43_sample_values_mode0_dir1_stop_at_the_right_edge_of_org() -> None:
    """The manual's example [M §4.3]: MODE 0, DIR 1, CURVE 0, ACC 1e6, VM 1e5, VO 5e4, EZA 0,
    SHIFT 0, POS 0; from between MEL and ORG (case A) the negative search meets MEL, turns,
    crosses ORG and comes back at VO to its right edge (the side nearest PEL [M §4.3.1])."""
    with stage(PRA_HOME_MODE=0, PRA_HOME_DIR=1, PRA_HOME_CURVE=0, PRA_HOME_ACC=1e6,
               PRA_HOME_VM=1e5, PRA_HOME_VO=5e4, PRA_HOME_EZA=0, PRA_HOME_SHIFT=0,
               PRA_HOME_POS=0) as rack:
        move_to(rack, -10_000)
        home(rack, every_ms=1)  # HMV 1, MDN 0 in every cycle, across the turn at MEL
        assert_homed()
        assert i32(aps.APS_get_encoder, 0) == 0 and i32(aps.APS_get_command_counter, 0) == 0
        assert HIGH - VO_CYCLE <= physical(rack) <= HIGH


@pytest.mark.parametrize("start", [0, -60_000, 25_000, 40_000, 60_000],
                         ids=["A", "A_on_MEL", "B_on_ORG", "C", "C_on_PEL"])
@pytest.mark.parametrize("direction", [0, 1], ids=["dir0_positive", "dir1_negative"])
def test_m431_org_homing_from_each_start_condition_stops_on_the_org_edge(start: int,
                                                                        direction: int) -> None:
    """[M §4.3.1]: DIR 0 stops on ORG's left edge, DIR 1 on its right edge, whatever side
    (A, B on ORG, C) the axis starts from; command = feedback = 0 after."""
    with stage(PRA_HOME_MODE=0, PRA_HOME_DIR=direction) as rack:
        if start:
            move_to(rack, start)
        home(rack)
        assert_homed()
        assert bit(aps.APS_motion_io_status(0), aps.MIO_ORG)
        at = physical(rack)
        if direction == 0:
            assert LOW <= at <= LOW + VO_CYCLE
        else:
            assert HIGH - VO_CYCLE <= at <= HIGH


def test_m431_home_pos_and_shift_in_user_units() -> None:
    """HOME_SHIFT moves on from the ORG edge; command and feedback then read HOME_POS; both in
    user units (unit factor 2 counts per unit) [M §4.3, §4.2.2]."""
    with stage(PRA_POS_UNIT_FACTOR=2, PRA_HOME_DIR=0, PRA_HOME_VM=5e4, PRA_HOME_VO=2.5e4,
               PRA_HOME_ACC=5e5, PRA_HOME_SHIFT=-1500, PRA_HOME_POS=123.5) as rack:
        home(rack)
        assert_homed(123.5)
        assert i32(aps.APS_get_encoder, 0) == 0
        assert LOW - 3000 <= physical(rack) <= LOW - 3000 + VO_CYCLE


def test_m431_eza_aligns_on_the_first_index_mark_past_the_org_edge() -> None:
    """EZA 1 [M §4.3.1]: after the ORG edge the axis goes on in the home direction at VO to the
    first EZ and stops on it (marks every 4096 counts from 100: the first past 20 000 is
    20 580); SHIFT then applies from the mark."""
    with stage(PRA_HOME_DIR=0, PRA_HOME_EZA=1) as rack:
        rack.card("amp0").control("set_index", axis=0, period=4096, phase=100)
        home(rack)
        assert_homed()
        assert bit(aps.APS_motion_io_status(0), aps.MIO_EZ)
        assert physical(rack) == 100 + 5 * 4096
    with stage(PRA_HOME_DIR=1, PRA_HOME_EZA=1, PRA_HOME_SHIFT=300, PRA_HOME_POS=-7) as rack:
        rack.card("amp0").control("set_index", axis=0, period=4096, phase=100)
        home(rack)
        assert_homed(-7)
        assert physical(rack) == 100 + 7 * 4096 + 300  # the first mark below 30 000: 28 772


def test_m431_el_decelerate_mode_turns_the_search_without_astp() -> None:
    """PRA_EL_MODE 1: the search meets PEL (case C) and decelerates there; the sequence turns
    back and still homes, no ASTP and no stop code (spec Q8)."""
    with stage(PRA_EL_MODE=1, PRA_SD_DEC=1e7) as rack:
        move_to(rack, 40_000)
        home(rack, every_ms=1)
        assert_homed()
        assert LOW <= physical(rack) <= LOW + VO_CYCLE


def test_m423_s_curve_home_profile_with_start_velocity() -> None:
    """PRA_HOME_CURVE 1 (pure S-curve [M §4.2.3.2]) and PRA_HOME_VS: the same edge; the search
    starts at VS (the first cycle's speed is VS, not a ramp from 0)."""
    with stage(PRA_HOME_CURVE=1, PRA_HOME_VS=2e4) as rack:
        assert aps.APS_home_move(0) == 0
        step_ms(rack, 1)
        assert f64(aps.APS_get_command_velocity_f, 0) >= 2e4
        wait_home(rack)
        assert_homed()
        assert LOW <= physical(rack) <= LOW + VO_CYCLE


# -- mode 1: EL, mode 2: EZ ---------------------------------------------------------------------

@pytest.mark.parametrize("direction", [0, 1])
def test_m432_el_homing_stops_on_the_limit_edge(direction: int) -> None:
    """[M §4.3.2]: DIR 0 finds PEL, DIR 1 MEL; the axis stops on the edge of the EL signal
    (leaving it at VO), with no ASTP from the EL stop."""
    with stage(PRA_HOME_MODE=1, PRA_HOME_DIR=direction) as rack:
        home(rack)
        assert_homed()
        assert not aps.APS_motion_io_status(0) & (aps.MIO_PEL_V | aps.MIO_MEL_V)
        at = physical(rack)
        if direction == 0:
            assert 60_000 - VO_CYCLE <= at < 60_000
        else:
            assert -60_000 < at <= -60_000 + VO_CYCLE


def test_m432_el_homing_with_eza_and_shift() -> None:
    """EZA 1 in mode 1: from the PEL edge the axis goes back (it cannot go on into the limit,
    spec §2.6) to the first index mark, then SHIFT."""
    with stage(PRA_HOME_MODE=1, PRA_HOME_DIR=0, PRA_HOME_EZA=1, PRA_HOME_SHIFT=-250) as rack:
        rack.card("amp0").control("set_index", axis=0, period=4096, phase=100)
        home(rack)
        assert_homed()
        assert physical(rack) == 100 + 14 * 4096 - 250


@pytest.mark.parametrize(("direction", "start"), [(0, 0), (1, 0), (0, 10_000), (1, -3000)],
                         ids=["ahead", "behind_turns_at_MEL", "behind_turns_at_PEL", "ahead_neg"])
def test_m433_single_ez_homing_stops_on_the_mark(direction: int, start: int) -> None:
    """[M §4.3.3]: one index mark (at 5000; the next ones are far beyond the limits): found at
    VM (turning once at an EL), then returned to at VO: the axis rests on the mark."""
    with stage(PRA_HOME_MODE=2, PRA_HOME_DIR=direction, PRA_HOME_POS=1.0) as rack:
        rack.card("amp0").control("set_index", axis=0, period=1_000_000, phase=5000)
        if start:
            move_to(rack, start)
        home(rack)
        assert_homed(1.0)
        assert physical(rack) == 5000


@pytest.mark.parametrize("mode", [0, 2])
def test_m43_homing_again_from_home_finds_the_same_place(mode: int) -> None:
    """A second home move from the home position (on ORG, on the mark: the coordinates redefined
    by the first) ends where the first did, on the mark (EZA in mode 0)."""
    with stage(PRA_HOME_MODE=mode, PRA_HOME_EZA=1, PRA_HOME_POS=50) as rack:
        rack.card("amp0").control("set_index", axis=0, period=1_000_000, phase=25_000)
        home(rack)
        assert_homed(50)
        home(rack)
        assert_homed(50)
        assert physical(rack) == 25_000


# -- aborts [X8 stop codes 20-23] ------------------------------------------------------------------

def test_q8_no_org_between_the_limits_aborts_with_stop_no_org() -> None:
    with stage({"limits": [-20_000, 20_000]}, PRA_HOME_DIR=0) as rack:
        home(rack)
        assert_aborted(aps.STOP_NO_ORG)


def test_q8_org_over_mel_aborts_with_stop_org_el() -> None:
    """Started on ORG (case B) the axis leaves it backwards, but ORG lasts into MEL."""
    with stage({"limits": [-20_000, 20_000], "home": [-30_000, -10_000]}) as rack:
        move_to(rack, -15_000)
        home(rack)
        assert_aborted(aps.STOP_ORG_EL)


def test_q8_no_index_mark_aborts_with_stop_no_ez() -> None:
    with stage({"limits": [-20_000, 20_000]}, PRA_HOME_MODE=2) as rack:
        home(rack)
        assert_aborted(aps.STOP_NO_EZ)
    with stage(PRA_HOME_EZA=1) as rack:  # ORG found, no EZ after it before PEL
        home(rack)
        assert_aborted(aps.STOP_NO_EZ)


def test_q8_both_limits_abort_with_stop_both_el() -> None:
    """Both ELs on at the start: no motion, code 23 at once; a PEL that never releases: the EL
    homing meets MEL on its way back: 23."""
    with stage(PRA_HOME_MODE=1) as rack:
        card = rack.card("amp0")
        card.control("set_limit", axis=0, side="positive", active=True)
        card.control("set_limit", axis=0, side="negative", active=True)
        step_ms(rack, 1)
        assert aps.APS_home_move(0) == 0
        assert_aborted(aps.STOP_BOTH_EL)
        card.control("set_limit", axis=0, side="negative", active=False)
        home(rack)
        assert_aborted(aps.STOP_BOTH_EL)


def test_m43_homing_rules_refusals_and_stops() -> None:
    """While homing other motion is refused (-15, the jog ignored); APS_stop_move ends the home
    move (stop code 9, no ASTP, HMV 0); EMG refuses it (code 1, ASTP); a moving axis -15."""
    with stage() as rack:
        assert aps.APS_home_move(0) == 0
        step_ms(rack, 20)
        assert aps.APS_ptp(0, 0, 100.0) == aps.ERR_CommandInProcess
        assert aps.APS_vel(0, 0, 100.0) == aps.ERR_CommandInProcess
        assert aps.APS_home_move(0) == aps.ERR_CommandInProcess
        assert aps.APS_jog_start(0, 1) == 0
        step_ms(rack, 10)
        assert not bit(status(), aps.MTS_JOG) and bit(status(), aps.MTS_HMV)
        assert aps.APS_jog_start(0, 0) == 0
        assert aps.APS_stop_move(0) == 0
        step_ms(rack, 300)
        st = status()
        assert bit(st, aps.MTS_MDN) and not bit(st, aps.MTS_HMV) and not bit(st, aps.MTS_ASTP)
        assert i32(aps.APS_get_stop_code, 0) == aps.STOP_USER
        assert aps.APS_vel(0, 0, 1000.0) == 0
        assert aps.APS_home_move(0) == aps.ERR_CommandInProcess
        aps.APS_emg_stop(0)
        rack.card("amp0").control("set_estop", active=True)
        step_ms(rack, 1)
        assert aps.APS_home_move(0) == 0
        assert_aborted(aps.STOP_EMG)
        assert aps.APS_home_move(99) == aps.ERR_ParametersInvalid


# -- jog ------------------------------------------------------------------------------------------

JOG = {"PRA_JG_VM": 1e4, "PRA_JG_ACC": 1e6, "PRA_JG_DEC": 1e5, "PRA_JG_SF": 0}


def test_m45_continuous_jog_runs_at_jg_vm_and_stops_with_jg_dec() -> None:
    """JOG-ON rising edge: a velocity move at JG_VM in JG_DIR (1 positive) [M §4.5]; JOG 1 and
    MDN 0; falling edge: deceleration with JG_DEC: 1e4^2 / (2 x 1e5) = 500 counts, 100 ms."""
    with stage(PRA_JG_MODE=0, PRA_JG_DIR=1, **JOG) as rack:
        assert aps.APS_jog_start(0, 1) == 0
        st = status()
        assert bit(st, aps.MTS_JOG) and not bit(st, aps.MTS_MDN)
        step_ms(rack, 100)
        assert f64(aps.APS_get_command_velocity_f, 0) == pytest.approx(1e4)
        assert bit(status(), aps.MTS_DIR)
        assert f64(aps.APS_get_target_position_f, 0) == f64(aps.APS_get_command_f, 0)
        assert aps.APS_jog_on(0, 0) == 0  # the manual's name
        off_at = f64(aps.APS_get_command_f, 0)
        step_ms(rack, 95)
        assert bit(status(), aps.MTS_JOG) and bit(status(), aps.MTS_DEC)
        step_ms(rack, 10)
        st = status()
        assert bit(st, aps.MTS_MDN) and not bit(st, aps.MTS_JOG) and not bit(st, aps.MTS_ASTP)
        assert i32(aps.APS_get_stop_code, 0) == aps.STOP_NORMAL
        assert f64(aps.APS_get_command_f, 0) - off_at == pytest.approx(500, abs=1)


def test_q6_jg_dir_0_is_negative() -> None:
    with stage(PRA_JG_DIR=0, **JOG) as rack:
        aps.APS_jog_start(0, 1)
        step_ms(rack, 50)
        assert f64(aps.APS_get_command_velocity_f, 0) == pytest.approx(-1e4)
        assert not bit(status(), aps.MTS_DIR)


def test_m45_step_jog_moves_exactly_jg_offset() -> None:
    """Step mode [M §4.5, Fig 4-18]: the rising edge moves exactly JG_OFFSET and stops; released
    within JG_DELAY (us, spec Q22) the jog ends there."""
    with stage(PRA_JG_MODE=1, PRA_JG_DIR=1, PRA_JG_OFFSET=1234, PRA_JG_DELAY=300_000,
               **JOG) as rack:
        aps.APS_jog_start(0, 1)
        step_ms(rack, 200)  # the step (about 130 ms), then the delay
        assert f64(aps.APS_get_command_f, 0) == 1234
        st = status()
        assert bit(st, aps.MTS_JOG) and not bit(st, aps.MTS_MDN)
        aps.APS_jog_start(0, 0)
        step_ms(rack, 1)
        st = status()
        assert bit(st, aps.MTS_MDN) and not bit(st, aps.MTS_JOG)
        assert i32(aps.APS_get_command_counter, 0) == 1234
        aps.APS_jog_start(0, 1)  # a quick tap: one more step
        aps.APS_jog_start(0, 0)
        step_ms(rack, 200)
        assert bit(status(), aps.MTS_MDN)
        assert f64(aps.APS_get_command_f, 0) == 2468


def test_m45_step_jog_held_past_jg_delay_runs_on_and_stops_on_a_multiple_of_the_offset() -> None:
    """Held past JG_DELAY the step jog runs on continuously; the falling edge stops it on an
    integer multiple of JG_OFFSET from where it began (spec §2.8 ASSUMPTION) [M §4.5]."""
    with stage(PRA_JG_MODE=1, PRA_JG_DIR=0, PRA_JG_OFFSET=1000, PRA_JG_DELAY=100_000,
               **JOG) as rack:
        move_to(rack, 333)
        aps.APS_jog_start(0, 1)
        step_ms(rack, 180)  # the step (155 ms), then waiting
        assert f64(aps.APS_get_command_f, 0) == 333 - 1000
        assert f64(aps.APS_get_command_velocity_f, 0) == 0
        step_ms(rack, 300)  # the delay over: running on at JG_VM
        assert f64(aps.APS_get_command_velocity_f, 0) == pytest.approx(-1e4)
        assert bit(status(), aps.MTS_JOG)
        aps.APS_jog_start(0, 0)
        here = f64(aps.APS_get_command_f, 0)
        step_ms(rack, 400)
        st = status()
        assert bit(st, aps.MTS_MDN) and not bit(st, aps.MTS_JOG)
        end = f64(aps.APS_get_command_f, 0)
        assert (333 - end) % 1000 == 0 and 333 - end >= 3000
        assert here - end >= 500  # at least the JG_DEC stop distance


def test_m45_jog_from_mapped_digital_inputs() -> None:
    """PRA_JG_MAP_DI_EN bits 0 and 1 (spec ASSUMPTION, [X5] uses 0x3): DI 0 is positive JOG-ON,
    DI 1 negative; bit 2: DI 5 with the direction of PRA_JG_DIR. The DI word is read every
    cycle."""
    with stage(PRA_JG_MAP_DI_EN=3, PRA_JG_P_JOG_DI=0, PRA_JG_N_JOG_DI=1, **JOG) as rack:
        card = rack.card("amp0")
        card.control("set_di", channel=0, level=True)
        step_ms(rack, 50)
        assert bit(status(), aps.MTS_JOG)
        assert f64(aps.APS_get_command_velocity_f, 0) == pytest.approx(1e4)
        card.control("set_di", channel=1, level=True)  # another source while jogging: ignored
        step_ms(rack, 10)
        assert f64(aps.APS_get_command_velocity_f, 0) == pytest.approx(1e4)
        card.control("set_di", channel=0, level=False)
        step_ms(rack, 150)
        assert bit(status(), aps.MTS_MDN) and not bit(status(), aps.MTS_JOG)
        card.control("set_di", channel=1, level=False)
        step_ms(rack, 1)
        card.control("set_di", channel=1, level=True)
        step_ms(rack, 50)
        assert f64(aps.APS_get_command_velocity_f, 0) == pytest.approx(-1e4)
        card.control("set_di", channel=1, level=False)
        step_ms(rack, 150)
        assert bit(status(), aps.MTS_MDN)
        setp(aps.PRA_JG_MAP_DI_EN, 4)
        setp(aps.PRA_JG_JOG_DI, 5)
        setp(aps.PRA_JG_DIR, 1)
        card.control("set_di", channel=5, level=True)
        step_ms(rack, 50)
        assert f64(aps.APS_get_command_velocity_f, 0) == pytest.approx(1e4)
        assert aps.APS_jog_start(0, 0) == 0  # not its source: ignored
        step_ms(rack, 10)
        assert bit(status(), aps.MTS_JOG)
        card.control("set_di", channel=5, level=False)
        step_ms(rack, 150)
        assert bit(status(), aps.MTS_MDN) and not bit(status(), aps.MTS_JOG)


def test_m45_note_motion_commands_refused_while_jogging_and_limits_end_it() -> None:
    """[M §4.5 NOTE]: while jogging other movement commands are disabled (-15, spec
    ASSUMPTION); a stop command still stops it; PEL ends it with ASTP and STOP_PEL."""
    with stage(PRA_JG_DIR=1, **JOG) as rack:
        aps.APS_jog_start(0, 1)
        step_ms(rack, 10)
        assert aps.APS_ptp(0, 0, 100.0) == aps.ERR_CommandInProcess
        assert aps.APS_vel(0, 0, 100.0) == aps.ERR_CommandInProcess
        assert aps.APS_home_move(0) == aps.ERR_CommandInProcess
        assert aps.APS_stop_move(0) == 0
        step_ms(rack, 150)
        assert bit(status(), aps.MTS_MDN) and not bit(status(), aps.MTS_JOG)
        assert i32(aps.APS_get_stop_code, 0) == aps.STOP_USER
        aps.APS_jog_start(0, 0)
        aps.APS_jog_start(0, 1)
        rack.card("amp0").control("set_limit", axis=0, side="positive", active=True)
        step_ms(rack, 5)
        assert bit(status(), aps.MTS_ASTP) and not bit(status(), aps.MTS_JOG)
        assert i32(aps.APS_get_stop_code, 0) == aps.STOP_PEL
        aps.APS_jog_start(0, 0)
        assert aps.APS_jog_start(0, 1) == 0  # into the active limit: refused, code kept
        assert not bit(status(), aps.MTS_JOG)
        assert aps.APS_jog_start(0, 2) == aps.ERR_ParametersInvalid
        assert aps.APS_jog_start(8, 1) == aps.ERR_ParametersInvalid
