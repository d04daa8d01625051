"""Contour mode [M Ch6 §Contour Mode] on the firmware alone: the manual's trajectory of Fig. 6.5,
the 2^n-sample intervals, WC, the buffer running empty, leaving the mode, and misuse."""

from __future__ import annotations

import numpy as np
from vdevmaps.galil import AxisStatus, InterruptStatus

from tests.devices.galil.follow_rig import Rig
from vdevd.devices.galil.contour import BUFFER_SIZE
from vdevd.devices.galil.errors import TC
from vdevd.devices.galil.record import record_dtype

#: [M Ch6 §Specifying Contour Segments]: X = 0 at 0 ms, 48 at 4, 288 at 12, 336 at 28
MANUAL_PROGRAM = "CMX;DT 2;CD 48;WC;DT 3;CD 240;WC;DT 4;CD 48;WC;DT0;CD0"


def trace(rig: Rig, samples: int) -> list[int]:
    """RP X after each of the next samples."""
    out = []
    for _ in range(samples):
        rig.run(1)
        out.append(int(rig.fw.motion.reference()[0]))
    return out


def test_the_manual_s_contour_passes_its_points_at_their_times() -> None:
    rig = Rig()
    assert rig.send(MANUAL_PROGRAM) == b":::"  # CMX, DT, CD, then WC holds the rest
    rp = trace(rig, 40)
    assert rp[0:2] == [12, 24]  # "position 12 at 1 msec, position 24 at 2 msec"
    assert (rp[3], rp[11], rp[27]) == (48, 288, 336)
    assert rp[4] == 48 + 30 and rp[12] == 288 + 3  # 240 over 8 samples, 48 over 16
    assert rp[28:] == [336] * 12
    assert rig.fw.follow.contour.on is False
    assert rig.ints("SC X") == [51]  # contour stopped (spec §4.4)


def test_an_interval_lasts_2_to_the_dt_samples() -> None:
    for dt in (1, 5, 8):
        rig = Rig()
        rig.cmd(f"CMY;DT {dt};CD ,1000")
        samples = 1 << dt
        rp = [0] * 0
        for _ in range(samples + 3):
            rig.run(1)
            rp.append(int(rig.fw.motion.reference()[1]))
        assert rp.index(1000) == samples - 1  # reached at the 2^n-th sample
        assert rp[samples - 2] < 1000


def test_with_the_buffer_empty_the_axes_wait_in_contour_mode() -> None:
    rig = Rig()
    rig.cmd("CMXY;DT 1;CD 10,-20")
    assert rig.value("_CM") == 1
    rig.run(2)
    rig.run(100)
    assert rig.ints("RP X;RP Y") == [10, -20]
    assert rig.value("_CM") == 0  # the contour buffer is empty [M Ch6 §Operand Summary]
    assert int(rig.cmd("TB")) & 0x20  # TB bit 5: contouring
    assert rig.fw.rest_state() is None
    rig.cmd("CD 5,5")  # new data: the motion goes on from there
    rig.run(2)
    assert rig.ints("RP X;RP Y") == [15, -15]
    rig.cmd("DT 0;CD 0")
    rig.run(3)
    assert not int(rig.cmd("TB")) & 0x20
    rig.run(2)
    assert rig.fw.rest_state() is not None


def test_wc_waits_for_the_interval_before_the_last_one() -> None:
    rig = Rig()
    assert rig.send("CMX;DT 3;CD 80;CD 80;WC") == b"::::"
    rig.run(1)  # the first interval starts, the second waits in the buffer
    assert rig.receive() == b""
    rig.run(7)  # the first ends at its 8th sample
    assert rig.receive() == b""
    rig.run(1)  # and the second starts: WC is satisfied
    assert rig.receive() == b":"


def test_cd_with_the_buffer_full_waits_for_room() -> None:
    rig = Rig()
    rig.cmd("CMX;DT 1")
    for _ in range(BUFFER_SIZE):
        rig.cmd("CD 1")
    assert rig.send("CD 1") == b""  # held until a segment leaves the buffer
    rig.run(1)
    assert rig.receive() == b":"


def test_contour_misuse_answers_with_its_tc() -> None:
    rig = Rig()
    assert rig.refused("CD 10") == TC.NOT_VALID_WHEN_NOT_RUNNING  # CD without CM
    rig.cmd("CMX")
    assert rig.refused("CD 10") == TC.NO_TIME_SPECIFIED  # DT 0: no interval
    assert rig.refused("DT 9") == TC.NUMBER_OUT_OF_RANGE
    rig.cmd("DT 2")
    assert rig.refused("CD 32001") == TC.NUMBER_OUT_OF_RANGE  # +-32000 [M Ch6]
    rig.cmd("CD 100")
    assert rig.refused("CMY") == TC.NOT_VALID_CONTOURING  # contour data still to run
    rig = Rig()
    rig.cmd("PR 1000;BGX")
    rig.run(2)
    assert rig.refused("CMX") == TC.NOT_VALID_WHILE_RUNNING


def test_the_record_shows_contour_mode_and_its_end_is_a_motion_complete() -> None:
    """Status word bit 6 "mode of motion contour" [M Ch4 §Explanation of Status Information];
    EI bit 0: X's motion complete (D0) when the contour ends [M Ch4 §Interrupts]."""
    rig = Rig()
    dtype = record_dtype(4, "little")

    def status() -> int:
        return int(np.frombuffer(rig.fw.data_record(), dtype)["axis"]["status"][0][0])

    rig.cmd("EI 1;CMX;DT 2;CD 100")
    rig.run(2)
    assert status() & AxisStatus.CONTOUR and status() & AxisStatus.MOVING
    rig.cmd("DT 0;CD 0")
    rig.run(10)
    assert not status() & (AxisStatus.CONTOUR | AxisStatus.MOVING)
    assert rig.bus.pending_interrupts == (InterruptStatus.AXIS_COMPLETE,)
    assert rig.ints("SC X;RP X") == [51, 100]


def test_a_limit_switch_in_the_path_ends_the_contour() -> None:
    rig = Rig()
    rig.cmd("CMX;DT 3;CD 800")
    rig.run(3)
    rig.fw.set_limits(np.array([True, False, False, False]), np.zeros(4, dtype=bool))
    rig.run(20)
    x = rig.ints("RP X")[0]
    assert 0 < x < 800
    assert rig.ints("SC X") == [2] and not rig.fw.follow.contour.on
