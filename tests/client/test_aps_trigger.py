"""APS compare trigger and timer through the client against a lockstep daemon [M §4.9.2; spec
adlink.md §2.16, §4.8]."""

from __future__ import annotations

from ctypes import byref, c_int32
from typing import Any

from vdevclient import aps

from tests.client.aps_rack import amp, aps_session, i32, step_ms


def trg(getter: Any, ch: int) -> int:
    v = c_int32()
    assert getter(0, ch, byref(v)) == aps.ERR_NoError
    return v.value


def outputs(rack: Any) -> dict[str, Any]:
    return rack.card("amp0").control("get_outputs")


def test_linear_compare_counts_and_last_value_during_a_move_m_4_9_2_2_1() -> None:
    """The M §4.9.2.2.1 example: P1 = start, 4 repeats, interval L; every point passed pulses
    TRG0 once, the comparator then shows the next point, and the last one at the end."""
    with aps_session() as (_, rack):
        for no, v in ((aps.TGR_LCMP0_SRC, 0), (aps.TGR_TRG0_SRC, aps.TGR_SRC_LCMP0),
                      (aps.TGR_TRG_EN, 0b1)):
            assert aps.APS_set_trigger_param(0, no, v) == aps.ERR_NoError
        assert aps.APS_set_trigger_linear(0, 0, 2000, 4, 1500) == aps.ERR_NoError
        assert trg(aps.APS_get_trigger_linear_cmp, 0) == 2000
        assert aps.APS_set_servo_on(0, 1) == aps.ERR_NoError
        assert aps.APS_ptp(0, aps.OPT_ABSOLUTE, 10_000.0) == aps.ERR_NoError
        step_ms(rack, 100)
        enc = i32(aps.APS_get_encoder, 0)
        fired = sum(1 for p in (2000, 3500, 5000, 6500) if p <= enc)
        assert 0 < fired < 4
        assert trg(aps.APS_get_trigger_count, 0) == fired
        assert trg(aps.APS_get_trigger_linear_cmp, 0) == 2000 + 1500 * fired
        step_ms(rack, 300)
        assert trg(aps.APS_get_trigger_count, 0) == 4
        assert trg(aps.APS_get_trigger_linear_cmp, 0) == 6500
        out = outputs(rack)
        assert out["trg_count"][0] == 4 and out["trg_width_ns"][0] == 100
        assert aps.APS_reset_trigger_count(0, 0) == aps.ERR_NoError
        assert trg(aps.APS_get_trigger_count, 0) == 0


def test_table_compare_streams_a_long_table_m_4_9_2_2_2() -> None:
    """5000 points (more than the 255 + 999 FIFOs): the library streams them; every one fires."""
    with aps_session() as (_, rack):
        for no, v in ((aps.TGR_TCMP0_SRC, 0), (aps.TGR_TCMP0_DIR, aps.TGR_CMP_DIR_POSITIVE),
                      (aps.TGR_TRG0_SRC, aps.TGR_SRC_FCMP0), (aps.TGR_TRG_EN, 0b1)):
            assert aps.APS_set_trigger_param(0, no, v) == aps.ERR_NoError
        table = (c_int32 * 5000)(*range(1, 10_001, 2))
        assert aps.APS_set_trigger_table(0, 0, table, 5000) == aps.ERR_NoError
        assert trg(aps.APS_get_trigger_table_cmp, 0) == 1
        assert trg(aps.APS_get_trigger_fifo_status, 0) >> 16 == 255
        aps.APS_set_servo_on(0, 1)
        aps.APS_ptp(0, aps.OPT_ABSOLUTE, 12_000.0)
        step_ms(rack, 500)
        assert trg(aps.APS_get_trigger_count, 0) == 5000
        assert trg(aps.APS_get_trigger_table_cmp, 0) == 9999
        assert trg(aps.APS_get_trigger_fifo_status, 0) & 1  # empty


def test_table_bad_arguments_return_minus_10() -> None:
    with aps_session():
        assert aps.APS_set_trigger_table(0, 2, [1], 1) == aps.ERR_ParametersInvalid
        assert aps.APS_set_trigger_table(0, 0, [1], 0) == aps.ERR_ParametersInvalid
        assert aps.APS_set_trigger_table(0, 0, [1], 2) == aps.ERR_ParametersInvalid
        assert aps.APS_set_trigger_fifo_data(0, 0, [1], 1, 2) == aps.ERR_ParametersInvalid


