"""Twin cards for the "runs" tests (docs/card-pattern.md "Moving ticks in runs"): the card as it
is, and its twin whose `run` returns 0 (every tick through `step`), driven alike and compared
after every batch."""

from __future__ import annotations

from typing import Any

from vdevd.devices.base import Card, CardContext


def one_by_one(card_class: type[Card]) -> type[Card]:
    """`card_class` with every tick through `step`, as Card.tick runs them."""

    class OneByOne(card_class):  # type: ignore[valid-type, misc]
        def run(self, room: int) -> int:
            return 0

    OneByOne.__name__ = f"OneByOne{card_class.__name__}"
    return OneByOne


class TwinCards:
    """Two cards of `card_class` named `name` with `config`: `cards[0]` runs its ticks in runs,
    `cards[1]` one by one; `events[i]` is what card i emitted."""

    def __init__(self, card_class: type[Card], name: str, config: dict[str, Any],
                 skip_quiet: bool) -> None:
        self.events: list[list[str]] = [[], []]
        self.cards: list[Any] = [
            cls(name, config, CardContext(emit=lambda e, seen=seen: seen.append(repr(e))))
            for cls, seen in zip((card_class, one_by_one(card_class)), self.events, strict=True)]
        for card in self.cards:
            card.skip_quiet = skip_quiet

    def control(self, action: str, params: dict[str, Any]) -> None:
        for card in self.cards:
            card.control(action, params)

    def tick(self, n: int) -> None:
        """n ticks, in batches that each card ends at an interrupt (alike on both)."""
        done = 0
        while done < n:
            ran = [card.tick(n - done) for card in self.cards]
            assert ran[0] == ran[1]
            done += ran[0]
