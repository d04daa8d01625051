"""MAXk ASCII command syntax (vdevd/devices/oms/syntax.py; spec oms.md §4.1, §4.4; [CRM-1-1],
[S App C "Programming"]): the lexer without I/O, then the parser's error rules through a real
card (ODBR bit 24, no reply, nothing changed, parsing goes on)."""

from __future__ import annotations

import pytest
from hypothesis import given
from hypothesis import strategies as st
from vdevmaps.oms import MaxkDoorbell, Mu, Omisr, Shm

from tests.devices.oms.conftest import Maxk
from vdevd.devices.oms import firmware  # noqa: F401  (registers the command handlers)
from vdevd.devices.oms.commands import OPERANDS
from vdevd.devices.oms.syntax import Command, Lexer, Operand, numbers

#: the card's mnemonics and operand kinds
CARD_TABLE = OPERANDS
#: with VO, the velocity override of the vector commands (`VO[n]=pct` [E-traj]; spec §4.3)
WITH_VO = {**CARD_TABLE, "VO": Operand.NUMBERS}

#: what EPICS sends for a motor-record move [E-drvMAXv mod 25; spec §4.1]
EPICS_MOVE = b"AY VB100 VL4000 AC19500 MA5100 GD ID;"
SAMPLES = [EPICS_MOVE, b"AXRP;", b"MR,100,,-5;", b"#UR?;", b"?KP;", b"PS?;", b"LMH,H;",
           b"VO[2]=120;", b"LPE5;", b"MR10.9;", b"XYZZY;WY;", b"ax mr-5 go;"]


def lex(*pieces: bytes, table: dict[str, Operand] = WITH_VO) -> list[Command]:
    """The commands of the stream as it arrives in `pieces`."""
    lexer = Lexer(table)
    out: list[Command] = []
    for piece in pieces:
        out += lexer.feed(piece)
    return out


def words(commands: list[Command]) -> list[tuple[str, str]]:
    return [(c.mnemonic, c.operand) for c in commands]


# -- mnemonics [CRM-1-1; S App C "two or three character ASCII strings"] ----------------------
@pytest.mark.parametrize("text", [b"AX;RP;", b"ax;rp;", b"Ax;rP;"])
def test_mnemonics_are_upper_or_lower_case(text: bytes) -> None:
    assert words(lex(text)) == [("AX", ""), ("RP", "")]


def test_commands_without_operands_need_no_separator() -> None:
    """[CRM-1-1]: `AXRP` is AX then RP."""
    assert words(lex(b"AXRP;")) == [("AX", ""), ("RP", "")]


def test_epics_move_string_is_seven_commands() -> None:
    """`AY VB100 VL4000 AC19500 MA5100 GD ID;` as EPICS sends it (spec §4.1)."""
    assert words(lex(EPICS_MOVE)) == [("AY", ""), ("VB", "100"), ("VL", "4000"), ("AC", "19500"),
                                      ("MA", "5100"), ("GD", ""), ("ID", "")]


def test_separators_are_space_cr_lf_and_semicolon() -> None:
    assert words(lex(b"AX\r\nVL5000 AC50000;\tRP\n")) == [
        ("AX", ""), ("VL", "5000"), ("AC", "50000"), ("RP", "")]


def test_three_letter_mnemonic_wins_over_its_two_letter_prefix() -> None:
    """LPE (load encoder) is not LP with operand E."""
    assert words(lex(b"LPE5;LP7;")) == [("LPE", "5"), ("LP", "7")]


@pytest.mark.parametrize(("text", "expected"), [
    (b"#UR?;", ("#UR", "?")),
    (b"#UR2048;", ("#UR", "2048")),
    (b"?KP;", ("?KP", "")),
    (b"PS?;", ("PS", "?")),
    (b"LT?;", ("LT", "?")),
])
def test_queries_with_hash_and_question_mark(text: bytes, expected: tuple[str, str]) -> None:
    """`#UR`, `#WS`, the older `?XX` form and the modern `XX?` form (spec §4.1)."""
    (cmd,) = lex(text)
    assert (cmd.mnemonic, cmd.operand) == expected
    assert not cmd.error
    assert cmd.query == (expected[1] == "?")


# -- operands [S App C: "MR#,#,#,#,#,#,#,#,#;", "An axis may be skipped"] ----------------------
def test_per_axis_list_keeps_empty_fields() -> None:
    """`MR,100,,-5;`: X skipped, Y 100, Z skipped, T -5."""
    (cmd,) = lex(b"MR,100,,-5;")
    assert cmd.operand == ",100,,-5"
    assert numbers(cmd.operand) == [None, 100.0, None, -5.0]


def test_letter_operands_per_axis_are_upper_cased() -> None:
    """`LMH,H;` as `AA; LMH,H,H,...` (spec §4.3 "Limits")."""
    assert words(lex(b"LMH,H;", b"lms,,f;")) == [("LM", "H,H"), ("LM", "S,,F")]