def test_timer_source_fires_the_adlink_sample_x6() -> None:
    """[X6]: linear compare on the timer, start 0, 10 repeats, interval 1000, TIMR_ITV 10000
    (1 ms a count): the points come 1 s apart."""
    with aps_session() as (_, rack):
        for no, v in ((aps.TGR_LCMP0_SRC, aps.TGR_CMP_SRC_TIMER0), (aps.TGR_TRG_EN, 0b1),
                      (aps.TGR_TRG0_SRC, aps.TGR_SRC_LCMP0)):
            aps.APS_set_trigger_param(0, no, v)
        assert aps.APS_set_timer_counter(0, 0, 0) == aps.ERR_NoError
        assert aps.APS_set_trigger_linear(0, 0, 0, 10, 1000) == aps.ERR_NoError
        assert aps.APS_set_trigger_param(0, aps.TIMR_ITV, 10_000) == aps.ERR_NoError
        assert aps.APS_set_trigger_param(0, aps.TIMR_EN, 1) == aps.ERR_NoError
        step_ms(rack, 2500)
        assert trg(aps.APS_get_timer_counter, 0) == 2500
        assert trg(aps.APS_get_trigger_count, 0) == 3  # 0, 1000, 2000
        assert aps.APS_start_timer(0, 0, 0) == aps.ERR_NoError
        step_ms(rack, 100)
        assert trg(aps.APS_get_timer_counter, 0) == 2500
        assert aps.APS_get_timer_counter(0, 1, byref(c_int32())) == aps.ERR_ParametersInvalid


def test_manual_trigger_on_several_channels_and_toggle_level() -> None:
    with aps_session() as (_, rack):
        aps.APS_set_trigger_param(0, aps.TGR_TRG_EN, 0xF)
        for ch in range(4):
            aps.APS_set_trigger_param(0, aps.TGR_TRG0_SRC + ch, aps.TGR_SRC_MANUAL)
        aps.APS_set_trigger_param(0, aps.TGR_TRG1_TGL, 1)
        assert aps.APS_set_trigger_manual(0, 1) == aps.ERR_NoError
        assert aps.APS_set_trigger_manual_s(0, 0b1010) == aps.ERR_NoError
        out = outputs(rack)
        assert out["trg_count"] == [0, 2, 0, 1]
        assert out["trg_level"][1] == 0  # toggled twice
        assert aps.APS_set_trigger_manual(0, 4) == aps.ERR_ParametersInvalid


def test_trigger_parameters_read_back_with_defaults_spec_3_3() -> None:
    with aps_session():
        v = c_int32()
        assert aps.APS_get_trigger_param(0, aps.TGR_TRG0_PWD, byref(v)) == 0 and v.value == 6
        assert aps.APS_get_trigger_param(0, aps.TIMR_ITV, byref(v)) == 0 and v.value == 10_000
        assert aps.APS_set_trigger_param(0, aps.TGR_TRG0_PWD, 1) == aps.ERR_ParametersInvalid
        assert aps.APS_set_trigger_param(0, aps.TGR_TRG0_PWD, 2) == aps.ERR_NoError  # Q24
        assert aps.APS_get_trigger_param(0, aps.TGR_TRG0_PWD, byref(v)) == 0 and v.value == 2


def test_amp_204c_has_trg0_1_only_q25() -> None:
    with aps_session(amp(model="AMP-204C")):
        v = c_int32()
        assert aps.APS_get_trigger_count(0, 1, byref(v)) == aps.ERR_NoError
        assert aps.APS_get_trigger_count(0, 2, byref(v)) == aps.ERR_ParametersInvalid
        assert aps.APS_reset_trigger_count(0, 3) == aps.ERR_ParametersInvalid
        assert aps.APS_set_trigger_param(0, aps.TGR_TRG2_SRC, 1) == aps.ERR_ParametersInvalid
        assert aps.APS_set_trigger_param(0, aps.TGR_LCMP0_SRC, 5) == aps.ERR_ParametersInvalid
