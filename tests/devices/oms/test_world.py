"""The axis world on the MAXk (README.md "Axis world", "Backdoor"), through the host library an
application calls (`vdevclient.maxk`): home searches and limit stops that find the switches the
card's `[[card.axis]]` tables place, with no backdoor flipping them; positions that stay physical
when LP or a home search renumber the axis; faults configured at power-up; probe positions; the
shared backdoor vocabulary and the card's deprecated names."""

from __future__ import annotations

from collections.abc import Iterator
from contextlib import contextmanager
from typing import Any

import pytest
import vdevclient
from vdevclient import maxk
from vdevmaps.oms import AXES

from tests.client.galil import card, rack_config
from vdevd.testing import DaemonThread

DT = 1 / 1024  # the update period at the default 1024 Hz
VL, AC = 10000, 100000
STOP = VL**2 / (2 * AC)  # counts run while ramping down from VL at AC: 500
CYCLE = VL * DT + 1  # what one update cycle at VL may add
WAIT_MS = 10000
X, Y, Z, T = 1, 2, 4, 8  # axis masks of wait_done
STEPPERS = ["stepper", "stepper_encoder", "servo", "stepper_encoder"]


@contextmanager
def board(axis: list[dict[str, Any]], **options: Any
          ) -> Iterator[tuple[maxk.Maxk, vdevclient.Rack]]:
    """Board 1 (4 axes: X stepper, Y stepper with encoder, Z servo, T stepper with encoder) with
    the `[[card.axis]]` tables `axis`, opened with the host library; VL and AC set on every
    axis, as an application does first."""
    spec = card("oms-maxk", "maxk0", board=1, axes=4, axis_types=STEPPERS, axis=axis, **options)
    with DaemonThread(rack_config(spec)) as d, \
            vdevclient.connect(d.endpoint, d.events, timeout=10) as rack, \
            maxk.open(1, endpoint=d.endpoint) as m:
        m.send_string(f"AA VL{VL},{VL},{VL},{VL} AC{AC},{AC},{AC},{AC}; AX")
        yield m, rack


def rp(m: maxk.Maxk, axis: str = "X") -> int:
    return int(m.send_and_get_string(f"A{axis} RP"))


def qa(m: maxk.Maxk, axis: str = "X") -> str:
    return m.send_and_get_string(f"A{axis} QA")


def rests(m: maxk.Maxk, rack: vdevclient.Rack, axis: str = "X") -> int:
    """RP once the axis has stopped (a move, a jog into a limit)."""
    rack.sim.step(seconds=0.05)
    while m.send_and_get_string(f"A{axis} RV") != "0":
        rack.sim.step(seconds=0.05)
    return rp(m, axis)


# -- home searches [S §4.3 "Homing", §4.8 "Home switch"; spec oms.md §5.5] ---------------------------
HOME = [{"home": [5000, 6000], "limits": [-20000, 20000]}]


def test_s4_8_hm_finds_the_configured_switch_loads_the_operand_there_and_ramps_down() -> None:
    """"the axis position counter will be reset to a selected value when the switch is
    activated. At this point the MAXk can either ramp the axis to a stop" [S §4.8]: HM100
    runs at VL to the switch at physical 5000, 100 is loaded there, and the ramp-down at AC
    leaves the axis at 100 + 500 with done (ID) and QA's home 'H' (it rests inside the
    5000-6000 window)."""
    with board(HOME) as (m, rack):
        m.send_string("AX HM100 ID")
        assert m.wait_done(X, WAIT_MS) == maxk.StatusFlags(done=X)
        assert rp(m) == pytest.approx(100 + STOP, abs=CYCLE)
        assert qa(m) == "PDNH"
        assert m.read_home() & 1 == 0  # active low (factory): the raw level reads 0
        m.send_string("AX MA99 GO")  # one count below the operand: below the switch's edge
        assert rests(m, rack) == 99
        assert qa(m)[3] == "N"
        m.send_string("AX MA100 GO")  # the operand is where the switch begins
        assert rests(m, rack) == 100
        assert qa(m)[3] == "H"


def test_s4_8_km_stops_at_the_switch_within_the_cycle() -> None:
    """KM: home and "stop the axis immediately" [S §4.8]."""
    with board(HOME) as (m, _):
        m.send_string("AX KM0 ID")
        assert m.wait_done(X, WAIT_MS) == maxk.StatusFlags(done=X)
        assert 0 <= rp(m) <= CYCLE
        assert qa(m) == "PDNH"


