"""Data gathering without sockets: I5000-I5051, DEFINE GATHER, GATHER, ENDGATHER, DELETE GATHER,
LIST GATHER [spec pmac.md §2.2 "I5000-I5099 data gathering", §2.5, §3.3 (dls-pmaccontrol's
gather.py), global status bit 19 §2.1; README "Data gathering"]."""

from __future__ import annotations

import pytest

from tests.devices.pmac.test_cycle_runs import Twin
from tests.devices.pmac.test_online import Card
from vdevd.devices.pmac.numbers import from_pmac_float_words

#: motor 1 actual position D:$00008B (48 bits, 1/(I108*32) count) [registers.py; DLS-ctl
#: gatherchannel.py reg 0x0B, format digit 8]; P1 L:$006001 (48-bit float, digit C)
ACTPOS1, P1 = "$80008B", "$C06001"
GATHER_ON = 1 << 19


@pytest.fixture
def card() -> Card:
    c = Card()
    c.raw("I3=2")
    return c


def words(lines: list[str]) -> list[list[int]]:
    """LIST GATHER as dls-pmaccontrol reads it: each 12-digit word [6:] then [:6]."""
    return [[int(part, 16) for tok in line.split() for part in (tok[6:], tok[:6])]
            for line in lines]


def fixed48(low: int, high: int) -> int:
    v = high << 24 | low
    return v - (1 << 48) if v >> 47 else v


def expected_run(card: Card, period: int, cycles: int) -> list[tuple[int, float]]:
    """Step the card cycle by cycle, recording D:$00008B and P1 after each servo cycle; P1 is set
    to the cycle's number before it so each sample says when it was taken."""
    seen = []
    mem = card.fw.memory
    for k in range(1, cycles + 1):
        card.fw.p[1] = float(k)
        card.tick()
        seen.append((mem.read_fixed(0x8B), mem.read_float(0x6001)))
    return seen


