"""APS host interrupts [M §4.11; spec adlink.md §2.23, §4.7]: the main switch, the factors, and
the waits, which wait in the daemon (a `wait` op on the card's signaled flags, or on its `inta`
line), never by polling over the network.

Int_No = board x INT_NO_PER_BOARD (352) + item x 32 + factor (spec §2.23 ASSUMPTION, Q23). The
flags live in BAR0 (Bar.INT_SIGNAL, one U32 per item) beside the enable words and the main
switch, so one batch checks "enabled" (-8 otherwise) and waits. A HANDLE is opaque here (no
Win32 event): Int_No + 1, 0 (NULL) on error.
"""

from __future__ import annotations

from collections.abc import Sequence
from typing import Any

from vdevmaps.adlink import BAR, Bar
from vdevmaps.aps_defs import (
    INT_FACTOR_COUNT,
    INT_NO_PER_BOARD,
    ERR_InterruptNotEnable,
    ERR_NoError,
    ERR_ParametersInvalid,
    ERR_TimeOut,
)

from vdevclient._aps_bus import Board
from vdevclient._aps_session import (
    ApsArgError,
    as_int,
    board,
    guarded,
    ints,
    put,
)

#: a wait of Time_Out = -1 (forever) goes in rounds of one simulated hour (a `wait` op's
#: timeout is at most a day, and the client's wall allowance follows it)
ROUND_NS = 3600 * 1_000_000_000
_NS_PER_MS = 1_000_000
_WORDS = INT_NO_PER_BOARD // INT_FACTOR_COUNT  # the items


def _split(int_no: Any) -> tuple[Board, int, int]:
    """The board, item and factor of an interrupt number (-10 if no board has it)."""
    n = as_int(int_no)
    if n < 0:
        raise ApsArgError(ERR_ParametersInvalid)
    bid, rest = divmod(n, INT_NO_PER_BOARD)
    item, factor = divmod(rest, INT_FACTOR_COUNT)
    return board(bid), item, factor


def _timeout(time_out: Any) -> int | None:
    """Time_Out in ms as ns; None for -1 (wait forever); -10 below -1."""
    ms = as_int(time_out)
    if ms == -1:
        return None
    if ms < 0:
        raise ApsArgError(ERR_ParametersInvalid)
    return ms * _NS_PER_MS


def _value_wait(b: Board, offset: int, mask: int, value: int, timeout_ns: int,
                equal: bool = True) -> dict[str, Any]:
    return {"op": "wait", "on": "value", "card": b.card, "region": BAR, "offset": offset,
            "size": 4, "mask": mask, "value": value, "cmp": "eq" if equal else "ne",
            "timeout_ns": timeout_ns}


def _guards(b: Board, items: dict[int, int]) -> list[dict[str, Any]]:
    """Waits that do not wait: the main switch on, every factor of `items` enabled."""
    ops = [_value_wait(b, Bar.INT_MAIN, 1, 1, 0)]
    ops += [_value_wait(b, Bar.INT_ENABLE + 4 * item, bits, bits, 0)
            for item, bits in items.items()]
    return ops


def _wait_flags(b: Board, item: int, mask: int, all_of: bool, timeout_ns: int | None,
                ) -> tuple[int, int]:
    """Wait for the flags `mask` of one item (any or all): (return code, the signal word).
    One batch per round: the guards (-8), the wait, the word."""
    left = timeout_ns
    while True:
        rnd = ROUND_NS if left is None else min(left, ROUND_NS)
        ops: list[Any] = _guards(b, {item: mask})
        ops.append(_value_wait(b, Bar.INT_SIGNAL + 4 * item, mask, mask if all_of else 0, rnd,
                               equal=all_of))
        ops.append(["r", b.card, BAR, int(Bar.INT_SIGNAL + 4 * item), 4])
        res = b.rack.call({"op": "batch", "ops": ops}, rnd / 1e9)
        if not all(r and r["fired"] for r in res[:-2]):
            return ERR_InterruptNotEnable, 0
        if res[-2]["fired"]:
            return ERR_NoError, int.from_bytes(res[-1], "little")
        if left is not None:
            left -= rnd
            if left <= 0:
                return ERR_TimeOut, 0


def _state(b: Board, res: Sequence[Any]) -> tuple[bool, list[int], list[int]]:
    """The main switch, the enable and the signal words from three reads."""
    main = int.from_bytes(res[0], "little") & 1
    enable = [int.from_bytes(res[1][4 * i:4 * i + 4], "little") for i in range(_WORDS)]
    signal = [int.from_bytes(res[2][4 * i:4 * i + 4], "little") for i in range(_WORDS)]
    return bool(main), enable, signal


