"""APS host interrupts against a lockstep daemon [M §4.11; spec adlink.md §2.23, §4.7]: events on
the rising edge of their condition, waits in simulated time, -8/-9/-10."""

from __future__ import annotations

from ctypes import byref, c_int32

from vdevclient import aps

from tests.client.aps_rack import amp, aps_session, step_ms

MS = 1_000_000
AXIS_ITEM0, SYSTEM, DI_RISE, DI_FALL = 0, 8, 9, 10


def _open(item: int, factor: int, board: int = 0) -> int:
    no = aps.APS_set_int_factor(board, item, factor, 1)
    assert no >= 0
    assert aps.APS_int_enable(board, 1) == 0
    return no


def test_int_no_is_board_352_item_32_factor() -> None:
    """spec §2.23 ASSUMPTION (Q23); the handle is opaque and non-NULL."""
    with aps_session():
        assert aps.APS_set_int_factor(0, 3, aps.IMDN, 1) == 3 * 32 + 12
        assert aps.APS_set_int_factor(0, SYSTEM, aps.IEMG_SYS, 1) == 8 * 32
        assert aps.APS_set_int_factor(0, DI_FALL, 23, 1) == 10 * 32 + 23
        assert aps.APS_int_no_to_handle(3 * 32 + 12) == aps.APS_set_int_factorH(0, 3, 12, 1) != 0
        assert aps.APS_int_no_to_handle(5 * aps.INT_NO_PER_BOARD) == 0  # no board 5
        enable = c_int32(7)
        assert aps.APS_get_int_factor(0, 3, aps.IMDN, byref(enable)) == 0 and enable.value == 1
        assert aps.APS_set_int_factor(0, 3, aps.IMDN, 0) == 3 * 32 + 12
        assert aps.APS_get_int_factor(0, 3, aps.IMDN, byref(enable)) == 0 and enable.value == 0


def test_imdn_interrupt_wakes_the_wait_when_the_ptp_is_done() -> None:
    """IMDN (axis factor 12) [M §4.11]: a 20000-pulse T-curve move at the default VM 1e5,
    ACC/DEC 1e6 takes 300 ms; the wait returns in the cycle whose status shows MDN."""
    with aps_session() as (_, rack):
        no = _open(AXIS_ITEM0, aps.IMDN)
        assert aps.APS_ptp(0, 0, 20000.0, None) == 0
        assert aps.APS_wait_single_int(no, 5000) == 0
        now = rack.sim.now_ns()
        assert 300 * MS <= now <= 301 * MS
        assert aps.APS_motion_status(0) & aps.MTS_MDN_V
        step_ms(rack, 0)
        before = rack.sim.now_ns()
        # [M §4.11 step (4)]: signaled until reset, so the next wait returns at once
        assert aps.APS_wait_single_int(no, 5000) == 0
        assert rack.sim.now_ns() == before


def test_wait_with_no_event_times_out_after_exactly_time_out_ms() -> None:
    with aps_session() as (_, rack):
        no = _open(AXIS_ITEM0, aps.IMDN)
        start = rack.sim.now_ns()
        assert aps.APS_wait_single_int(no, 250) == aps.ERR_TimeOut
        assert rack.sim.now_ns() == start + 250 * MS
        assert aps.APS_wait_single_int(no, 0) == aps.ERR_TimeOut  # a poll
        assert rack.sim.now_ns() == start + 250 * MS


def test_a_condition_already_true_fires_only_at_its_next_rising_edge() -> None:
    """spec §2.23 ASSUMPTION: MDN is 1 at rest, enabling IMDN does not signal it."""
    with aps_session():
        no = _open(AXIS_ITEM0, aps.IMDN)
        assert aps.APS_wait_single_int(no, 20) == aps.ERR_TimeOut


def test_wait_on_a_closed_factor_or_with_the_main_switch_off_is_minus_8() -> None:
    with aps_session() as (_, rack):
        no = aps.APS_set_int_factor(0, AXIS_ITEM0, aps.IMDN, 1)
        start = rack.sim.now_ns()
        assert aps.APS_wait_single_int(no, 100) == aps.ERR_InterruptNotEnable  # main off
        assert aps.APS_int_enable(0, 1) == 0
        closed = AXIS_ITEM0 * 32 + aps.IACC
        assert aps.APS_wait_single_int(closed, 100) == aps.ERR_InterruptNotEnable
        assert aps.APS_wait_multiple_int(2, [no, closed], 0, 100) == aps.ERR_InterruptNotEnable
        assert rack.sim.now_ns() == start  # refused before any waiting


