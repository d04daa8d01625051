"""The remaining variants of the APS functions, each run once against a lockstep daemon: the
`_v` arcs and helices with their Vm, the centre-end helix forms and the manual's `sprial`
spellings, the FIFO comparator calls, the 8-channel asynchronous capture [M §4.7.2, §4.9.2,
§4.9.4; spec adlink.md §4.4, §4.8, §2.19]."""

from __future__ import annotations

import math
from collections.abc import Callable
from ctypes import byref, c_double, c_int32
from typing import Any

import pytest
from vdevclient import aps

from tests.client.aps_rack import aps_session, f64, i32, step_ms

F = c_double * 3
X2, X3 = (c_int32 * 2)(0, 1), (c_int32 * 3)(0, 1, 2)
NORMAL = F(0.0, 0.0, 1.0)


def pos(n: int) -> list[float]:
    return [f64(aps.APS_get_command_f, a) for a in range(n)]


def done(rack: Any, n: int = 3, ms: int = 3000) -> None:
    step_ms(rack, ms)
    assert all(aps.APS_motion_status(a) >> aps.MTS_MDN & 1 for a in range(n))


# (call, the end it reaches from the origin, its Vm: the time of a quarter circle of r 10)
ARCS: list[tuple[str, Callable[[], int], list[float]]] = [
    ("arc2_ca_v", lambda: aps.APS_arc2_ca_v(X2, 0, (c_double * 2)(10.0, 0.0), math.pi / 2, None,
                                            50.0, None), [10.0, -10.0, 0.0]),
    ("arc2_ce_v", lambda: aps.APS_arc2_ce_v(X2, 0, (c_double * 2)(10.0, 0.0),
                                            (c_double * 2)(20.0, 0.0), 0, None, 50.0, None),
     [20.0, 0.0, 0.0]),
    ("arc3_ca_v", lambda: aps.APS_arc3_ca_v(X3, 0, F(10.0, 0.0, 0.0), NORMAL, math.pi / 2, None,
                                            50.0, None), [10.0, -10.0, 0.0]),
    ("arc3_ce_v", lambda: aps.APS_arc3_ce_v(X3, 0, F(10.0, 0.0, 0.0), F(10.0, 10.0, 0.0), 0,
                                            None, 50.0, None), [10.0, 10.0, 0.0]),
    ("spiral_ca_v", lambda: aps.APS_spiral_ca_v(X3, 0, F(10.0, 0.0, 0.0), NORMAL, math.pi / 2,
                                                5.0, 10.0, None, 50.0, None),
     [10.0, -10.0, 5.0]),
    ("sprial_ca_v", lambda: aps.APS_sprial_ca_v(X3, 0, F(10.0, 0.0, 0.0), NORMAL, math.pi / 2,
                                                5.0, 10.0, None, 50.0, None),
     [10.0, -10.0, 5.0]),
    ("sprial_ca", lambda: aps.APS_sprial_ca(X3, 0, F(10.0, 0.0, 0.0), NORMAL, math.pi / 2,
                                            5.0, 10.0, None, None), [10.0, -10.0, 5.0]),
    ("sprial_ca_all", lambda: aps.APS_sprial_ca_all(X3, 0, F(10.0, 0.0, 0.0), NORMAL,
                                                    math.pi / 2, 5.0, 10.0, None, 0, 50.0, 0,
                                                    1e4, 1e4, 0, None), [10.0, -10.0, 5.0]),
    ("spiral_ce", lambda: aps.APS_spiral_ce(X3, 0, F(10.0, 0.0, 0.0), NORMAL, F(10.0, 10.0, 5.0),
                                            0, None, None), [10.0, 10.0, 5.0]),
    ("spiral_ce_v", lambda: aps.APS_spiral_ce_v(X3, 0, F(10.0, 0.0, 0.0), NORMAL,
                                                F(10.0, 10.0, 5.0), 0, None, 50.0, None),
     [10.0, 10.0, 5.0]),
    ("spiral_ce_all", lambda: aps.APS_spiral_ce_all(X3, 0, F(10.0, 0.0, 0.0), NORMAL,
                                                    F(10.0, 10.0, 5.0), 0, None, 0, 50.0, 0,
                                                    1e4, 1e4, 0, None), [10.0, 10.0, 5.0]),
    ("sprial_ce", lambda: aps.APS_sprial_ce(X3, 0, F(10.0, 0.0, 0.0), NORMAL, F(10.0, 10.0, 5.0),
                                            0, None, None), [10.0, 10.0, 5.0]),
    ("sprial_ce_v", lambda: aps.APS_sprial_ce_v(X3, 0, F(10.0, 0.0, 0.0), NORMAL,
                                                F(10.0, 10.0, 5.0), 0, None, 50.0, None),
     [10.0, 10.0, 5.0]),
]