def _wait_irq(b: Board, pairs: list[tuple[int, int]], all_of: bool, timeout_ns: int | None,
              ) -> int:
    """Flags of several items: read the words, then wait for the next `inta` assertion after
    the one seen with them and read again, until the condition holds or time is up. The
    `after_seq` of the assertion read with the words never misses one in between."""
    reads: list[Any] = [["r", b.card, BAR, int(Bar.INT_MAIN), 4],
                        ["r", b.card, BAR, int(Bar.INT_ENABLE), 4 * _WORDS],
                        ["r", b.card, BAR, int(Bar.INT_SIGNAL), 4 * _WORDS]]
    probe = {"op": "wait", "on": "irq", "card": b.card, "line": "inta", "after_seq": 0,
             "timeout_ns": 0}
    res = b.rack.call({"op": "batch", "ops": [*reads, probe]})
    seq = res[3]["event"]["seq"] if res[3]["fired"] else 0
    deadline = None if timeout_ns is None else res[3]["now_ns"] + timeout_ns
    now = res[3]["now_ns"]
    while True:
        main, enable, signal = _state(b, res)
        if not main or any(not enable[item] & 1 << f for item, f in pairs):
            return ERR_InterruptNotEnable
        hits = [bool(signal[item] & 1 << f) for item, f in pairs]
        if all(hits) if all_of else any(hits):
            return 0 if all_of else hits.index(True)
        rnd = ROUND_NS if deadline is None else max(0, min(deadline - now, ROUND_NS))
        if deadline is not None and rnd == 0:
            return ERR_TimeOut
        wait = {"op": "wait", "on": "irq", "card": b.card, "line": "inta", "after_seq": seq,
                "timeout_ns": rnd}
        got = b.rack.call({"op": "batch", "ops": [wait, *reads]}, rnd / 1e9)
        now = got[0]["now_ns"]
        if got[0]["fired"]:
            seq, res = got[0]["event"]["seq"], got[1:]


@guarded
def APS_int_enable(Board_ID: int, Enable: int) -> int:
    """The main switch: no event is signaled while it is off [M §4.11 step (2)]."""
    return board(Board_ID).post("int_enable", as_int(Enable))[0]


@guarded
def APS_set_int_factor(Board_ID: int, Item_No: int, Factor_No: int, Enable: int) -> int:
    """Enable (1) or close (0) an event: its Int_No, or a negative code [M §4.11 step (1)]."""
    b = board(Board_ID)
    item, factor = as_int(Item_No), as_int(Factor_No)
    rc = b.post("set_int_factor", item, factor, as_int(Enable))[0]
    return rc if rc < 0 else b.board_id * INT_NO_PER_BOARD + item * INT_FACTOR_COUNT + factor


@guarded
def APS_get_int_factor(Board_ID: int, Item_No: int, Factor_No: int, Enable: Any) -> int:
    rc, vals = board(Board_ID).post("get_int_factor", as_int(Item_No), as_int(Factor_No))
    if rc == ERR_NoError:
        put(Enable, vals[0])
    return rc


def APS_set_int_factorH(Board_ID: int, Item_No: int, Factor_No: int, Enable: int) -> int:
    """As APS_set_int_factor, returning the event's HANDLE (opaque: Int_No + 1; 0 = NULL)."""
    no = APS_set_int_factor(Board_ID, Item_No, Factor_No, Enable)
    return no + 1 if no >= 0 else 0


def APS_int_no_to_handle(Int_No: int) -> int:
    """The HANDLE of an interrupt number (opaque: Int_No + 1; 0 = NULL if no board has it)."""
    try:
        _split(Int_No)
    except ApsArgError:
        return 0
    return as_int(Int_No) + 1


@guarded
def APS_wait_single_int(Int_No: int, Time_Out: int) -> int:
    """Wait until the event is signaled: 0; -9 after Time_Out ms (-1: no limit); -8 if its
    factor is closed or the main switch off. A signaled event returns at once until
    APS_reset_int [M §4.11 steps (3), (4)]."""
    b, item, factor = _split(Int_No)
    timeout = _timeout(Time_Out)
    return _wait_flags(b, item, 1 << factor, True, timeout)[0]


@guarded
def APS_wait_multiple_int(Int_Count: int, Int_No_Array: Any, Wait_All: int, Time_Out: int
                          ) -> int:
    """Wait for any (Wait_All = 0: the index of the first signaled in the array) or all
    (Wait_All = 1: 0) of the events; -9, -8 as APS_wait_single_int (spec §2.23 ASSUMPTION).
    vdevd: the events must be of one board (-10 otherwise)."""
    count = as_int(Int_Count)
    if count < 1:
        raise ApsArgError(ERR_ParametersInvalid)
    split = [_split(n) for n in ints(Int_No_Array, count)]
    all_of = as_int(Wait_All)
    if all_of not in (0, 1):
        raise ApsArgError(ERR_ParametersInvalid)
    timeout = _timeout(Time_Out)
    b = split[0][0]
    if any(s[0] is not b for s in split):
        raise ApsArgError(ERR_ParametersInvalid)
    pairs = [(item, factor) for _, item, factor in split]
    if len({item for item, _ in pairs}) == 1:
        item = pairs[0][0]
        mask = 0
        for _, f in pairs:
            mask |= 1 << f
        rc, word = _wait_flags(b, item, mask, bool(all_of), timeout)
        if rc < 0 or all_of:
            return rc
        return next(i for i, (_, f) in enumerate(pairs) if word & 1 << f)
    return _wait_irq(b, pairs, bool(all_of), timeout)


@guarded
def APS_reset_int(Int_No: int) -> int:
    """The event back to non-signaled [M §4.11 step (4)]."""
    b, item, factor = _split(Int_No)
    return b.post("reset_int", item, factor)[0]


@guarded
def APS_set_int(Int_No: int) -> int:
    """Signal the event by software (-8 if its factor is closed) [M §4.11]."""
    b, item, factor = _split(Int_No)
    return b.post("set_int", item, factor)[0]


__all__ = [n for n in dir() if n.startswith("APS_")]
