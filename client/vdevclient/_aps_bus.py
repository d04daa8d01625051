"""The APS library's link to the virtual AMP-204C/208C cards: the session `APS_initial` opens
(the boards of the rack, the global axis IDs), a kernel command posted through the BAR0 mailbox
in one round trip, and the status block's reads (vdevmaps.adlink).

A ZeroMQ socket serves one thread, so the session's connections are per thread (`Links`): the
rack APS_initial opened serves the thread that opened it, and any other thread calling the
library gets a connection of its own on first use. A thread can then wait in
APS_wait_single_int while another commands the card, as with the DLL.

A post is one batch: the command's code, length and arguments, the doorbell with a sequence
number (the kernel runs the command there and then), and the acknowledgement with the return
code and the reply values. A status read is one read of the status block, served from the
daemon's shared memory when the client maps it.
"""

from __future__ import annotations

import itertools
import struct
import threading
import weakref
from collections.abc import Sequence
from dataclasses import dataclass, field
from typing import Any

from vdevmaps.adlink import (
    ACK_BYTES,
    ARGS_MAX,
    BAR,
    BY_NAME,
    CARD_TYPE,
    REPLY_MAX,
    Axis,
    Bar,
    Call,
    axis_offset,
    decode,
    encode,
)
from vdevmaps.aps_defs import ERR_ParametersInvalid

from vdevclient.core import Rack

_HEAD = struct.Struct("<II")  # code, length
_ACK = struct.Struct("<IiII")  # seq, rc, length, code
_SEQ = struct.Struct("<I")
_I32 = struct.Struct("<i")
_F64 = struct.Struct("<d")
#: reply bytes read with the acknowledgement when the reply's size is not fixed
_FIRST_READ = 256
_FIXED = {"i": 4, "d": 8}
_CODE, _DOORBELL, _ACK_SEQ = int(Bar.CODE), int(Bar.DOORBELL), int(Bar.ACK_SEQ)


@dataclass(frozen=True, slots=True)
class _Form:
    """A command as `Board.post` sends it, worked out once: its call, the packer of its
    arguments when every one is a scalar (else None: `encode`), the bytes read with the
    acknowledgement."""

    call: Call
    args: struct.Struct | None
    want: int


def _form(name: str) -> _Form:
    call = BY_NAME[name]
    scalar = all(kind in _FIXED for kind in call.args)
    size = reply_size(call.reply)
    return _Form(call, struct.Struct("<" + "".join(call.args)) if scalar else None,
                 ACK_BYTES + (size if size is not None else _FIRST_READ))



def reply_size(spec: Sequence[str]) -> int | None:
    """The reply's bytes when every field has a fixed size, else None."""
    total = 0
    for kind in spec:
        if kind not in _FIXED:
            return None
        total += _FIXED[kind]
    return total


_FORMS = {name: _form(name) for name in BY_NAME}


class Links:
    """The session's connections to the daemon, one per thread: `home` (the rack APS_initial
    opened) for the thread that opened it, a connection of the same endpoint, keys and mapping
    for each other thread, made on its first call. A finished thread's connection goes with
    it; `close` closes those left."""

    def __init__(self, home: Rack) -> None:
        self.home = home
        self._owner = threading.get_ident()
        self._local = threading.local()
        self._others: weakref.WeakSet[Rack] = weakref.WeakSet()
        self._lock = threading.Lock()
        self._closed = False

    def rack(self) -> Rack:
        """The calling thread's connection."""
        if threading.get_ident() == self._owner:
            return self.home
        rack: Rack | None = getattr(self._local, "rack", None)
        if rack is None:
            h = self.home
            rack = Rack(h.endpoint, h.events_endpoint or None, h.timeout, curve=h.curve,
                        shm=h.shm is not None)
            with self._lock:
                if self._closed:
                    rack.close()
                    raise RuntimeError("the APS session is closed")
                self._others.add(rack)
            self._local.rack = rack
        return rack

    def close(self) -> None:
        with self._lock:
            self._closed = True
            others = list(self._others)
        for rack in others:
            rack.close()
        self.home.close()


