"""The command table of a card: one declarative pattern for every card (docs/card-pattern.md).

A card's command set is a `CommandTable` of `Command`s: plain data (the mnemonic as the manual
spells it, the name of the method that runs it, static arguments, the manual section), built in
the card's `commands.py` with no import side effects and no reference to the code that runs it.
The interpreter binds the table to itself once (`table.bind(self)`), which yields a plain dict
of callables for the hot path. Mnemonics the manual documents that the card does not emulate are
listed in the table's `not_emulated` with the reason, so a test can check that every mnemonic of
the card's digest is one or the other.
"""

from __future__ import annotations

import functools
from collections.abc import Callable, Iterable, Iterator, Mapping
from dataclasses import dataclass
from typing import Any


@dataclass(frozen=True, slots=True)
class Command:
    """One mnemonic: the handler's method name, static arguments, card data, the manual section.

    `args` are passed before the command's own operands (`Command("RX", "memory", ("X", False))`
    binds to `partial(interp.memory, "X", False)`); `kind` is card-specific plain data the parser
    reads (OMS: the operand kind; Galil: where the command may appear).
    """

    name: str
    handler: str
    args: tuple[Any, ...] = ()
    kind: Any = None
    section: str = ""


class CommandTable(Mapping[str, Command]):
    """The mnemonics a card knows, by name; plain data until `bind`."""

    def __init__(self, commands: Iterable[Command], not_emulated: Mapping[str, str] | None = None
                 ) -> None:
        self._commands: dict[str, Command] = {}
        for cmd in commands:
            if cmd.name in self._commands:
                raise ValueError(f"command {cmd.name!r} is in the table twice")
            self._commands[cmd.name] = cmd
        self.not_emulated: dict[str, str] = dict(not_emulated or {})
        both = sorted(set(self._commands) & set(self.not_emulated))
        if both:
            raise ValueError(f"commands both in the table and not emulated: {', '.join(both)}")

    def __getitem__(self, name: str) -> Command:
        return self._commands[name]

    def __iter__(self) -> Iterator[str]:
        return iter(self._commands)

    def __len__(self) -> int:
        return len(self._commands)

    def bind(self, *targets: object) -> dict[str, Callable[..., Any]]:
        """name -> callable: each handler looked up on the first of `targets` that has it (an
        object's method, or a function of a module passed as a target), with the command's static
        `args` bound first. A handler no target has is an error here, at construction, not at the
        first use."""
        bound: dict[str, Callable[..., Any]] = {}
        for name, cmd in self._commands.items():
            fn = next((f for t in targets if callable(f := getattr(t, cmd.handler, None))), None)
            if fn is None:
                raise AttributeError(f"command {name!r}: no handler {cmd.handler!r} on "
                                     f"{', '.join(type(t).__name__ for t in targets)}")
            bound[name] = functools.partial(fn, *cmd.args) if cmd.args else fn
        return bound

    def covers(self, mnemonics: Iterable[str]) -> list[str]:
        """The mnemonics of `mnemonics` that are neither in the table nor listed as not emulated
        (a test of the card against its manual's digest wants this empty)."""
        return sorted({m for m in mnemonics if m not in self._commands and m not in self.not_emulated})
