"""APS PWM and VAO (laser power) [M §4.9.3; spec adlink.md §2.17, §4.9]: plain PWM per channel,
the VAO parameters and tables, table switching and the VAO outputs."""

from __future__ import annotations

from typing import Any

from vdevmaps.aps_defs import VAO_DATA_MAX_POINTS, ERR_NoError, ERR_ParametersInvalid

from vdevclient._aps_session import as_int, board, get_one, guarded, ints, put
from vdevclient._cargs import target


@guarded
def APS_set_vao_param(Board_ID: int, Param_No: int, Param_Val: int) -> int:
    """A VAO parameter: 0x00 + 2N output type, 0x01 + 2N input type, 0x10 + N PWM_Config,
    0x20 + N source axes of table N [M §4.9.3.5]."""
    return board(Board_ID).post("set_vao_param", as_int(Param_No), as_int(Param_Val))[0]


@guarded
def APS_get_vao_param(Board_ID: int, Param_No: int, Param_Val: Any) -> int:
    return get_one(Board_ID, "get_vao_param", (Param_No,), Param_Val)


@guarded
def APS_set_vao_table(Board_ID: int, Table_No: int, MinVelocity: int, VelInterval: int,
                      TotalPoints: int, MappingDataArray: Any) -> int:
    """Table Table_No: point i at speed MinVelocity + i x VelInterval has power
    MappingDataArray[i], 1-32 points [M §4.9.3.7]."""
    n = as_int(TotalPoints)
    if not 1 <= n <= VAO_DATA_MAX_POINTS:
        return ERR_ParametersInvalid
    return board(Board_ID).post("set_vao_table", as_int(Table_No), as_int(MinVelocity),
                                as_int(VelInterval), ints(MappingDataArray, n))[0]


@guarded
def APS_switch_vao_table(Board_ID: int, Table_No: int) -> int:
    """Select the VAO's table (0-7; -1 disables every table)."""
    return board(Board_ID).post("switch_vao_table", as_int(Table_No))[0]


@guarded
def APS_start_vao(Board_ID: int, Output_Ch: int, Enable: int) -> int:
    """Start (1) or stop (0) the VAO on the PWM channels of the bit mask Output_Ch (spec Q17)."""
    return board(Board_ID).post("start_vao", as_int(Output_Ch), as_int(Enable))[0]


@guarded
def APS_get_vao_status(Board_ID: int, Status: Any) -> int:
    """Bits 0-7: the active table; bit 16 + n: the VAO drives PWM n."""
    rc, vals = board(Board_ID).post("get_vao_status")
    if rc == ERR_NoError:
        put(Status, vals[0])
    return rc


@guarded
def APS_check_vao_param(Board_ID: int, Table_No: int, Status: Any) -> int:
    """Status 0 when table Table_No can drive the output (vdevd's bits: 1 PWM_Config outside its
    mode's range, 2 no points, 4 a power outside the mode's range)."""
    return get_one(Board_ID, "check_vao_param", (Table_No,), Status)


@guarded
def APS_set_vao_param_ex(Board_ID: int, Table_No: int, VaoData: Any) -> int:
    """A whole table from a VAO_DATA, all fields checked before any is set."""
    d = target(VaoData)
    if d is None:
        return ERR_ParametersInvalid
    n = as_int(d.totalPoints)
    if not 1 <= n <= VAO_DATA_MAX_POINTS:
        return ERR_ParametersInvalid
    return board(Board_ID).post(
        "set_vao_param_ex", as_int(Table_No), as_int(d.outputType), as_int(d.inputType),
        as_int(d.config), as_int(d.inputSrc), as_int(d.minVel), as_int(d.velInterval),
        list(d.mappingDataArr)[:n])[0]


@guarded
def APS_get_vao_param_ex(Board_ID: int, Table_No: int, VaoData: Any) -> int:
    d = target(VaoData)
    if d is None:
        return ERR_ParametersInvalid
    rc, vals = board(Board_ID).post("get_vao_param_ex", as_int(Table_No))
    if rc != ERR_NoError:
        return rc
    d.outputType, d.inputType, d.config, d.inputSrc, d.minVel, d.velInterval, data = vals
    d.totalPoints = len(data)
    for i in range(VAO_DATA_MAX_POINTS):
        d.mappingDataArr[i] = data[i] if i < len(data) else 0
    return ERR_NoError


@guarded
def APS_set_pwm_frequency(Board_ID: int, PWM_Ch: int, Frequency: int) -> int:
    """Hz, 3 ... 50 000 000 [X5]."""
    return board(Board_ID).post("set_pwm_frequency", as_int(PWM_Ch), as_int(Frequency))[0]


@guarded
def APS_get_pwm_frequency(Board_ID: int, PWM_Ch: int, Frequency: Any) -> int:
    return get_one(Board_ID, "get_pwm_frequency", (PWM_Ch,), Frequency)


@guarded
def APS_set_pwm_width(Board_ID: int, PWM_Ch: int, Width: int) -> int:
    """ns, 20 ... 335 544 300 [X5]."""
    return board(Board_ID).post("set_pwm_width", as_int(PWM_Ch), as_int(Width))[0]


@guarded
def APS_get_pwm_width(Board_ID: int, PWM_Ch: int, Width: Any) -> int:
    return get_one(Board_ID, "get_pwm_width", (PWM_Ch,), Width)


@guarded
def APS_set_pwm_on(Board_ID: int, PWM_Ch: int, PWM_On: int) -> int:
    """Plain PWM on (1) or off (0); not together with APS_start_vao on a channel [X5]."""
    return board(Board_ID).post("set_pwm_on", as_int(PWM_Ch), as_int(PWM_On))[0]


__all__ = [n for n in dir() if n.startswith("APS_")]