def test_s4_3_hr_homes_in_the_reverse_direction_at_the_switch_s_upper_edge() -> None:
    """HR: the same search toward negative positions [S §4.3]; a switch from -6000 to -5000 is
    met at -5000."""
    with board([{"home": [-6000, -5000]}]) as (m, _):
        m.send_string("AX HR-20 ID")
        assert m.wait_done(X, WAIT_MS) == maxk.StatusFlags(done=X)
        assert rp(m) == pytest.approx(-20 - STOP, abs=CYCLE)
        assert qa(m) == "MDNH"


def test_s4_8_hi_homes_on_the_configured_index_pulse_inside_the_switch() -> None:
    """HI: home = index AND switch [S §4.8]: with pulses every 1000 counts from 250 (the
    `[[card.axis]]` index) and the switch from 5000, home is the pulse at 5250."""
    with board([{}, {"home": [5000, 9000], "index": {"period": 1000, "phase": 250}}]) as (m, _):
        m.send_string("AY HI HM0 ID")
        assert m.wait_done(Y, WAIT_MS) == maxk.StatusFlags(done=Y)
        assert int(m.send_and_get_string("AY RE")) == pytest.approx(STOP, abs=CYCLE)
        m.send_string("AY MA-250 GO ID")  # physical 5000 again: the switch's edge
        m.wait_done(Y, WAIT_MS)
        assert qa(m, "Y")[3] == "H"


def test_lp_and_a_home_search_leave_the_switches_where_the_stage_has_them() -> None:
    """LP renumbers the counters, not the stage: after LP-3000 at physical 0 the switch
    (physical 5000) is at 2000, and after a home search (HM0, found at physical 5000) the
    positive limit (physical 20000) is at 15000."""
    with board(HOME) as (m, rack):
        m.send_string("AX LP-3000 MA1999 GO")
        assert rests(m, rack) == 1999
        assert qa(m)[3] == "N"
        m.send_string("AX MA2000 GO")
        assert rests(m, rack) == 2000
        assert qa(m)[3] == "H"
        m.send_string("AX MA-3000 GO HM0 ID")
        assert m.wait_done(X, WAIT_MS) == maxk.StatusFlags(done=X)
        m.send_string("AX JG5000")
        assert m.wait_done(X, WAIT_MS) == maxk.StatusFlags(overtravel=X)
        assert 15000 <= rests(m, rack) <= 15000 + 5000 * DT + 1


@pytest.mark.parametrize(("axis", "load"), [("X", "LP"), ("X", "LO"), ("Z", "LPE"), ("Y", "LP")])
def test_every_load_of_the_position_leaves_the_switch_on_the_stage(axis: str, load: str) -> None:
    """LP, LO and (on a servo, whose loop uses the encoder) LPE renumber the axis [S §2.13]:
    the switch at physical 5000 is at 2000 after a load of -3000 at physical 0."""
    tables = [{"home": [5000, 6000]}] * 3
    with board(tables) as (m, rack):
        m.send_string(f"A{axis} {load}-3000 MA1999 GO")
        rests(m, rack, axis)
        rack.sim.step(seconds=0.5)  # a servo settles
        assert qa(m, axis)[3] == "N"
        m.send_string(f"A{axis} MA2000 GO")
        rests(m, rack, axis)
        rack.sim.step(seconds=0.5)
        assert qa(m, axis)[3] == "H"


def test_set_index_period_0_removes_the_index_pulses(
        plain: tuple[maxk.Maxk, vdevclient.Rack]) -> None:
    """In HS mode an index capture (`CPH2`) records the index pulses [S §3.7]: the card's
    default one every 4096 counts, none after `set_index` with period 0."""
    m, rack = plain
    m.send_string("AY CPH2 MR5000 GO ID")
    m.wait_done(Y, WAIT_MS)
    assert [(e.encoder, e.home) for e in m.get_rt_capture()] == [(4096, 2)]
    rack.control("maxk0", "set_index", axis="Y", period=0)
    m.send_string("AY MR5000 GO ID")
    m.wait_done(Y, WAIT_MS)
    assert m.get_rt_capture() == []


def test_a_reset_zeroes_the_counters_where_the_stage_stands() -> None:
    """RS restarts the firmware with positions 0 (spec §4.3): the stage stays where it is, so
    its switches are where they were, now counted from there."""
    with board(HOME) as (m, rack):
        m.send_string("AX MA5500 GO")
        assert rests(m, rack) == 5500
        m.send_string("RS")
        rack.sim.step(seconds=0.01)
        m.send_string(f"AX VL{VL} AC{AC}")
        assert rp(m) == 0
        assert qa(m)[3] == "H"  # still inside the 5000-6000 window
        m.send_string("AX MA-501 GO")
        assert rests(m, rack) == -501
        assert qa(m)[3] == "N"


