"""The PCI DPRAM: the ASCII command/response handshake and the reporting buffers, without I/O
[spec pmac.md §2.10]. The offsets are vdevmaps.pmac's, which the client shares.

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

Reporting buffers [PComm32 dprrtdbt.h `realtTURBO`, dprbkg.h `backgTURBO`; EPICS tpmac
drvPmac.c; README "Reporting buffers"]: real-time motor data from X:$06001A (I48 enables, every I47
servo cycles) and background global and C.S. data from Y:$06019D (I49 enables, every I50 servo
cycles). Each has a host-busy bit (X word bit 15 of its first address) and a 24-bit servo timer
whose X word's bit 15 is the data-ready bit: the card writes only while both bits are clear,
then sets data ready; the host clears it to request the next sample.
"""

from __future__ import annotations

import struct
from collections import deque
from collections.abc import Callable

import numpy as np
from vdevmaps.pmac import (
    ACK,
    BG_CS,
    BG_CS_COUNT,
    BG_CS_SIZE,
    BG_HOST_BUSY,
    BG_READY,
    BG_STATUS,
    BG_TIMER,
    CMD_BUFFER,
    CMD_CHAR,
    CMD_CONTROL,
    CMD_MAX,
    CR,
    CS_COUNT,
    CS_STATUS1,
    CS_STATUS2,
    CS_STATUS3,
    CS_TIMEBASE,
    READY,
    RESP_CONTROL,
    RESP_MAX,
    RT_ACTUAL,
    RT_BIAS,
    RT_DAC,
    RT_FE,
    RT_HOST_BUSY,
    RT_MASK,
    RT_MOTOR,
    RT_MOTORS,
    RT_READY,
    RT_STATUS1,
    RT_STATUS2,
    RT_TIMER,
    RT_VEL,
)

from vdevd.region import Memory

