"""Output and text parameters as Python code that calls a vendor DLL through ctypes passes them
(DESIGN.md "Clients"): `byref(x)`, `pointer(x)` or `x`; char buffers, bytearrays, str, bytes;
and, for the Python-minded, a list that receives one str."""

from __future__ import annotations

import ctypes
from typing import Any

_BYREF = type(ctypes.byref(ctypes.c_int()))  # ctypes' CArgObject


def target(param: Any) -> Any:
    """The object behind an output parameter: byref(x), pointer(x) or x."""
    if type(param) is _BYREF:
        return param._obj  # type: ignore[attr-defined]
    if isinstance(param, ctypes._Pointer):
        return param.contents
    return param


def text(value: Any) -> bytes:
    """A command string as bytes: str (latin-1, so control characters pass), bytes up to NUL,
    ctypes char arrays and c_char_p."""
    if type(value) is str:  # the usual argument, first
        return value.encode("latin-1")
    value = target(value)
    if isinstance(value, str):
        return value.encode("latin-1")
    if isinstance(value, ctypes.c_char_p) or (
            isinstance(value, ctypes.Array) and value._type_ is ctypes.c_char):
        return bytes(value.value or b"")
    return bytes(value).split(b"\0", 1)[0]


def put_text(buffer: Any, size: int, data: bytes) -> int:
    """Copy `data` NUL-terminated into a text buffer of `size` bytes (a ctypes char array, a
    bytearray, a list that gets one str, or None for none); the characters copied."""
    dest = target(buffer)
    if dest is None:
        return len(data)
    if isinstance(dest, list):
        n = min(len(data), max(int(size) - 1, 0))
        dest[:] = [data[:n].decode("latin-1")]
        return n
    if (isinstance(dest, ctypes.Array) and dest._type_ is ctypes.c_char
            and len(data) < min(size, len(dest))):
        dest.value = data  # the common case, and the quickest copy ctypes has
        return len(data)
    room = min(int(size), ctypes.sizeof(dest) if isinstance(dest, ctypes.Array) else len(dest))
    if room <= 0:
        return 0
    n = min(len(data), room - 1)
    if isinstance(dest, bytearray):
        dest[:n + 1] = data[:n] + b"\0"
    else:
        ctypes.memmove(ctypes.addressof(dest), data[:n] + b"\0", n + 1)
    return n
