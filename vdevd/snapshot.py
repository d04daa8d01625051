"""Rack snapshots (issue 23 §2): every card's state and the simulated clock in one versioned file.

A snapshot is the rack's object graph (the scheduler and its cards: regions, firmware, queues,
programs, motion core arrays, the axis world, the NV image; the scope recorders armed on them)
pickled without its I/O
(vdevd/snapshot_pickle.py), behind a header that says what it fits:

    b"VDEVSNAP" | u32 header length (big-endian) | header (JSON) | zlib(pickle)

The header carries the format version, the vdevd version, the clock mode, the rack layout (each
card's name, type, axis count and a digest of its options but its TCP ports) and the size and
SHA-256 of the payload. `load` checks all of it before it unpickles anything, then unpickles into
a NEW rack with the restricted unpickler; any failure is a `bad_snapshot` error naming why, and
the running rack is not touched (the server swaps the new one in only once it is whole).
"""

from __future__ import annotations

import hashlib
import importlib.metadata
import io
import json
import pickle
import struct
import zlib
from typing import TYPE_CHECKING, Any

from vdevd.card_ports import PORT_KEYS
from vdevd.errors import ErrorCode, VdevError
from vdevd.rt.scheduler import Scheduler
from vdevd.scope.op import Scopes
from vdevd.shm import Segment
from vdevd.snapshot_pickle import SnapshotPickler, SnapshotUnpickler, bad

if TYPE_CHECKING:
    from vdevd.rack import Rack

MAGIC = b"VDEVSNAP"
#: the snapshot format; a file of another format is refused
FORMAT = 1
#: the largest snapshot file the daemon writes or reads (compressed), and the largest payload
#: it decompresses
MAX_SNAPSHOT = 64 << 20
MAX_PAYLOAD = 256 << 20
MAX_HEADER = 64 << 10


def vdevd_version() -> str:
    """The installed vdevd's version (a snapshot loads only into the version that saved it)."""
    try:
        return importlib.metadata.version("vdevd")
    except importlib.metadata.PackageNotFoundError:  # run from a source tree
        return "0+unknown"


# -- the layout a snapshot fits ------------------------------------------------------------------
def layout(rack: Rack) -> list[dict[str, Any]]:
    """Each card's name, type, axis count and the digest of its options (but its TCP ports,
    which a daemon may move: `--card-port`, the test plugin's free ports)."""
    out = []
    for card in rack.cards.values():
        options = {k: v for k, v in card.opts.items() if k not in PORT_KEYS}
        text = json.dumps(options, sort_keys=True, default=repr)
        out.append({"name": card.name, "type": card.type_name, "axes": card.world.n,
                    "options": hashlib.sha256(text.encode()).hexdigest()[:16]})
    return out


def _layout_difference(saved: list[dict[str, Any]], ours: list[dict[str, Any]]) -> str:
    """What differs between the snapshot's rack and this daemon's, in words."""
    names = [c.get("name") for c in saved]
    if names != [c["name"] for c in ours]:
        return (f"its cards are {', '.join(map(str, names)) or 'none'}, this rack's are "
                f"{', '.join(c['name'] for c in ours) or 'none'}")
    for s, o in zip(saved, ours, strict=True):
        for key, what in (("type", "type"), ("axes", "axis count"), ("options", "options")):
            if s.get(key) != o[key]:
                return (f"card {o['name']}: its {what} {s.get(key)!r} differs from this "
                        f"rack's {o[key]!r}")
    return "the layouts differ"



def save(rack: Rack) -> bytes:
    """The snapshot of `rack` (module docstring); `bad_snapshot` when it is larger than
    MAX_SNAPSHOT or holds what cannot be saved (a bug: named)."""
    buf = io.BytesIO()
    state = {"sched": rack.sched, "cards": list(rack.cards.values()), "scopes": rack.scopes}
    try:
        SnapshotPickler(buf, rack).dump(state)
    except (pickle.PicklingError, TypeError, AttributeError) as exc:
        raise VdevError(ErrorCode.INTERNAL, f"snapshot: the rack holds what cannot be saved: "
                        f"{exc}") from None
    raw = buf.getvalue()
    payload = zlib.compress(raw, 6)
    header = {
        "format": FORMAT,
        "vdevd": vdevd_version(),
        "clock": rack.mode,
        "now_ns": rack.now_ns,
        "layout": layout(rack),
        "payload_size": len(payload),
        "payload_sha256": hashlib.sha256(payload).hexdigest(),
        "raw_size": len(raw),
    }
    head = json.dumps(header, sort_keys=True).encode()
    data = MAGIC + struct.pack(">I", len(head)) + head + payload
    if len(data) > MAX_SNAPSHOT:
        raise bad(f"the snapshot of {len(data)} bytes exceeds the maximum of {MAX_SNAPSHOT}")
    return data



