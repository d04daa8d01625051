"""The DPRAM binary rotary ring without sockets (I45): the control block at 0x1050 (PComm32 dpr.h
`struct rotbuf`), host and PMAC indexes, the end-of-buffer word, lines handed in order to the
coordinate system's rotary buffer, a full buffer (bit 14) and a refused line (bit 15) [PMAC1
DPRAM UM p.30; dpram_rotary.py; README "Binary rotary buffer"]."""

from __future__ import annotations

import struct

import pytest
from vdevmaps.pmac import (
    DPRAM_SIZE,
    OPEN_USE,
    ROT_BUSY,
    ROT_END,
    ROT_ERROR,
    ROT_HOST,
    ROT_PMAC,
    ROT_STATUS,
    rot_line_words,
)

from vdevd.devices.pmac.dpram_rotary import LINES_PER_CYCLE, BinaryRotary
from vdevd.devices.pmac.errors import CommandError

START = 0x100  # the ring at $060550


class Host:
    """The host side as the PMAC1 DPRAM UM's rules have it: whole lines, then the end word, then
    the host index."""

    def __init__(self, size: int, cs: int = 2) -> None:
        self.mem = bytearray(DPRAM_SIZE)
        self.size = size
        struct.pack_into("<HHHHHH", self.mem, ROT_STATUS, 0, cs, 0, 0, size, START)
        self.word(0, ROT_END)

    def word(self, k: int, value: int) -> None:
        struct.pack_into("<I", self.mem, OPEN_USE + 4 * START + 4 * (k % self.size), value)

    def u16(self, at: int) -> int:
        return int(struct.unpack_from("<H", self.mem, at)[0])

    def put(self, text: str) -> None:
        host = self.u16(ROT_HOST)
        words = rot_line_words(text)
        for k, w in enumerate([*words, ROT_END]):
            self.word(host + k, w)
        struct.pack_into("<H", self.mem, ROT_HOST, (host + len(words)) % self.size)


class Sink:
    """A rotary buffer that holds `room` lines (ERR006 beyond) and refuses `BAD` (ERR003)."""

    def __init__(self, room: int = 1000) -> None:
        self.lines: list[tuple[int, str]] = []
        self.room = room

    def __call__(self, cs: int, text: str) -> None:
        if text == "BAD":
            raise CommandError(3, "no such statement")
        if len(self.lines) >= self.room:
            raise CommandError(6, "rotary buffer full")
        self.lines.append((cs, text))


@pytest.fixture
def ring() -> tuple[Host, BinaryRotary, Sink]:
    host = Host(16)
    rot = BinaryRotary(host.mem)
    sink = Sink()
    rot.on_rotary_line = sink
    return host, rot, sink


def test_lines_reach_the_coordinate_systems_rotary_buffer_in_order_across_the_ring_end(
        ring: tuple[Host, BinaryRotary, Sink]) -> None:
    host, rot, sink = ring
    assert not rot.due()  # indexes equal: empty
    sent = []
    for k in range(12):  # 3-4 words a line in a 16-word ring: it wraps twice
        text = f"X{k} Y{-k}" if k % 2 else f"LINEAR X{k}"
        host.put(text)
        sent.append((2, text))
        assert rot.due()
        rot.service()
        assert host.u16(ROT_PMAC) == host.u16(ROT_HOST)
    assert sink.lines == sent
    assert not rot.due() and host.u16(ROT_STATUS) == 0


def test_a_full_rotary_buffer_holds_the_line_with_bit_14_until_there_is_room(
        ring: tuple[Host, BinaryRotary, Sink]) -> None:
    host, rot, sink = ring
    sink.room = 1
    host.put("X1")
    host.put("X2")
    rot.service()
    assert sink.lines == [(2, "X1")]
    assert host.u16(ROT_STATUS) & ROT_BUSY and host.u16(ROT_PMAC) == 2  # "X2" waits
    assert rot.due()
    sink.room = 2
    rot.service()
    assert sink.lines == [(2, "X1"), (2, "X2")] and not host.u16(ROT_STATUS) & ROT_BUSY


def test_a_refused_line_sets_the_error_bit_and_number_and_the_card_waits_for_the_host(
        ring: tuple[Host, BinaryRotary, Sink]) -> None:
    host, rot, sink = ring
    host.put("BAD")
    host.put("X5")
    rot.service()
    assert host.u16(ROT_STATUS) == ROT_ERROR | 3
    assert not rot.due() and sink.lines == []
    struct.pack_into("<H", host.mem, ROT_STATUS, 0)  # the host takes the error
    rot.service()
    assert sink.lines == [(2, "X5")]


def test_bad_ring_contents_and_bounds(ring: tuple[Host, BinaryRotary, Sink]) -> None:
    """A word that is no line header (length 0 or > 255, or longer than what the host index
    covers) drops everything up to the host index with ERR003; a ring under six words or past
    the DPRAM's end is not served; at most LINES_PER_CYCLE lines a cycle."""
    host, rot, sink = ring
    host.word(0, 0)
    struct.pack_into("<H", host.mem, ROT_HOST, 3)
    rot.service()
    assert host.u16(ROT_STATUS) == ROT_ERROR | 3 and host.u16(ROT_PMAC) == 3
    big = Host(200)
    rot2 = BinaryRotary(big.mem)
    sink2 = Sink()
    rot2.on_rotary_line = sink2
    for k in range(LINES_PER_CYCLE + 4):
        big.put(f"X{k}")
    rot2.service()
    assert len(sink2.lines) == LINES_PER_CYCLE
    rot2.service()
    assert len(sink2.lines) == LINES_PER_CYCLE + 4
    struct.pack_into("<H", big.mem, ROT_STATUS + 8, 4)  # size 4: too small
    big.put("X99")
    assert not rot2.due()
    struct.pack_into("<HH", big.mem, ROT_STATUS + 8, 200, (DPRAM_SIZE - OPEN_USE) // 4 - 100)
    assert not rot2.due()


def test_without_a_rotary_buffer_the_line_is_refused_with_err003() -> None:
    host = Host(16)
    rot = BinaryRotary(host.mem)
    host.put("X1")
    rot.service()
    assert host.u16(ROT_STATUS) == ROT_ERROR | 3