# -- limits [S §4.2 "Limit switch"; spec §5.6] -------------------------------------------------------
LIMITS = [{"limits": [-8000, 8000]}]


def test_s4_2_a_jog_into_the_configured_limit_stops_there_with_over_travel() -> None:
    """Hard mode (factory): the axis stops within the cycle it reaches the switch, the
    over-travel flag comes instead of done (ODBR bit 8), QA shows 'L', the limit word the
    positive input at its active (low) level, and only motion away is allowed."""
    with board(LIMITS) as (m, rack):
        m.send_string("AX JG5000")
        assert m.wait_done(X, WAIT_MS) == maxk.StatusFlags(overtravel=X)
        assert 8000 <= rests(m, rack) <= 8000 + 5000 * DT + 1
        assert qa(m) == "PNLN"
        assert m.read_limits() & (1 << 8) == 0  # X positive: active low
        assert m.read_limits() & 1  # X negative: idle high
        m.send_string("AX JG5000")  # further in: refused with over-travel
        assert m.wait_done(X, WAIT_MS) == maxk.StatusFlags(overtravel=X)
        m.send_string("AX MA0 GO ID")  # away from it: runs
        assert m.wait_done(X, WAIT_MS) == maxk.StatusFlags(done=X)
        assert rp(m) == 0
        assert qa(m)[2] == "N"


def test_s4_2_a_move_into_a_soft_mode_limit_ramps_down_past_it() -> None:
    """LMS: the switch decelerates the axis at AC [S §4.2]: a move to -20000 meets the
    negative limit at -8000 and rests 500 counts past it, with over-travel and no done."""
    with board(LIMITS) as (m, rack):
        m.send_string("AX LMS MA-20000 GO ID")
        assert m.wait_done(X, WAIT_MS) == maxk.StatusFlags(overtravel=X)
        assert rests(m, rack) == pytest.approx(-8000 - STOP, abs=CYCLE)
        assert qa(m) == "MNLN"
        assert m.get_status_flags() == maxk.StatusFlags()  # the flushed ID never fires


def test_s4_3_a_home_search_that_meets_the_configured_limit_stops_without_done() -> None:
    """A limit hit before home: stop, over-travel, no done (spec §5.5)."""
    with board([{"limits": [-8000, 8000], "home": [9000, 9500]}]) as (m, rack):
        m.send_string("AX HM0 ID")
        assert m.wait_done(X, WAIT_MS) == maxk.StatusFlags(overtravel=X)
        assert 8000 <= rests(m, rack) <= 8000 + CYCLE
        assert qa(m) == "PNLN"


def test_configured_switches_follow_the_polarity_the_application_sets() -> None:
    """An installation with active-high switches sends LTH and HH first [S §2.14, §4.2]: the
    configured switches are wired for it, so they are inactive where the stage is not on them
    and still act at their positions."""
    with board([{"limits": [-8000, 8000], "home": [5000, 6000]}]) as (m, rack):
        m.send_string("AX LTH HH")
        rack.sim.step(seconds=0.01)  # the words are published every update cycle
        assert qa(m) == "PNNN"
        assert m.read_limits() & 0x0101 == 0  # idle inputs of an active-high switch: low
        m.send_string("AX HM0 ID")
        assert m.wait_done(X, WAIT_MS) == maxk.StatusFlags(done=X)
        assert rp(m) == pytest.approx(STOP, abs=CYCLE)
        assert m.read_home() & 1  # on the switch: high
        m.send_string("AX JG5000")
        assert m.wait_done(X, WAIT_MS) == maxk.StatusFlags(overtravel=X)
        assert 3000 <= rests(m, rack) <= 3000 + 5000 * DT + 1  # physical 8000
        assert qa(m)[2] == "L"


# -- faults, jam and probes from the world -------------------------------------------------------------
def test_a_configured_amp_fault_holds_the_servo_open_at_power_up() -> None:
    """`amp_fault = true` on Z (a servo): at power-up its loop is open (CL? off) and it is
    reported as a slip (faults.py); clearing it by the backdoor lets CL1 close it again."""
    with board([{}, {}, {"amp_fault": True}]) as (m, rack):
        assert m.send_and_get_string("AZ CL?") == "off"
        assert m.get_status_flags() == maxk.StatusFlags(slip=Z)
        rack.control("maxk0", "set_amp_fault", axis="Z", active=False)
        m.send_string("AZ CL1 MR1000 GO ID")
        assert m.wait_done(Z, WAIT_MS) == maxk.StatusFlags(done=Z)


