"""vdevclient._maxk_bus's ring helpers: `ring_pieces` places every byte where the ring puts it
(its one-piece fast path included), `ring_slice` over a view of the read window."""

from __future__ import annotations

from vdevclient._maxk_bus import ring_pieces, ring_slice
from vdevmaps.oms import RING_SIZE


def test_ring_pieces_place_each_byte_where_the_ring_puts_it() -> None:
    """Written piece by piece, the bytes land at (index + k) mod 1024, every 2- or 4-byte piece
    is aligned (a bus access of that width), and a command that fits is one piece."""
    for index in range(RING_SIZE):
        for size in (*range(1, 10), 100, 1022, 1023):
            data = bytes((k * 7 + 1) % 256 for k in range(size))
            ring, expected = bytearray(RING_SIZE), bytearray(RING_SIZE)
            for k in range(size):
                expected[(index + k) % RING_SIZE] = data[k]
            pieces = ring_pieces(index, size)
            for offset, start, length in pieces:
                assert offset >= 0 and offset + length <= RING_SIZE, (index, size)
                assert length not in (2, 4) or offset % length == 0, (index, size)
                ring[offset:offset + length] = data[start:start + length]
            assert ring == expected, (index, size)
            assert sum(length for _, _, length in pieces) == size
            if index + size <= RING_SIZE and (size not in (2, 4) or index % size == 0):
                assert len(pieces) == 1, (index, size)


def test_ring_slice_of_a_view_is_the_slice_of_the_bytes() -> None:
    window = bytes(range(256)) * 9
    for start, end in ((0, 0), (3, 9), (1020, 4), (1023, 0), (500, 499)):
        assert ring_slice(memoryview(window)[16:], start, end) == ring_slice(window[16:], start, end)
