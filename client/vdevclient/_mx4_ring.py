"""The Mx4 Octavia's 672 bytes at 120h from the host's side [Ch6 Contouring; Ch5 LOAD_*; spec
§2.5.4, §8.1]: the contouring ring buffer (`ring_free`, `ring_put`, the streaming procedure
`contour`) and the staging area of the table downloads (`load_table`).

`vdevclient.mx4` re-exports these; `h` is its `Mx4`.
"""

from __future__ import annotations

import struct
from collections.abc import Iterable, Sequence
from typing import Any

from vdevmaps.octavia import RING_SLOTS, SLOT_BYTES, Dpr, HostInt

from vdevclient._mx4_bus import Mx4, acknowledged, expect
from vdevclient._mx4_codec import Mx4Error, Post, bits_text, encode, i16, i32

#: the load RTCs and their chunks: entries per 672-byte staging area, entry format [Ch5 LOAD_*]
_TABLES = {"cam": ("LOAD_CAM_TABLE", 67, "<iih"), "cubic": ("LOAD_CUBIC_TABLE", 168, "<i"),
           "pos": ("LOAD_POS_TABLE", 336, "<H"), "vel": ("LOAD_VEL_TABLE", 336, "<H")}
_TABLE_POSTS_PER_BATCH = 64  # 43 KB of staged data per round trip
_SLOT = struct.Struct("<ii")


# -- the ring [Ch6 Contouring] ------------------------------------------------------------------------
def ring_free(h: Mx4) -> int:
    """Free slots of the contouring ring: 83 when empty (INPTR = OUTPTR; one slot stays empty)."""
    inptr, outptr = h.dpr.read(Dpr.INPTR, 2)
    return (outptr - inptr - 1) % RING_SLOTS


def ring_put(h: Mx4, slots: Sequence[tuple[int, int, int]]) -> int:
    """Append (axis, pos, vel) slots at INPTR, wrapping from 3BFh to 120h, then move INPTR past
    them: as many as fit. The slots of one point go in increasing axis order [Ch6 Contouring
    rules 2-5]: `axis` is only checked. One batch, none where the DPR is mapped (the card reads
    the pointers at its samples). Returns the number written."""
    inptr, outptr = h.dpr.read(Dpr.INPTR, 2)
    n = min((outptr - inptr - 1) % RING_SLOTS, len(slots))
    for axis, _, _ in slots[:n]:
        if not 1 <= axis <= 8:
            raise ValueError(f"ring_put: axis {axis} outside 1..8")
    writes = ring_writes(inptr, [(pos, vel) for _, pos, vel in slots[:n]])
    if all(h.dpr.is_mapped(offset, len(data)) for offset, data in writes):
        for offset, data in writes:  # the slots, then INPTR
            h.dpr.write(offset, data)
    else:
        h.batch([h.write(offset, data) for offset, data in writes])
    return n


def ring_writes(inptr: int, slots: Sequence[tuple[int, int]]) -> list[tuple[int, bytes]]:
    """(offset, bytes) of `slots` from slot `inptr`, split where the ring wraps, then INPTR's."""
    data = b"".join(_SLOT.pack(i32(p), i32(v)) for p, v in slots)
    first = min(len(slots), RING_SLOTS - inptr) * SLOT_BYTES
    out = [(int(Dpr.RINGBUF) + inptr * SLOT_BYTES, data[:first]), (int(Dpr.RINGBUF), data[first:])]
    return [*(w for w in out if w[1]), (int(Dpr.INPTR), bytes(((inptr + len(slots)) % RING_SLOTS,)))]