def test_decimal_operand_is_kept_for_the_handler_to_truncate() -> None:
    """EPICS sends `MR<n>.9` ("OMS bug that ignores MR+/-1", spec §4.1)."""
    (cmd,) = lex(b"MR10.9;")
    assert (cmd.mnemonic, cmd.operand, cmd.error) == ("MR", "10.9", "")


def test_task_index_in_brackets_and_equals_sign() -> None:
    """`VO[n]=pct` [E-traj]: task index 2, operand 120."""
    (cmd,) = lex(b"VO[2]=120;")
    assert (cmd.mnemonic, cmd.index, cmd.operand, cmd.error) == ("VO", 2, "120", "")


def test_bad_task_index_is_an_error() -> None:
    commands = lex(b"VO[x]=120; WY;")
    assert commands[0].mnemonic == "VO" and commands[0].error
    assert words(commands)[-1] == ("WY", "")


# -- the stream [spec §2.4: "A partial trailing command stays pending across writes"] --------
def test_command_split_across_two_writes() -> None:
    assert words(lex(b"AY VB1", b"00 VL4000;")) == [("AY", ""), ("VB", "100"), ("VL", "4000")]


def test_incomplete_operand_waits_for_its_terminator() -> None:
    lexer = Lexer(CARD_TABLE)
    assert words(lexer.feed(b"AX VL50")) == [("AX", "")]
    assert lexer.feed(b"00") == []
    assert words(lexer.feed(b";")) == [("VL", "5000")]


@pytest.mark.parametrize("text", SAMPLES)
def test_every_split_point_gives_the_same_commands(text: bytes) -> None:
    whole = lex(text)
    for cut in range(1, len(text)):
        assert lex(text[:cut], text[cut:]) == whole, f"cut at {cut}: {text[:cut]!r}|{text[cut:]!r}"


@given(st.lists(st.sampled_from(SAMPLES), min_size=1, max_size=6), st.data())
def test_stream_cut_anywhere_gives_the_same_commands(texts: list[bytes], data: st.DataObject) -> None:
    stream = b" ".join(texts)
    cuts = sorted(data.draw(st.lists(st.integers(0, len(stream)), max_size=8)))
    pieces = [stream[a:b] for a, b in zip([0, *cuts], [*cuts, len(stream)], strict=True)]
    assert lex(*pieces) == lex(stream)


def test_reset_drops_a_pending_command() -> None:
    lexer = Lexer(CARD_TABLE)
    assert lexer.feed(b"VL12") == []
    lexer.reset()
    assert lexer.pending == b""
    assert words(lexer.feed(b";WY;")) == [("WY", "")]


# -- errors [spec §4.4: "the firmware discards the rest of that command only"] --------------------
def test_unknown_mnemonic_is_an_error_and_parsing_continues() -> None:
    commands = lex(b"XYZZY;WY;AX;")
    assert commands[0].error and commands[0].mnemonic == "XYZZY"
    assert words(commands[1:]) == [("WY", ""), ("AX", "")]
    assert not any(c.error for c in commands[1:])


def test_unknown_mnemonic_between_spaces() -> None:
    commands = lex(b"AX QQ RP;")
    assert [bool(c.error) for c in commands] == [False, True, False]
    assert words(commands)[2] == ("RP", "")


def test_malformed_letter_operand_is_an_error() -> None:
    (cmd, after) = lex(b"PSO3;WY;")
    assert cmd.mnemonic == "PS" and cmd.error
    assert (after.mnemonic, after.error) == ("WY", "")


# -- through the card ----------------------------------------------------------------------------
def test_epics_move_string_runs_on_the_card(maxk: Maxk) -> None:
    """EPICS' move string: Y goes to 5100 and its done flag is set (spec §4.1, §3.4)."""
    maxk.send(EPICS_MOVE)
    maxk.step(3000)  # 5100 counts at 4000 counts/s: 1.5 s
    assert maxk.query("AA RP;") == "0,5100,0,0"
    assert maxk.query("AY QA;")[1] == "D"
    assert not maxk.command_error()


def test_lower_case_commands_run_on_the_card(maxk: Maxk) -> None:
    assert maxk.query("wy;").startswith("MAXk-4000")
    assert maxk.query("ay ps?;") == "=M"


def test_decimal_move_is_truncated_toward_zero(maxk: Maxk) -> None:
    """`MR10.9` moves 10 counts, `MR-10.9` -10 (spec §4.1, ASSUMPTION)."""
    maxk.send("AX MR10.9 GO; AY MR-10.9 GO;")
    maxk.step(100)
    assert maxk.query("AA RP;") == "10,-10,0,0"


def test_per_axis_list_with_skipped_axes_moves_y_and_t(maxk: Maxk) -> None:
    """[S App C]: "An axis may be skipped by entering the comma with no parameter"."""
    maxk.send("AA MR,100,,-5; GO;")
    maxk.step(100)
    assert maxk.query("AA RP;") == "0,100,0,-5"