def test_no_event_is_signaled_while_the_main_switch_is_off() -> None:
    with aps_session() as (_, rack):
        no = aps.APS_set_int_factor(0, AXIS_ITEM0, aps.IMDN, 1)
        aps.APS_ptp(0, 0, 1000.0, None)
        step_ms(rack, 200)
        assert aps.APS_int_enable(0, 1) == 0
        assert aps.APS_wait_single_int(no, 10) == aps.ERR_TimeOut


def test_reset_int_clears_the_event() -> None:
    with aps_session():
        no = _open(AXIS_ITEM0, aps.IMDN)
        aps.APS_ptp(0, 0, 1000.0, None)
        assert aps.APS_wait_single_int(no, 1000) == 0
        assert aps.APS_reset_int(no) == 0
        assert aps.APS_wait_single_int(no, 10) == aps.ERR_TimeOut


def test_set_int_signals_an_open_event_by_software() -> None:
    with aps_session() as (_, rack):
        no = _open(SYSTEM, aps.IMOV)
        start = rack.sim.now_ns()
        assert aps.APS_set_int(no) == 0
        assert aps.APS_wait_single_int(no, 100) == 0
        assert rack.sim.now_ns() == start
        closed = SYSTEM * 32 + aps.IHOV
        assert aps.APS_set_int(closed) == aps.ERR_InterruptNotEnable


def test_a_move_of_one_cycle_still_signals_imdn() -> None:
    """MDN falls at the command and rises in the next cycle: an edge (spec §2.23)."""
    with aps_session():
        no = _open(AXIS_ITEM0, aps.IMDN)
        assert aps.APS_ptp_all(0, 0, 10.0, 0.0, 1e5, 0.0, 1e10, 1e10, 0.0, None) == 0
        assert aps.APS_wait_single_int(no, 50) == 0


def test_wait_multiple_any_returns_the_index_of_the_first_signaled() -> None:
    """Items 0 and 1 (the irq loop): axis 1's short move ends first."""
    with aps_session() as (_, rack):
        a0, a1 = _open(0, aps.IMDN), _open(1, aps.IMDN)
        aps.APS_ptp(0, 0, 20000.0, None)
        aps.APS_ptp(1, 0, 1000.0, None)
        assert aps.APS_wait_multiple_int(2, [a0, a1], 0, 5000) == 1
        assert rack.sim.now_ns() < 100 * MS
        assert aps.APS_wait_multiple_int(2, (c_int32 * 2)(a0, a1), 1, 5000) == 0
        assert 300 * MS <= rack.sim.now_ns() <= 301 * MS
        start = rack.sim.now_ns()
        aps.APS_reset_int(a0)
        aps.APS_reset_int(a1)
        assert aps.APS_wait_multiple_int(2, [a0, a1], 0, 30) == aps.ERR_TimeOut
        assert rack.sim.now_ns() == start + 30 * MS


def test_wait_multiple_on_one_item_any_and_all() -> None:
    """IACC and IDEC of one axis (one wait on its signal word)."""
    with aps_session() as (_, rack):
        acc, dec = _open(0, aps.IACC), _open(0, aps.IDEC)
        aps.APS_ptp(0, 0, 20000.0, None)
        assert aps.APS_wait_multiple_int(2, [dec, acc], 0, 5000) == 1
        assert aps.APS_wait_multiple_int(2, [dec, acc], 1, 5000) == 0
        assert 200 * MS <= rack.sim.now_ns() <= 201 * MS  # DEC starts at 200 ms


def test_forever_wait_returns_at_the_event() -> None:
    with aps_session() as (_, rack):
        no = _open(AXIS_ITEM0, aps.IMDN)
        aps.APS_ptp(0, 0, 20000.0, None)
        assert aps.APS_wait_single_int(no, -1) == 0
        assert rack.sim.now_ns() <= 301 * MS