_SLOT_HEAD = struct.Struct("<HH")  # a posted line: control word, characters + 1
#: the response control word of a program's SEND message [PMAC1 DPRAM UM p.29]
SEND_LINE = 0x0200 | CR


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

    def __init__(self, mem: Memory, execute: Callable[[str], tuple[list[str], int | None]],
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
            end = mem.find(b"\0", CMD_BUFFER, CMD_BUFFER + CMD_MAX)
            line = mem[CMD_BUFFER:end if end >= 0 else CMD_BUFFER + CMD_MAX].decode("latin-1")
            lines, error = self._execute(line)
            for text in lines:
                pending.append(slot(text, CR))
            pending.append(_ACK_SLOT if error is None else slot("", error_word(error)))
        mem[CMD_CONTROL:CMD_CONTROL + 4] = _CLEAR  # command taken (and the control char)
        if not (mem[RESP_CONTROL] or mem[RESP_CONTROL + 1]):
            self._post_next()

    def post_message(self, text: str, backlog: int) -> bool:
        """An unsolicited line (a program's SEND): control word 0x020D, "a PMAC program SEND
        command message, end of transmission, no ACK is sent" [PMAC1 DPRAM UM p.29]; False (not
        taken) while `backlog` lines already wait for the host."""
        if len(self.pending) >= backlog:
            return False
        self.pending.append(slot(text, SEND_LINE))
        if not (self.mem[RESP_CONTROL] or self.mem[RESP_CONTROL + 1]):
            self._post_next()
        return True

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
    """The real-time (I47/I48) and background (I49/I50) fixed data buffers in the Turbo layout
    [dprrtdbt.h, dprbkg.h; README "Reporting buffers"]. Values are 24-bit words sign-extended to
    32 bits, 48-bit ones as two such halves, low first [UM p.402]."""

    def __init__(self, mem: Memory) -> None:
        self.mem = mem
        words = (BG_CS + CS_COUNT * BG_CS_SIZE - RT_MOTORS) // 4
        #: every 32-bit word from the first motor record to the last C.S. record
        self._words = np.frombuffer(mem, dtype="<i4", count=words, offset=RT_MOTORS)
        self._motors = self._words[:32 * RT_MOTOR // 4].reshape(32, RT_MOTOR // 4)
        first_cs = (BG_CS - RT_MOTORS) // 4
        self._cs = self._words[first_cs:].reshape(CS_COUNT, BG_CS_SIZE // 4)

    def _requested(self, host_busy: int, ready: int) -> bool:
        """The host has taken the last sample (data ready clear) and is not reading."""
        return not (self.mem[host_busy + 1] & 0x80 or self.mem[ready + 1] & 0x80)

    def realtime_requested(self) -> bool:
        """The host waits for a real-time buffer (`realtime_due` at the next multiple of I47)."""
        return self._requested(RT_HOST_BUSY, RT_READY)

    def background_requested(self) -> bool:
        """The host waits for a background buffer (`background_due` at the next multiple of I50)."""
        return self._requested(BG_HOST_BUSY, BG_READY)

    def realtime_due(self, cycle: int, period: float) -> bool:
        """At a multiple of I47 servo cycles (0 counts as 1) with the buffer requested."""
        return cycle % max(int(period), 1) == 0 and self._requested(RT_HOST_BUSY, RT_READY)

    def background_due(self, cycle: int, period: float) -> bool:
        """At a multiple of I50 servo cycles (0 counts as 1) with the buffer requested."""
        return cycle % max(int(period), 1) == 0 and self._requested(BG_HOST_BUSY, BG_READY)

    def motor_mask(self, motors: int) -> np.ndarray:
        """The indices of the motors (0-based, below `motors`) the host selected at L:$06001C."""
        mask = struct.unpack_from("<I", self.mem, RT_MASK)[0]
        return np.flatnonzero((mask >> np.arange(motors)) & 1)

    def cs_count(self) -> int:
        """The coordinate systems to report, from Y:$06019D bits 0-7 (at most 16)."""
        return min(self.mem[BG_CS_COUNT], CS_COUNT)

    def _stamp(self, timer: int, ready: int, cycle: int) -> None:
        """The 24-bit servo timer, then data ready: the sample is complete."""
        cycle &= 0xFFFFFF
        struct.pack_into("<HH", self.mem, timer, cycle & 0xFFFF, cycle >> 16 | READY)

    def realtime(self, cycle: int, motors: np.ndarray, status: tuple[np.ndarray, np.ndarray],
                 following_error: np.ndarray, dac: np.ndarray, bias: np.ndarray,
                 velocity: np.ndarray, actual: np.ndarray) -> None:
        """Post the selected `motors` (0-based indices): status words, the DAC register (16-bit
        value in bits 8-23), following error, position bias and actual position (1/(Ixx08·32)
        count) and filtered velocity (1/(Ixx09·32) count per servo cycle), all for those motors."""
        rec = np.zeros((len(motors), RT_MOTOR // 4), dtype=np.int64)
        rec[:, RT_FE], rec[:, RT_FE + 1] = split48(following_error)
        rec[:, RT_DAC] = sign24(np.round(dac).astype(np.int64) << 8)
        rec[:, RT_STATUS1] = sign24(status[0])
        rec[:, RT_STATUS2] = sign24(status[1])
        rec[:, RT_BIAS], rec[:, RT_BIAS + 1] = split48(bias)
        rec[:, RT_VEL] = sign24(np.round(velocity).astype(np.int64))
        rec[:, RT_ACTUAL], rec[:, RT_ACTUAL + 1] = split48(actual)
        self._motors[motors] = rec
        self._stamp(RT_TIMER, RT_READY, cycle)

    def background(self, cycle: int, global_words: tuple[int, int],
                   cs: list[tuple[int, int, int]], time_base: np.ndarray,
                   program: np.ndarray | None = None) -> None:
        """Post the global status words (as `???` gives them) and, for the first len(`cs`)
        coordinate systems, their `??` words and time base (I10 units, 24-bit), and the
        program fields `program` gives (24-bit words, prog_dpram.py)."""
        struct.pack_into("<ii", self.mem, BG_STATUS, *sign24(np.array(global_words[::-1])))
        n = len(cs)
        rec = np.zeros((n, BG_CS_SIZE // 4), dtype=np.int64)
        if n:
            words = sign24(np.array(cs, dtype=np.int64).reshape(n, 3))
            rec[:, CS_STATUS1], rec[:, CS_STATUS2], rec[:, CS_STATUS3] = words.T
            rec[:, CS_TIMEBASE] = sign24(np.round(time_base[:n]).astype(np.int64))
            if program is not None:
                rec += sign24(program[:n])
        self._cs[:n] = rec
        self._stamp(BG_TIMER, BG_READY, cycle)
