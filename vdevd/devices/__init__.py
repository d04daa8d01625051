"""The card types a rack can hold, by type name (DESIGN.md "Card")."""

from __future__ import annotations

import importlib

from vdevd.devices.base import Card

#: type name -> "module:Class"; imported only when a rack uses the type
CARD_TYPES: dict[str, str] = {
    "generic-servo": "vdevd.devices.generic.card:GenericServoCard",
    "galil-dmc13x8": "vdevd.devices.galil.card:GalilCard",
    "oms-maxk": "vdevd.devices.oms.card:MaxkCard",
    "pmac-turbo": "vdevd.devices.pmac.card:PmacCard",
    "dspcg-octavia": "vdevd.devices.octavia.card:OctaviaCard",
    "adlink-amp20xc": "vdevd.devices.adlink.card:AdlinkCard",
}

#: the prefix of the default name of each type in the embedded default rack
DEFAULT_NAMES: dict[str, str] = {
    "generic-servo": "servo",
    "galil-dmc13x8": "galil",
    "oms-maxk": "maxk",
    "pmac-turbo": "pmac",
    "dspcg-octavia": "octavia",
    "adlink-amp20xc": "adlink",
}


def card_class(type_name: str) -> type[Card]:
    """The class of a card type; KeyError for an unknown type."""
    module, _, cls = CARD_TYPES[type_name].partition(":")
    return getattr(importlib.import_module(module), cls)