@pytest.mark.parametrize("period", [1, 3])
def test_gathered_positions_are_the_motor_position_at_those_servo_cycles(card: Card,
                                                                          period: int) -> None:
    """Sources: motor 1's actual position (48-bit, two words, low first) and P1 (48-bit float);
    I5049 = period: a sample at the first cycle after GATHER and then every `period` cycles."""
    card.ask(f"I5001={ACTPOS1} I5002={P1} I5050=$3 I5051=0 I5049={period} DEFINE GATHER 500")
    card.ask("I122=100 I119=10 I120=1 I121=0 #1J+ GATHER")
    assert int(card.ask("???")[:6], 16) & GATHER_ON
    seen = expected_run(card, period, 60)
    card.ask("ENDGATHER")
    assert not int(card.ask("???")[:6], 16) & GATHER_ON
    lines = card.ask("LIST GATHER").split("\r")
    got = words(lines)
    taken = seen[::period]
    assert len(got) == len(taken) == -(-60 // period)
    for row, (pos, p1) in zip(got, taken, strict=True):
        assert len(row) == 4
        assert fixed48(row[0], row[1]) == pos
        assert from_pmac_float_words(row[3], row[2]) == p1
    # the motor moved during the gathering, and the 48-bit word reads as the register X:Y
    assert taken[-1][0] > taken[0][0] >= 0
    assert lines[0].split()[0] == f"{pos_words(taken[0][0])}"


def pos_words(v: int) -> str:
    return f"{v & (1 << 48) - 1:012X}"


def test_a_24_bit_source_pads_each_sample_to_a_whole_48_bit_word(card: Card) -> None:
    """X:$00009D (motor 1 actual velocity, format 4) alone: one word, then a pad word, so the
    odd-word skip of dls-pmaccontrol's parseData finds the next sample [DLS-ctl gather.py]."""
    card.ask("I5001=$40009D I5050=1 I5049=2 DEFINE GATHER 10 #1J+ GATHER")
    card.tick(7)
    rows = words(card.ask("LIST GATHER").split("\r"))
    assert len(rows) == 4
    assert all(len(r) == 2 and r[1] == 0 for r in rows)
    assert rows[-1][0] == card.fw.memory.read("X", 0x9D)


def test_mixed_widths_and_long_samples_read_as_a_word_stream(card: Card) -> None:
    """A 24-bit source then a 48-bit one: three words, padded to four; 20 48-bit sources: 40
    words a sample, 16 48-bit words a line (a DPRAM response line holds 255 characters)."""
    card.ask("I5001=$40009D I5002=$80008B I5050=3 I5049=1 DEFINE GATHER 100")
    card.ask("I122=100 I119=10 I120=1 I121=0 #1J+ GATHER")
    card.tick(5)
    card.ask("ENDGATHER")
    mem = card.fw.memory
    rows = words(card.ask("LIST GATHER").split("\r"))
    assert len(rows) == 5 and all(len(r) == 4 and r[3] == 0 for r in rows)
    assert rows[-1][0] == mem.read("X", 0x9D)
    assert fixed48(rows[-1][1], rows[-1][2]) == mem.read_fixed(0x8B)
    card.ask("".join(f"I{5001 + k}=$C{0x6001 + k:05X}" for k in range(20)))
    card.ask("I5050=$FFFFF P1..20=7 DEFINE GATHER 200 GATHER")
    card.tick(2)
    card.ask("ENDGATHER")
    lines = card.ask("LIST GATHER").split("\r")
    assert [len(line.split()) for line in lines] == [16, 4, 16, 4]
    assert max(map(len, lines)) < 255
    stream = [w for row in words(lines) for w in row]
    assert [from_pmac_float_words(stream[i + 1], stream[i]) for i in range(0, 80, 2)] == [7.0] * 40


def test_full_buffer_stops_or_wraps_by_i5000(card: Card) -> None:
    """I5000 = 0: gathering ends when the buffer is full (bit 19 clears); 1: it wraps to the
    start [PComm Gather.h GATMODE GAT_RAM_NOWRAP / GAT_RAM_WRAP]."""
    card.ask(f"I5001={P1} I5050=1 I5049=1 DEFINE GATHER 4 GATHER")
    expected_run(card, 1, 10)
    assert not int(card.ask("???")[:6], 16) & GATHER_ON
    vals = [from_pmac_float_words(r[1], r[0]) for r in words(card.ask("LIST GATHER").split("\r"))]
    assert vals == [1.0, 2.0, 3.0, 4.0]
    card.ask("I5000=1 GATHER")
    expected_run(card, 1, 6)
    assert int(card.ask("???")[:6], 16) & GATHER_ON
    vals = [from_pmac_float_words(r[1], r[0]) for r in words(card.ask("LIST GATHER").split("\r"))]
    assert vals == [5.0, 6.0, 3.0, 4.0]  # samples 5 and 6 over the first two, memory order


def test_keywords_as_the_parser_takes_them(card: Card) -> None:
    card.ask(f"i5001={P1} i5050=1 def gat 8 gat")
    card.tick(2)
    card.ask("end gat")
    assert len(card.ask("list gat").split("\r")) == 2
    card.ask("GATHER")
    card.tick(1)
    card.ask("ENDG")
    assert len(card.ask("LIST GATHER").split("\r")) == 1
    card.ask("delete gather")
    assert card.ask("LIST GATHER") == ""


def test_gather_i_variables_read_as_dls_pmaccontrol_parses_them(card: Card) -> None:
    """i5049 decimal, i5050/i5051 and the sources in hex with the format digit first [§3.3]."""
    card.ask(f"I5001={ACTPOS1} I5050=$1F I5049=10")
    assert card.ask("I5001 I5049 I5050 I5051") == "$80008B\r10\r$1F\r$0"
    assert card.ask("I5000") == "0"


# -- bad input: the card's error, nothing else changes -------------------------------------------
def test_gather_without_define_gather_is_err003(card: Card) -> None:
    card.ask(f"I5001={P1} I5050=1")
    assert card.raw("GATHER") == b"\x07ERR003\r"
    assert not card.fw.gather.on


def test_gather_with_no_source_enabled_is_err003(card: Card) -> None:
    card.ask("I5050=0 I5051=0 DEFINE GATHER 10")
    assert card.raw("GATHER") == b"\x07ERR003\r"


@pytest.mark.parametrize("value", ["$0FFFFF", "$480000", "$10000B", "$20008B", "$1000000"])
def test_a_source_the_card_lacks_is_err003_and_keeps_the_old_one(card: Card, value: str) -> None:
    """A format digit other than 0/4/8/C or an address above $07FFFF [§2.1]."""
    card.ask(f"I5001={ACTPOS1}")
    assert card.raw(f"I5001={value}") == b"\x07ERR003\r"
    assert card.ask("I5001") == ACTPOS1


def test_buffer_in_use_is_err007(card: Card) -> None:
    """While gathering, DEFINE GATHER and DELETE GATHER answer ERR007; a gather buffer blocks
    DEFINE COMP with ERR007 [A L3139, L3179-3186; digest §1.7]."""
    card.ask(f"I5001={P1} I5050=1 DEFINE GATHER 50 GATHER")
    assert card.raw("DEFINE GATHER 20") == b"\x07ERR007\r"
    assert card.raw("DELETE GATHER") == b"\x07ERR007\r"
    assert card.fw.gather.on and card.fw.gather.size == 50
    card.ask("ENDGATHER")
    assert card.raw("#1 DEFINE COMP 12.10,#4,1280,1200") == b"\x07ERR007\r"
    card.ask("DELETE GATHER")
    assert card.raw("#1 DEFINE COMP 12.10,#4,1280,1200") == b"\x06"


def test_define_gather_size_out_of_range_is_err003(card: Card) -> None:
    assert card.raw("DEFINE GATHER 0") == b"\x07ERR003\r"
    assert card.raw("DEFINE GATHER 99999999") == b"\x07ERR003\r"
    assert not card.fw.gather.defined


def test_gather_trigger_is_refused(card: Card) -> None:
    """Not emulated (README): the trigger source was not retrieved (digest §2.10). (The DPRAM
    modes, I5000 = 2 and 3: test_dpram_gather.py.)"""
    card.ask(f"I5001={P1} I5050=1 DEFINE GATHER 10")
    assert card.raw("GATHER TRIGGER") == b"\x07ERR003\r"
    assert not card.fw.gather.on


def test_reset_ends_gathering_and_frees_the_buffer(card: Card) -> None:
    card.ask(f"I5001={P1} I5050=1 DEFINE GATHER 10 GATHER")
    card.raw("$$$")
    assert not card.fw.gather.on and not card.fw.gather.defined


# -- decision 0008: gathering is work; batched cycles gather as cycles one by one -----------------
def test_a_card_gathering_is_not_at_rest_and_batches_gather_as_one_by_one() -> None:
    twin = Twin(True, "servo")
    twin.send(f"I5001={ACTPOS1} I5002=$40009D I5003={P1} I5050=7 I5049=3 DEFINE GATHER 400")
    for card in twin.cards:
        assert card.rest_state() is not None
    twin.send("GATHER")
    for card in twin.cards:  # no motion: gathering alone is work
        assert card.rest_state() is None
    twin.send("ENDGATHER")
    for card in twin.cards:
        assert card.rest_state() is not None
    twin.send("#1J+ #2J=300 GATHER")
    for n in [1, 2, 3, 5, 7, 11, 13, 64, 65, 200]:
        twin.tick(n)
        twin.same()
    twin.send("LIST GATHER")
    twin.same()
    fast = twin.replies[0][-1]
    assert fast.count(b"\r") == -(-371 // 3)  # a sample at cycles 1, 4, 7 ... of 371
    twin.send("ENDGATHER #1J/")
    twin.tick(700)
    twin.same()

