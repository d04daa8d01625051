"""OC, output compare: CMP pulses as a main encoder passes programmed positions [M Ch3 §TTL
Outputs; spec §1; the form of OC from the Galil command reference (README "Assumptions")]."""

from __future__ import annotations

import pytest

from tests.devices.galil.test_firmware import Rig


def _run(rig: Rig, samples: int) -> list[tuple[int, int, int]]:
    """(TPX before, TPX after, pulses) of each sample."""
    fw = rig.fw
    out = []
    for _ in range(samples):
        before = int(fw.motion.position()[0])
        pulses = fw.compare.pulses
        rig.sample()
        out.append((before, int(fw.motion.position()[0]), fw.compare.pulses - pulses))
    return out


def test_pulses_every_n_counts_from_m_in_the_samples_that_pass_them() -> None:
    rig = Rig()
    events: list[int] = []
    rig.fw.on_compare = events.append
    assert rig.send(b"OCX=1000,100;SP 50000;PR 2000;BG X\r") == b"::::"
    trace = _run(rig, 200)
    assert trace[-1][1] == 2000
    positions = range(1000, 2001, 100)
    for before, after, pulses in trace:
        assert pulses == sum(before < p <= after for p in positions), (before, after)
    assert rig.fw.compare.pulses == 11
    assert events[-1] == 11 and len(events) == 11  # one event per sample that pulsed


def test_a_fast_axis_passing_several_positions_in_one_sample_pulses_for_each() -> None:
    rig = Rig()
    assert rig.send(b"OCY=3,7;JG ,120000;AC ,67107840;BG Y\r") == b"::::"
    for _ in range(20):
        rig.sample()
    tp = int(rig.fw.motion.position()[1])
    assert tp > 2000
    assert rig.fw.compare.pulses == (tp - 3) // 7 + 1  # 3, 10, 17, ... up to TP
    before = rig.fw.compare.pulses
    rig.sample()
    assert rig.fw.compare.pulses - before >= 120 // 7  # 120 counts a sample: 17 or 18 pulses


def test_n_zero_is_one_shot_once_the_position_is_passed() -> None:
    rig = Rig()
    assert rig.send(b"OCX=500;PR 1000;SP 100000;AC 67107840;BG X\r") == b":::::"
    _run(rig, 100)
    assert rig.fw.compare.pulses == 1 and rig.fw.compare.low and not rig.fw.compare.armed
    assert rig.send(b"PR -1000;BG X\r") == b"::"
    _run(rig, 100)
    assert rig.fw.compare.pulses == 1  # passing 500 again: nothing until the next OC


def test_against_the_sign_of_n_the_pulses_come_every_65536_minus_n_counts() -> None:
    """"When moving in the opposite direction, output compare pulses will occur at the
    incremental distance of 65536-|n|" [Galil command reference OC]."""
    rig = Rig()
    rig.send(b"OCX=100,-65000;JG 600000;AC 67107840;BG X\r")
    trace = _run(rig, 10)
    tp = trace[-1][1]
    assert 1100 < tp < 5000
    expected = [100 + k * 536 for k in range(20) if 100 + k * 536 <= tp]
    assert rig.fw.compare.pulses == len(expected)


def test_ocx_0_turns_the_compare_off() -> None:
    rig = Rig()
    rig.send(b"OCX=10,10;OCX=0;PR 1000;BG X\r")
    _run(rig, 100)
    assert rig.fw.compare.pulses == 0 and not rig.fw.compare.armed


@pytest.mark.parametrize(("bad", "code"), [(b"OCX=1000,70000", b"006"), (b"OCX=1.5,10", b"006"),
                                           (b"OCX=?", b"051"), (b"OC", b"050")])
def test_bad_oc_is_refused_with_its_tc_and_changes_nothing(bad: bytes, code: bytes) -> None:
    rig = Rig()
    assert rig.send(bad + b"\r") == b"?"
    assert rig.send(b"TC\r") == code + b"\r\n:"
    assert not rig.fw.compare.armed
    assert rig.send(b"TPX\r") == b"0000000000\r\n:"


def test_an_armed_compare_at_standstill_lets_the_card_rest_and_rs_clears_it() -> None:
    rig = Rig()
    rig.send(b"OCX=100,10\r")
    rig.sample()
    state = rig.fw.rest_state()
    assert state is not None
    rig.sample()
    assert rig.fw.rest_state() == state  # nothing moves: nothing can pass a position
    rig.send(b"PR 1000;AC 67107840;BG X\r")
    rig.sample()
    assert rig.fw.rest_state() is None
    _run(rig, 100)
    assert rig.fw.compare.pulses == 91
    assert rig.send(b"RS\r") == b":"
    assert rig.fw.compare.pulses == 0 and not rig.fw.compare.armed


def test_a_redefinition_of_the_position_passes_no_compare_position() -> None:
    rig = Rig()
    rig.send(b"OCX=500,10\r")
    rig.sample()
    assert rig.send(b"DP 1000\r") == b":"  # the counter jumps over 500..1000: no pulses
    rig.sample()
    assert rig.fw.compare.pulses == 0
    rig.send(b"PR -600;AC 67107840;BG X\r")  # back through 500 (against n: then every 65526)
    _run(rig, 50)
    assert rig.fw.compare.pulses == 1
