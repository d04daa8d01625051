"""Bad input through the APS client, every function family [spec adlink.md §4 "General rules",
§3.8]: a NULL (None) output pointer, NaN or infinite floats, an unknown axis or board ID, an
array shorter than its Dimension, an out-of-range parameter. Each returns the documented
negative code, changes nothing on the card (its kernel and units compared whole before and
after) and leaves the daemon serving."""

from __future__ import annotations

import hashlib
from collections import deque
from collections.abc import Callable, Iterator
from ctypes import byref, c_double, c_int32
from typing import Any

import numpy as np
import pytest
import vdevclient
from vdevclient import aps
from vdevmaps.adlink import Bar

from tests.client.aps_rack import aps_session, step_ms
from vdevd.devices.adlink.card import AdlinkCard
from vdevd.testing import DaemonThread

NAN, INF = float("nan"), float("inf")
BAD, NOT_INIT = aps.ERR_ParametersInvalid, aps.ERR_DeviceNotInitial
#: what a command changes that is no state of the card: the mailbox's bookkeeping, the load
_KERNEL_SKIP = frozenset({"ack_seq", "timing", "refusal", "buf", "records", "handlers", "units",
                          "core", "raise_line", "clear_line", "int_enable", "int_signal",
                          "_jit"})
_BAR_STATE = ((0, Bar.LOAD), (Bar.TRG_COUNT, Bar.DOORBELL), (Bar.AXIS, Bar.AXIS_END))


def _walk(obj: Any, out: list[bytes], depth: int = 0) -> None:
    """Every value `obj` holds, in order, as bytes (the kernel a unit refers to aside)."""
    if depth > 8:
        return
    if isinstance(obj, np.ndarray):
        out.append(obj.tobytes())
    elif isinstance(obj, (int, float, str, bytes, type(None))):
        out.append(repr(obj).encode())
    elif isinstance(obj, (list, tuple, deque)):
        out.append(b"[%d" % len(obj))
        for v in obj:
            _walk(v, out, depth + 1)
    elif isinstance(obj, dict):
        out.append(b"{%d" % len(obj))
        for key in sorted(obj, key=repr):
            out.append(repr(key).encode())
            _walk(obj[key], out, depth + 1)
    elif callable(obj) or not type(obj).__module__.startswith(("vdevd", "vdevmaps", "builtins")):
        out.append(b"fn")  # code and library objects: no state of the card
    else:
        fields = getattr(obj, "__dict__", None) or {
            s: getattr(obj, s) for s in getattr(type(obj), "__slots__", ()) if hasattr(obj, s)}
        for name, v in fields.items():
            if name != "k" and not callable(v):
                out.append(name.encode())
                _walk(v, out, depth + 1)


def snapshot(card: AdlinkCard) -> str:
    """A digest of the card's state: the kernel's values, every unit's, the motion core's
    axes and the status block (the load figures and the mailbox aside)."""
    k = card.kernel
    out: list[bytes] = []
    _walk({n: v for n, v in vars(k).items() if n not in _KERNEL_SKIP}, out)
    for u in k.units:
        _walk(u, out)
    _walk(vars(k.core.axes), out)
    out += [bytes(card.bar.buf[a:b]) for a, b in _BAR_STATE]
    return hashlib.sha256(b"\0".join(out)).hexdigest()


def test_every_call_before_initial_is_not_initialised() -> None:
    """First in the module: its other tests share one session."""
    assert aps.APS_ptp(0, 0, 1.0, None) == NOT_INIT
    assert aps.APS_get_position(0, byref(i32())) == NOT_INIT
    assert aps.APS_set_trigger_param(0, aps.TGR_TRG_EN, 1) == NOT_INIT
    assert aps.APS_wait_single_int(12, 0) == NOT_INIT
    assert aps.APS_line(2, [0, 1], 0, [1.0, 1.0], None) == NOT_INIT
    assert aps.APS_close() == 0