@pytest.mark.parametrize("name, call, end", ARCS, ids=[a[0] for a in ARCS])
def test_arc_and_helix_variants_reach_their_end(name: str, call: Callable[[], int],
                                                end: list[float]) -> None:
    """From the origin, counterclockwise about +z [M §4.7.2]; `_v` moves at its Vm (50: a
    quarter circle of radius 10 takes ~0.31 s, which the default Vm 1e5 would do in 1 ms)."""
    with aps_session() as (_, rack):
        for a in range(3):
            assert aps.APS_set_servo_on(a, 1) == 0
        assert call() == 0
        if name.endswith("_v") and "ca" in name:
            step_ms(rack, 150)
            assert not aps.APS_motion_status(0) >> aps.MTS_MDN & 1  # still on its way at Vm 50
        done(rack)
        assert pos(3) == pytest.approx(end, abs=1e-9)


def test_fifo_comparator_calls() -> None:
    """APS_set_trigger_fifo_data, APS_enable_trigger_fifo_cmp, APS_get_trigger_fifo_cmp: the
    FIFO comparator fires on its points as the encoder passes them [M §4.9.2.2.2]."""
    with aps_session() as (_, rack):
        assert aps.APS_set_servo_on(0, 1) == 0
        for no, value in ((aps.TGR_TCMP0_SRC, 0), (aps.TGR_TCMP0_DIR, 2),
                          (aps.TGR_TRG0_SRC, 1 << 2), (aps.TGR_TRG_EN, 1)):
            assert aps.APS_set_trigger_param(0, no, value) == 0
        assert aps.APS_set_trigger_fifo_data(0, 0, (c_int32 * 3)(100, 200, 300), 3, 1) == 0
        assert aps.APS_enable_trigger_fifo_cmp(0, 0, 1) == 0
        nxt = c_int32()
        assert aps.APS_get_trigger_fifo_cmp(0, 0, byref(nxt)) == 0 and nxt.value == 100
        assert aps.APS_ptp_all(0, 0, 250.0, 0, 1000, 0, 1e5, 1e5, 0, None) == 0
        step_ms(rack, 1000)
        assert aps.APS_get_trigger_fifo_cmp(0, 0, byref(nxt)) == 0 and nxt.value == 300
        count = c_int32()
        assert aps.APS_get_trigger_count(0, 0, byref(count)) == 0 and count.value == 2
        assert aps.APS_enable_trigger_fifo_cmp(0, 0, 0) == 0  # paused: 300 passes unseen
        assert aps.APS_ptp_all(0, 0, 400.0, 0, 1000, 0, 1e5, 1e5, 0, None) == 0
        step_ms(rack, 1000)
        assert aps.APS_get_trigger_count(0, 0, byref(count)) == 0 and count.value == 2


def test_eight_channel_asynchronous_capture() -> None:
    """APS_wait_trigger_sampling_async_ex returns at once; APS_get_sampling_count follows the
    capture and fills DataArr when it is complete [spec §2.19]."""
    with aps_session() as (_, rack):
        p = aps.SAMP_PARAM(rate=1, edge=0, level=100, trigCh=0)
        p.sourceByCh[0][0], p.sourceByCh[0][1] = aps.SAMP_SRC_COM_POS, 0
        assert aps.APS_set_sampling_param_ex(0, byref(p)) == 0
        assert aps.APS_set_servo_on(0, 1) == 0
        arr = (aps.STR_SAMP_DATA_8CH * 20)()
        assert aps.APS_wait_trigger_sampling_async_ex(0, 20, 4, 5000, arr) == 0
        assert aps.APS_ptp_all(0, 0, 1000.0, 0, 1000, 0, 1e5, 1e5, 0, None) == 0
        step_ms(rack, 500)
        count = c_int32()
        assert aps.APS_get_sampling_count(0, byref(count)) == 0 and count.value == 20
        assert arr[3].data[0] < 100 <= arr[4].data[0]
        assert i32(aps.APS_get_command, 0) == 495  # 1000 x 0.5 s less the 10 ms ramp's 5