def test_di_edges_signal_items_9_and_10() -> None:
    """IDIRn / IDIFn: DI n's rising and falling edges [M §4.11]."""
    with aps_session() as (_, rack):
        rise, fall = _open(DI_RISE, 3), _open(DI_FALL, 3)
        card = rack.card("amp0")
        card.control("set_di", channel=3, level=True)
        assert aps.APS_wait_single_int(rise, 10) == 0
        assert aps.APS_wait_single_int(fall, 10) == aps.ERR_TimeOut
        card.control("set_di", channel=3, level=False)
        assert aps.APS_wait_single_int(fall, 10) == 0
        ttl = _open(DI_RISE, aps.INT_DI_TTL0 + 15)  # TDI15
        assert aps.APS_reset_int(rise) == 0
        card.control("set_di", channel=23, level=True)
        assert aps.APS_wait_multiple_int(2, [rise, ttl], 1, 10) == aps.ERR_TimeOut
        card.control("set_di", channel=3, level=True)
        assert aps.APS_wait_multiple_int(2, [rise, ttl], 1, 10) == 0


def test_estop_signals_system_and_axis_iemg_but_not_iez() -> None:
    """System IEMG (item 8 bit 0) and axis IEMG (bit 6); the MIO word's EMG bit (4) is not
    the axis factor 4 (IEZ) [M §4.11, L3355]."""
    with aps_session() as (_, rack):
        sys_emg = _open(SYSTEM, aps.IEMG_SYS)
        axis_emg = _open(2, aps.IEMG_AXIS)
        iez, iinp = _open(2, aps.IEZ), _open(2, aps.IINP)
        rack.card("amp0").control("set_estop", active=True)
        assert aps.APS_wait_single_int(sys_emg, 10) == 0
        assert aps.APS_wait_single_int(axis_emg, 10) == 0
        assert aps.APS_wait_multiple_int(2, [iez, iinp], 0, 10) == aps.ERR_TimeOut


def test_bad_arguments_are_minus_10_and_change_nothing() -> None:
    with aps_session(amp("amp0", model="AMP-204C")):
        enable = c_int32()
        assert aps.APS_set_int_factor(0, 11, 0, 1) == aps.ERR_ParametersInvalid
        assert aps.APS_set_int_factor(0, 4, aps.IMDN, 1) == aps.ERR_ParametersInvalid  # 204C
        assert aps.APS_set_int_factor(0, 0, 7, 1) == aps.ERR_ParametersInvalid  # reserved
        assert aps.APS_set_int_factor(0, 0, 32, 1) == aps.ERR_ParametersInvalid
        assert aps.APS_set_int_factor(0, SYSTEM, 7, 1) == aps.ERR_ParametersInvalid
        assert aps.APS_set_int_factor(0, DI_RISE, 5, 1) == aps.ERR_ParametersInvalid  # EDI5
        assert aps.APS_set_int_factor(0, 0, aps.IMDN, 2) == aps.ERR_ParametersInvalid
        assert aps.APS_get_int_factor(0, 0, aps.IMDN, byref(enable)) == 0 and enable.value == 0
        assert aps.APS_set_int_factor(1, 0, aps.IMDN, 1) == aps.ERR_ParametersInvalid  # board
        assert aps.APS_int_enable(0, 2) == aps.ERR_ParametersInvalid
        no = _open(0, aps.IMDN)
        assert aps.APS_wait_single_int(no, -2) == aps.ERR_ParametersInvalid
        assert aps.APS_wait_single_int(-1, 10) == aps.ERR_ParametersInvalid
        assert aps.APS_wait_multiple_int(0, [no], 0, 10) == aps.ERR_ParametersInvalid
        assert aps.APS_wait_multiple_int(1, [no], 2, 10) == aps.ERR_ParametersInvalid
        assert aps.APS_reset_int(aps.INT_NO_PER_BOARD + 12) == aps.ERR_ParametersInvalid


def test_wait_multiple_across_boards_is_minus_10() -> None:
    """vdevd: one board per APS_wait_multiple_int (README "Not emulated")."""
    with aps_session(amp("amp0", card_id=0), amp("amp1", card_id=1)):
        a, b = _open(0, aps.IMDN, board=0), _open(0, aps.IMDN, board=1)
        assert b == aps.INT_NO_PER_BOARD + 12
        assert aps.APS_wait_multiple_int(2, [a, b], 0, 10) == aps.ERR_ParametersInvalid