@pytest.fixture(scope="module")
def daemon() -> Iterator[tuple[DaemonThread, vdevclient.Rack, AdlinkCard]]:
    with aps_session() as (d, rack):
        assert d.server is not None
        card = d.server.rack.cards["amp0"]
        assert isinstance(card, AdlinkCard)
        for a in range(4):
            assert aps.APS_set_servo_on(a, 1) == 0
        assert aps.APS_int_enable(0, 1) == 0
        assert aps.APS_set_int_factor(0, 0, aps.IMDN, 1) >= 0
        arr = (aps.I32 * 2)(2, 3)
        assert aps.APS_pt_enable(0, 0, 2, arr) == 0
        assert aps.APS_auto_sampling(0, 1) == 0
        step_ms(rack, 5)
        assert aps.APS_auto_sampling(0, 0) == 0  # 5 records held
        yield d, rack, card


i32, f64 = c_int32, c_double
I2 = aps.I32 * 2
F2 = aps.F64 * 2
ST = aps.PTSTS
REC4 = aps.STR_SAMP_DATA_4CH


def _pt_line(dim: int, *pos: float) -> Any:
    p = aps.PTLINE()
    p.Dim = dim
    for i, v in enumerate(pos):
        p.Pos[i] = v
    return p


def _dwell(ms: float) -> Any:
    p = aps.PTDWL()
    p.DwTime = ms
    return p


