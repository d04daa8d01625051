"""APS PWM, VAO and digital I/O through the client against a lockstep daemon [M §4.9.3; spec
adlink.md §2.17, §2.18, §4.6, §4.9]."""

from __future__ import annotations

from ctypes import byref, c_int32
from typing import Any

import pytest
from vdevclient import aps

from tests.client.aps_rack import amp, aps_session, step_ms


def get(getter: Any, *args: int) -> int:
    v = c_int32()
    assert getter(0, *args, byref(v)) == aps.ERR_NoError
    return v.value


def outputs(rack: Any) -> dict[str, Any]:
    return rack.card("amp0").control("get_outputs")


# -- PWM -------------------------------------------------------------------------------------------

@pytest.mark.parametrize(("setter", "lo", "hi"), [
    (aps.APS_set_pwm_frequency, aps.PWM_FREQUENCY_MIN, aps.PWM_FREQUENCY_MAX),
    (aps.APS_set_pwm_width, aps.PWM_WIDTH_MIN, aps.PWM_WIDTH_MAX)])
def test_pwm_parameters_within_the_documented_ranges_else_minus_10(setter: Any, lo: int,
                                                                  hi: int) -> None:
    getter = aps.APS_get_pwm_frequency if setter is aps.APS_set_pwm_frequency \
        else aps.APS_get_pwm_width
    with aps_session():
        for v in (lo, hi):
            assert setter(0, 1, v) == aps.ERR_NoError
            assert get(getter, 1) == v
        for v in (lo - 1, hi + 1):
            assert setter(0, 1, v) == aps.ERR_ParametersInvalid
        assert get(getter, 1) == hi
        assert setter(0, 4, lo) == aps.ERR_ParametersInvalid


def test_pwm_on_outputs_frequency_width_and_duty() -> None:
    with aps_session() as (_, rack):
        aps.APS_set_pwm_frequency(0, 0, 10_000)
        aps.APS_set_pwm_width(0, 0, 25_000)
        assert outputs(rack)["pwm"][0]["on"] is False
        assert aps.APS_set_pwm_on(0, 0, 1) == aps.ERR_NoError
        ch = outputs(rack)["pwm"][0]
        assert ch["on"] and ch["frequency"] == 10_000 and ch["width"] == 25_000
        assert ch["duty"] == pytest.approx(25.0)
        assert aps.APS_set_pwm_on(0, 0, 2) == aps.ERR_ParametersInvalid
        aps.APS_set_pwm_on(0, 0, 0)
        assert outputs(rack)["pwm"][0]["on"] is False


def test_amp_204c_has_pwm0_1_only_q25() -> None:
    with aps_session(amp(model="AMP-204C")):
        assert aps.APS_set_pwm_on(0, 1, 1) == aps.ERR_NoError
        assert aps.APS_set_pwm_on(0, 2, 1) == aps.ERR_ParametersInvalid
        assert aps.APS_set_pwm_frequency(0, 3, 1000) == aps.ERR_ParametersInvalid
        assert aps.APS_start_vao(0, 0b100, 1) == aps.ERR_ParametersInvalid


def test_pwm_gated_by_a_do_channel_and_its_logic_m_4_9_3_6() -> None:
    """PRB_PWM0_MAP_DO = DO2 with logic 1: PWM0 outputs while DO2 is on; logic 0: the inverse."""
    with aps_session() as (_, rack):
        aps.APS_set_pwm_on(0, 0, 1)
        assert aps.APS_set_board_param(0, aps.PRB_PWM0_MAP_DO, 0x100 | 2) == aps.ERR_NoError
        assert outputs(rack)["pwm"][0]["on"] is False
        assert aps.APS_write_d_channel_output(0, 0, 2, 1) == aps.ERR_NoError
        assert outputs(rack)["pwm"][0]["on"] is True
        aps.APS_set_board_param(0, aps.PRB_PWM0_MAP_DO, 2)
        assert outputs(rack)["pwm"][0]["on"] is False
        aps.APS_write_d_channel_output(0, 0, 2, 0)
        assert outputs(rack)["pwm"][0]["on"] is True
        aps.APS_set_board_param(0, aps.PRB_PWM0_MAP_DO, aps.PWM_MAP_DO_DISABLED)
        assert outputs(rack)["pwm"][0]["on"] is True


# -- VAO -------------------------------------------------------------------------------------------

