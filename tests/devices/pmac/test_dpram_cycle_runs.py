"""The DPRAM automatic functions added for issue 21 (variable buffers I55, the binary rotary ring
I45, DPRAM gathering I5000 = 3) in batched cycles: a card running its quiet cycles in runs or
skipping them ends every batch as one run cycle by cycle, the host's requests (written through
the shared mapping) are served at the same cycle, and between them the card rests (decision
0008) [dpram_vars.py, dpram_rotary.py, dpram_gather.py]."""

from __future__ import annotations

import struct

import pytest
from vdevmaps.pmac import OPEN_USE, ROT_END, ROT_HOST, ROT_STATUS, VB_CONTROL, VBW_SIZE, rot_line_words

from tests.devices.pmac.test_cycle_runs import Twin
from tests.devices.pmac.test_dpram_rotary import Sink
from vdevd.devices.pmac.numbers import from_pmac_float_words, pmac_float_words

VB_TABLE, VBW_TABLE, RING = 0x100, 0x140, 0x180  # PMAC words from $060450
RING_SIZE = 32


def poke(twin: Twin, offset: int, data: bytes) -> None:
    for card in twin.cards:
        card.dpram.buf[offset:offset + len(data)] = data


def put_line(twin: Twin, host: int, text: str) -> int:
    words = rot_line_words(text)
    for k, w in enumerate([*words, ROT_END]):
        poke(twin, OPEN_USE + 4 * (RING + (host + k) % RING_SIZE), struct.pack("<I", w))
    host = (host + len(words)) % RING_SIZE
    poke(twin, ROT_HOST, struct.pack("<H", host))
    return host


@pytest.mark.parametrize("skip_quiet", [True, False])
def test_variable_buffers_rotary_ring_and_dpram_gathering_act_as_one_by_one(
        skip_quiet: bool) -> None:
    twin = Twin(skip_quiet, "ideal")
    sinks = [Sink(room=6), Sink(room=6)]
    for card, sink in zip(twin.cards, sinks, strict=True):
        card.binrot.on_rotary_line = sink
    twin.send("I55=1 I45=1 P1=2.5")
    # the read buffer: P1 (L) and the servo counter (X), EPICS-style; the rotary ring for C.S. 1
    poke(twin, OPEN_USE + 4 * VB_TABLE, struct.pack("<HHHH", 0x6001, 0x10, 0x0000, 0x20))
    poke(twin, 0x1048, struct.pack("<HH", 2, VB_TABLE))
    poke(twin, VB_CONTROL, b"\0\0")
    poke(twin, OPEN_USE + 4 * RING, struct.pack("<I", ROT_END))
    poke(twin, ROT_STATUS, struct.pack("<HHHHHH", 0, 1, 0, 0, RING_SIZE, RING))
    host = 0
    for step, n in enumerate([1, 2, 3, 5, 7, 11, 13, 17, 19, 23] * 6):
        if step % 4 == 0:
            poke(twin, VB_CONTROL, b"\0\0")  # the host asks for the next update
        if step % 5 == 1:
            host = put_line(twin, host, f"X{step} Y{-step}")
        if step % 7 == 2:  # P2 := the step's number, through the write buffer (an L entry)
            x, y = pmac_float_words(float(step))
            poke(twin, OPEN_USE + 4 * VBW_TABLE, struct.pack("<HHii", 0x6002, 0x10, y, x))
            poke(twin, VBW_SIZE, struct.pack("<HH", 1, VBW_TABLE))
        if step == 30:
            for sink in sinks:
                sink.room = 100  # room again in the C.S.'s rotary buffer: the held line goes in
        if step == 20:
            twin.send("I5000=3 I5001=$400000 I5050=1 I5051=0 I5049=2 DEFINE GATHER 50 GATHER")
        if step == 40:
            twin.send("ENDGATHER")
        twin.tick(n)
        twin.same()
    assert sinks[0].lines == sinks[1].lines and len(sinks[0].lines) == 12
    fast = twin.cards[0]
    assert fast.fw.p[2] == 58  # the last write-buffer entry
    assert bytes(fast.dpram.buf[VB_CONTROL:VB_CONTROL + 2]) == b"\1\0"  # served
    low, high, counter = struct.unpack_from("<iii", fast.dpram.buf, OPEN_USE + 4 * (VB_TABLE + 2))
    assert from_pmac_float_words(high & 0xFFFFFF, low & 0xFFFFFF) == 2.5
    assert 0 < counter <= fast.fw.servo_cycles
    if skip_quiet:
        assert fast.quiet_skipped > 0  # it rested between the host's requests