#: (family, call, code): each call has one bad argument
CASES: list[tuple[str, Callable[[], int], int]] = [
    # system, parameters, status
    ("system", lambda: aps.APS_get_axis_param(0, aps.PRA_VM, None), BAD),
    ("system", lambda: aps.APS_get_axis_param_f(0, aps.PRA_VM, None), BAD),
    ("system", lambda: aps.APS_set_axis_param_f(0, aps.PRA_VM, NAN), BAD),
    ("system", lambda: aps.APS_set_axis_param_f(0, aps.PRA_VM, INF), BAD),
    ("system", lambda: aps.APS_set_axis_param_f(0, aps.PRA_ACC, -1.0), BAD),
    ("system", lambda: aps.APS_set_axis_param(99, aps.PRA_VM, 10), BAD),
    ("system", lambda: aps.APS_set_axis_param(-1, aps.PRA_VM, 10), BAD),
    ("system", lambda: aps.APS_set_board_param(7, aps.PRB_DO_LOGIC, 1), BAD),
    ("system", lambda: aps.APS_set_board_param(0, aps.PRB_DO_LOGIC, 2), BAD),
    ("system", lambda: aps.APS_get_board_param(0, aps.PRB_DO_LOGIC, None), BAD),
    ("system", lambda: aps.APS_get_first_axisId(0, None, byref(i32())), BAD),
    ("system", lambda: aps.APS_get_position(0, None), BAD),
    ("system", lambda: aps.APS_get_command_f(8, byref(f64())), BAD),
    ("system", lambda: aps.APS_set_command_f(0, NAN), BAD),
    ("system", lambda: aps.APS_set_position_f(0, INF), BAD),
    ("system", lambda: aps.APS_set_servo_on(0, 2), BAD),
    ("system", lambda: aps.APS_motion_status(-1), BAD),
    ("system", lambda: aps.APS_get_stop_code(0, None), BAD),
    ("system", lambda: aps.APS_get_board_cycle_count(0, None), BAD),
    # single-axis motion
    ("motion", lambda: aps.APS_ptp(0, 0, NAN, None), BAD),
    ("motion", lambda: aps.APS_ptp(0, 0, INF, None), BAD),
    ("motion", lambda: aps.APS_ptp(8, 0, 100.0, None), BAD),
    ("motion", lambda: aps.APS_ptp_v(0, 0, 100.0, NAN, None), BAD),
    ("motion", lambda: aps.APS_ptp_v(0, 0, 100.0, -5.0, None), BAD),
    ("motion", lambda: aps.APS_ptp_all(0, 0, 100.0, 0.0, 1e3, 0.0, INF, 1e4, 0.0, None), BAD),
    ("motion", lambda: aps.APS_ptp_all(0, 0, 100.0, 0.0, 1e3, 0.0, 1e4, 1e4, 2.0, None), BAD),
    ("motion", lambda: aps.APS_vel(0, 0, NAN, None), BAD),
    ("motion", lambda: aps.APS_vel(99, 0, 100.0, None), BAD),
    ("motion", lambda: aps.APS_vel_all(0, 0, 0.0, 1e3, 0.0, 1e4, -1.0, 0.0, None), BAD),
    ("motion", lambda: aps.APS_relative_move(0, 100, -5), BAD),
    ("motion", lambda: aps.APS_stop_move(8), BAD),
    ("motion", lambda: aps.APS_stop_move_multi(3, [0, 1]), BAD),
    ("motion", lambda: aps.APS_move_trigger(2, [0]), BAD),
    ("motion", lambda: aps.APS_move_trigger(2, None), BAD),
    # home and jog
    ("home", lambda: aps.APS_home_move(8), BAD),
    ("home", lambda: aps.APS_jog_start(0, 2), BAD),
    ("home", lambda: aps.APS_jog_start(-3, 1), BAD),
    # interpolation
    ("interp", lambda: aps.APS_line(3, [0, 1], 0, [1.0, 2.0, 3.0], None), BAD),
    ("interp", lambda: aps.APS_line(2, [0, 1], 0, [1.0], None), BAD),
    ("interp", lambda: aps.APS_line(2, [0, 1], 0, [NAN, 1.0], None), BAD),
    ("interp", lambda: aps.APS_line(2, [0, 9], 0, [1.0, 1.0], None), BAD),
    ("interp", lambda: aps.APS_line(2, [0, 1], 0, None, None), BAD),
    ("interp", lambda: aps.APS_line_v(2, [0, 1], 0, [1.0, 1.0], INF, None), BAD),
    ("interp", lambda: aps.APS_arc2_ca([0, 1], 0, [NAN, 0.0], 1.0, None), BAD),
    ("interp", lambda: aps.APS_arc2_ca([0], 0, [5.0, 0.0], 1.0, None), BAD),
    ("interp", lambda: aps.APS_arc2_ca([0, 1], 0, [5.0, 0.0], INF, None), BAD),
    ("interp", lambda: aps.APS_arc2_ce([0, 1], 0, [5.0, 0.0], [10.0], 0, None), BAD),
    ("interp", lambda: aps.APS_arc3_ca([0, 1, 2], 0, [5.0, 0.0, 0.0], [0.0, 0.0], 1.0, None),
     BAD),
    ("interp", lambda: aps.APS_spiral_ca([0, 1, 2], 0, [5.0, 0.0, 0.0], [0.0, 0.0, 1.0],
                                         1.0, NAN, 0.0, None), BAD),
    # point tables
    ("ptable", lambda: aps.APS_pt_enable(0, 1, 3, I2(0, 1)), BAD),
    ("ptable", lambda: aps.APS_pt_enable(0, 5, 2, I2(0, 1)), BAD),
    ("ptable", lambda: aps.APS_pt_enable(0, 1, 2, I2(0, 8)), BAD),
    ("ptable", lambda: aps.APS_pt_enable(0, 1, 2, None), BAD),
    ("ptable", lambda: aps.APS_pt_line(0, 0, None, byref(ST())), BAD),
    ("ptable", lambda: aps.APS_pt_line(0, 0, byref(_pt_line(2, 1.0, 2.0)), None), BAD),
    ("ptable", lambda: aps.APS_pt_line(0, 0, byref(_pt_line(2, NAN, 2.0)), byref(ST())), BAD),
    ("ptable", lambda: aps.APS_pt_line(0, 0, byref(_pt_line(3, 1.0, 2.0, 3.0)), byref(ST())),
     BAD),
    ("ptable", lambda: aps.APS_pt_line(0, 0, byref(_pt_line(7, 1.0)), byref(ST())), BAD),
    ("ptable", lambda: aps.APS_pt_dwell(0, 0, byref(_dwell(INF)), byref(ST())), BAD),
    ("ptable", lambda: aps.APS_pt_dwell(0, 0, byref(_dwell(-5.0)), byref(ST())), BAD),
    ("ptable", lambda: aps.APS_pt_dwell(1, 0, byref(_dwell(5.0)), byref(ST())), BAD),
    ("ptable", lambda: aps.APS_pt_set_vm(0, 0, NAN), BAD),
    ("ptable", lambda: aps.APS_pt_set_acc_dec(0, 0, -1.0), BAD),
    ("ptable", lambda: aps.APS_get_pt_status(0, 0, None), BAD),
    ("ptable", lambda: aps.APS_pt_get_error(0, 0, None), BAD),
    ("ptable", lambda: aps.APS_pt_ext_set_do_ch(0, 0, 99, 1), BAD),
    # gearing
    ("gear", lambda: aps.APS_start_gear(8, aps.GEAR_STANDARD), BAD),
    ("gear", lambda: aps.APS_start_gear(1, 7), BAD),
    ("gear", lambda: aps.APS_get_gear_status(1, None), BAD),
    # compare trigger and timer
    ("trigger", lambda: aps.APS_set_trigger_param(0, 0x999, 1), BAD),
    ("trigger", lambda: aps.APS_set_trigger_param(0, aps.TGR_TRG0_PWD, 0), BAD),
    ("trigger", lambda: aps.APS_set_trigger_param(3, aps.TGR_TRG_EN, 1), BAD),
    ("trigger", lambda: aps.APS_get_trigger_param(0, aps.TGR_TRG_EN, None), BAD),
    ("trigger", lambda: aps.APS_set_trigger_linear(0, 5, 0, 10, 100), BAD),
    ("trigger", lambda: aps.APS_set_trigger_table(0, 0, I2(1, 2), 5), BAD),
    ("trigger", lambda: aps.APS_set_trigger_table(0, 0, None, 2), BAD),
    ("trigger", lambda: aps.APS_set_trigger_fifo_data(0, 0, I2(1, 2), 3, 0), BAD),
    ("trigger", lambda: aps.APS_get_trigger_count(0, 0, None), BAD),
    ("trigger", lambda: aps.APS_get_trigger_count(0, 9, byref(i32())), BAD),
    ("trigger", lambda: aps.APS_get_timer_counter(0, 0, None), BAD),
    # PWM and VAO
    ("pwm", lambda: aps.APS_set_pwm_frequency(0, 9, 1000), BAD),
    ("pwm", lambda: aps.APS_set_pwm_frequency(0, 0, -1), BAD),
    ("pwm", lambda: aps.APS_get_pwm_width(0, 0, None), BAD),
    ("pwm", lambda: aps.APS_set_vao_table(0, 0, 0, 10, 5, I2(1, 2)), BAD),
    ("pwm", lambda: aps.APS_set_vao_table(0, 9, 0, 10, 2, I2(1, 2)), BAD),
    ("pwm", lambda: aps.APS_set_vao_param_ex(0, 0, None), BAD),
    ("pwm", lambda: aps.APS_get_vao_status(0, None), BAD),
    ("pwm", lambda: aps.APS_check_vao_param(0, 0, None), BAD),
    # digital I/O
    ("dio", lambda: aps.APS_read_d_input(0, 0, None), BAD),
    ("dio", lambda: aps.APS_read_d_output(0, 0, None), BAD),
    ("dio", lambda: aps.APS_write_d_output(4, 0, 1), BAD),
    ("dio", lambda: aps.APS_write_d_channel_output(0, 0, 99, 1), BAD),
    # sampling
    ("sampling", lambda: aps.APS_set_sampling_param(0, 0x999, 1), BAD),
    ("sampling", lambda: aps.APS_get_sampling_param(0, aps.SAMP_PA_RATE, None), BAD),
    ("sampling", lambda: aps.APS_get_sampling_count(0, None), BAD),
    ("sampling", lambda: aps.APS_get_sampling_data(0, byref(i32(10)), (REC4 * 5)(),
                                                   byref(i32())), BAD),
    ("sampling", lambda: aps.APS_get_sampling_data(0, None, (REC4 * 5)(), byref(i32())), BAD),
    ("sampling", lambda: aps.APS_get_sampling_data(0, byref(i32(2)), (REC4 * 5)(), None), BAD),
    ("sampling", lambda: aps.APS_get_sampling_data(0, byref(i32(2)), None, byref(i32())), BAD),
    ("sampling", lambda: aps.APS_wait_trigger_sampling(0, 10, 20, 10, (REC4 * 10)()), BAD),
    ("sampling", lambda: aps.APS_wait_trigger_sampling(0, 10, 2, 10, (REC4 * 5)()), BAD),
    ("sampling", lambda: aps.APS_wait_trigger_sampling_async(0, 10, 2, -5, (REC4 * 10)()), BAD),
    # interrupts
    ("int", lambda: aps.APS_wait_single_int(-5, 10), BAD),
    ("int", lambda: aps.APS_wait_single_int(12, -7), BAD),
    ("int", lambda: aps.APS_wait_multiple_int(3, [12, 44], 0, 10), BAD),
    ("int", lambda: aps.APS_wait_multiple_int(2, None, 0, 10), BAD),
    ("int", lambda: aps.APS_get_int_factor(0, 0, aps.IMDN, None), BAD),
    ("int", lambda: aps.APS_set_int_factor(0, 11, 0, 1), BAD),
    ("int", lambda: aps.APS_set_int_factor(0, 0, 7, 1), BAD),
    ("int", lambda: aps.APS_reset_int(5 * aps.INT_NO_PER_BOARD), BAD),
    # parameter files
    ("file", lambda: aps.APS_save_param_to_file(0, None), BAD),
    ("file", lambda: aps.APS_load_param_from_file(None), BAD),
    ("file", lambda: aps.APS_load_param_from_file(""), BAD),
    ("file", lambda: aps.APS_load_param_from_file("/nonexistent/amp.xml"), aps.ERR_FILE_FORMAT),
    ("file", lambda: aps.APS_save_param_to_file(3, "/tmp/never-written.xml"), BAD),
    # arguments of the wrong kind
    ("kind", lambda: aps.APS_set_servo_on(0.5, 1), BAD),
    ("kind", lambda: aps.APS_ptp("a", 0, 1.0, None), BAD),
    ("kind", lambda: aps.APS_ptp(0, 0, "x", None), BAD),
    ("kind", lambda: aps.APS_set_axis_param(0, aps.PRA_VM, 2**40), BAD),
    ("kind", lambda: aps.APS_ptp(2**40, 0, 1.0, None), BAD),
    ("kind", lambda: aps.APS_ptp(0, 0x7777, 1.0, None), BAD),
    ("kind", lambda: aps.APS_get_device_info(0, 99, byref(i32())), BAD),
    ("kind", lambda: aps.APS_get_card_name(0, None), BAD),
    # watchdog
    ("wdt", lambda: aps.APS_wdt_start(0, 0, -5), BAD),
    ("wdt", lambda: aps.APS_wdt_start(0, 1, 100), BAD),
    ("wdt", lambda: aps.APS_wdt_get_counter(0, 0, None), BAD),
    ("wdt", lambda: aps.APS_wdt_set_action_event(0, 0, 99), BAD),
]


