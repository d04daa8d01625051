"""The on-line command table against the digest: every command the digest's on-line command
reference documents is run by the card or listed as not emulated, with its reason [spec pmac.md
§2.5; vdevd/devices/pmac/commands.py]."""

from __future__ import annotations

import re

import pytest

from tests.devices.digest import digest_text
from tests.devices.pmac.test_online import Card
from vdevd.devices.pmac.commands import CHAR, COMMANDS, REFUSED, VARIABLES, WORD
from vdevd.devices.pmac.online import Interpreter
from vdevd.devices.pmac.reply import frame

#: digest words that are not commands: the variable letters with a number (`I{n}`, `M{n}`);
#: `P{n}` and `Q{n}` are variables too, but `P` and `Q` alone are commands
NOT_COMMANDS = {"I", "M"}
_SPAN = re.compile(r"`([^`]+)`")
_PLACEHOLDER = re.compile(r"\{[^}]*\}")
_CONTROL = re.compile(r"\^[A-Z]")


def digest_commands(text: str) -> set[str]:
    """The mnemonics of §2.5's table (first column, one per code span): the leading word of a
    span that starts with a letter (`OPEN PROG n` is OPEN, `WL:$addr,...` WL, `I65` I), else its
    first character (`#n?` is #, `$$$***` $). A leading operand placeholder is not a command
    (`{expr}` forms nothing, `{jog}^{c}` is ^); control characters (`^K`) act in the port
    (Firmware.control), not through the table."""
    section = text.split("### 2.5", 1)[1].split("\n### ", 1)[0]
    rows = [r for r in section.splitlines() if r.startswith("|")][2:]  # header, separator
    assert rows, "§2.5 has no command table"
    found: set[str] = set()
    for row in rows:
        for span in _SPAN.findall(row.split("|")[1]):
            span = span.strip()
            if _CONTROL.fullmatch(span):
                continue
            if span.startswith("{"):
                span = _PLACEHOLDER.sub("", span, count=1)
                if not span:
                    continue
            word = re.match(r"[A-Z]+", span)
            found.add(word.group() if word else span[0])
    return found


@pytest.fixture(scope="module")
def words() -> set[str]:
    return digest_commands(digest_text("pmac"))


def test_the_digest_documents_the_on_line_commands(words: set[str]) -> None:
    assert {"#", "&", "?", "$", "%", "J", "HM", "HMZ", "K", "O", "RX", "WL", "OPEN", "MS"} <= words
    assert not {"PROG", "PLC", "ROT", "TCOMP", "ALL"} & words  # operands, not commands


def test_every_digest_command_is_in_the_table_or_not_emulated(words: set[str]) -> None:
    assert COMMANDS.covers(words - NOT_COMMANDS) == []


def test_the_words_that_are_not_commands_are_variables() -> None:
    assert set(VARIABLES) >= NOT_COMMANDS


def test_the_refused_words_are_the_not_emulated_words_the_parser_recognises() -> None:
    assert set(REFUSED) <= set(COMMANDS.not_emulated)
    assert all(reason for reason in COMMANDS.not_emulated.values())


def test_one_character_commands_are_one_character() -> None:
    assert all(len(name) == 1 and not name.isalpha()
               for name, cmd in COMMANDS.items() if cmd.kind == CHAR)
    assert all(name.isalpha() for name, cmd in COMMANDS.items() if cmd.kind == WORD)


def test_the_table_binds_to_the_interpreter() -> None:
    bound = COMMANDS.bind(Interpreter(Card().fw))
    assert set(bound) == set(COMMANDS)


@pytest.mark.parametrize("word", sorted(REFUSED))
def test_a_refused_word_answers_its_error(word: str) -> None:
    card = Card()
    card.fw.set_ivar(6, 1)
    assert frame(card.fw.execute(card.port, word), 2, 1) == f"\x07ERR{REFUSED[word]:03d}\r".encode()
