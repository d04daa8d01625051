"""The APS library from several threads, as applications use the DLL: a thread waiting in
APS_wait_single_int while another commands and reads the card, and threads posting kernel
commands at once. Each thread has its own connection (a ZeroMQ socket serves one thread)."""

from __future__ import annotations

import threading
from ctypes import byref, c_double

from vdevclient import _aps_session, aps

from tests.client.aps_rack import aps_session

MS = 1_000_000


def test_a_thread_waits_for_imdn_while_another_reads_and_commands() -> None:
    """[M §4.11]: the wait returns in the cycle the 300 ms move is done; meanwhile the main
    thread's reads and posts are answered, each with its own value."""
    with aps_session() as (_, rack):
        no = aps.APS_set_int_factor(0, 0, aps.IMDN, 1)
        assert no >= 0 and aps.APS_int_enable(0, 1) == 0
        assert aps.APS_set_axis_param_f(1, aps.PRA_VM, 12345.0) == 0
        assert aps.APS_ptp(0, 0, 20000.0, None) == 0
        result: list[int] = []
        waiter = threading.Thread(target=lambda: result.append(aps.APS_wait_single_int(no, 5000)))
        waiter.start()
        vm, pos = c_double(), c_double()
        answered = 0
        while waiter.is_alive() or answered < 50:
            assert aps.APS_get_axis_param_f(1, aps.PRA_VM, byref(vm)) == 0
            assert vm.value == 12345.0
            assert aps.APS_get_position_f(0, byref(pos)) == 0
            assert 0.0 <= pos.value <= 20000.0
            answered += 1
        waiter.join()
        assert result == [0]
        assert 300 * MS <= rack.sim.now_ns() <= 301 * MS
        assert aps.APS_motion_status(0) & aps.MTS_MDN_V


def test_threads_posting_at_once_each_get_their_own_answer() -> None:
    """Four threads set and read back a parameter of their own axis 100 times each."""
    with aps_session():
        errors: list[str] = []

        def work(axis: int) -> None:
            got = c_double()
            for i in range(100):
                value = 1000.0 * (axis + 1) + i
                if aps.APS_set_axis_param_f(axis, aps.PRA_VM, value) != 0:
                    errors.append(f"axis {axis}: set failed")
                if aps.APS_get_axis_param_f(axis, aps.PRA_VM, byref(got)) != 0 \
                        or got.value != value:
                    errors.append(f"axis {axis}: read {got.value}, set {value}")

        threads = [threading.Thread(target=work, args=(a,)) for a in range(4)]
        for t in threads:
            t.start()
        for t in threads:
            t.join()
        assert errors == []
        links = _aps_session.session().links
        assert len(list(links._others)) <= 4  # one connection per thread at most


def test_close_closes_every_threads_connection() -> None:
    with aps_session():
        links = _aps_session.session().links
        racks = []

        def work() -> None:
            vm = c_double()
            assert aps.APS_get_axis_param_f(0, aps.PRA_VM, byref(vm)) == 0
            racks.append(links.rack())

        t = threading.Thread(target=work)
        t.start()
        t.join()
        assert racks and racks[0] is not links.home
        other = racks[0]
        assert aps.APS_close() == 0
        assert other._sock.closed and links.home._sock.closed
