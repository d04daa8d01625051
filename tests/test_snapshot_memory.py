"""A snapshot's shared regions (decision 0010) placed in the new segment at load: each region's
bytes at the offset `hello` announces, wherever the new segment puts it; without a segment the
regions are private memory again (vdevd/snapshot.py)."""

from __future__ import annotations

import mmap
from pathlib import Path

from vdevd.config import default_config
from vdevd.daemon import build_rack
from vdevd.shm import Segment


def test_shared_regions_land_where_hello_says_in_the_new_segment(tmp_path: Path) -> None:
    cfg = default_config()
    old = build_rack(cfg, Segment.create(tmp_path, "tcp://127.0.0.1:5555"))
    shared = [(c.name, r) for c in old.cards.values() for r in c.regions.values()
              if r.shared_offset is not None]
    assert len(shared) >= 3
    for i, (_, region) in enumerate(shared):  # something of its own in each
        start = region.passive[0][0]
        region.buf[start:start + 4] = bytes([i + 1, 0xA5, 0x5A, i + 1])
    data = old.snapshot()
    memory = Segment.create(tmp_path, "tcp://127.0.0.1:6666")
    assert memory is not None
    memory.allocate(3 * mmap.PAGESIZE)  # the new segment places every region elsewhere
    new = old.restore(data, memory)
    offsets = new.hello(local=True)["shm"]["regions"]
    with open(memory.path, "rb") as f:
        whole = f.read()
    for i, (card, region) in enumerate(shared):
        at = offsets[card][region.name]
        assert at != region.shared_offset  # moved
        start = region.passive[0][0]
        assert whole[at + start:at + start + 4] == bytes([i + 1, 0xA5, 0x5A, i + 1])
        restored = new.cards[card].regions[region.name]
        assert bytes(restored.buf) == bytes(region.buf)
    private = old.restore(data)  # no segment: private memory, announced to no one
    assert private.shared_memory() is None
    assert all(r.shared_offset is None and isinstance(r.buf, bytearray)
               for c in private.cards.values() for r in c.regions.values()
               if r.passive)
    for rack in (old, new, private):
        rack.stop()
