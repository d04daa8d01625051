"""PComm32's DPRAM binary rotary buffer functions (I45): PmacDPRRotBufInit, PmacDPRRotBuf,
PmacDPRRotBufChange, PmacDPRRotBufRemove, PmacDPRAsciiStrToRotA [PComm32 runtime headers for the
signatures; dpr.h `struct rotbuf` for the control block at 0x1050; PMAC1 DPRAM UM p.30 for the
ring's rules; the return codes DprOK 0, DprBufBsy 1, DprEOF 2, DprCmdErr -6, DprBufErr -9 as a
public PComm-compatible header lists them (`Rot_Errors`); the card's dpram_rotary.py and README
"Binary rotary buffer"]. Re-exported from `vdevclient.pcomm`.

ASSUMPTIONS: the lines travel in the card's text coding (`vdevmaps.pmac.rot_line_words`), not
Delta Tau's unpublished binary one; one ring, for C.S. `bufnum + 1`, at `ROT_CLIENT_START`;
PmacDPRAsciiStrToRotA answers DprCmdErr once for a line the card refused earlier (the card's
status word, which it then clears), DprBufBsy when the ring has no room or the coordinate
system's rotary buffer is full (bit 14).
"""

from __future__ import annotations

import struct
from typing import Any

from vdevmaps.pmac import (
    OPEN_USE,
    ROT_BUSY,
    ROT_CLIENT_SIZE,
    ROT_END,
    ROT_ERROR,
    ROT_MIN_SIZE,
    ROT_STATUS,
    VBW_CLIENT_START,
    rot_line_words,
)

from vdevclient._cargs import text as _text
from vdevclient._pcomm_codes import COMM_EOT
from vdevclient._pcomm_device import _Device, _guarded, _reply
from vdevclient._pcomm_dpr import _get, _set

DprOk, DprBufBsy, DprEOF, DprCmdErr, DprBufErr = 0, 1, 2, -6, -9
_CONTROL = struct.Struct("<HHHHHH")  # status, C.S., host index, PMAC index, size, start


def _command(dev: _Device, line: str) -> bool:
    data = line.encode()
    return _reply(*dev.collect(dev.command_ops(data, dev.begin()), data))[1] == COMM_EOT


def _setup(dev: _Device, bufnum: int, size: int) -> int:
    """The control block for a ring of `size` words just below the variable write table, both
    indexes 0, the end word at 0, then I45 = 1."""
    if not 0 <= bufnum <= 15 or size < ROT_MIN_SIZE or size % 2 or size > VBW_CLIENT_START:
        return DprBufErr
    start = VBW_CLIENT_START - size
    _set(dev, ROT_STATUS, _CONTROL.pack(0, 0, 0, 0, 0, start))  # size 0 while it changes
    _set(dev, OPEN_USE + 4 * start, struct.pack("<I", ROT_END))
    _set(dev, ROT_STATUS, _CONTROL.pack(0, bufnum + 1, 0, 0, size, start))
    return DprOk if _command(dev, "I45=1") else DprBufErr


@_guarded(DprBufErr)
def PmacDPRRotBufInit(dev: _Device, bufnum: int) -> int:
    """The ring for C.S. `bufnum` + 1 (0-15), ROT_CLIENT_SIZE words, transfer on (I45 = 1)."""
    return _setup(dev, int(bufnum), ROT_CLIENT_SIZE)


@_guarded(DprBufErr)
def PmacDPRRotBufChange(dev: _Device, bufnum: int, new_size: int) -> int:
    """The ring set up afresh with `new_size` words (even, at least 6)."""
    return _setup(dev, int(bufnum), int(new_size))


@_guarded(DprBufErr)
def PmacDPRRotBufRemove(dev: _Device, bufnum: int) -> int:
    """Transfer off (I45 = 0) and the ring's size 0."""
    ok = _command(dev, "I45=0")
    _set(dev, ROT_STATUS, bytes(12))
    return DprOk if ok else DprBufErr


@_guarded(DprBufErr)
def PmacDPRRotBuf(dev: _Device, on: Any) -> int:
    """I45 := 1 (the card takes lines from the ring) or 0."""
    return DprOk if _command(dev, f"I45={1 if on else 0}") else DprBufErr


@_guarded(DprBufErr)
def PmacDPRAsciiStrToRotA(dev: _Device, inpstr: Any, bufnum: int) -> int:
    """One program line (`inpstr`, CR/LF stripped) into the ring: its words, the end word after
    them, then the host index [PMAC1 DPRAM UM p.30 rules 1 and 5]. An empty line only asks
    whether there is room."""
    status, cs, host, pmac, size, start = _CONTROL.unpack(_get(dev, ROT_STATUS, 12))
    if size < ROT_MIN_SIZE or cs != int(bufnum) + 1:
        return DprBufErr
    if status & ROT_ERROR:
        _set(dev, ROT_STATUS, b"\0\0")
        return DprCmdErr
    text = _text(inpstr).decode("latin-1").strip("\r\n")
    words = rot_line_words(text) if text else []
    room = (pmac - host - 1) % size  # one slot stays free: equal indexes mean empty
    if status & ROT_BUSY or len(words) + 1 > room:
        return DprBufBsy
    if not words:
        return DprOk
    base = OPEN_USE + 4 * start
    ops = [dev.write(base + 4 * ((host + k) % size), struct.pack("<I", w))
           for k, w in enumerate([*words, ROT_END])]
    ops.append(dev.write(ROT_STATUS + 4, struct.pack("<H", (host + len(words)) % size)))
    dev.batch(dev.begin() + ops)
    return DprOk
