"""APS data sampling [M §4.9.4; spec adlink.md §2.19, Q28]: the parameters, the triggered
capture (blocking, or _async with APS_get_sampling_count), and auto sampling drained with
APS_get_sampling_data. The card records into its own ring (vdevd/devices/adlink/sampling.py);
the library waits in the daemon on Bar.SAMP_STATUS and reads the records in chunks through the
mailbox's reply.

An _async capture's DataArr is filled by the APS_get_sampling_count call that first sees the
capture complete (the library has no thread of its own; spec Q28, vdevd choice).
"""

from __future__ import annotations

import ctypes
import struct
from typing import Any

from vdevmaps.adlink import BAR, Bar, SampState, samp_records_per_reply
from vdevmaps.aps_defs import (
    MAX_SAMPL_CH,
    MAX_SAMPL_SRC,
    ERR_NoError,
    ERR_ParametersInvalid,
    ERR_TimeOut,
)

from vdevclient._aps_bus import Board
from vdevclient._aps_int import ROUND_NS, _timeout
from vdevclient._aps_session import ApsArgError, as_int, board, guarded, put
from vdevclient._aps_types import SAMP_PARAM, STR_SAMP_DATA_4CH, STR_SAMP_DATA_8CH
from vdevclient._cargs import target

#: the _async captures waiting for APS_get_sampling_count, by board: (DataArr, Length, channels)
_pending: dict[int, tuple[Any, int, int]] = {}


def _record_type(channels: int) -> type[ctypes.Structure]:
    return STR_SAMP_DATA_4CH if channels == 4 else STR_SAMP_DATA_8CH


def _check_array(data: Any, length: int, channels: int) -> None:
    """DataArr: a ctypes array of the record type (at least Length), a pointer to one, or a
    list (it gets the records); NULL is -10."""
    dest = target(data)
    if dest is None:
        raise ApsArgError(ERR_ParametersInvalid)
    if isinstance(dest, ctypes.Array):
        if dest._type_ is not _record_type(channels) or len(dest) < length:
            raise ApsArgError(ERR_ParametersInvalid)
    elif not isinstance(dest, list | _record_type(channels)):
        raise ApsArgError(ERR_ParametersInvalid)


def _store(data: Any, first: int, words: list[int], channels: int) -> None:
    """Records (tick + channels I32 each, as the card sends them) into DataArr at `first`."""
    dest = target(data)
    cls = _record_type(channels)
    raw = struct.pack(f"<{len(words)}i", *words)
    count = len(words) // (1 + channels)
    if isinstance(dest, list):
        size = ctypes.sizeof(cls)
        recs = [cls.from_buffer_copy(raw, i * size) for i in range(count)]
        dest[first:first + count] = recs
        return
    ctypes.memmove(ctypes.addressof(dest) + first * ctypes.sizeof(cls), raw, len(raw))


def _fetch(b: Board, data: Any, length: int, channels: int) -> int:
    """Read a complete capture's `length` records into DataArr, a reply at a time."""
    step = samp_records_per_reply(channels)
    for first in range(0, length, step):
        rc, vals = b.post("read_sampling", first, min(step, length - first), channels)
        if rc < 0:
            return rc
        _store(data, first, vals[0], channels)
    return ERR_NoError


def _status(b: Board) -> tuple[int, int]:
    state, count = struct.unpack("<II", b.bar.read(Bar.SAMP_STATUS, 8))
    return state, count


def _wait_done(b: Board, timeout_ns: int | None) -> bool:
    """Wait in the daemon until the capture holds its records (DONE), in rounds."""
    left = timeout_ns
    done = int(SampState.DONE)
    while True:
        rnd = ROUND_NS if left is None else min(left, ROUND_NS)
        op = {"op": "wait", "on": "value", "card": b.card, "region": BAR,
              "offset": int(Bar.SAMP_STATUS), "size": 4, "mask": done, "value": done,
              "timeout_ns": rnd}
        if b.rack.call({"op": "batch", "ops": [op]}, rnd / 1e9)[0]["fired"]:
            return True
        if left is not None:
            left -= rnd
            if left <= 0:
                return False


