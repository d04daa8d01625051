"""APS data sampling against a lockstep daemon [M §4.9.4; spec adlink.md §2.19, Q28]: sources,
rate in cycles, trigger with pre-trigger, F64 words, the 8-channel form, auto sampling, -10/-15."""

from __future__ import annotations

import struct
from ctypes import byref, c_int32

from vdevclient import aps

from tests.client.aps_rack import aps_session, i32, step_ms

MS = 1_000_000


def _src(signal: int, axis: int = 0) -> int:
    return signal | axis << 8


def _set(**params: int) -> None:
    names = {"rate": aps.SAMP_PA_RATE, "edge": aps.SAMP_PA_EDGE, "level": aps.SAMP_PA_LEVEL,
             "trig": aps.SAMP_PA_TRIGCH, "ch0": aps.SAMP_PA_SRC_CH0,
             "ch1": aps.SAMP_PA_SRC_CH1, "ch2": aps.SAMP_PA_SRC_CH2,
             "ch3": aps.SAMP_PA_SRC_CH3}
    for name, value in params.items():
        assert aps.APS_set_sampling_param(0, names[name], value) == 0, name


def _drain(count: int, eight: bool = False) -> tuple[list[aps.STR_SAMP_DATA_4CH], int]:
    rec = aps.STR_SAMP_DATA_8CH if eight else aps.STR_SAMP_DATA_4CH
    arr = (rec * count)()
    length, status = c_int32(count), c_int32(-1)
    get = aps.APS_get_sampling_data_ex if eight else aps.APS_get_sampling_data
    assert get(0, byref(length), arr, byref(status)) == 0
    return list(arr[:length.value]), status.value


def _f64(lo: int, hi: int) -> float:
    return struct.unpack("<d", struct.pack("<ii", lo, hi))[0]


def test_auto_sampling_records_the_command_position_every_cycle() -> None:
    """Rate 1: a record per motion cycle, the tick the cycle counter; the last record of a
    drain is the command counter now."""
    with aps_session() as (_, rack):
        _set(rate=1, ch0=_src(aps.SAMP_SRC_COM_POS), ch1=_src(aps.SAMP_SRC_CMD_VEL),
             ch2=_src(aps.SAMP_SRC_MSTS_MDN), ch3=_src(aps.SAMP_SRC_COM_POS, 1))
        assert aps.APS_auto_sampling(0, 1) == 0
        assert aps.APS_ptp(0, 0, 20000.0, None) == 0
        step_ms(rack, 150)
        recs, status = _drain(1000)
        assert status == 1  # running
        assert len(recs) == 150
        assert [r.tick for r in recs] == list(range(recs[0].tick, recs[0].tick + 150))
        assert recs[-1].data[0] == i32(aps.APS_get_command, 0) == 10000  # half way
        assert recs[-1].data[1] == 100000  # VM, pulses/s
        step_ms(rack, 250)
        assert aps.APS_auto_sampling(0, 0) == 0
        recs2, status = _drain(1000)
        assert status == 0 and len(recs2) == 250
        assert recs2[0].tick == recs[-1].tick + 1
        pos = [r.data[0] for r in recs + recs2]
        assert pos == sorted(pos) and pos[-1] == 20000
        assert [r.data[2] for r in recs2][-1] == 1 and recs[0].data[2] == 0  # MDN
        assert all(r.data[3] == 0 for r in recs2)  # axis 1 stands
        assert _drain(10)[0] == []


def test_rate_2_samples_every_other_cycle() -> None:
    with aps_session() as (_, rack):
        _set(rate=2, ch0=_src(aps.SAMP_SRC_COM_POS))
        aps.APS_auto_sampling(0, 1)
        aps.APS_ptp(0, 0, 20000.0, None)
        step_ms(rack, 400)
        recs, _ = _drain(1000)
        assert len(recs) == 200
        assert all(b.tick - a.tick == 2 for a, b in zip(recs, recs[1:], strict=False))
        assert recs[0].tick == 2  # the first record at the rate's first cycle
        assert recs[73].data[0] < 10000 <= recs[74].data[0]  # 10000 pulses at 150 ms


def test_rising_edge_trigger_with_pre_trigger_records() -> None:
    """The record where COM_POS first reaches the level is the trigger record, index
    PreTrgLen; the records before it are consecutive samples (spec §2.19 ASSUMPTION)."""
    with aps_session() as (_, rack):
        _set(rate=1, ch0=_src(aps.SAMP_SRC_COM_POS), trig=0, edge=0, level=10000)
        aps.APS_ptp(0, 0, 20000.0, None)
        arr = (aps.STR_SAMP_DATA_4CH * 100)()
        assert aps.APS_wait_trigger_sampling(0, 100, 20, 5000, arr) == 0
        assert arr[19].data[0] < 10000 <= arr[20].data[0]
        assert [r.tick for r in arr] == list(range(arr[0].tick, arr[0].tick + 100))
        assert rack.sim.now_ns() == (arr[99].tick) * MS  # returns as the last one is taken
        count = c_int32()
        assert aps.APS_get_sampling_count(0, byref(count)) == 0 and count.value == 100