def vao_setup() -> None:
    """Table 0: mode 1 at 1000 Hz, command speed of axes 0-1, duty 0-1600 over 0-8000 pulses/s;
    table 1: mode 3 at 10 % duty, 1000-3000 Hz over 0-10000 pulses/s [M §4.9.3.7]."""
    for no, v in ((0x00, aps.VAO_OUTPUT_FIX_FREQUENCY), (0x01, aps.VAO_INPUT_COMMAND),
                  (0x10, 1000), (0x20, 0b11),
                  (0x02, aps.VAO_OUTPUT_FIX_DUTY), (0x03, aps.VAO_INPUT_COMMAND),
                  (0x11, 200), (0x21, 0b11)):
        assert aps.APS_set_vao_param(0, no, v) == aps.ERR_NoError, hex(no)
    table0 = (c_int32 * 5)(0, 400, 800, 1200, 1600)
    assert aps.APS_set_vao_table(0, 0, 0, 2000, 5, table0) == aps.ERR_NoError
    assert aps.APS_set_vao_table(0, 1, 0, 10_000, 2, [1000, 3000]) == aps.ERR_NoError
    assert get(aps.APS_check_vao_param, 0) == 0 and get(aps.APS_check_vao_param, 1) == 0


def test_vao_output_follows_the_composite_speed_through_the_table_m_4_9_3_3() -> None:
    with aps_session() as (_, rack):
        vao_setup()
        assert aps.APS_switch_vao_table(0, 0) == aps.ERR_NoError
        assert aps.APS_start_vao(0, 0b101, 1) == aps.ERR_NoError
        assert get(aps.APS_get_vao_status) == 1 | 0b101 << 16
        out = outputs(rack)
        assert out["pwm"][0]["on"] and out["pwm"][0]["duty"] == 0.0  # at rest: P0
        aps.APS_set_servo_on(0, 1)
        aps.APS_set_servo_on(1, 1)
        aps.APS_vel(0, 0, 3000.0)
        aps.APS_vel(1, 0, -4000.0)
        step_ms(rack, 50)
        out = outputs(rack)
        vao = out["vao"][0]
        assert vao["speed"] == pytest.approx(5000.0)
        assert vao["power"] == 1000  # between (4000, 800) and (6000, 1200)
        for ch in (0, 2):
            pwm = out["pwm"][ch]
            assert pwm["source"] == "vao" and pwm["frequency"] == 1000
            assert pwm["duty"] == pytest.approx(50.0) and pwm["width"] == pytest.approx(5e5)
        assert out["pwm"][1]["on"] is False
        aps.APS_vel(0, 0, 9000.0)
        step_ms(rack, 50)
        assert outputs(rack)["vao"][0]["power"] == 1600  # above the last point: its power
        aps.APS_vel(0, 0, 3000.0)
        step_ms(rack, 50)
        assert aps.APS_switch_vao_table(0, 1) == aps.ERR_NoError
        pwm = outputs(rack)["pwm"][0]
        assert pwm["frequency"] == 2000 and pwm["duty"] == pytest.approx(10.0)
        assert pwm["width"] == pytest.approx(5e4)
        assert aps.APS_start_vao(0, 0b1, 0) == aps.ERR_NoError
        out = outputs(rack)
        assert out["pwm"][0]["on"] is False and out["pwm"][2]["on"] is True
        assert aps.APS_switch_vao_table(0, -1) == aps.ERR_NoError
        assert outputs(rack)["pwm"][2]["on"] is False


def test_vao_fixed_width_mode_gives_frequency_and_duty_m_4_9_3_2() -> None:
    with aps_session() as (_, rack):
        data = aps.VAO_DATA(outputType=aps.VAO_OUTPUT_FIX_WIDTH, inputType=1, config=1000,
                            inputSrc=0b1, minVel=0, velInterval=1000, totalPoints=2)
        data.mappingDataArr[0], data.mappingDataArr[1] = 10_000, 20_000
        assert aps.APS_set_vao_param_ex(0, 3, byref(data)) == aps.ERR_NoError
        back = aps.VAO_DATA()
        assert aps.APS_get_vao_param_ex(0, 3, byref(back)) == aps.ERR_NoError
        assert (back.outputType, back.config, back.totalPoints) == (2, 1000, 2)
        assert list(back.mappingDataArr)[:3] == [10_000, 20_000, 0]
        aps.APS_switch_vao_table(0, 3)
        aps.APS_start_vao(0, 0b10, 1)
        aps.APS_set_servo_on(0, 1)
        aps.APS_vel(0, 0, 500.0)
        step_ms(rack, 20)
        pwm = outputs(rack)["pwm"][1]
        assert pwm["frequency"] == 15_000 and pwm["width"] == 1000
        assert pwm["duty"] == pytest.approx(1.5)