def _start(Board_ID: Any, Length: Any, PreTrgLen: Any, DataArr: Any, channels: int
           ) -> tuple[Board, int, int]:
    b = board(Board_ID)
    length, pre = as_int(Length), as_int(PreTrgLen)
    _check_array(DataArr, max(length, 0), channels)
    rc = b.post("start_trigger_sampling", length, pre)[0]
    if rc == ERR_NoError:
        _pending.pop(b.board_id, None)  # a new capture replaces the last
    return b, rc, length


def _wait_trigger(Board_ID: Any, Length: Any, PreTrgLen: Any, TimeOutMs: Any, DataArr: Any,
                  channels: int) -> int:
    timeout = _timeout(TimeOutMs)
    b, rc, length = _start(Board_ID, Length, PreTrgLen, DataArr, channels)
    if rc < 0:
        return rc
    if not _wait_done(b, timeout):
        b.post("stop_sampling")
        return ERR_TimeOut
    return _fetch(b, DataArr, length, channels)


@guarded
def APS_set_sampling_param(Board_ID: int, ParaNum: int, ParaDat: int) -> int:
    """SAMP_PA_RATE (motion cycles per record), SAMP_PA_EDGE (0 rising, 1 falling),
    SAMP_PA_LEVEL, SAMP_PA_TRIGCH, SAMP_PA_SRC_CH0-3 (signal | axis << 8) [X1, X2; Q28]."""
    return board(Board_ID).post("set_sampling_param", as_int(ParaNum), as_int(ParaDat))[0]


@guarded
def APS_get_sampling_param(Board_ID: int, ParaNum: int, ParaDat: Any) -> int:
    rc, vals = board(Board_ID).post("get_sampling_param", as_int(ParaNum))
    if rc == ERR_NoError:
        put(ParaDat, vals[0])
    return rc


@guarded
def APS_set_sampling_param_ex(Board_ID: int, Param: Any) -> int:
    """All 8 channels: SAMP_PARAM {rate, edge, level, trigCh, sourceByCh[8][2]} [X3]."""
    p = target(Param)
    if not isinstance(p, SAMP_PARAM):
        raise ApsArgError(ERR_ParametersInvalid)
    flat = [p.sourceByCh[ch][i] for ch in range(MAX_SAMPL_CH) for i in range(MAX_SAMPL_SRC)]
    return board(Board_ID).post("set_sampling_param_ex", p.rate, p.edge, p.level, p.trigCh,
                                flat)[0]


@guarded
def APS_get_sampling_param_ex(Board_ID: int, Param: Any) -> int:
    p = target(Param)
    if not isinstance(p, SAMP_PARAM):
        raise ApsArgError(ERR_ParametersInvalid)
    rc, vals = board(Board_ID).post("get_sampling_param_ex")
    if rc == ERR_NoError:
        p.rate, p.edge, p.level, p.trigCh = vals[:4]
        for ch in range(MAX_SAMPL_CH):
            for i in range(MAX_SAMPL_SRC):
                p.sourceByCh[ch][i] = vals[4][ch * MAX_SAMPL_SRC + i]
    return rc


@guarded
def APS_wait_trigger_sampling(Board_ID: int, Length: int, PreTrgLen: int, TimeOutMs: int,
                              DataArr: Any) -> int:
    """Sample until the trigger, then until Length records (PreTrgLen of them before the
    trigger record) are in DataArr (STR_SAMP_DATA_4CH); -9 after TimeOutMs (-1: no limit),
    the capture then abandoned [X1; spec §2.19 ASSUMPTION]."""
    return _wait_trigger(Board_ID, Length, PreTrgLen, TimeOutMs, DataArr, 4)


@guarded
def APS_wait_trigger_sampling_ex(Board_ID: int, Length: int, PreTrgLen: int, TimeOutMs: int,
                                 DataArr: Any) -> int:
    """As APS_wait_trigger_sampling, 8 channels (STR_SAMP_DATA_8CH) [X3]."""
    return _wait_trigger(Board_ID, Length, PreTrgLen, TimeOutMs, DataArr, 8)


