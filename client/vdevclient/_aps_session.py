"""The APS library's process-wide state (the DLL keeps it too): the session `APS_initial`
opens, and the argument helpers every APS function uses [spec adlink.md §4 "General rules"]."""

from __future__ import annotations

import ctypes
import math
from collections.abc import Sequence
from typing import Any

from vdevmaps.aps_defs import ERR_DeviceNotInitial, ERR_NoError, ERR_ParametersInvalid

from vdevclient._aps_bus import Board, Session
from vdevclient._cargs import target

_state: dict[str, Session | None] = {"session": None}


class ApsArgError(Exception):
    """An argument the library refuses before it reaches the card: the call returns `code`."""

    def __init__(self, code: int) -> None:
        super().__init__(code)
        self.code = code


def session() -> Session:
    s = _state["session"]
    if s is None:
        raise ApsArgError(ERR_DeviceNotInitial)
    return s


def open_session(s: Session) -> None:
    _state["session"] = s


def close_session() -> Session | None:
    s, _state["session"] = _state["session"], None
    return s


def axis(axis_id: Any) -> tuple[Board, int]:
    """The board and local axis of a global axis ID; -4 before APS_initial, -10 unknown."""
    found = session().axis(_int(axis_id))
    if found is None:
        raise ApsArgError(ERR_ParametersInvalid)
    return found


def board(board_id: Any) -> Board:
    found = session().boards.get(_int(board_id))
    if found is None:
        raise ApsArgError(ERR_ParametersInvalid)
    return found


def axes_of(dimension: Any, axis_ids: Any) -> tuple[Board, list[int]]:
    """The board and local axes of an axis array (one card; spec §2.10 ASSUMPTION)."""
    n = _int(dimension)
    ids = ints(axis_ids, n)
    if n < 1:
        raise ApsArgError(ERR_ParametersInvalid)
    pairs = [axis(a) for a in ids]
    b = pairs[0][0]
    if any(p[0] is not b for p in pairs):
        raise ApsArgError(ERR_ParametersInvalid)
    return b, [p[1] for p in pairs]


def _int(value: Any) -> int:
    value = target(value)
    if isinstance(value, ctypes._SimpleCData):
        value = value.value
    if isinstance(value, bool) or not isinstance(value, int):
        try:
            if isinstance(value, float) and value.is_integer():
                return int(value)
        except (TypeError, ValueError):
            pass
        raise ApsArgError(ERR_ParametersInvalid)
    return value


def as_int(value: Any) -> int:
    return _int(value)


def as_float(value: Any) -> float:
    """An F64 argument: finite, else -10."""
    value = target(value)
    if isinstance(value, ctypes._SimpleCData):
        value = value.value
    try:
        f = float(value)
    except (TypeError, ValueError):
        raise ApsArgError(ERR_ParametersInvalid) from None
    if not math.isfinite(f):
        raise ApsArgError(ERR_ParametersInvalid)
    return f


def ints(values: Any, count: int) -> list[int]:
    """`count` I32 of a C array argument (a ctypes array, pointer, list or tuple)."""
    return [_int(v) for v in _items(values, count)]


def floats(values: Any, count: int) -> list[float]:
    """`count` F64 of a C array argument; NaN or infinite values are -10."""
    return [as_float(v) for v in _items(values, count)]


def _items(values: Any, count: int) -> Sequence[Any]:
    if values is None or count < 0:
        raise ApsArgError(ERR_ParametersInvalid)
    values = target(values)
    if isinstance(values, ctypes._Pointer):
        return [values[i] for i in range(count)]
    if isinstance(values, ctypes._SimpleCData) and count == 1:
        return [values.value]
    try:
        if len(values) < count:
            raise ApsArgError(ERR_ParametersInvalid)
        return list(values)[:count]
    except TypeError:
        raise ApsArgError(ERR_ParametersInvalid) from None


def put(param: Any, value: Any) -> None:
    """Store an output value where a C pointer argument points (byref(x), pointer(x), x or a
    one-element list); a NULL (None) output is -10 [the DLL dereferences it]."""
    dest = target(param)
    if dest is None:
        raise ApsArgError(ERR_ParametersInvalid)
    if isinstance(dest, list):
        dest[:1] = [value]
    elif isinstance(dest, ctypes.Array):
        dest[0] = value
    else:
        dest.value = value


def put_array(param: Any, values: Sequence[Any]) -> None:
    dest = target(param)
    if dest is None:
        raise ApsArgError(ERR_ParametersInvalid)
    if isinstance(dest, list):
        dest[:len(values)] = list(values)
        return
    for i, v in enumerate(values):
        dest[i] = v


def get_one(board_id: Any, name: str, args: tuple[Any, ...], out: Any) -> int:
    """A board command whose reply is one value: its I32 arguments posted, the value stored
    where `out` points when the command succeeded; the return code."""
    rc, vals = board(board_id).post(name, *(as_int(a) for a in args))
    if rc == ERR_NoError:
        put(out, vals[0])
    return rc


def asyncall(wait: Any, rc: int) -> int:
    """An ASYNCALL argument: NULL returns at once; otherwise its i32_ret takes the code (the
    command is accepted when the call returns; spec §4 ASSUMPTION)."""
    if wait is not None and wait != 0:
        w = target(wait)
        if hasattr(w, "i32_ret"):
            w.i32_ret = rc
    return rc


def guarded(fn: Any) -> Any:
    """An APS function: an ApsArgError becomes its return code."""
    import functools

    @functools.wraps(fn)
    def call(*args: Any, **kwargs: Any) -> Any:
        try:
            return fn(*args, **kwargs)
        except ApsArgError as exc:
            return exc.code
    return call


OK = ERR_NoError