def test_falling_edge_trigger_on_an_f64_source() -> None:
    """An F64 source: its channel holds the low, the next the high word of the double; the
    trigger compares the double."""
    with aps_session():
        aps.APS_set_position_f(0, 0.0)
        _set(rate=1, ch0=_src(aps.SAMP_SRC_CMD_VEL), ch1=_src(aps.SAMP_SRC_COM_POS_F64),
             trig=1, edge=1, level=-5000)
        aps.APS_ptp(0, 0, -20000.0, None)
        arr = (aps.STR_SAMP_DATA_4CH * 10)()
        assert aps.APS_wait_trigger_sampling(0, 10, 2, 5000, arr) == 0
        pos = [_f64(r.data[1], r.data[2]) for r in arr]
        assert pos[1] > -5000 >= pos[2]
        assert arr[2].data[0] < 0  # moving negative


def test_eight_channels_with_set_sampling_param_ex() -> None:
    with aps_session():
        p = aps.SAMP_PARAM(rate=1, edge=0, level=1000, trigCh=6)
        for ch, (src, axis) in enumerate([
                (aps.SAMP_SRC_COM_POS, 0), (aps.SAMP_SRC_COM_POS, 1), (aps.SAMP_SRC_MSTS, 0),
                (aps.SAMP_SRC_MIO, 0), (aps.SAMP_SRC_FBK_POS_F64, 1), (0, 0),
                (aps.SAMP_SRC_COM_POS, 7), (aps.SAMP_SRC_ERR_POS, 7)]):
            p.sourceByCh[ch][0], p.sourceByCh[ch][1] = src, axis
        assert aps.APS_set_sampling_param_ex(0, byref(p)) == 0
        back = aps.SAMP_PARAM()
        assert aps.APS_get_sampling_param_ex(0, byref(back)) == 0
        assert (back.rate, back.level, back.trigCh, back.sourceByCh[6][1]) == (1, 1000, 6, 7)
        assert aps.APS_set_servo_on(1, 1) == 0  # the drive follows: feedback = command
        aps.APS_ptp(1, 0, 500.0, None)
        aps.APS_ptp(7, 0, 2000.0, None)
        arr = (aps.STR_SAMP_DATA_8CH * 40)()
        assert aps.APS_wait_trigger_sampling_ex(0, 40, 5, 5000, arr) == 0
        assert arr[4].data[6] < 1000 <= arr[5].data[6]
        assert all(r.data[0] == 0 for r in arr)
        # the ideal drive follows the command (the encoder counts whole pulses)
        assert all(abs(_f64(r.data[4], r.data[5]) - r.data[1]) <= 1 for r in arr)
        assert _f64(arr[-1].data[4], arr[-1].data[5]) == 500.0
        assert arr[-1].data[1] > 0
        ticks = c_int32()
        assert aps.APS_get_sampling_param(0, aps.SAMP_PA_TRIGCH, byref(ticks)) == 0
        assert ticks.value == 6


def test_async_capture_fills_the_array_when_the_count_is_complete() -> None:
    with aps_session() as (_, rack):
        _set(rate=1, ch0=_src(aps.SAMP_SRC_COM_POS), level=5000)
        arr = (aps.STR_SAMP_DATA_4CH * 50)()
        assert aps.APS_wait_trigger_sampling_async(0, 50, 10, -1, arr) == 0
        count = c_int32()
        step_ms(rack, 30)
        assert aps.APS_get_sampling_count(0, byref(count)) == 0 and count.value == 10  # pre
        aps.APS_ptp(0, 0, 20000.0, None)
        step_ms(rack, 120)  # 5000 pulses at 100 ms
        aps.APS_get_sampling_count(0, byref(count))
        assert 10 < count.value < 50 and arr[0].tick == 0
        step_ms(rack, 50)
        assert aps.APS_get_sampling_count(0, byref(count)) == 0 and count.value == 50
        assert arr[9].data[0] < 5000 <= arr[10].data[0]
        assert arr[49].tick == arr[0].tick + 49


def test_a_null_count_leaves_a_finished_async_capture_uncopied() -> None:
    """-10 for a NULL SampCnt changes nothing: the capture is copied into DataArr by the next
    call that can report its count, not by the refused one."""
    with aps_session() as (_, rack):
        _set(rate=1, ch0=_src(aps.SAMP_SRC_COM_POS), level=100)
        arr = (aps.STR_SAMP_DATA_4CH * 20)()
        assert aps.APS_wait_trigger_sampling_async(0, 20, 5, -1, arr) == 0
        step_ms(rack, 10)
        aps.APS_ptp(0, 0, 2000.0, None)
        step_ms(rack, 100)
        assert aps.APS_get_sampling_count(0, None) == aps.ERR_ParametersInvalid
        assert all(r.tick == 0 for r in arr)
        count = c_int32()
        assert aps.APS_get_sampling_count(0, byref(count)) == 0 and count.value == 20
        assert arr[19].tick == arr[0].tick + 19 > 0


