"""Region: bounds, bus widths, alignment, byte order, hooks and block accesses (DESIGN.md Region)."""

from __future__ import annotations

import mmap

import pytest

from vdevd.errors import ErrorCode, VdevError
from vdevd.region import Region, passive_except


def fifo_region() -> tuple[Region, list[bytes]]:
    """A 16-byte D08 window with a FIFO data port at 1 (read pops, write pushes)."""
    region = Region("a16", 16, widths=(1,), endian="big")
    fifo = [b"a", b"b", b"c"]
    written: list[bytes] = []
    region.hook(1, 1, on_read=lambda off, n: fifo.pop(0) if fifo else b"\0",
                on_write=lambda off, data: written.append(data),
                peek=lambda off, n: fifo[0] if fifo else b"\0")
    return region, written


def code_of(fn: object, *args: object) -> ErrorCode:
    with pytest.raises(VdevError) as info:
        fn(*args)  # type: ignore[operator]
    return info.value.code


def test_plain_memory_round_trips_in_the_region_byte_order() -> None:
    region = Region("bar", 64, endian="big")
    region.write(4, b"\x12\x34\x56\x78")
    assert region.get(4) == 0x12345678
    region.set(8, 0xAABB, 2)
    assert region.read(8, 2) == b"\xaa\xbb"


def test_out_of_range_and_forbidden_widths_are_errors() -> None:
    region = Region("bar", 64, widths=(2, 4))
    assert code_of(region.read, 62, 4) == ErrorCode.OUT_OF_RANGE
    assert code_of(region.read, -1, 1) == ErrorCode.OUT_OF_RANGE
    assert code_of(region.read, 0, 0) == ErrorCode.OUT_OF_RANGE
    assert code_of(region.read, 2, 4) == ErrorCode.BAD_WIDTH  # misaligned
    assert code_of(region.read, 0, 1) == ErrorCode.BAD_WIDTH  # narrower than the bus allows
    assert code_of(region.write, 1, b"\0\0") == ErrorCode.BAD_WIDTH
    assert region.read(0, 8) == bytes(8)  # a block access of whole bus units


def test_hook_runs_for_every_access_and_peek_has_no_side_effect() -> None:
    region, written = fifo_region()
    assert region.peek(1, 1) == b"a"
    assert region.read(1, 1) == b"a"
    assert region.peek(1, 1) == b"b"
    region.write(1, b"x")
    assert written == [b"x"]
    assert region.read(0, 1) == b"\0"  # plain memory beside the hook


def test_block_read_through_a_fifo_port_pops_once_per_bus_access() -> None:
    region, _ = fifo_region()
    assert region.read(0, 3) == b"\0a\0"
    assert region.read(1, 1) == b"b"


def test_block_write_through_a_port_pushes_each_byte() -> None:
    region, written = fifo_region()
    region.write(0, b"\x01\x02\x03\x04")
    assert written == [b"\x02"]
    assert region.read(2, 1) == b"\x03"


def test_hooks_may_not_overlap_or_leave_the_region() -> None:
    region = Region("bar", 16)
    region.hook(4, 4)
    with pytest.raises(ValueError):
        region.hook(6, 4)
    with pytest.raises(ValueError):
        region.hook(14, 4)


def test_single_access_straddling_a_register_is_refused() -> None:
    region = Region("bar", 16, aligned=False)
    region.hook(4, 2, on_read=lambda off, n: b"\1" * n)
    assert code_of(region.read, 3, 2) == ErrorCode.BAD_WIDTH
    assert region.read(4, 2) == b"\1\1"


# -- passive ranges (decision 0010) -----------------------------------------------------------------
class Pages:
    """A Backing that hands out anonymous shared mappings, as the daemon's segment does."""

    def __init__(self) -> None:
        self.offset = 0

    def allocate(self, size: int) -> tuple[mmap.mmap, int]:
        offset, self.offset = self.offset, self.offset + size
        return mmap.mmap(-1, size), offset


def test_passive_ranges_are_sorted_merged_and_listed_by_describe() -> None:
    region = Region("bar", 64, passive=[(32, 40), (0, 8), (8, 16), (12, 20)])
    assert region.passive == ((0, 20), (32, 40))
    assert region.describe()["passive"] == [[0, 20], [32, 40]]
    for bad in ([(0, 65)], [(8, 8)], [(-4, 4)]):
        with pytest.raises(ValueError):
            Region("bar", 64, passive=bad)


def test_a_hook_may_not_cover_a_passive_byte() -> None:
    region = Region("bar", 64, passive=[(8, 16)])
    region.hook(4, 4)
    region.hook(16, 4)
    with pytest.raises(ValueError, match="passive"):
        region.hook(12, 2)


def test_passive_except_is_the_region_outside_its_registers() -> None:
    assert passive_except(64, [(16, 4), (0, 4), (20, 4)]) == [(4, 16), (24, 64)]
    assert passive_except(8, [(0, 8)]) == []


def test_a_region_with_passive_ranges_takes_its_memory_from_the_backing() -> None:
    pages = Pages()
    shared = Region("bar", 64, endian="big", passive=[(0, 8)], memory=pages)
    private = Region("cfg", 64, memory=pages)  # no passive range: nothing to share
    assert isinstance(shared.buf, mmap.mmap) and shared.shared_offset == 0
    assert isinstance(private.buf, bytearray) and private.shared_offset is None
    shared.write(0, b"\1\2\3\4")
    shared.set(4, 0x05060708)
    assert shared.buf[:8] == bytes(range(1, 9))
    assert shared.read(0, 8) == bytes(range(1, 9)) and shared.get(0) == 0x01020304


def test_without_a_backing_a_passive_region_keeps_private_memory() -> None:
    region = Region("bar", 64, passive=[(0, 8)])
    assert isinstance(region.buf, bytearray) and region.shared_offset is None
