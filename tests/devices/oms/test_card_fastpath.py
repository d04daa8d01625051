"""The MAXk card's fast paths give what the general paths give: the lexer's memo of parsed
streams (syntax.py), whole-word host writes (card.py `_store`), the one-slice reply post
(rings.py), the plain-count reply format (params.py) and the message unit's register reads
(mu.py). Cards are driven through their regions, with no daemon (spec oms.md §2.4-2.5, §2.9)."""

from __future__ import annotations

from typing import Any

from hypothesis import given
from hypothesis import strategies as st
from vdevmaps.oms import MU_SIZE, RING_SIZE, SHM_SIZE, Mu, Omisr, Shm

from vdevd.devices.base import CardContext
from vdevd.devices.oms import rings
from vdevd.devices.oms.card import MaxkCard
from vdevd.devices.oms.commands import OPERANDS
from vdevd.devices.oms.mu import MessageUnit
from vdevd.devices.oms.params import Params
from vdevd.devices.oms.syntax import MEMO_BYTES, MEMO_ENTRIES, Lexer

#: the card's mnemonics and operand kinds
CARD_TABLE = OPERANDS

#: streams a host sends, valid or not, some cut where a later write goes on
PIECES = [b"AX RP;", b"AX RP", b";", b"AA RP;", b"WY;", b"AY RP;WY;", b"AX MR1000 GO ID;", b"XYZZY;",
          b"AX VL5", b"000;", b"VV[2]1000,1000;", b"VO[1]=120;", b"AX LMH;", b"#UR?;", b"AX V",
          b"L", b" ", b"AM;VL5000,,3000;", b"BH0A0F;", b"?KP;", b"AX PS?;", b"Q" * 300,
          b"X" * 1100, b"AXRP;"]


def _plain_parse(pending: bytes, data: bytes) -> tuple[list[Any], bytes]:
    """What a lexer that remembers nothing makes of `data` after `pending`."""
    lexer = Lexer(CARD_TABLE, memo_entries=0)
    lexer.pending = pending
    return lexer.feed(data), lexer.pending


@given(st.lists(st.sampled_from(PIECES), max_size=40))
def test_the_lexer_memo_parses_as_a_lexer_without_one(pieces: list[bytes]) -> None:
    lexer = Lexer(CARD_TABLE)
    for piece in pieces * 2:  # the second round comes from the memo
        expected = _plain_parse(lexer.pending, piece)
        assert (lexer.feed(piece), lexer.pending) == expected, piece


