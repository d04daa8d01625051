"""Helpers of the Galil client tests (tests/client/test_galil.py, test_gclib.py): a lockstep rack of
galil-dmc13x8 cards and a count of the round trips a call makes."""

from __future__ import annotations

import contextlib
from collections.abc import Iterator
from typing import Any

import pytest
from vdevclient.core import Prepared, Rack

from vdevd.config import CardSpec, Config
from vdevd.devices import card_class

GALIL = "galil-dmc13x8"
LOOPBACK = "tcp://127.0.0.1:*"


def card(type_name: str, name: str, **options: Any) -> CardSpec:
    """A card of `type_name` with its default options, `options` changed."""
    defaults = {key: opt.default for key, opt in card_class(type_name).options.items()}
    return CardSpec(type_name, name, {**defaults, **options})


def rack_config(*cards: CardSpec) -> Config:
    """A lockstep rack of `cards` on free loopback ports."""
    return Config(endpoint=LOOPBACK, events=LOOPBACK, clock="lockstep", cards=list(cards))


class RoundTrips:
    """Every request of every Rack goes through `Rack.call`: this counts them and keeps the
    request maps, a prepared request's too (a batch's ops are in `sent[i]["ops"]`)."""

    def __init__(self) -> None:
        self.sent: list[dict[str, Any]] = []

    @property
    def count(self) -> int:
        return len(self.sent)

    def reset(self) -> None:
        self.sent.clear()


@contextlib.contextmanager
def round_trips(monkeypatch: pytest.MonkeyPatch) -> Iterator[RoundTrips]:
    spy = RoundTrips()
    call = Rack.call

    def counted(self: Rack, message: dict[str, Any] | Prepared, wait_s: float = 0.0) -> Any:
        spy.sent.append(message.message if isinstance(message, Prepared) else message)
        return call(self, message, wait_s)

    with monkeypatch.context() as m:
        m.setattr(Rack, "call", counted)
        yield spy