# -- loading --------------------------------------------------------------------------------------
def read_header(data: bytes) -> tuple[dict[str, Any], bytes]:
    """The header and the payload of a snapshot file; `bad_snapshot` naming what is wrong."""
    if len(data) > MAX_SNAPSHOT:
        raise bad(f"a snapshot of {len(data)} bytes exceeds the maximum of {MAX_SNAPSHOT}")
    if not data.startswith(MAGIC):
        raise bad("not a vdevd snapshot (it does not begin with VDEVSNAP)")
    if len(data) < len(MAGIC) + 4:
        raise bad("truncated: the file ends inside its header")
    (n,) = struct.unpack_from(">I", data, len(MAGIC))
    start = len(MAGIC) + 4
    if n > MAX_HEADER or start + n > len(data):
        raise bad("truncated: the file ends inside its header" if n <= MAX_HEADER
                  else f"a header of {n} bytes (at most {MAX_HEADER})")
    try:
        header = json.loads(data[start:start + n])
    except ValueError as exc:
        raise bad(f"its header is not JSON: {exc}") from None
    if not isinstance(header, dict):
        raise bad("its header is not a map")
    return header, data[start + n:]


def check_header(header: dict[str, Any], payload: bytes, rack: Rack) -> None:
    """Refuse a snapshot of another format, version, clock mode or rack layout, or one whose
    payload is not the one it was saved with (truncated, changed)."""
    if header.get("format") != FORMAT:
        raise bad(f"snapshot format {header.get('format')!r}, this daemon reads format {FORMAT}")
    if header.get("vdevd") != vdevd_version():
        raise bad(f"saved by vdevd {header.get('vdevd')}, this is vdevd {vdevd_version()}: a "
                  "snapshot loads into the version that saved it")
    if header.get("clock") != rack.mode:
        raise bad(f"saved with the {header.get('clock')} clock, this daemon runs the "
                  f"{rack.mode} clock")
    saved = header.get("layout")
    if not isinstance(saved, list) or saved != layout(rack):
        raise bad("another rack layout: " + (_layout_difference(saved, layout(rack))
                                             if isinstance(saved, list) else "none given"))
    size = header.get("payload_size")
    if size != len(payload):
        raise bad(f"truncated or extended: its payload is {len(payload)} bytes, its header "
                  f"says {size}")
    if hashlib.sha256(payload).hexdigest() != header.get("payload_sha256"):
        raise bad("corrupt: its payload does not match the checksum of its header")
    raw_size = header.get("raw_size")
    if not isinstance(raw_size, int) or not 0 < raw_size <= MAX_PAYLOAD:
        raise bad(f"a payload of {raw_size!r} bytes (at most {MAX_PAYLOAD})")


def _inflate(payload: bytes, size: int) -> bytes:
    """The payload decompressed, never more than `size` bytes."""
    z = zlib.decompressobj()
    try:
        raw = z.decompress(payload, size)
    except zlib.error as exc:
        raise bad(f"corrupt: its payload does not decompress ({exc})") from None
    if len(raw) != size or z.unconsumed_tail or not z.eof:
        raise bad("corrupt: its payload does not decompress to the size its header says")
    return raw


def load(data: bytes, old: Rack, memory: Segment | None = None) -> Rack:
    """A NEW rack with `old`'s settings, sink and non-volatile store and the snapshot's cards
    and clock, its shared regions in `memory`; `old` is not touched. `bad_snapshot` naming why
    the snapshot does not load."""
    header, payload = read_header(data)
    check_header(header, payload, old)
    raw = _inflate(payload, header["raw_size"])
    new = old.empty_like(memory)
    nvram = next((c.ctx.nvram for c in old.cards.values() if c.ctx.nvram is not None), None)
    unpickler = SnapshotUnpickler(io.BytesIO(raw), new, nvram, memory)
    try:
        state = unpickler.load()
    except VdevError:
        raise
    except Exception as exc:  # whatever a damaged or hostile payload makes the unpickler meet
        raise bad(f"corrupt: {type(exc).__name__}: {exc}") from None
    sched, cards = (state.get("sched"), state.get("cards")) if isinstance(state, dict) else (
        None, None)
    if not isinstance(cards, list) or not isinstance(sched, Scheduler) or sched.cards != cards \
            or [getattr(c, "name", None) for c in cards] != list(old.cards):
        raise bad("corrupt: its payload is not the rack its header describes")
    scopes = state.get("scopes")
    if not isinstance(scopes, Scopes):
        raise bad("corrupt: its payload holds no scope recorders")
    new.adopt(sched)
    new.scopes = scopes  # the recorders armed on its cards, as they were
    for card in new.cards.values():  # where each shared region is in the new segment
        for region in card.regions.values():
            if region.shared_offset is not None:
                region.shared_offset = unpickler.shared_offsets.get(id(region.buf))
    for card in new.cards.values():
        # the connections to the saving daemon's card ports are gone: closed as a dropped
        # connection closes (what it left open is released)
        for port in list(getattr(card, "ethernet_ports", ())):
            port.close()
    return new


def write_nv_images(rack: Rack) -> None:
    """Each card's NV image to the non-volatile store (a restored rack's, once the rack it
    replaced has written its last: what a restart of the daemon then finds)."""
    for card in rack.cards.values():
        image = card.nvram() if card.ctx.nvram is not None else None
        if image and card.ctx.nvram is not None:
            card.ctx.nvram.save(card.name, image)



__all__ = ["FORMAT", "MAGIC", "MAX_SNAPSHOT", "bad", "layout", "load", "read_header", "save",
           "write_nv_images"]
