"""The compare trigger unit on a bare kernel (no daemon) [M §4.9.2; spec adlink.md §2.16]: the
crossing rule, sub-cycle counting, directions, the timer, streamed tables and the system
interrupt factors ILCF/IFCF."""

from __future__ import annotations

from typing import Any

import numpy as np
from vdevmaps.adlink import BAR_SIZE, BY_NAME, decode, encode
from vdevmaps.aps_defs import (
    IFCF0,
    ILCF0,
    ILCF1,
    TGR_CMP_DIR_BIDIR,
    TGR_CMP_DIR_NEGATIVE,
    TGR_CMP_DIR_POSITIVE,
    TGR_CMP_SRC_TIMER0,
    TGR_LCMP0_SRC,
    TGR_LCMP1_SRC,
    TGR_SRC_FCMP0,
    TGR_SRC_LCMP0,
    TGR_SRC_LCMP1,
    TGR_TCMP0_DIR,
    TGR_TCMP0_SRC,
    TGR_TRG0_SRC,
    TGR_TRG1_SRC,
    TGR_TRG_EN,
    TIMR_DIR,
    TIMR_EN,
    TIMR_ITV,
    TIMR_RING_EN,
    ERR_ParametersInvalid,
)

from vdevd.devices.adlink import trigger
from vdevd.devices.adlink.kernel import ITEM_SYSTEM, Kernel

NAN = float("nan")


def kernel(n: int = 8) -> Kernel:
    k = Kernel(bytearray(BAR_SIZE), n, 0x200 + n, 0, 1000, "ideal", lambda: None)
    k.servo(np.arange(n), True)
    return k


def post(k: Kernel, name: str, *args: Any) -> tuple[int, list[Any]]:
    call = BY_NAME[name]
    k.execute(1, call.code, encode(call.args, args))
    rc = int.from_bytes(k.buf[0x1004:0x1008], "little", signed=True)
    length = int.from_bytes(k.buf[0x1008:0x100C], "little")
    return rc, decode(call.reply, bytes(k.buf[0x1010:0x1010 + length])) if rc == 0 else []


def ok(k: Kernel, name: str, *args: Any) -> list[Any]:
    rc, out = post(k, name, *args)
    assert rc == 0, (name, args, rc)
    return out


def run(k: Kernel, cycles: int) -> None:
    for _ in range(cycles):
        k.cycle()


def counts(k: Kernel) -> list[int]:
    return list(trigger.unit(k).count)


def move(k: Kernel, pos: float, vm: float = 1e5, acc: float = 1e6) -> None:
    ok(k, "ptp", 0, 0, pos, NAN, vm, NAN, acc, acc, NAN)


def route_lcmp0(k: Kernel, src: int = 0) -> None:
    ok(k, "set_trigger_param", TGR_LCMP0_SRC, src)
    ok(k, "set_trigger_param", TGR_TRG0_SRC, TGR_SRC_LCMP0)
    ok(k, "set_trigger_param", TGR_TRG_EN, 1)


# -- the crossing rule ------------------------------------------------------------------------

def test_crossed_counts_points_passed_in_order_up_to_the_new_value() -> None:
    pts = np.array([10, 20, 30, 40], dtype=np.int64)
    n, dist = trigger.crossed(pts, 5, 30, 2**32, TGR_CMP_DIR_POSITIVE, 0, False)
    assert n == 3 and dist.tolist() == [5, 15, 25]


def test_crossed_excludes_the_start_value_unless_just_armed_q21() -> None:
    pts = np.array([5, 6], dtype=np.int64)
    assert trigger.crossed(pts, 5, 1, 2**32, TGR_CMP_DIR_POSITIVE, 0, False)[0] == 0
    assert trigger.crossed(pts, 5, 1, 2**32, TGR_CMP_DIR_POSITIVE, 0, True)[0] == 2
    assert trigger.crossed(pts, 5, 0, 2**32, TGR_CMP_DIR_POSITIVE, 0, True)[0] == 1


def test_crossed_direction_only_fires_moving_that_way() -> None:
    pts = np.array([3], dtype=np.int64)
    assert trigger.crossed(pts, 5, -4, 2**32, TGR_CMP_DIR_POSITIVE, 0, False)[0] == 0
    assert trigger.crossed(pts, 5, -4, 2**32, TGR_CMP_DIR_NEGATIVE, 0, False)[0] == 1
    assert trigger.crossed(pts, 5, -4, 2**32, TGR_CMP_DIR_BIDIR, 0, False)[0] == 1


def test_crossed_wraps_at_32_bits_q20() -> None:
    pts = np.array([-2**31 + 5], dtype=np.int64)
    assert trigger.crossed(pts, 2**31 - 5, 20, 2**32, TGR_CMP_DIR_POSITIVE, 0, False)[0] == 1


def test_crossed_stops_at_a_point_behind_the_last_fired() -> None:
    pts = np.array([10, 5, 20], dtype=np.int64)  # 5 was passed before 10: not this move
    assert trigger.crossed(pts, 0, 30, 2**32, TGR_CMP_DIR_BIDIR, 0, False)[0] == 1


