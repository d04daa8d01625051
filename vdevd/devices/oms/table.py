"""The command table: every mnemonic the interpreter knows, its operand kind and its handler.

Handler modules (`cmd_*.py`) register with `@command("MR", operand=Operand.NUMBERS)`. A handler
gets the firmware and the parsed command and returns the reply text (without the LF) or None;
it raises `CommandError` for anything the card refuses (spec oms.md §4.4: the command-error flag
is raised, nothing else changes).
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass
from typing import TYPE_CHECKING, Any

from vdevd.devices.oms.syntax import Command, Operand

if TYPE_CHECKING:
    from vdevd.devices.oms.firmware import Firmware

Handler = Callable[["Firmware", Command], "str | None"]


class CommandError(Exception):
    """The firmware refuses a command: ODBR bit 24, no reply [spec §3.4, §4.4]."""


@dataclass(frozen=True)
class Spec:
    operand: Operand
    handler: Handler


TABLE: dict[str, Spec] = {}


def command(*names: str, operand: Operand = Operand.NONE) -> Callable[[Any], Any]:
    def register(fn: Handler) -> Handler:
        for name in names:
            if name in TABLE:
                raise ValueError(f"command {name} registered twice")
            TABLE[name] = Spec(operand, fn)
        return fn

    return register