def contour(h: Mx4, mask: int, points: Iterable[Sequence[tuple[int, int]]], *,
            btrate: int | None = None, cubic_rate: int | None = None, bufbrk: int = 30,
            timeout_ms: int = 10_000) -> int:
    """Stream a contour [Ch6 Contouring, Fig. 6-5; spec §8.1]: each point holds (pos, vel) per
    axis of `mask`, in increasing axis order. The ring (which must be empty) is preloaded from
    OUTPTR, and BTRATE m (2nd order) or CUBIC_RATE m (cubic), EN_BUFBRK bufbrk and START(mask)
    go in the same batch; then each refill is one batch: the ring filled as far as the card's
    OUTPTR (as last read) allows, a server-side wait for the buffer-breakpoint interrupt (1FFEh
    b0), the pointers read, the interrupt acknowledged. A data run-out (b5) or ESTOP (b2) raises
    Mx4Error. Returns, with the number of points sent, once the card has read the last of them
    (and the breakpoints they caused are acknowledged); the last interval then runs."""
    k = int(mask & 0xFF).bit_count()
    if not k or (btrate is None) == (cubic_rate is None):
        raise ValueError("contour: a mask and one of btrate, cubic_rate")
    if not k <= bufbrk <= RING_SLOTS - 1 - k:
        raise ValueError(f"contour: bufbrk {bufbrk} outside {k}..{RING_SLOTS - 1 - k} slots")
    t, rtc_ns = h.timeout_ns(timeout_ms), h.timeout_ns()
    inptr, outptr = h.dpr.read(Dpr.INPTR, 2)
    if inptr != outptr:
        raise Mx4Error(f"{h.card}: the ring is not empty (INPTR {inptr}, OUTPTR {outptr})")
    feed = _Points(points, k)
    first = feed.take((RING_SLOTS - 1) // k)
    rate = (encode("BTRATE", {"m": btrate}) if btrate is not None
            else encode("CUBIC_RATE", {"m": cubic_rate}))
    posts = [*rate, *encode("EN_BUFBRK", {"buffbrk": bufbrk}), *encode("START", {"n": mask})]
    preload = [h.write(offset, data) for offset, data in ring_writes(inptr, first)]
    start = h.post_ops(posts, rtc_ns)
    res = h.batch([*preload, *start, *h.check_ops(rtc_ns)], rtc_ns * (len(posts) + 2))
    h.taken(res[len(preload):], posts)
    h.checked(res, len(preload) + len(start), posts, rtc_ns)
    inptr, sent = (inptr + len(first)) % RING_SLOTS, len(first) // k
    change = acknowledged(int(HostInt.BUFBRK), 0, 0, True)
    stop = int(HostInt.BUFBRK | HostInt.RUN_OUT | HostInt.ESTOP)
    while True:
        slots = feed.take(((outptr - inptr - 1) % RING_SLOTS) // k)
        writes = [h.write(o, d) for o, d in ring_writes(inptr, slots)] if slots else []
        inptr, sent = (inptr + len(slots)) % RING_SLOTS, sent + len(slots) // k
        if feed.done:
            break
        h.status = expect(h.status, int(HostInt.BUFBRK), 0, 0, True)
        res = h.batch([*writes, h.wait(Dpr.HOSTINT1, 0, t, mask=stop, equal=False),
                       h.read(Dpr.INPTR, 2), *h.ack_ops(change, t)], 2 * t)
        at = len(writes)
        h.fired(res[at], "buffer breakpoint (1FFEh b0)", t)
        outptr = res[at + 1][1]
        found = h.ack_results(res, at + 2, change)
        failed = int(found.hostint or 0) & (HostInt.RUN_OUT | HostInt.ESTOP)
        if failed:
            raise Mx4Error(f"{h.card}: contour stopped after {sent} points were sent: 1FFEh "
                           f"{bits_text(HostInt(failed))}", status=found)
    h.status = expect(h.status, int(HostInt.BUFBRK), 0, 0, True)
    res = h.batch([*writes, h.wait(Dpr.OUTPTR, inptr, t), *h.ack_ops(change, t)], 2 * t)
    h.fired(res[len(writes)], f"read of the ring up to INPTR {inptr}", t)
    h.ack_results(res, len(writes) + 1, change)  # the breakpoints of the last points
    return sent


class _Points:
    """The points of a contour, taken as ring slots as room comes, with a look-ahead of one
    point so that the last batch knows it is the last."""

    def __init__(self, points: Iterable[Sequence[tuple[int, int]]], k: int) -> None:
        self._it, self._k = iter(points), k
        self._next = next(self._it, None)

    @property
    def done(self) -> bool:
        return self._next is None

    def take(self, count: int) -> list[tuple[int, int]]:
        """The slots of up to `count` points."""
        out: list[tuple[int, int]] = []
        for _ in range(count):
            point = self._next
            if point is None:
                break
            if len(point) != self._k:
                raise ValueError(f"contour: a point of {len(point)} (pos, vel) pairs for {self._k} axes")
            out += point
            self._next = next(self._it, None)
        return out


# -- table download [Ch5 LOAD_CAM_TABLE, LOAD_CUBIC_TABLE, LOAD_POS_TABLE, LOAD_VEL_TABLE] -----------
def load_table(h: Mx4, kind: str, index: int, data: Sequence[Any], *, table: int = 1,
               timeout_ms: int | None = None) -> None:
    """Download a table in chunks of at most 672 bytes staged at 120h, each followed by its LOAD
    RTC; the card has copied a chunk out when it clears 3C2h, and the next is staged then. `kind`:
    "cam" ((master, slave, ratio) points, ratio 1.8.7, 67 per chunk), "cubic" (int32 positions,
    168), "pos" / "vel" (16-bit compensation entries of the tables of the mask `table`, 336).
    Up to 64 chunks per round trip."""
    if kind not in _TABLES:
        raise ValueError(f"load_table: kind {kind!r} (one of {', '.join(_TABLES)})")
    name, per_chunk, fmt = _TABLES[kind]
    entry = struct.Struct(fmt)
    posts = []
    for start in range(0, len(data), per_chunk):
        chunk = data[start:start + per_chunk]
        head: dict[str, int]
        if kind == "cam":
            stage = b"".join(entry.pack(i32(m), i32(s), i16(r)) for m, s, r in chunk)
            head = {"index": index + start, "numpts": len(chunk)}
        elif kind == "cubic":
            stage = b"".join(entry.pack(i32(p)) for p in chunk)
            head = {"index": index + start, "num": len(chunk)}
        else:
            stage = b"".join(entry.pack(e & 0xFFFF) for e in chunk)
            head = {"table": table, "index": index + start, "num": len(chunk)}
        post, = encode(name, head)
        posts.append(Post(name, post.code, post.args, stage))
    for i in range(0, len(posts), _TABLE_POSTS_PER_BATCH):
        h.send(posts[i:i + _TABLE_POSTS_PER_BATCH], timeout_ms=timeout_ms, check=False)
