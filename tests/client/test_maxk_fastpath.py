"""vdevclient._maxk_bus's fast paths give what the general paths give: `ring_pieces` for a
command that fits before the ring's end, `ring_slice` over a view of the read window."""

from __future__ import annotations

from vdevclient._maxk_bus import RING_SIZE, ring_pieces, ring_slice


def _pieces_in_general(index: int, size: int) -> list[tuple[int, int, int]]:
    """The split at the ring's end, then a 2- or 4-byte piece at an odd place as a byte and
    the rest (the procedure `ring_pieces` documents)."""
    first = min(size, RING_SIZE - index)
    pieces = [(index, 0, first)] + ([(0, first, size - first)] if first < size else [])
    out = []
    for offset, start, length in pieces:
        if length in (2, 4) and offset % length:
            out += [(offset, start, 1), (offset + 1, start + 1, length - 1)]
        else:
            out.append((offset, start, length))
    return out


def test_ring_pieces_are_the_general_split_at_every_ring_place() -> None:
    for index in range(RING_SIZE):
        for size in (*range(1, 10), 100, 1022, 1023):
            assert ring_pieces(index, size) == _pieces_in_general(index, size), (index, size)


def test_ring_slice_of_a_view_is_the_slice_of_the_bytes() -> None:
    window = bytes(range(256)) * 9
    for start, end in ((0, 0), (3, 9), (1020, 4), (1023, 0), (500, 499)):
        assert ring_slice(memoryview(window)[16:], start, end) == ring_slice(window[16:], start, end)