def test_the_lexer_memo_stays_within_its_bound() -> None:
    lexer = Lexer(CARD_TABLE)
    for i in range(3 * MEMO_ENTRIES):
        assert [c.operand for c in lexer.feed(f"AX MR{i};".encode())] == ["", str(i)]
        assert len(lexer._memo) <= MEMO_ENTRIES
    lexer.feed(b"AX " + b"VL5000 " * (MEMO_BYTES // 7 + 1) + b";")
    assert all(len(stream) <= MEMO_BYTES for stream in lexer._memo)


# -- a card driven with whole words and its memo, and one driven byte by byte parsing afresh -------
class Host:
    """The EPICS MAXv procedure on a card's regions (spec §2.4-2.5): whole 32-bit words, or
    (`byte_wise`) every word and every ring byte as single byte writes (the card acts on a word's
    last byte); `byte_wise` also makes the card's lexer parse every stream afresh."""

    def __init__(self, byte_wise: bool) -> None:
        self.card = MaxkCard("maxk0", {"board": 1, "axes": 10}, CardContext(emit=lambda event: None))
        self.byte_wise = byte_wise
        self.shm, self.mu = self.card.shm, self.card.mu_region
        if byte_wise:
            fw = self.card.fw
            fw.lexer = Lexer(fw.lexer.table, memo_entries=0)

    def word(self, offset: int, value: int) -> None:
        data = value.to_bytes(4, "big")
        if self.byte_wise:
            for i in range(4):
                self.shm.write(offset + i, data[i:i + 1])
        else:
            self.shm.write(offset, data)

    def send(self, text: bytes) -> None:
        put = rings.u32(self.shm.buf, Shm.COMMAND_INSERT)
        if self.byte_wise:
            for i, c in enumerate(text):
                self.shm.write(Shm.COMMAND_RING + (put + i) % RING_SIZE, bytes([c]))
        else:
            first = text[:RING_SIZE - put]
            for offset, piece in ((Shm.COMMAND_RING + put, first), (Shm.COMMAND_RING, text[len(first):])):
                if len(piece) in (2, 4) and offset % len(piece):
                    self.shm.write(offset, piece[:1])
                    offset, piece = offset + 1, piece[1:]
                if piece:
                    self.shm.write(offset, piece)
        self.word(Shm.COMMAND_INSERT, (put + len(text)) % RING_SIZE)

    def replies(self) -> list[bytes]:
        """Every reply the card posts as the last one is released (0x0FC := 0x0F8, OM0I W1C,
        semaphore 0)."""
        out = []
        buf = self.shm.buf
        while (end := rings.u32(buf, Shm.RESPONSE_INSERT)) != (start := rings.u32(buf, Shm.RESPONSE_PROCESS)):
            out.append(bytes(buf[Shm.RESPONSE_RING + (start + i) % RING_SIZE]
                             for i in range((end - start) % RING_SIZE)))
            self.word(Shm.RESPONSE_PROCESS, end)
            self.mu.write(Mu.OMISR, int(Omisr.OM0I).to_bytes(4, "little"))
            self.word(Shm.MESSAGE_SEMAPHORE, 0)
        return out

    def state(self) -> tuple[bytes, list[int]]:
        return bytes(self.shm.buf), [self.card.mu.read(o) for o in range(0, MU_SIZE, 4)]


STEPS: list[tuple[str, Any]] = [
    ("send", b"AX RP;"),
    ("send", b"AX MR1000 GO ID;"),
    ("tick", 300),
    ("send", b"AX RP;"),  # the same text, a longer reply
    ("send", b"XYZZY;AX RP;"),  # a command error beside a reply
    ("send", b"WY;AY RP;"),  # two replies: the second waits for the release of the first
    ("send", b"AX RP;"),
    ("hold", b"AA RP;"),  # posted, left unreleased: the next reply waits
    ("hold", b"AX RP;"),
    ("send", b"AX V"),  # a command cut between two writes
    ("send", b"L5000;AX RP;"),
    *[("send", b"AX " + b"MR1 GO " * 140 + b";") for _ in range(4)],  # the X queue overflows
    ("send", b"AX RQC;"),
    ("word", (Shm.DIRECT_COMMAND, 2)),  # kill all motion
    ("send", b"AW MR100 GO ID;"),
    ("tick", 300),
    ("word", (Shm.W_STATUS_FLAGS, 0x0101_0101)),  # W done cleared by writing ones
    ("word", (Shm.POSITION_REQUEST, 1)),
    ("send", b"AA RP;"),
    ("send", b"#UR?;AX RP;"),
]


def test_a_card_on_its_fast_paths_answers_as_one_on_the_general_paths() -> None:
    fast, plain = Host(byte_wise=False), Host(byte_wise=True)
    for step, arg in STEPS * 3:  # later rounds: the memo answers, the rings wrap
        held: list[list[bytes]] = [[], []]
        for i, host in enumerate((fast, plain)):
            if step == "tick":
                ran = 0
                while ran < arg:  # a tick that raises INTA ends a run early
                    ran += host.card.tick(arg - ran)
            elif step == "word":
                host.word(*arg)
            else:
                host.send(arg)
            if step != "hold":
                held[i] = host.replies()
        assert held[0] == held[1], (step, arg)
        assert fast.state() == plain.state(), (step, arg)
    assert fast.card.fw.errors == plain.card.fw.errors > 0


# -- the reply post, the reply format, the message unit ---------------------------------------------
def _post_as_before(buf: bytearray, text: bytes) -> None:
    """rings.post_response written piece by piece (the general path)."""
    if len(text) >= RING_SIZE:
        text = text[: RING_SIZE - 2] + b"\n"
    insert = rings.u32(buf, Shm.RESPONSE_INSERT) % RING_SIZE
    for i, c in enumerate(text):
        buf[Shm.RESPONSE_RING + (insert + i) % RING_SIZE] = c
    rings.put_u32(buf, Shm.RESPONSE_INSERT, (insert + len(text)) % RING_SIZE)
    rings.put_u32(buf, Shm.MESSAGE_SEMAPHORE, 1)


def test_a_reply_posted_at_any_ring_place_lands_as_byte_by_byte() -> None:
    for insert in [*range(0, 8), *range(RING_SIZE - 40, RING_SIZE), 5000]:
        for size in (1, 2, 5, 13, 39, 40, 41, RING_SIZE - 1, RING_SIZE, 1500):
            text = bytes(48 + i % 10 for i in range(size - 1)) + b"\n"
            fast, slow = bytearray(SHM_SIZE), bytearray(SHM_SIZE)
            for buf in (fast, slow):
                rings.put_u32(buf, Shm.RESPONSE_INSERT, insert)
            rings.post_response(fast, text)
            _post_as_before(slow, text)
            assert fast == slow, (insert, size)


def test_counts_without_user_units_format_as_the_scaled_formula() -> None:
    params = Params(3, ["O", "E", "M"])
    for ratio in (1.0, 0.25, 3.0):  # ER on the PSE axis: its motor replies in encoder counts
        params.ratio[1] = ratio
        for a in range(3):
            for kind in ("motor", "encoder"):
                for v in (0.0, 1.0, -1.0, 0.5, 1.5, -2.5, 1234567.0, -2147483648.0, 3.4999):
                    expected = str(int(round(v / params.scale(a, kind))))
                    assert params.format(a, v, kind) == expected, (ratio, a, kind, v)


def test_every_message_unit_register_reads_its_value() -> None:
    mu = MessageUnit()
    mu.ring(0x0100_0003)
    mu.message(0, 7)
    mu.message(1, 2)
    mu.write(Mu.OMIMR, 0x1)
    mu.write(Mu.IMR0, 11)
    mu.write(Mu.IMR1, 12)
    values: dict[int, int] = {Mu.OMISR: mu.omisr, Mu.OMIMR: 1, Mu.OMR0: 7, Mu.OMR1: 2,
                              Mu.ODBR: 0x0100_0003, Mu.IMR0: 11, Mu.IMR1: 12}
    assert values[Mu.OMISR] == 0x0B  # OM0I, OM1I and the doorbell
    for offset in range(0, MU_SIZE, 4):
        assert mu.read(offset) == values.get(offset, 0), hex(offset)