@dataclass
class Board:
    """One AMP card of the session: board ID, its card in the rack, its axes."""

    links: Links
    card: str
    board_id: int
    first_axis: int
    axes: int
    card_id: int
    model: int
    _bar: Any = field(init=False, repr=False)

    def __post_init__(self) -> None:
        self._bar = self.links.home.card(self.card).region(BAR)
        self._seq = itertools.count(1)
        #: a post's acknowledgement and the rest of its reply are read before another thread's
        #: post can overwrite them
        self._post_lock = threading.Lock()

    @property
    def rack(self) -> Rack:
        """The calling thread's connection to the daemon."""
        return self.links.rack()

    @property
    def bar(self) -> Any:
        """Region `bar0` through the calling thread's connection."""
        links = self.links
        if threading.get_ident() == links._owner:
            return self._bar
        return links.rack().card(self.card).region(BAR)

    def post(self, name: str, *values: Any) -> tuple[int, list[Any]]:
        """Run kernel command `name` with `values`: (return code, reply values)."""
        form = _FORMS[name]
        call = form.call
        try:
            args = form.args.pack(*values) if form.args is not None else encode(call.args, values)
        except (struct.error, TypeError, ValueError, OverflowError):
            return ERR_ParametersInvalid, []
        if len(args) > ARGS_MAX:
            return ERR_ParametersInvalid, []
        card = self.card
        with self._post_lock:
            seq = next(self._seq) & 0xFFFFFFFF
            ops: list[Any] = [
                ["w", card, BAR, _CODE, _HEAD.pack(call.code, len(args)) + args],
                ["w", card, BAR, _DOORBELL, _SEQ.pack(seq)],
                ["r", card, BAR, _ACK_SEQ, form.want]]
            ack = self.rack.call({"op": "batch", "ops": ops})[2]
            got_seq, rc, length, _ = _ACK.unpack_from(ack)
            if got_seq != seq:
                raise RuntimeError(f"{card}: the mailbox acknowledged {got_seq}, not {seq}")
            if rc < 0 or not call.reply:
                return rc, []
            data = bytes(ack[ACK_BYTES:ACK_BYTES + length])
            if length > len(data):
                data += self.bar.read(Bar.REPLY + len(data), min(length, REPLY_MAX) - len(data))
        return rc, decode(call.reply, data)

    # -- the status block ------------------------------------------------------------------------
    def read_i32(self, axis: int, fld: Axis) -> int:
        return _I32.unpack(self.bar.read(axis_offset(axis, fld), 4))[0]

    def read_f64(self, axis: int, fld: Axis) -> float:
        return _F64.unpack(self.bar.read(axis_offset(axis, fld), 8))[0]

    def read_u32(self, offset: int) -> int:
        return _SEQ.unpack(self.bar.read(offset, 4))[0]


@dataclass
class Session:
    """What APS_initial opened: its connections, the boards by board ID, the global axis IDs."""

    links: Links
    boards: dict[int, Board]
    axes: list[tuple[Board, int]]  # global axis ID -> (board, local axis)

    def axis(self, axis_id: int) -> tuple[Board, int] | None:
        if isinstance(axis_id, bool) or not isinstance(axis_id, int):
            return None
        if 0 <= axis_id < len(self.axes):
            return self.axes[axis_id]
        return None

    @property
    def rack(self) -> Rack:
        """The calling thread's connection to the daemon."""
        return self.links.rack()

    def close(self) -> None:
        self.links.close()


def find_cards(rack: Rack) -> list[tuple[str, int, int, int]]:
    """The rack's AMP cards in configuration order: (name, card ID, axes, model code)."""
    names = [c["name"] for c in rack.info["cards"] if c["type"] == CARD_TYPE]
    if not names:
        return []
    ops = [["r", n, BAR, int(Bar.MODEL), 12] for n in names]
    found = []
    for name, raw in zip(names, rack.call({"op": "batch", "ops": ops}), strict=True):
        model, axes, card_id = struct.unpack("<III", raw)
        found.append((name, card_id, axes, model))
    return found