@pytest.mark.parametrize(("family", "call", "code"), CASES,
                         ids=[f"{c[0]}-{i}" for i, c in enumerate(CASES)])
def test_bad_input_returns_its_code_and_changes_nothing(
        daemon: tuple[DaemonThread, vdevclient.Rack, AdlinkCard], family: str,
        call: Callable[[], int], code: int) -> None:
    _, rack, card = daemon
    before = snapshot(card)
    assert call() == code
    assert snapshot(card) == before
    assert aps.APS_motion_status(0) >= 0  # the daemon serves


def test_the_snapshot_sees_a_change_a_good_call_makes(
        daemon: tuple[DaemonThread, vdevclient.Rack, AdlinkCard]) -> None:
    """Else the sweep proves nothing: a legal value of each kind of state changes it."""
    _, _, card = daemon
    for call, undo in (
            (lambda: aps.APS_set_axis_param_f(0, aps.PRA_VM, 5e4),
             lambda: aps.APS_set_axis_param_f(0, aps.PRA_VM, 1e5)),
            (lambda: aps.APS_set_trigger_param(0, aps.TGR_TRG0_PWD, 9),
             lambda: aps.APS_set_trigger_param(0, aps.TGR_TRG0_PWD, 6)),
            (lambda: aps.APS_pt_set_vm(0, 0, 123.0), lambda: aps.APS_pt_set_vm(0, 0, 456.0)),
            (lambda: aps.APS_set_sampling_param(0, aps.SAMP_PA_RATE, 2),
             lambda: aps.APS_set_sampling_param(0, aps.SAMP_PA_RATE, 1)),
            (lambda: aps.APS_write_d_output(0, 0, 1), lambda: aps.APS_write_d_output(0, 0, 0))):
        before = snapshot(card)
        assert call() == 0
        assert snapshot(card) != before
        assert undo() == 0


def test_the_daemon_still_works_after_the_sweep(
        daemon: tuple[DaemonThread, vdevclient.Rack, AdlinkCard]) -> None:
    _, rack, _ = daemon
    assert aps.APS_ptp(0, aps.OPT_RELATIVE, 100.0, None) == 0
    step_ms(rack, 200)
    assert aps.APS_motion_status(0) & aps.MTS_MDN_V
    assert rack.stats()["scheduler"]["card_faults"] == 0