def test_a_configured_amp_fault_acts_once_ps_makes_the_axis_a_servo() -> None:
    """The amplifier fault acts on servo axes (README "Axis world"): configured on stepper X,
    it acts as soon as the host makes X a servo (PSM): X is reported as a slip and a jog does
    not move it."""
    with board([{"amp_fault": True}]) as (m, rack):
        m.send_string("AX PSM CL1")
        rack.sim.step(seconds=0.01)
        assert m.get_status_flags().slip & X
        m.send_string("AX JG1000")
        rack.sim.step(seconds=1.0)
        assert abs(rp(m)) <= 1


def test_a_fault_of_a_servo_made_a_stepper_leaves_the_stepper_free() -> None:
    """A servo axis with an amplifier fault made a stepper (PSO) moves as a stepper: the fault
    no longer acts, and clearing it by the backdoor is accepted on any type."""
    with board([{}, {}, {"amp_fault": True}]) as (m, rack):
        m.send_string("AZ PSO MR1000 GO")
        rack.sim.step(seconds=1.0)
        assert rp(m, "Z") == 1000
        rack.control("maxk0", "set_amp_fault", axis="Z", active=False)


def test_rdf_restores_the_types_with_the_faults_they_have() -> None:
    """RDF makes X a factory stepper again [S §2.14]: the amplifier fault configured on it,
    which acted while it was a servo, no longer holds it."""
    with board([{"amp_fault": True}]) as (m, rack):
        m.send_string("AX PSM CL1")
        m.send_string("RDF")
        m.send_string("AX MR1000 GO")
        rack.sim.step(seconds=1.0)
        assert rp(m) == 1000


def test_a_configured_encoder_loss_freezes_the_encoder_from_power_up() -> None:
    with board([{}, {"encoder_loss": True}]) as (m, _):
        m.send_string("AY MR1000 GO ID")
        m.wait_done(Y, WAIT_MS)
        assert rp(m, "Y") == 1000
        assert int(m.send_and_get_string("AY RE")) == 0
        assert m.get_positions().encoder[1] == 0


def test_a_jammed_motor_leaves_the_encoder_behind_the_command() -> None:
    """`jam` on the servo Z: the stage stays put while the command goes on
    (MotionCore.set_jammed); freed, the loop takes it to the command."""
    with board([]) as (m, rack):
        rack.control("maxk0", "jam", axis="Z")
        m.send_string("AZ MR1000 GO ID")
        m.wait_done(Z, WAIT_MS)
        assert rp(m, "Z") == 1000
        assert m.get_positions().encoder[2] == 0
        rack.control("maxk0", "jam", axis="Z", active=False)
        rack.sim.step(seconds=1.0)
        assert m.get_positions().encoder[2] == pytest.approx(1000, abs=2)


def test_a_probe_position_captures_the_encoder_where_it_is() -> None:
    """A `[[card.axis]]` probe is wired to input line IOa of its axis (README "Assumptions"):
    crossing it pulses IO1 for Y, and Y's capture on IO1's falling edge (`CPF0002`) holds the
    encoder count of the probe position itself [S §3.7]."""
    with board([{}, {"probe": [3000.5, 7000]}]) as (m, _):
        m.send_string("AY CPF0002 MR5000 GO ID")
        m.wait_done(Y, WAIT_MS)
        entries = m.get_rt_capture()
        assert [(e.encoder, e.axis, e.io_falling) for e in entries] == [(3000, 1, 2)]


# -- the backdoor vocabulary ----------------------------------------------------------------------------
@pytest.fixture
def plain() -> Iterator[tuple[maxk.Maxk, vdevclient.Rack]]:
    with board([]) as pair:
        yield pair


def test_the_shared_vocabulary_drives_the_maxk_s_signals(
        plain: tuple[maxk.Maxk, vdevclient.Rack]) -> None:
    m, rack = plain
    rack.control("maxk0", "set_limit", axis="y", side="negative")
    assert m.read_limits() & (1 << 1) == 0  # Y negative active: low
    rack.control("maxk0", "set_limit", axis="Y", side="negative", active=False)
    assert m.read_limits() & (1 << 1)
    rack.control("maxk0", "set_home", axis=2, active=True)  # a number counts from X = 0
    assert m.read_home() & 0b100 == 0
    rack.control("maxk0", "set_input", line=3, level=0)
    assert not m.read_gpio() & (1 << 3)
    rack.control("maxk0", "set_analog", channel=1, volts=2.5)
    assert m.send_and_get_string("AI1") == "2.500"
    rack.control("maxk0", "set_encoder_loss", axis="T")
    m.send_string("AT MR100 GO ID")
    m.wait_done(T, WAIT_MS)
    assert m.get_positions().encoder[3] == 0


