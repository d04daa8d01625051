"""The PCI DPRAM: the ASCII command/response handshake and the reporting buffers, without I/O
[spec pmac.md §2.10].

Host byte offsets (little-endian, 16-bit control words) [UM p.402; EPICS-VME pmacDriver.c]:

- 0x0E9C command control: the host waits for 0, writes the command (one character per byte, no
  CR, NUL-terminated, at most 160) at 0x0EA0, then 1 here; the card takes the command and writes 0.
  A non-zero byte at 0x0E9E with the control word is a control character instead (ASSUMPTION,
  from the PMAC(1) layout).
- 0x0F40 response control: 0 = the host has consumed the last line. The card writes the line's
  characters at 0x0F44 (NUL-terminated), their count + 1 at 0x0F42, then the control word: low byte
  0x0D for a data line, 0x06 for the final acknowledgement; for an error 0x80 | hundreds digit in
  the high byte and BCD tens/units in the low byte. The host writes 0 after reading; the next line
  follows at once. One host interrupt (IR4) per posted line.

Reporting buffers (Turbo layouts not retrieved, §6 q17: the layout here is this card's, README):
real-time motor data at 0x006A (I48 enables, every I47 servo cycles) and background global and
C.S. data at 0x0676 (I50 enables, every I49 servo cycles). Each starts with a 16-bit handshake
word: the card writes fresh data only while bit 15 is clear, then sets it; the host clears it.
"""

from __future__ import annotations

import struct
from collections import deque
from collections.abc import Callable

import numpy as np

SIZE = 0x4000  # 8k x 16: ends at 0x3FFC [UM p.402]
BASE = 0x060000  # PMAC address of host offset 0; A <-> 4 (A - BASE)
CMD_CONTROL, CMD_CHAR, CMD_BUFFER, CMD_MAX = 0x0E9C, 0x0E9E, 0x0EA0, 160
RESP_CONTROL, RESP_COUNT, RESP_BUFFER, RESP_MAX = 0x0F40, 0x0F42, 0x0F44, 255
REALTIME, BACKGROUND = 0x006A, 0x0676
#: real-time buffer: handshake u16, motors reported u16, servo counter u32, then 48 bytes/motor
RT_HEADER, RT_MOTOR = 8, 48
#: background buffer: handshake u16, pad u16, servo counter u32, global status 2 x u32,
#: then per coordinate system status 3 x u32 and the feed-rate override (float32)
BG_HEADER, BG_CS = 16, 16
READY = 0x8000
CR, ACK = 0x0D, 0x06
_SLOT_HEAD = struct.Struct("<HH")  # a posted line: control word, characters + 1


def error_word(code: int) -> int:
    """The response control word of ERRnnn: 0x80 | hundreds, BCD tens and units [EPICS-VME]."""
    hundreds, rest = divmod(code, 100)
    tens, units = divmod(rest, 10)
    return (0x80 | hundreds) << 8 | tens << 4 | units


def sign24(values: np.ndarray) -> np.ndarray:
    """24-bit words sign-extended to 32 bits, as the automatic functions write them [UM p.402]."""
    v = values.astype(np.int64) & 0xFFFFFF
    return np.where(v >= 0x800000, v - 0x1000000, v)


