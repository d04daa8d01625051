"""PComm32's return codes, buffer sizes and types (its runtime header, spec pmac.md §3.1), shared by
the `vdevclient.pcomm` modules and re-exported from there."""

from __future__ import annotations

import ctypes

# -- return codes and sizes (PComm32 runtime header) -------------------------------------------------
COMM_EOT = 0x80000000  # the response ended with ACK
COMM_TIMEOUT = 0xC0000000
COMM_ERROR = 0xE0000000  # the card answered BELL ERRnnn
COMM_FAIL = 0xF0000000
COMM_ANYERR = 0x70000000
COMM_UNSOLICITED = 0x10000000
COMM_OK = 1
MAX_COMM_BUFFER = 256
MAX_DPRBUFFER = 160
MAX_DPRREADBUFFER = 256


def COMM_CHARS(c: int) -> int:
    return c & 0x0FFFFFFF


def COMM_STATUS(c: int) -> int:
    return c & 0xF0000000


def IS_COMM_EOT(c: int) -> bool:
    return COMM_STATUS(c) == COMM_EOT


def IS_COMM_ERROR(c: int) -> bool:
    return COMM_STATUS(c) == COMM_ERROR


def IS_COMM_TIMEOUT(c: int) -> bool:
    return COMM_STATUS(c) == COMM_TIMEOUT


def IS_COMM_FAIL(c: int) -> bool:
    return COMM_STATUS(c) == COMM_FAIL


class INTRBUFFER(ctypes.Structure):
    """What a PMACINTRPROC receives a pointer to; `dwInterruptType` is the IR number (0-7)."""

    _fields_ = [("lpData", ctypes.c_char_p), ("dwBufferLength", ctypes.c_ulong),
                ("dwInterruptType", ctypes.c_ulong)]


class CommResult(int):
    """A PComm status code (`COMM_EOT | count` ...) that also carries the response as `.text`."""

    text: str

    def __new__(cls, value: int, text: str = "") -> CommResult:
        obj = super().__new__(cls, value)
        obj.text = text
        return obj