def test_set_index_places_pulses_on_the_stage_not_on_the_counters(
        plain: tuple[maxk.Maxk, vdevclient.Rack]) -> None:
    """`set_index` after LP: the pulse at physical 250 is found where the stage has it."""
    m, rack = plain
    m.send_string("AY LP10000")
    rack.control("maxk0", "set_index", axis="Y", period=1000, phase=250)
    rack.control("maxk0", "set_home_window", axis="Y", low=5000, high=9000)
    m.send_string("AY HI HM0 ID")
    assert m.wait_done(Y, WAIT_MS) == maxk.StatusFlags(done=Y)
    m.send_string("AY MA-250 GO ID")
    m.wait_done(Y, WAIT_MS)
    assert qa(m, "Y")[3] == "H"
    m.send_string("AY MA-251 GO ID")
    m.wait_done(Y, WAIT_MS)
    assert qa(m, "Y")[3] == "N"


def test_set_estop_holds_every_limit_input_active(
        plain: tuple[maxk.Maxk, vdevclient.Rack]) -> None:
    """The MAXk has no E-stop input: the chain is wired into the limit inputs (README
    "Assumptions"): a jog stops with over-travel, motion either way is refused, and once
    released the axes move again."""
    m, rack = plain
    m.send_string("AX JG5000")
    rack.sim.step(seconds=0.2)
    rack.control("maxk0", "set_estop", active=True)
    assert m.wait_done(X, WAIT_MS) == maxk.StatusFlags(overtravel=X)
    assert m.read_limits() & 0x0F0F == 0  # every input of X..T at its active (low) level
    m.send_string("AY MR-100 GO")
    assert m.wait_done(Y, WAIT_MS) == maxk.StatusFlags(overtravel=Y)
    rack.control("maxk0", "set_estop", active=False)
    assert m.read_limits() & 0x0F0F == 0x0F0F
    m.send_string("AY MR-100 GO ID")
    assert m.wait_done(Y, WAIT_MS) == maxk.StatusFlags(done=Y)


def test_the_deprecated_names_keep_working_and_hello_lists_them(
        plain: tuple[maxk.Maxk, vdevclient.Rack]) -> None:
    m, rack = plain
    rack.control("maxk0", "set_limits", axis="Z", positive=True, negative=True)
    assert m.read_limits() & (1 << 2 | 1 << 10) == 0
    rack.control("maxk0", "set_limits", axis="Z", positive=False)
    assert m.read_limits() & (1 << 2 | 1 << 10) == 1 << 10
    rack.control("maxk0", "set_input", bit=4, level=0)  # `bit`: the former name of `line`
    assert not m.read_gpio() & (1 << 4)
    (info,) = [c for c in rack.info["cards"] if c["name"] == "maxk0"]
    assert info["deprecated"] == {"set_limits": "set_limit"}
    assert set(info["controls"]) >= {
        "set_limit", "set_home", "set_home_window", "set_index", "set_input", "set_analog",
        "set_amp_fault", "set_encoder_loss", "set_estop", "jam", "set_home_edge",
        "set_encoder_slip", "get_outputs", "set_firmware_state"}


@pytest.mark.parametrize(("action", "params", "message"), [
    ("set_switches", {"axis": "X"}, "has no control action 'set_switches' (has: "),
    ("set_limit", {"axis": "X", "level": 1}, "set_limit(axis"),
    ("set_limit", {"axis": "X", "side": "up"}, "side 'up' is not one of positive, negative"),
    ("set_home", {"axis": "Q"}, f"no axis 'Q' (axes: {', '.join(AXES[:4])} or 0..3)"),
    ("set_input", {"line": 16, "level": 1}, "line must be 0-15"),
    ("set_input", {"pin": 1, "level": 1}, "set_input(line"),
    ("set_amp_fault", {"axis": "X"}, "axis X is PSO, this needs PSM"),
    ("jam", {"axis": "X", "force": 1}, "jam(axis"),
])
def test_a_wrong_action_or_parameter_is_an_error_naming_it(
        plain: tuple[maxk.Maxk, vdevclient.Rack], action: str, params: dict[str, object],
        message: str) -> None:
    m, rack = plain
    with pytest.raises(vdevclient.VdevClientError) as info:
        rack.control("maxk0", action, **params)
    assert message in str(info.value)
    assert rp(m) == 0  # still serving
