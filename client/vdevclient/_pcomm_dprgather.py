"""The host side of the Turbo PMAC's DPRAM data gathering (I5000 = 2 or 3): the buffer from 0x1140
($060450), its size at 0x113C and the offset of the next item at 0x113E, 32-bit words, a 24-bit
value sign-extended, a 48-bit one as two such words low first [Turbo UM p.422 "Real-Time Data
Gathering Through the Dual-Ported RAM"; ACC-24E2 manual, same text; PMAC1 DPRAM UM p.26; the
card's vdevd/devices/pmac/dpram_gather.py]. Used by `_pcomm_gather.PmacCollectGatherData`.
"""

from __future__ import annotations

import struct

from vdevmaps.pmac import GAT_BUFFER, GAT_SIZE

from vdevclient._pcomm_device import _Device
from vdevclient._pcomm_dpr import _get


def dpram_samples(dev: _Device, per_sample: int) -> list[int]:
    """The whole samples from the buffer's start up to the next-item offset, as 24-bit words
    (each 48-bit value two, low first). ASSUMPTION for a wrapping buffer: the samples since its
    last wrap (a host that wants them all reads as the card goes, watching 0x113E)."""
    size, index = struct.unpack("<HH", _get(dev, GAT_SIZE, 4))
    count = min(index, size) // per_sample * per_sample if per_sample else 0
    if not count:
        return []
    raw = _get(dev, GAT_BUFFER, 4 * count)
    return [w & 0xFFFFFF for w in struct.unpack(f"<{count}i", raw)]