def split48(values: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """A 48-bit fixed value as its two sign-extended 24-bit halves (low, high)."""
    v = np.round(values).astype(np.int64)
    return sign24(v & 0xFFFFFF), sign24(v >> 24)


class AsciiChannel:
    """The DPRAM ASCII handshake over the region's bytes.

    `execute(line) -> (lines, error)` runs a command line; `control(ch) -> text` a control
    character; `post` is called with each line posted (the card raises IR4 there).
    `command_control` and `response_control` are the write hooks of the two control words.
    """

    def __init__(self, mem: bytearray, execute: Callable[[str], tuple[list[str], int | None]],
                 control: Callable[[int], str], post: Callable[[], None]) -> None:
        self.mem = mem
        self._execute = execute
        self._control = control
        self._post = post
        #: the lines still to post, each as the bytes of the response slot (`slot`)
        self.pending: deque[bytes] = deque()

    def reset(self) -> None:
        self.pending.clear()
        self.mem[CMD_CONTROL:CMD_CONTROL + 4] = bytes(4)
        self.mem[RESP_CONTROL:RESP_CONTROL + 4] = bytes(4)

    def command_control(self, offset: int, data: bytes) -> None:
        """The host wrote (part of) 0x0E9C: a non-zero word hands the command over."""
        mem = self.mem
        mem[offset:offset + len(data)] = data
        if mem[CMD_CONTROL] or mem[CMD_CONTROL + 1]:
            self._take_command()

    def response_control(self, offset: int, data: bytes) -> None:
        """The host wrote (part of) 0x0F40: 0 means it consumed the line, the next one follows."""
        mem = self.mem
        mem[offset:offset + len(data)] = data
        if not (mem[RESP_CONTROL] or mem[RESP_CONTROL + 1]):
            self._post_next()

    def _take_command(self) -> None:
        mem, pending = self.mem, self.pending
        ch = mem[CMD_CHAR]
        if ch:
            text = self._control(ch)
            if text:
                pending.extend(slot(line, CR) for line in text.split("\r"))
            pending.append(_ACK_SLOT)
        else:
            end = mem.find(0, CMD_BUFFER, CMD_BUFFER + CMD_MAX)
            line = mem[CMD_BUFFER:end if end >= 0 else CMD_BUFFER + CMD_MAX].decode("latin-1")
            lines, error = self._execute(line)
            for text in lines:
                pending.append(slot(text, CR))
            pending.append(_ACK_SLOT if error is None else slot("", error_word(error)))
        mem[CMD_CONTROL:CMD_CONTROL + 4] = _CLEAR  # command taken (and the control char)
        if not (mem[RESP_CONTROL] or mem[RESP_CONTROL + 1]):
            self._post_next()

    def _post_next(self) -> None:
        if not self.pending:
            return
        posted = self.pending.popleft()
        self.mem[RESP_CONTROL:RESP_CONTROL + len(posted)] = posted
        self._post()


def slot(text: str, terminator: int) -> bytes:
    """A line as the card posts it from 0x0F40: the control word, the characters + 1, the
    characters (at most 254) and their NUL."""
    data = text.encode("latin-1")[:RESP_MAX - 1]
    return _SLOT_HEAD.pack(terminator, len(data) + 1) + data + b"\0"


_ACK_SLOT = slot("", ACK)
_CLEAR = bytes(4)


class Reporting:
    """The real-time (I47/I48) and background (I49/I50) reporting buffers."""

    def __init__(self, mem: bytearray) -> None:
        self.mem = mem

    def due(self, cycle: int, period: float, offset: int) -> bool:
        """A buffer the host has read (handshake bit 15 clear) at a multiple of its period."""
        if self.mem[offset + 1] & 0x80:
            return False
        return cycle % max(int(period), 1) == 0

    def realtime(self, cycle: int, words: tuple[np.ndarray, np.ndarray],
                 fixed: list[np.ndarray], velocity: np.ndarray, dac: np.ndarray) -> None:
        """Post one motor sample: per motor status words, then commanded, actual, following
        error (48-bit, 1/(Ixx08*32) count, as two sign-extended halves), velocity, DAC output."""
        n = len(velocity)
        cols = [words[0], words[1]]
        for v in fixed:
            lo, hi = split48(v)
            cols += [lo, hi]
        cols += [sign24(np.round(velocity).astype(np.int64)), np.round(dac).astype(np.int64)]
        block = np.zeros((n, RT_MOTOR // 4), dtype="<i4")
        block[:, :len(cols)] = np.stack(cols, axis=1)
        start = REALTIME + RT_HEADER
        self.mem[start:start + block.nbytes] = block.tobytes()
        struct.pack_into("<HHI", self.mem, REALTIME, READY, n, cycle & 0xFFFFFFFF)

    def background(self, cycle: int, global_words: tuple[int, int],
                   cs: list[tuple[int, int, int]], feed: np.ndarray) -> None:
        buf = bytearray()
        for (w1, w2, w3), f in zip(cs, feed, strict=True):
            buf += struct.pack("<IIIf", w1, w2, w3, float(f))
        start = BACKGROUND + BG_HEADER
        self.mem[start:start + len(buf)] = buf
        struct.pack_into("<HHIII", self.mem, BACKGROUND, READY, 0, cycle & 0xFFFFFFFF,
                         *global_words)
