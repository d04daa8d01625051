"""The command table (vdevd/devices/galil/commands.py) against the digest spec/galil.md: every
mnemonic the digest documents is run by the interpreter or listed as not emulated, with a reason."""

from __future__ import annotations

import re
from pathlib import Path

import pytest

from tests.devices.digest import digest_text
from vdevd.devices.galil.commands import COMMANDS, NOT_EMULATED_CODES
from vdevd.devices.galil.errors import TC
from vdevd.devices.galil.follow_commands import FollowCommands
from vdevd.devices.galil.interpreter import Interpreter
from vdevd.devices.galil.program_commands import ProgramCommands

#: a mnemonic: two capitals, not part of a longer word (BGS), an operand (_TPX) or a function
#: (@IN[n]); a digit or a bracket may follow (AB1, ET[n])
MNEMONIC = re.compile(r"(?<![@_\w])[A-Z]{2}(?![A-Za-z])")
#: the columns of the digest's command tables that name commands
COMMAND_COLUMNS = ("Cmd", "Item")


def digest_mnemonics(text: str) -> set[str]:
    """The mnemonics of the command tables of digest chapter 4 "Command language": §4.2's binary
    command table, §4.4's interrogation commands, §4.5's complete command table. Only the columns
    headed Cmd or Item count: hex numbers (DA, CE) and prose fill the others."""
    chapter = text[text.index("\n## 4. "):text.index("\n## 5. ")]
    found: set[str] = set()
    columns: list[int] | None = None
    for line in chapter.splitlines():
        if not line.startswith("|"):
            columns = None  # a table ends
            continue
        cells = [c.strip() for c in line.strip().strip("|").split("|")]
        if columns is None:  # the header row
            columns = [i for i, c in enumerate(cells) if c in COMMAND_COLUMNS]
            continue
        for i in columns:
            if i < len(cells):
                found.update(MNEMONIC.findall(cells[i]))
    return found


@pytest.fixture(scope="module")
def mnemonics() -> set[str]:
    return digest_mnemonics(digest_text("galil"))


def test_the_digest_tables_give_the_mnemonics() -> None:
    table = ("| No. | Cmd | No. | Cmd |\n|---|---|---|---|\n| DA | TE | DF | TS |\n\n"
             "| Cmd | Effect |\n|---|---|\n| SB n / CB n | set @IN[n] _TPX |\n"
             "| BGS/BGT, AB1 | ET[n] |\n")
    assert digest_mnemonics(f"\n## 4. Commands\n{table}\n## 5. Next\n") == {
        "TE", "TS", "SB", "CB", "AB"}


def test_the_digest_documents_the_commands_of_every_family(mnemonics: set[str]) -> None:
    assert {"PR", "BG", "TP", "KP", "EI", "DR", "JP", "VM", "GA", "EA", "CM", "BN"} <= mnemonics
    assert len(mnemonics) > 100


def test_every_digest_mnemonic_is_run_or_listed_as_not_emulated(mnemonics: set[str]) -> None:
    assert COMMANDS.covers(mnemonics) == []


def test_a_command_not_emulated_has_a_reason_and_a_tc_code() -> None:
    assert set(NOT_EMULATED_CODES) == set(COMMANDS.not_emulated)
    assert all(reason.strip() for reason in COMMANDS.not_emulated.values())
    assert all(code in set(TC) for code in NOT_EMULATED_CODES.values())


def test_every_command_of_the_table_binds_to_the_interpreter() -> None:
    handlers = COMMANDS.bind(Interpreter.__new__(Interpreter),
                             FollowCommands.__new__(FollowCommands),
                             ProgramCommands.__new__(ProgramCommands))
    assert set(handlers) == set(COMMANDS)


def test_the_readme_not_emulated_table_lists_the_table_s_commands() -> None:
    """README.md "Not emulated" names every command of `not_emulated`, and no other."""
    readme = (Path(__file__).resolve().parents[3] / "vdevd" / "devices" / "galil" / "README.md")
    section = readme.read_text(encoding="utf-8").split("\n## Not emulated\n", 1)[1].split("\n## ")[0]
    listed = {name for line in section.splitlines() if line.startswith("| `")
              for name in line.split("`")[1].split()}
    assert listed == set(COMMANDS.not_emulated)