def test_vao_bad_parameters_and_tables_return_minus_10_with_nothing_changed() -> None:
    with aps_session():
        for no, v in ((0x00, 4), (0x01, 2), (0x10, 2), (0x20, 0), (0x20, 0x10), (0x30, 1)):
            assert aps.APS_set_vao_param(0, no, v) == aps.ERR_ParametersInvalid, hex(no)
        assert get(aps.APS_get_vao_param, 0x10) == 100
        assert aps.APS_set_vao_table(0, 0, 0, 100, 1, [2001]) == aps.ERR_ParametersInvalid
        assert aps.APS_set_vao_table(0, 0, 0, 100, 33, [0] * 33) == aps.ERR_ParametersInvalid
        assert aps.APS_set_vao_table(0, 0, 0, 0, 2, [0, 1]) == aps.ERR_ParametersInvalid
        assert aps.APS_set_vao_table(0, 8, 0, 100, 1, [0]) == aps.ERR_ParametersInvalid
        assert get(aps.APS_check_vao_param, 0) == 2  # no points
        assert aps.APS_switch_vao_table(0, 8) == aps.ERR_ParametersInvalid
        assert aps.APS_start_vao(0, 0, 1) == aps.ERR_ParametersInvalid
        assert aps.APS_start_vao(0, 1, 2) == aps.ERR_ParametersInvalid


# -- digital I/O ------------------------------------------------------------------------------------

def test_do_word_and_channels_with_logic_inversion_spec_2_18() -> None:
    with aps_session() as (_, rack):
        assert aps.APS_write_d_output(0, 0, 0x12345) == aps.ERR_NoError
        assert get(aps.APS_read_d_output, 0) == 0x12345
        assert outputs(rack)["do"] == 0x12345
        assert aps.APS_write_d_channel_output(0, 0, 23, 1) == aps.ERR_NoError
        assert get(aps.APS_read_d_channel_output, 0, 23) == 1
        assert get(aps.APS_read_d_channel_output, 0, 1) == 0
        aps.APS_set_board_param(0, aps.PRB_DO_LOGIC, 1)
        assert get(aps.APS_read_d_output, 0) == 0x812345  # as written
        assert outputs(rack)["do"] == 0x812345 ^ 0xFFFFFF  # at the connector
        assert aps.APS_write_d_output(0, 1, 0) == aps.ERR_ParametersInvalid
        assert aps.APS_write_d_channel_output(0, 0, 24, 1) == aps.ERR_ParametersInvalid
        assert aps.APS_write_d_channel_output(0, 0, 0, 2) == aps.ERR_ParametersInvalid
        assert get(aps.APS_read_d_output, 0) == 0x812345


def test_di_word_with_logic_inversion_spec_2_18() -> None:
    with aps_session() as (_, rack):
        card = rack.card("amp0")
        card.control("set_di", channel=9, level=True)
        card.control("set_di", channel=2, level=True)
        assert get(aps.APS_read_d_input, 0) == 1 << 9 | 1 << 2
        aps.APS_set_board_param(0, aps.PRB_DI_LOGIC, 1)
        assert get(aps.APS_read_d_input, 0) == (1 << 9 | 1 << 2) ^ 0xFFFFFF
        assert aps.APS_read_d_input(0, 1, byref(c_int32())) == aps.ERR_ParametersInvalid


def test_amp_204c_lacks_edo4_7() -> None:
    with aps_session(amp(model="AMP-204C")):
        assert aps.APS_write_d_output(0, 0, 0xFFFFFF) == aps.ERR_NoError
        assert get(aps.APS_read_d_output, 0) == 0xFFFF0F
        assert aps.APS_write_d_channel_output(0, 0, 5, 1) == aps.ERR_ParametersInvalid
        assert aps.APS_read_d_channel_output(0, 0, 4, byref(c_int32())) \
            == aps.ERR_ParametersInvalid


def test_analog_functions_are_not_available_on_the_amp() -> None:
    with aps_session():
        v = c_int32()
        assert aps.APS_read_a_input_value(0, 0, byref(v)) == aps.ERR_FunctionNotAvailable
        assert aps.APS_read_a_input_data(0, 0, byref(v)) == aps.ERR_FunctionNotAvailable
        assert aps.APS_write_a_output_value(0, 0, 1.0) == aps.ERR_FunctionNotAvailable
        assert aps.APS_write_a_output_data(0, 0, 1) == aps.ERR_FunctionNotAvailable
        assert aps.APS_read_a_output_value(0, 0, byref(v)) == aps.ERR_FunctionNotAvailable
        assert aps.APS_read_a_input_value(5, 0, byref(v)) == aps.ERR_ParametersInvalid