# -- linear compare -----------------------------------------------------------------------------

def test_linear_compare_fires_every_point_of_a_fast_move_m_4_9_2_2_1() -> None:
    """1000 points 2 counts apart at 1e5 counts/s: ~50 points per cycle, all counted."""
    k = kernel()
    route_lcmp0(k)
    ok(k, "set_trigger_linear", 0, 2, 1000, 2)
    move(k, 5000)
    run(k, 20)
    enc = int(k.core.axes.encoder[0])
    assert counts(k)[0] == min(enc // 2, 1000)
    run(k, 200)
    assert counts(k)[0] == 1000
    assert ok(k, "get_trigger_linear_cmp", 0) == [2000]  # the last point


def test_linear_compare_negative_interval_compares_downward() -> None:
    k = kernel()
    route_lcmp0(k)
    ok(k, "set_trigger_linear", 0, -100, 4, -100)
    move(k, 1000)
    run(k, 100)
    assert counts(k)[0] == 0  # moving up: no point fires
    move(k, -1000)
    run(k, 200)
    assert counts(k)[0] == 4


def test_linear_compare_end_raises_ilcf_with_the_interrupt_enabled_m_4_11() -> None:
    k = kernel()
    route_lcmp0(k)
    k.int_main = True
    k.int_enable[ITEM_SYSTEM] = 1 << ILCF0 | 1 << ILCF1
    ok(k, "set_trigger_linear", 0, 100, 3, 100)
    move(k, 250)
    run(k, 100)
    assert k.int_signal[ITEM_SYSTEM] == 0  # 2 of 3 points
    move(k, 400)
    run(k, 100)
    assert k.int_signal[ITEM_SYSTEM] == 1 << ILCF0


def test_linear_compare_on_lcmp1_drives_only_the_trg_routed_to_it() -> None:
    k = kernel()
    ok(k, "set_trigger_param", TGR_LCMP1_SRC, 0)
    ok(k, "set_trigger_param", TGR_TRG1_SRC, TGR_SRC_LCMP1)
    ok(k, "set_trigger_param", TGR_TRG_EN, 0b11)
    ok(k, "set_trigger_linear", 1, 10, 5, 10)
    move(k, 100)
    run(k, 100)
    assert counts(k)[:2] == [0, 5]


def test_trg_disabled_counts_nothing_but_the_comparator_advances() -> None:
    k = kernel()
    route_lcmp0(k)
    ok(k, "set_trigger_param", TGR_TRG_EN, 0)
    ok(k, "set_trigger_linear", 0, 10, 5, 10)
    move(k, 100)
    run(k, 100)
    assert counts(k)[0] == 0
    assert ok(k, "get_trigger_linear_cmp", 0) == [50]


def test_a_point_at_the_current_value_fires_at_the_next_update_q21() -> None:
    k = kernel()
    route_lcmp0(k)
    ok(k, "set_trigger_linear", 0, 0, 1, 1)
    run(k, 1)
    assert counts(k)[0] == 1


def test_linear_bad_arguments_are_refused_with_nothing_changed() -> None:
    k = kernel()
    for args in ((2, 0, 1, 1), (0, 0, 0, 1), (0, 0, 1, 16_777_216)):
        assert post(k, "set_trigger_linear", *args)[0] == ERR_ParametersInvalid
    assert not trigger.unit(k).lcmp[0].armed


# -- table compare ------------------------------------------------------------------------------

def test_streamed_table_arms_on_its_last_part_and_raises_ifcf_at_its_end() -> None:
    k = kernel()
    ok(k, "set_trigger_param", TGR_TCMP0_SRC, 0)
    ok(k, "set_trigger_param", TGR_TRG0_SRC, TGR_SRC_FCMP0)
    ok(k, "set_trigger_param", TGR_TRG_EN, 1)
    k.int_main = True
    k.int_enable[ITEM_SYSTEM] = 1 << IFCF0
    pts = list(range(1, 3001))
    ok(k, "set_trigger_table", 0, trigger.TABLE_FIRST, pts[:800])
    assert not trigger.unit(k).tcmp[0].armed
    ok(k, "set_trigger_table", 0, 0, pts[800:1600])
    ok(k, "set_trigger_table", 0, trigger.TABLE_LAST, pts[1600:])
    sts = ok(k, "get_trigger_fifo_status", 0)[0]
    assert sts & trigger.FIFO_FULL and sts >> 16 == trigger.HW_FIFO
    move(k, 4000)
    run(k, 20)
    enc = int(k.core.axes.encoder[0])
    assert counts(k)[0] == enc and ok(k, "get_trigger_table_cmp", 0) == [enc + 1]
    run(k, 200)
    assert counts(k)[0] == 3000
    assert ok(k, "get_trigger_fifo_status", 0)[0] & trigger.FIFO_EMPTY
    assert k.int_signal[ITEM_SYSTEM] == 1 << IFCF0


def test_table_part_without_a_first_part_is_refused() -> None:
    k = kernel()
    assert post(k, "set_trigger_table", 0, trigger.TABLE_LAST, [1])[0] == ERR_ParametersInvalid


def test_table_direction_positive_skips_points_crossed_moving_down() -> None:
    k = kernel()
    ok(k, "set_trigger_param", TGR_TCMP0_SRC, 0)
    ok(k, "set_trigger_param", TGR_TCMP0_DIR, TGR_CMP_DIR_POSITIVE)
    ok(k, "set_trigger_param", TGR_TRG0_SRC, TGR_SRC_FCMP0)
    ok(k, "set_trigger_param", TGR_TRG_EN, 1)
    move(k, 500)
    run(k, 100)
    ok(k, "set_trigger_table", 0, 3, [100, 300])
    move(k, 0)
    run(k, 100)
    assert counts(k)[0] == 0
    move(k, 500)
    run(k, 100)
    assert counts(k)[0] == 2


def test_fifo_data_appends_and_shift_flag_replaces() -> None:
    k = kernel()
    ok(k, "set_trigger_fifo_data", 0, 0, [10, 20])
    ok(k, "set_trigger_fifo_data", 0, 0, [30])
    assert trigger.unit(k).tcmp[0].remaining() == 3
    ok(k, "set_trigger_fifo_data", 0, 1, [40])
    assert trigger.unit(k).tcmp[0].remaining() == 1
    big = list(range(trigger.FIFO_DATA_MAX))
    assert post(k, "set_trigger_fifo_data", 0, 0, big)[0] == ERR_ParametersInvalid
    assert trigger.unit(k).tcmp[0].remaining() == 1


# -- timer ----------------------------------------------------------------------------------------

def test_timer_counts_one_per_interval_and_drives_a_comparator() -> None:
    k = kernel()
    route_lcmp0(k, TGR_CMP_SRC_TIMER0)
    ok(k, "set_trigger_linear", 0, 0, 10, 1000)  # the ADLINK sample's [X6]
    ok(k, "set_trigger_param", TIMR_ITV, 100)  # 10 us: 100 counts a 1 ms cycle
    ok(k, "set_trigger_param", TIMR_EN, 1)
    run(k, 50)
    assert ok(k, "get_timer_counter", 0) == [5000]
    assert counts(k)[0] == 6  # 0 (Q21), 1000 ... 5000
    ok(k, "set_trigger_param", TIMR_EN, 0)
    run(k, 5)
    assert ok(k, "get_timer_counter", 0) == [5000]


def test_timer_down_and_ring_wrap() -> None:
    k = kernel()
    ok(k, "set_trigger_param", TIMR_ITV, 10_000)
    ok(k, "set_trigger_param", TIMR_DIR, 1)
    ok(k, "set_trigger_param", TIMR_RING_EN, 1)
    ok(k, "set_timer_counter", 0, 1)
    ok(k, "start_timer", 0, 1)
    run(k, 3)
    assert ok(k, "get_timer_counter", 0) == [0x7FFFFFFE]  # 1, 0, 0x7FFFFFFF, ...
    ok(k, "set_trigger_param", TIMR_RING_EN, 0)
    ok(k, "set_timer_counter", 0, -2**31)
    run(k, 1)
    assert ok(k, "get_timer_counter", 0) == [2**31 - 1]


# -- manual trigger and parameters -------------------------------------------------------------------

def test_manual_trigger_needs_the_manual_source_bit_and_the_output_enabled() -> None:
    k = kernel()
    ok(k, "set_trigger_manual", 0b1)
    assert counts(k)[0] == 0
    ok(k, "set_trigger_param", TGR_TRG0_SRC, 1)
    ok(k, "set_trigger_manual", 0b1)
    assert counts(k)[0] == 0
    ok(k, "set_trigger_param", TGR_TRG_EN, 1)
    ok(k, "set_trigger_manual", 0b1)
    assert counts(k)[0] == 1
    ok(k, "reset_trigger_count", 0)
    assert counts(k)[0] == 0


def test_trigger_parameters_of_trg2_3_and_axes_4_7_are_refused_on_the_204c_q25() -> None:
    k = kernel(4)
    for no, v in ((TGR_TRG0_SRC + 2, 1), (TGR_TRG_EN, 0b100), (TGR_LCMP0_SRC, 4),
                  (TGR_TRG0_SRC, 0x40), (TIMR_ITV, 0), (0x07, 0)):
        assert post(k, "set_trigger_param", no, v)[0] == ERR_ParametersInvalid, hex(no)
    assert post(k, "get_trigger_param", TGR_TRG0_SRC + 3)[0] == ERR_ParametersInvalid
    assert ok(k, "get_trigger_param", TGR_TRG1_SRC) == [0]
    assert post(k, "set_trigger_manual", 0b100)[0] == ERR_ParametersInvalid