def test_stop_wait_sampling_abandons_the_capture() -> None:
    with aps_session() as (_, rack):
        arr = (aps.STR_SAMP_DATA_4CH * 10)()
        _set(level=1)
        assert aps.APS_wait_trigger_sampling_async(0, 10, 0, 0, arr) == 0
        assert aps.APS_auto_sampling(0, 1) == aps.ERR_CommandInProcess
        assert aps.APS_stop_wait_sampling(0) == 0
        step_ms(rack, 5)
        count = c_int32(-1)
        assert aps.APS_get_sampling_count(0, byref(count)) == 0 and count.value == 0
        assert aps.APS_auto_sampling(0, 1) == 0


def test_capture_without_trigger_times_out_after_exactly_time_out_ms() -> None:
    with aps_session() as (_, rack):
        _set(level=1)
        arr = (aps.STR_SAMP_DATA_4CH * 10)()
        start = rack.sim.now_ns()
        assert aps.APS_wait_trigger_sampling(0, 10, 0, 50, arr) == aps.ERR_TimeOut
        assert rack.sim.now_ns() == start + 50 * MS
        assert aps.APS_set_sampling_param(0, aps.SAMP_PA_RATE, 3) == 0  # the capture is gone


def test_bad_parameters_are_minus_10_and_change_nothing() -> None:
    with aps_session():
        _set(rate=4, ch0=_src(aps.SAMP_SRC_FBK_POS, 2))
        bad = [(0x1, 0), (aps.SAMP_PA_RATE, 0), (aps.SAMP_PA_EDGE, 2), (aps.SAMP_PA_TRIGCH, 8),
               (aps.SAMP_PA_SRC_CH0, 0x0E), (aps.SAMP_PA_SRC_CH0, _src(0, 8)),
               (aps.SAMP_PA_SRC_CH0, 0x1000), (aps.SAMP_PA_SRC_CH3, aps.SAMP_SRC_COM_POS_F64),
               (aps.SAMP_PA_SRC_CH1, _src(aps.SAMP_PWM_WIDTH_F64, 4))]
        for no, value in bad:
            assert aps.APS_set_sampling_param(0, no, value) == aps.ERR_ParametersInvalid, no
        got = c_int32()
        aps.APS_get_sampling_param(0, aps.SAMP_PA_RATE, byref(got))
        assert got.value == 4
        aps.APS_get_sampling_param(0, aps.SAMP_PA_SRC_CH0, byref(got))
        assert got.value == _src(aps.SAMP_SRC_FBK_POS, 2)
        p = aps.SAMP_PARAM(rate=1, trigCh=0)
        p.sourceByCh[7][0] = aps.SAMP_SRC_FBK_VEL_F64  # needs channels 7 and 8
        assert aps.APS_set_sampling_param_ex(0, byref(p)) == aps.ERR_ParametersInvalid
        assert aps.APS_set_sampling_param_ex(0, None) == aps.ERR_ParametersInvalid
        arr = (aps.STR_SAMP_DATA_4CH * 10)()
        for length, pre in ((0, 0), (10, 10), (10, -1), (65537, 0)):
            assert aps.APS_wait_trigger_sampling(0, length, pre, 10, arr) \
                == aps.ERR_ParametersInvalid
        assert aps.APS_wait_trigger_sampling(0, 11, 0, 10, arr) == aps.ERR_ParametersInvalid
        assert aps.APS_wait_trigger_sampling(0, 5, 0, -2, arr) == aps.ERR_ParametersInvalid
        assert aps.APS_wait_trigger_sampling(0, 5, 0, 10, None) == aps.ERR_ParametersInvalid
        assert aps.APS_auto_sampling(0, 2) == aps.ERR_ParametersInvalid
        aps.APS_get_sampling_param(0, aps.SAMP_PA_RATE, byref(got))
        assert got.value == 4


def test_parameters_are_locked_while_sampling_runs() -> None:
    with aps_session():
        assert aps.APS_auto_sampling(0, 1) == 0
        assert aps.APS_set_sampling_param(0, aps.SAMP_PA_RATE, 2) == aps.ERR_CommandInProcess
        arr = (aps.STR_SAMP_DATA_4CH * 10)()
        assert aps.APS_wait_trigger_sampling(0, 10, 0, 10, arr) == aps.ERR_CommandInProcess
        assert aps.APS_auto_sampling(0, 0) == 0
        assert aps.APS_set_sampling_param(0, aps.SAMP_PA_RATE, 2) == 0
