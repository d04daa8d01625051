"""Every card's passive ranges (decision 0010): none overlaps a hook, and a region that declares
some is built on the memory the rack gives (the daemon's shared segment)."""

from __future__ import annotations

import mmap
from typing import Any

import pytest

from vdevd.devices import CARD_TYPES, card_class
from vdevd.devices.base import CardContext

#: each type with its defaults, and with the most axes its options allow (more hooks)
VARIANTS: list[tuple[str, dict[str, Any]]] = [
    *((t, {}) for t in CARD_TYPES),
    ("generic-servo", {"axes": 16}),
    ("galil-dmc13x8", {"axes": 4}),
    ("oms-maxk", {"axes": 10}),
    ("pmac-turbo", {"motors": 32}),
]
#: the regions that have passive ranges; every other region is all hooks or has none
SHARED = {("generic-servo", "bar0"), ("oms-maxk", "shm"), ("pmac-turbo", "dpram"),
          ("dspcg-octavia", "dpr"), ("adlink-amp20xc", "bar0")}


class Pages:
    """Anonymous shared pages, handed out as the daemon's segment does."""

    def __init__(self) -> None:
        self.size = 0

    def allocate(self, size: int) -> tuple[mmap.mmap, int]:
        offset, self.size = self.size, self.size + size
        return mmap.mmap(-1, size), offset


def build(type_name: str, options: dict[str, Any]) -> Any:
    options = {"ethernet": "", **options} if type_name == "pmac-turbo" else options
    return card_class(type_name)("c0", options, CardContext(emit=lambda e: None, memory=Pages()))


@pytest.mark.parametrize(("type_name", "options"), VARIANTS,
                         ids=[f"{t}-{'-'.join(f'{k}{v}' for k, v in o.items()) or 'defaults'}"
                              for t, o in VARIANTS])
def test_no_passive_range_overlaps_a_hook(type_name: str, options: dict[str, Any]) -> None:
    card = build(type_name, options)
    for region in card.regions.values():
        for hook in region.hooks:
            for start, end in region.passive:
                assert hook.end <= start or end <= hook.offset, (
                    f"{type_name} {region.name}: hook {hook.offset:#x}+{hook.size} in passive "
                    f"{start:#x}..{end:#x}")
        assert ((type_name, region.name) in SHARED) == bool(region.passive), region.name
        assert (region.shared_offset is not None) == bool(region.passive), region.name
        if region.passive:
            assert isinstance(region.buf, mmap.mmap)


def test_passive_ranges_are_plain_memory_the_firmware_publishes() -> None:
    """The MAXk's status words are passive and hold what the firmware wrote at power-up."""
    from vdevmaps.oms import FirmwareState, Shm

    card = build("oms-maxk", {})
    shm = card.regions["shm"]
    assert any(s <= Shm.FIRMWARE_STATE and e >= Shm.FIRMWARE_STATE + 4 for s, e in shm.passive)
    word = int.from_bytes(shm.buf[Shm.FIRMWARE_STATE:Shm.FIRMWARE_STATE + 4], "big")
    assert word & FirmwareState.RUNNING
    assert not any(s <= Shm.COMMAND_INSERT < e for s, e in shm.passive)  # its doorbell
