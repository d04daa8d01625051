"""DPRAM data gathering without sockets (I5000 = 2, 3): the buffer at $060450 (host 0x1140), the
size at 0x113C and the next-item offset at 0x113E, 32-bit sign-extended words, a 48-bit source as
two words low first [UM p.422; Turbo SRM DEFINE GATHER; PMAC1 DPRAM UM p.26; dpram_gather.py]."""

from __future__ import annotations

import struct

import numpy as np
import pytest
from vdevmaps.pmac import DPRAM_SIZE, GAT_BUFFER, GAT_SIZE, OPEN_USE_WORDS

from tests.devices.pmac.test_online import Card
from vdevd.devices.pmac.dpram_gather import DpramGather
from vdevd.devices.pmac.numbers import from_pmac_float_words

#: X:$000000 the servo-cycle counter (format 4: a 24-bit X word), P1 L:$006001 (digit C, 48-bit)
SERVO_TIMER, P1 = "$400000", "$C06001"
GATHER_ON = 1 << 19


@pytest.fixture
def card() -> Card:
    c = Card()
    c.raw("I3=2")
    c.dpram = bytearray(DPRAM_SIZE)  # type: ignore[attr-defined]
    c.fw.gather.dpram = DpramGather(c.dpram)  # type: ignore[attr-defined]
    return c


def control(card: Card) -> tuple[int, int]:
    """(size, next-item offset) from Y:/X:$06044F."""
    return struct.unpack_from("<HH", card.dpram, GAT_SIZE)  # type: ignore[attr-defined]


def ring(card: Card, words: int) -> list[int]:
    return [int(w) for w in np.frombuffer(card.dpram, dtype="<i4", count=words,  # type: ignore[attr-defined]
                                          offset=GAT_BUFFER)]


def run(card: Card, cycles: int) -> list[tuple[int, float]]:
    """Tick one cycle at a time, P1 set to a negative value before each, recording what a sample
    of that cycle holds: the servo counter and P1."""
    seen = []
    for k in range(1, cycles + 1):
        card.fw.p[1] = -1.5 * k
        card.tick()
        seen.append((card.fw.memory.read("X", 0), card.fw.p[1]))
    return seen


def test_wrapping_dpram_buffer_holds_each_sample_as_32_bit_words(card: Card) -> None:
    """I5000 = 3: DEFINE GATHER 10 stores 10 at 0x113C; with three words a sample (a 24-bit and a
    48-bit source) GATHER grows it to 12 [SRM DEFINE GATHER]; each servo cycle's sample goes in
    at the offset 0x113E showed, which then names the next item, 0 again after the fourth."""
    card.ask(f"I5000=3 I5001={SERVO_TIMER} I5002={P1} I5050=3 I5051=0 I5049=1")
    card.ask("DEFINE GATHER 10")
    assert control(card) == (10, 0)
    card.ask("GATHER")
    assert control(card) == (12, 0)
    seen = run(card, 6)
    assert control(card)[1] == (6 % 4) * 3
    got = ring(card, 12)
    for j in range(4):  # samples 5 and 6 overwrote the first two slots
        timer, p1 = seen[j + 4] if j < 2 else seen[j]
        low, high = got[3 * j + 1], got[3 * j + 2]
        assert got[3 * j] == timer
        assert from_pmac_float_words(high & 0xFFFFFF, low & 0xFFFFFF) == p1
        assert -0x800000 <= low < 0x800000 and -0x800000 <= high < 0x800000  # sign-extended
    assert any(w < 0 for w in got)  # P1 < 0: its high word's bit 23 set, sign-extended
    assert int(card.ask("???")[:6], 16) & GATHER_ON
    assert card.ask("LIST GATHER") == ""  # the data is in the DPRAM


def test_non_wrapping_dpram_buffer_stops_at_its_end(card: Card) -> None:
    """I5000 = 2: when the offset reaches the size gathering ends (bit 19 clears) and nothing
    more is written [PMAC1 DPRAM UM p.26]; a new DEFINE GATHER resets the offset."""
    card.ask(f"I5000=2 I5001={SERVO_TIMER} I5050=1 I5051=0 I5049=2 DEFINE GATHER 5 GATHER")
    seen = run(card, 20)
    assert control(card) == (5, 5)
    assert ring(card, 6) == [t for t, _ in seen[::2][:5]] + [0]
    assert not int(card.ask("???")[:6], 16) & GATHER_ON
    card.ask("DEFINE GATHER 5")
    assert control(card) == (5, 0)


def test_dpram_buffer_bounds_and_errors(card: Card) -> None:
    """The buffer is the open-use space $060450-$060FFF: 2992 words; without a size it takes all
    of it; more answers ERR003. I5000 beyond 3: ERR003. A firmware without a DPRAM refuses a
    DPRAM buffer (ERR003). DELETE GATHER clears the size register."""
    card.ask("I5000=3")
    assert card.raw(f"DEFINE GATHER {OPEN_USE_WORDS + 1}") == b"\x07ERR003\r"
    card.ask("DEFINE GATHER")
    assert control(card) == (OPEN_USE_WORDS, 0)
    card.ask("DELETE GATHER")
    assert control(card) == (0, 0)
    assert card.raw("I5000=4") == b"\x07ERR003\r"
    bare = Card()
    bare.raw("I3=2")
    bare.ask("I5000=2")
    assert bare.raw("DEFINE GATHER 10") == b"\x07ERR003\r"
    assert not bare.fw.gather.defined


def test_ram_buffer_defined_before_i5000_3_stays_in_ram(card: Card) -> None:
    """I5000 places the buffer when it is defined [SRM I5000]: a buffer defined with I5000 = 0
    stays in regular RAM (LIST GATHER has it) when I5000 changes before GATHER."""
    card.ask(f"I5001={SERVO_TIMER} I5050=1 I5051=0 I5049=1 DEFINE GATHER 10 I5000=3 GATHER")
    card.tick(3)
    card.ask("ENDGATHER")
    assert len(card.ask("LIST GATHER").split("\r")) == 3
    assert control(card) == (0, 0)
