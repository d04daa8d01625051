"""The MAXk command table (commands.py) against the digest `spec/oms.md`: every mnemonic the
digest documents is either run by the card or listed as not emulated with a reason.

The digest documents its commands in the first column of the tables of §4.3 ("Command table"),
and names the `#`/`?` forms in §4.1 ("Syntax"). A cell may hold several mnemonics separated by
`/` or `,` (`RP / RE / RV`), a range of axis selectors (`AX…AS`), a query form (`LT?`, `SE?`), an
operand written into the mnemonic (`CL1 / CL0`, `SVP+ / SVP−`) or in braces (`LM{H,S,F?}`), and a
parenthesised gloss (`(`LTH`, `LTL`)`).
"""

from __future__ import annotations

import inspect
import re

import pytest
from vdevmaps.oms import AXES, MaxkDoorbell

from tests.devices.digest import digest_text
from vdevd.devices.oms import cmd_io, cmd_motion, cmd_servo, cmd_system, cmd_vector
from vdevd.devices.oms.commands import COMMANDS
from vdevd.devices.oms.firmware import Firmware

#: words of §4.3's first column that carry their operand in the letters: `PS` with the axis
#: type O, E or M (the digest's next row is `PS?`)
OPERAND_SPELLINGS = {"PSO": "PS", "PSE": "PS", "PSM": "PS"}
#: backticked words of §4.1 that are notation, not commands: the placeholder of the older query
#: form ("The older form is `?XX`")
NOT_COMMANDS = {"?XX"}
MNEMONIC = re.compile(r"[#?]?[A-Z]{2,3}")
HANDLER_MODULES = (cmd_system, cmd_motion, cmd_servo, cmd_io, cmd_vector)


def _section(text: str, heading: str) -> str:
    start = text.index(heading)
    end = text.find("\n### ", start + len(heading))
    return text[start: end if end >= 0 else len(text)]


def _cell_mnemonics(cell: str) -> list[str]:
    """The mnemonics of one first-column cell of a §4.3 table."""
    cell = re.sub(r"\{[^}]*\}|\([^)]*\)", "", cell.replace("`", ""))
    out: list[str] = []
    for word in re.split(r"[/,]", cell):
        word = word.strip()
        if not word:
            continue
        if "…" in word:  # `AX…AS`: the selectors in canonical axis order
            first, last = word.split("…")
            letters = AXES[AXES.index(first[1]): AXES.index(last[1]) + 1]
            out += [first[0] + a for a in letters]
            continue
        word = OPERAND_SPELLINGS.get(word, word)
        word = re.sub(r"[0-9+\-−]+$", "", word.removesuffix("?"))  # CL1, SVP+, LT?
        assert MNEMONIC.fullmatch(word), f"not a mnemonic in the digest's table: {cell!r}"
        out.append(word)
    return out


def digest_mnemonics(text: str) -> set[str]:
    """Every mnemonic of the digest's §4.3 tables and the `#`/`?` forms §4.1 names."""
    found: set[str] = set()
    for line in _section(text, "### 4.3 Command table").splitlines():
        if not line.startswith("|") or line.startswith("|---"):
            continue
        cell = line.split("|")[1].strip()
        if cell in ("Cmd", ""):
            continue
        found.update(_cell_mnemonics(cell))
    syntax = _section(text, "### 4.1 Syntax")
    found.update(re.findall(r"`([#?][A-Z]{2})`", syntax))
    return found - NOT_COMMANDS


@pytest.fixture(scope="module")
def mnemonics() -> set[str]:
    return digest_mnemonics(digest_text("oms"))


def test_the_digest_parse_finds_the_command_set(mnemonics: set[str]) -> None:
    """§4.3 covers "about 120 mnemonics"; a parse that finds far fewer is broken."""
    assert len(mnemonics) >= 100
    assert {"AX", "AK", "MR", "LT", "PS", "?KP", "CL", "SVP", "#UR", "IOK", "VIO"} <= mnemonics


def test_every_digest_mnemonic_is_run_or_listed_as_not_emulated(mnemonics: set[str]) -> None:
    assert COMMANDS.covers(mnemonics) == []


@pytest.mark.parametrize("name", sorted(COMMANDS.not_emulated))
def test_not_emulated_mnemonics_are_command_errors(name: str) -> None:
    """What the table lists as not emulated is refused: the command-error flag, no reply
    (spec §4.4), whatever the lexer makes of it (`IOK` reads as `IO` and a stray `K`)."""
    assert COMMANDS.not_emulated[name]
    rung: list[int] = []
    fw = Firmware(4, ["M"] * 4, 976_562, update_hz=1024, ideal=True, ring=rung.append,
                  version="1.50", serial=1, save=lambda image: None, saved=None)
    for sent in (name, name + "?"):
        fw.feed(sent.encode() + b";")
        assert rung and rung[-1] == MaxkDoorbell.COMMAND_ERROR and not fw.replies, sent
        rung.clear()


def test_each_handler_is_defined_in_exactly_one_command_module() -> None:
    """`bind` takes the first module that has the name: a handler must not also be a name
    another module defines or imports."""
    for name, cmd in COMMANDS.items():
        owners = [m.__name__ for m in HANDLER_MODULES
                  if inspect.isfunction(fn := getattr(m, cmd.handler, None))
                  and fn.__module__ == m.__name__]
        seen = [m.__name__ for m in HANDLER_MODULES if hasattr(m, cmd.handler)]
        assert owners == seen and len(owners) == 1, (name, cmd.handler, seen)


def test_every_command_cites_a_section() -> None:
    assert all(re.match(r"(S|spec) ", cmd.section) for cmd in COMMANDS.values())