def _async(Board_ID: Any, Length: Any, PreTrgLen: Any, TimeOutMs: Any, DataArr: Any,
           channels: int) -> int:
    _timeout(TimeOutMs)  # checked; the capture itself has no time limit
    b, rc, length = _start(Board_ID, Length, PreTrgLen, DataArr, channels)
    if rc == ERR_NoError:
        _pending[b.board_id] = (DataArr, length, channels)
    return rc


@guarded
def APS_wait_trigger_sampling_async(Board_ID: int, Length: int, PreTrgLen: int, TimeOutMs: int,
                                    DataArr: Any) -> int:
    """Start the capture and return; APS_get_sampling_count follows it and fills DataArr."""
    return _async(Board_ID, Length, PreTrgLen, TimeOutMs, DataArr, 4)


@guarded
def APS_wait_trigger_sampling_async_ex(Board_ID: int, Length: int, PreTrgLen: int,
                                       TimeOutMs: int, DataArr: Any) -> int:
    return _async(Board_ID, Length, PreTrgLen, TimeOutMs, DataArr, 8)


@guarded
def APS_get_sampling_count(Board_ID: int, SampCnt: Any) -> int:
    """The records the capture holds (PreTrgLen at most before its trigger, Length when
    complete), or the unread ones of auto sampling; a complete _async capture is copied into its
    DataArr here."""
    b = board(Board_ID)
    if target(SampCnt) is None:  # -10 before a finished capture is copied and forgotten
        raise ApsArgError(ERR_ParametersInvalid)
    state, count = _status(b)
    pending = _pending.get(b.board_id)
    if pending is not None and state & SampState.DONE:
        data, length, channels = pending
        rc = _fetch(b, data, length, channels)
        if rc < 0:
            return rc
        del _pending[b.board_id]
    put(SampCnt, count)
    return ERR_NoError


@guarded
def APS_stop_wait_sampling(Board_ID: int) -> int:
    """Abandon the capture (its records dropped); auto sampling is not affected."""
    b = board(Board_ID)
    _pending.pop(b.board_id, None)
    return b.post("stop_sampling")[0]


@guarded
def APS_auto_sampling(Board_ID: int, StartStop: int) -> int:
    """1: record continuously (the card keeps the last 65536 records); 0: stop, the unread
    records stay for APS_get_sampling_data."""
    return board(Board_ID).post("auto_sampling", as_int(StartStop))[0]


def _get_data(Board_ID: Any, Length: Any, DataArr: Any, Status: Any, channels: int) -> int:
    b = board(Board_ID)
    dest = target(Length)
    want = as_int(dest[0] if isinstance(dest, list) else Length)
    if want < 0 or target(Status) is None:  # NULL Status: -10 before a record is taken
        raise ApsArgError(ERR_ParametersInvalid)
    _check_array(DataArr, want, channels)
    got, state, step = 0, 0, samp_records_per_reply(channels)
    while got < want:
        n = min(step, want - got)
        rc, vals = b.post("take_sampling", n, channels)
        if rc < 0:
            return rc
        state |= vals[0]
        words = vals[1]
        _store(DataArr, got, words, channels)
        got += len(words) // (1 + channels)
        if len(words) < n * (1 + channels):
            break
    if want == 0:
        rc, vals = b.post("take_sampling", 0, channels)
        if rc < 0:
            return rc
        state = vals[0]
    put(Length, got)
    put(Status, int(bool(state & SampState.AUTO)) | (2 if state & SampState.LOST else 0))
    return ERR_NoError


@guarded
def APS_get_sampling_data(Board_ID: int, Length: Any, DataArr: Any, Status: Any) -> int:
    """Auto sampling's oldest unread records: *Length in, the records wanted; out, the records
    read. *Status: bit 0 sampling runs, bit 1 records were lost (the ring overran) since the
    last call (spec Q28, vdevd choice). -15 while the ring holds a trigger capture."""
    return _get_data(Board_ID, Length, DataArr, Status, 4)


@guarded
def APS_get_sampling_data_ex(Board_ID: int, Length: Any, DataArr: Any, Status: Any) -> int:
    return _get_data(Board_ID, Length, DataArr, Status, 8)


__all__ = [n for n in dir() if n.startswith("APS_")]