def test_queries_answer_in_their_documented_forms(maxk: Maxk) -> None:
    """spec §4.2: `#UR?` without `=` (read with atol), `PS?` `=M` (axes X..T are servos here),
    `?KP` the gain with two decimals, `#WS` `=0`."""
    assert maxk.query("#UR?;") == "1024"
    assert maxk.query("AX PS?;") == "=M"
    maxk.send("AX KP20;")
    maxk.step(2)
    assert maxk.query("?KP;") == "20.00"
    assert maxk.query("#WS;") == "=0"


def test_command_split_across_two_ring_writes(maxk: Maxk) -> None:
    """A partial trailing command waits for the next write of 0x0F0 (spec §2.4)."""
    maxk.send("AX #UR20")
    maxk.step(1)
    assert maxk.reply() is None
    assert maxk.shm.read32(Shm.COMMAND_PROCESS) == maxk.shm.read32(Shm.COMMAND_INSERT)
    assert maxk.query("48; #UR?;") == "2048"
    assert not maxk.command_error()


# -- the error rules [spec §4.4; S §3.4.4] ---------------------------------------------------------
def assert_refused(maxk: Maxk, text: str) -> None:
    """`text` raises ODBR bit 24 and posts no reply; then WY is still answered."""
    maxk.clear_odbr()
    before = maxk.shm.read32(Shm.RESPONSE_INSERT)
    maxk.send(text)
    maxk.step(2)
    assert maxk.odbr() & MaxkDoorbell.COMMAND_ERROR, f"{text!r} did not raise the command-error bit"
    assert maxk.shm.read32(Shm.RESPONSE_INSERT) == before, f"{text!r} posted a reply"
    assert maxk.shm.read32(Shm.MESSAGE_SEMAPHORE) == 0
    assert not maxk.mu.read32(Mu.OMISR) & Omisr.OM0I
    assert maxk.shm.read32(Shm.COMMAND_PROCESS) == maxk.shm.read32(Shm.COMMAND_INSERT)
    maxk.clear_odbr(MaxkDoorbell.COMMAND_ERROR)
    assert maxk.query("WY;").startswith("MAXk-4000"), "the card stopped answering"
    assert not maxk.odbr() & MaxkDoorbell.COMMAND_ERROR


@pytest.mark.parametrize("text", [
    "XYZZY;",  # unknown mnemonic
    "AX VL0;",  # VL outside 1..4,194,303
    "AX VL4194304;",
    "AX AC9000000;",  # AC outside 1..8,000,000
    "AX AC0;",
    "AX VB200000;",  # VB = VL ("OMS errors if VB = VL")
    "AX VB300000;",  # VB > VL
    "AX MR;",  # a position is required
    "AX MR1,2;",  # one value in single-axis mode
    "AA MR1,2,3,4,5;",  # more values than the 4 installed axes
])
def test_refused_motion_command_queues_nothing(maxk: Maxk, text: str) -> None:
    """spec §4.4: command error, no reply, and nothing queued (RQC unchanged)."""
    assert_refused(maxk, text)
    assert maxk.query("AA RQC;") == "2559,2559,2559,2559"


@pytest.mark.parametrize("text", ["AX KP-1;", "AX KP40000;", "AX KO-40000;"])
def test_refused_gain_leaves_the_gain(maxk: Maxk, text: str) -> None:
    """KP..KF outside 0..32767, KO outside +-32767 (spec §4.4): the gain keeps its value."""
    maxk.send("AX KP20 KO100;")
    maxk.step(2)
    assert maxk.query("?KP;") == "20.00"
    assert_refused(maxk, text)
    assert maxk.query("AX ?KP;") == "20.00"
    assert maxk.query("AX ?KO;") == "100.00"


@pytest.mark.parametrize("letter", ["W", "K", "V", "U"])
def test_axis_letter_beyond_the_installed_count_is_refused(maxk: Maxk, letter: str) -> None:
    """spec §4.4: `A<letter>` beyond the 4 installed axes; the addressed axis stays Y."""
    maxk.send("AA LP1,2,3,4;")
    maxk.step(2)
    maxk.send("AY;")
    assert_refused(maxk, f"A{letter};")
    assert maxk.query("RP;") == "2"


def test_error_discards_that_command_only(maxk: Maxk) -> None:
    """spec §4.4: after `XYZZY` and `VL0` the commands that follow in the same write run."""
    maxk.clear_odbr()
    assert maxk.query("XYZZY; AX VL0; AY; WY;").startswith("MAXk-4000")
    assert maxk.odbr() & MaxkDoorbell.COMMAND_ERROR
    assert maxk.query("RP;") == "0"
    maxk.send("AX LP77 AY LP-3 XYZZY AA;")
    maxk.step(2)
    assert maxk.query("AA RP;") == "77,-3,0,0"


def test_failed_query_posts_no_reply(maxk: Maxk) -> None:
    """[E-drvMAXv `motor_init` probes with `EA ID`]: `EA` on an axis without encoder (a PSO
    stepper) is a command error and answers nothing."""
    maxk.send("AX PSO;")
    assert_refused(maxk, "AX EA;")
