"""Record mode of the DMC-13X8 firmware (recorder.py): RA, RD, RC n,m capture operands into arrays
every 2^n samples, `_RC` and `_RD`, RC 0, and what recording does to rest (decision 0008)
[M Ch6 §Teach (Record and Play-Back); spec §1.2 "Record interval"]."""

from __future__ import annotations

import pytest

from tests.devices.galil.test_arrays import mg, refused, whole_reply
from tests.devices.galil.test_firmware import Rig


def values(rig: Rig, name: str) -> list[float]:
    reply = whole_reply(rig, f"QU {name}[],,,1\r".encode())
    return [float(v) for v in reply[:-3].split(b",")]


@pytest.fixture
def rig() -> Rig:
    return Rig()


def test_record_mode_captures_tp_every_2_to_the_n_samples_while_x_moves(rig: Rig) -> None:
    """The teach example's setup (`DM XPOS[501]; RA XPOS[]; RD _TPX; RC2`), with TIME recorded
    beside: each element is what TP reported at the sample its TIME names, 4 samples apart."""
    assert rig.send(b"DM XPOS[50],T[50];RA XPOS[],T[];RD _TPX,TIME\r") == b":::"
    assert rig.send(b"AC 1000000;DC 1000000;SP 200000;PR 20000;BGX\r") == b":::::"
    assert rig.send(b"RC 2,40\r") == b":"
    told: dict[int, float] = {}  # TIME -> TP after that sample
    for _ in range(200):
        rig.sample()
        told[int(mg(rig, "TIME"))] = mg(rig, "_TPX")
    times, positions = values(rig, "T"), values(rig, "XPOS")
    recorded = times[:40]
    assert [b - a for a, b in zip(recorded, recorded[1:], strict=False)] == [4] * 39
    assert positions[:40] == [told[int(t)] for t in recorded]
    assert positions[39] > positions[0] + 1000  # the axis moved while it recorded
    assert times[40:] == [0] * 10 and positions[40:] == [0] * 10  # m = 40 records
    assert mg(rig, "_RC") == 0 and mg(rig, "_RD") == 40
    assert rig.send(b"RC ?\r") == b"0\r\n:"


def test_the_first_record_is_the_sample_after_rc_and_m_omitted_fills_the_array(rig: Rig) -> None:
    rig.send(b"DM T[8];RA T[];RD TIME\r")
    start = mg(rig, "TIME")
    rig.send(b"RC 1\r")
    assert mg(rig, "_RC") == 1 and rig.send(b"RC ?\r") == b"1\r\n:"
    for _ in range(20):
        rig.sample()
    assert values(rig, "T") == [start + 1 + 2 * k for k in range(8)]
    assert mg(rig, "_RC") == 0 and mg(rig, "_RD") == 8


def test_rc_0_stops_recording(rig: Rig) -> None:
    rig.send(b"DM T[100];RA T[];RD TIME;RC 1\r")
    for _ in range(10):
        rig.sample()
    assert rig.send(b"RC 0\r") == b":"
    assert mg(rig, "_RC") == 0 and mg(rig, "_RD") == 5
    before = values(rig, "T")
    for _ in range(10):
        rig.sample()
    assert values(rig, "T") == before
    assert before[4] > 0 and before[5:] == [0] * 95


def test_a_negative_m_records_circularly_until_rc_0(rig: Rig) -> None:
    rig.send(b"DM T[10];RA T[];RD TIME\r")
    start = mg(rig, "TIME")
    rig.send(b"RC 1,-4\r")
    for _ in range(2 * 10):  # ten records into four elements
        rig.sample()
    assert mg(rig, "_RC") == 1 and mg(rig, "_RD") == 10 % 4
    assert values(rig, "T")[:4] == [start + 1 + 2 * k for k in (8, 9, 6, 7)]
    rig.send(b"RC 0\r")


def test_recording_operands_of_io_and_several_axes(rig: Rig) -> None:
    rig.send(b"DM A[4],B[4],C[4],D[4];OP 165;DP ,-300\r")
    rig.send(b"RA A[],B[],C[],D[];RD _OP,_TPY,_TEX,_TI;RC 1,4\r")
    for _ in range(4):
        rig.sample()
    rig.fw.set_input(2, 0)
    for _ in range(4):
        rig.sample()
    assert values(rig, "A") == [165] * 4
    assert values(rig, "B") == [-300] * 4
    assert values(rig, "C") == [0] * 4
    assert values(rig, "D") == [255, 255, 253, 253]  # IN2 low from the third record on


@pytest.mark.parametrize(("setup", "line", "code"), [
    (b"", b"RC 1\r", 81),  # no RA, no RD
    (b"RA T[]\r", b"RC 1\r", 81),  # no RD
    (b"RA T[],U[];RD TIME\r", b"RC 1\r", 81),  # an array without a source
    (b"", b"RA NONE[]\r", 82),
    (b"", b"RA T[],U[],T[],U[],T[]\r", 6),  # up to 4
    (b"", b"RD _XYZ\r", 57),
    (b"", b"RD _TPX+1\r", 57),  # an operand, not an expression
    (b"RA T[];RD TIME\r", b"RC 1,11\r", 84),  # more records than elements
    (b"RA T[];RD TIME\r", b"RC 9\r", 6),  # n 1..8
    (b"RA T[];RD TIME;DA T[]\r", b"RC 1\r", 82),  # deallocated since RA
])
def test_a_bad_record_setup_is_refused_and_nothing_records(rig: Rig, setup: bytes, line: bytes,
                                                          code: int) -> None:
    rig.send(b"DM T[10],U[10]\r")
    rig.send(setup)
    assert refused(rig, line) == code
    assert mg(rig, "_RC") == 0


def test_ra_rd_rc_and_da_of_a_recorded_array_are_tc_80_while_recording(rig: Rig) -> None:
    rig.send(b"DM T[100],U[5];RA T[];RD TIME;RC 3\r")
    assert refused(rig, b"RA U[]\r") == 80
    assert refused(rig, b"RD _TPX\r") == 80
    assert refused(rig, b"RC 2\r") == 80
    assert refused(rig, b"DA T[]\r") == 80
    assert refused(rig, b"DA *[]\r") == 80
    assert rig.send(b"DA U[]\r") == b":"  # not recorded
    assert mg(rig, "_RC") == 1
    assert rig.send(b"RC 0;DA T[]\r") == b"::"


def test_the_card_is_not_at_rest_while_it_records_and_runs_no_sample_past_a_record(rig: Rig) -> None:
    """Decision 0008: rest_state is None while recording; a run of motion-only samples stops
    before the sample that records."""
    fw = rig.fw
    rig.sample()
    assert fw.rest_state() is not None
    rig.send(b"DM T[10];RA T[];RD TIME;RC 4,3\r")
    assert fw.rest_state() is None
    assert fw.idle_samples(1000) == 0  # the next sample records
    rig.sample()
    assert fw.idle_samples(1000) == 15
    fw.run_samples(fw.idle_samples(1000), lambda k: None)
    rig.sample()
    assert mg(rig, "_RD") == 2
    for _ in range(16):
        rig.sample()
    assert mg(rig, "_RC") == 0
    assert fw.rest_state() is not None
    assert fw.idle_samples(1000) == 1000


def test_rs_stops_recording(rig: Rig) -> None:
    rig.send(b"DM T[10];RA T[];RD TIME;RC 1\r")
    rig.send(b"RS\r")
    assert mg(rig, "_RC") == 0
    rig.sample()
    assert rig.fw.rest_state() is not None
