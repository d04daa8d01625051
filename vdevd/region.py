"""Regions: named spans of a card's bus memory with the bus's width and endianness rules.

DESIGN.md "Region": plain memory is a buffer and needs no code; registers with side effects are
hooks on offsets (`on_read(offset, size) -> bytes`, `on_write(offset, data)`). An access outside
the region or of a width the bus forbids raises `VdevError`, never crashes the daemon.

A region may declare passive ranges (memory with no hook that the card only polls or only
publishes, decision 0010); given a `memory` (the daemon's shared segment, vdevd/shm.py) such a
region is backed by it from construction, so that local clients read and write those ranges
through a mapping of the same pages.
"""

from __future__ import annotations

import bisect
import mmap
import struct
from collections.abc import Callable, Iterable
from dataclasses import dataclass
from typing import Any, Literal, Protocol

from vdevd.errors import ErrorCode, VdevError

Endian = Literal["little", "big"]
ReadHook = Callable[[int, int], bytes]
WriteHook = Callable[[int, bytes], None]
PeekHook = Callable[[int, int], bytes]
RepReadHook = Callable[[int, int], bytes]
RepWriteHook = Callable[[int, bytes], None]

_FORMATS = {1: "B", 2: "H", 4: "I", 8: "Q"}
#: resolved accesses kept per region and kind (a client uses a handful of offsets and sizes)
MAX_PLANS = 4096

ReadPlan = Callable[[int, int], bytes]
WritePlan = Callable[[int, bytes], None]
#: a region's memory: private, or a part of the daemon's shared segment
Memory = bytearray | mmap.mmap


class Backing(Protocol):
    """Where a region with passive ranges gets its memory (vdevd.shm.Segment)."""

    def allocate(self, size: int) -> tuple[mmap.mmap, int] | None:
        """`size` zeroed bytes and their offset in the shared file; None to use private memory."""


@dataclass(frozen=True)
class Hook:
    """A register with side effects at [offset, offset + size)."""

    offset: int
    size: int
    on_read: ReadHook | None = None
    on_write: WriteHook | None = None
    peek: PeekHook | None = None
    #: optional fast paths of a repeated access (`read_rep`/`write_rep`), same effect as the loop
    on_read_rep: RepReadHook | None = None
    on_write_rep: RepWriteHook | None = None
    #: the one offset whose repeated accesses the fast paths serve (a FIFO port); None: every
    #: offset of the register. Elsewhere a repeated access is one hook call per single access.
    rep_at: int | None = None

    def rep_read(self, offset: int) -> RepReadHook | None:
        """The fast path of a repeated read at `offset`, if it serves that offset."""
        return self.on_read_rep if self.rep_at is None or self.rep_at == offset else None

    def rep_write(self, offset: int) -> RepWriteHook | None:
        """The fast path of a repeated write at `offset`, if it serves that offset."""
        return self.on_write_rep if self.rep_at is None or self.rep_at == offset else None

    @property
    def end(self) -> int:
        return self.offset + self.size


class Region:
    """A fixed-size span of bus memory (a PCI BAR, a DPRAM, a VME A16 window).

    `widths` are the single-access sizes the real bus allows (e.g. {1} for VME D08(O));
    a longer block access is allowed when `block` is true and is performed as consecutive
    accesses of the smallest width wherever it touches a hook. `aligned` requires natural
    alignment of single accesses.

    `passive`: the (start, end) byte ranges a local client may read and write through shared
    memory (no hook may ever cover them); with a `memory` to allocate from, the region's buffer
    is shared memory from the start (`shared_offset` is then its place in the segment).
    """

    def __init__(
        self,
        name: str,
        size: int,
        *,
        widths: Iterable[int] = (1, 2, 4),
        endian: Endian = "little",
        aligned: bool = True,
        block: bool = True,
        description: str = "",
        passive: Iterable[tuple[int, int]] = (),
        memory: Backing | None = None,
    ) -> None:
        if size <= 0:
            raise ValueError(f"region {name}: size must be positive")
        self.name = name
        self.size = size
        self.widths = frozenset(widths)
        self.endian: Endian = endian
        self.aligned = aligned
        self.block = block
        self.description = description
        self.passive = _ranges(name, size, passive)
        shared = memory.allocate(size) if self.passive and memory is not None else None
        #: where the region's memory starts in the shared segment (None: private memory)
        self.shared_offset: int | None = None
        self.buf: Memory
        if shared is None:
            self.buf = bytearray(size)
        else:
            self.buf, self.shared_offset = shared
        self.mem = memoryview(self.buf)
        self._hooks: list[Hook] = []
        self._starts: list[int] = []
        #: the spans of hooks with a read side effect: other reads are plain memory
        self._read_spans: list[tuple[int, int]] = []
        self._unit = min(self.widths)
        self._prefix = "<" if endian == "little" else ">"
        # Each host access of an (offset, size) met before runs its plan: what the checks and
        # the hook lookup decided the first time, as one callable. Hooks are declared before
        # the card serves; declaring one forgets every plan.
        self._read_plans: dict[tuple[int, int], ReadPlan] = {}
        self._write_plans: dict[tuple[int, int], WritePlan] = {}
        self._read_rep_plans: dict[tuple[int, int], ReadPlan] = {}
        self._write_rep_plans: dict[tuple[int, int], WritePlan] = {}
        #: (offset, size) -> whether `peek` of it is plain memory (no hook's peek serves it):
        #: a wait's condition peeks at every tick it watches
        self._peek_plain: dict[tuple[int, int], bool] = {}
        #: (offset, size, write) -> the hook calls of that (non-repeated) access
        self._hook_calls: dict[tuple[int, int, bool], int] = {}
        #: told of every host access (the card's `touched`: an input may have changed)
        self.on_access: Callable[[], None] | None = None

    # -- declaration -------------------------------------------------------------------------
    def hook(
        self,
        offset: int,
        size: int,
        *,
        on_read: ReadHook | None = None,
        on_write: WriteHook | None = None,
        peek: PeekHook | None = None,
        on_read_rep: RepReadHook | None = None,
        on_write_rep: RepWriteHook | None = None,
        rep_at: int | None = None,
    ) -> Hook:
        """Declare a register with side effects; hooks may not overlap. `on_read_rep(offset,
        size)`/`on_write_rep(offset, data)` may serve a repeated access in one call (at offset
        `rep_at` only, when given)."""
        h = Hook(offset, size, on_read, on_write, peek, on_read_rep, on_write_rep, rep_at)
        if offset < 0 or h.end > self.size:
            raise ValueError(f"region {self.name}: hook at {offset:#x} outside the region")
        i = bisect.bisect_left(self._starts, offset)
        if (i < len(self._hooks) and self._hooks[i].offset < h.end) or (
            i > 0 and self._hooks[i - 1].end > offset
        ):
            raise ValueError(f"region {self.name}: hook at {offset:#x} overlaps another")
        if any(start < h.end and offset < end for start, end in self.passive):
            raise ValueError(f"region {self.name}: hook at {offset:#x} in a passive range")
        self._hooks.insert(i, h)
        self._starts.insert(i, offset)
        if on_read is not None:
            self._read_spans.append((offset, h.end))
            self._read_spans.sort()
        for plans in (self._read_plans, self._write_plans, self._read_rep_plans,
                      self._write_rep_plans, self._peek_plain, self._hook_calls):
            plans.clear()
        return h

    @property
    def hooks(self) -> tuple[Hook, ...]:
        """The registers with side effects, in address order."""
        return tuple(self._hooks)

    def describe(self) -> dict[str, object]:
        return {
            "name": self.name,
            "size": self.size,
            "widths": sorted(self.widths),
            "endian": self.endian,
            "aligned": self.aligned,
            "block": self.block,
            "description": self.description,
            "passive": [list(r) for r in self.passive],
        }

    # -- bus accesses (from the host) -----------------------------------------------------------
    def read(self, offset: int, size: int) -> bytes:
        """A host read: plain memory from the buffer, hooked registers through their hook."""
        if self.on_access is not None:
            self.on_access()
        plan = self._read_plans.get((offset, size))
        if plan is None:
            plan = _keep(self._read_plans, (offset, size), self._plan_read(offset, size))
        data = plan(offset, size)
        if len(data) != size:
            raise _wrong_size(data, offset, size)
        return data

    def write(self, offset: int, data: bytes) -> None:
        """A host write: plain memory into the buffer, hooked registers through their hook."""
        if type(data) is not bytes:
            data = bytes(data)  # a hook gets bytes, whatever buffer the access carried
        if self.on_access is not None:
            self.on_access()
        plan = self._write_plans.get((offset, len(data)))
        if plan is None:
            plan = _keep(self._write_plans, (offset, len(data)), self._plan_write(offset, len(data)))
        plan(offset, data)

    def read_rep(self, offset: int, size: int) -> bytes:
        """A repeated read (string I/O, Linux `ioread8_rep`): `size` bytes read as single accesses
        of the bus's smallest width, all at `offset` (a FIFO port)."""
        if self.on_access is not None:
            self.on_access()
        plan = self._read_rep_plans.get((offset, size))
        if plan is None:
            plan = _keep(self._read_rep_plans, (offset, size), self._plan_read_rep(offset, size))
        data = plan(offset, size)
        if len(data) != size:
            raise _wrong_size(data, offset, size)
        return data

    def write_rep(self, offset: int, data: bytes) -> None:
        """A repeated write: `data` written as single accesses of the smallest width, all at
        `offset` (a FIFO port), in order."""
        if type(data) is not bytes:
            data = bytes(data)
        if self.on_access is not None:
            self.on_access()
        plan = self._write_rep_plans.get((offset, len(data)))
        if plan is None:
            plan = _keep(self._write_rep_plans, (offset, len(data)),
                         self._plan_write_rep(offset, len(data)))
        plan(offset, data)

    def rep_hook_calls(self, offset: int, size: int, write: bool) -> int:
        """The hook calls a repeated access of `size` bytes at `offset` makes: one per access of
        the smallest width on a register whose hook has no repeated-access fast path there, else
        0 (plain memory is one copy; `bounds.check_rep_work` limits the rest). No checks: an access
        the bus refuses is refused when it runs."""
        h = self._hook_at(offset)
        if h is None or size <= 0:
            return 0
        if write:
            slow = h.on_write is not None and h.rep_write(offset) is None
        else:
            slow = h.on_read is not None and h.rep_read(offset) is None
        return size // self._unit if slow else 0

    def hook_calls(self, offset: int, size: int, write: bool) -> int:
        """The hook calls a plain (not repeated) access makes: 1 for a single access of a
        register, one per register or bus unit of one for a block access (`_pieces`), 0 for
        plain memory and for an access the bus refuses (refused when it runs)."""
        key = (offset, size, write)
        calls = self._hook_calls.get(key)
        if calls is None:
            calls = _keep(self._hook_calls, key, self._count_hook_calls(offset, size, write))
        return calls

    def _count_hook_calls(self, offset: int, size: int, write: bool) -> int:
        if size <= 0 or offset < 0 or offset + size > self.size or not self._hooks:
            return 0
        if not self._overlapping(offset, offset + size):
            return 0
        try:
            pieces = [(offset, size)] if self._check(offset, size) else self._pieces(offset, size)
            hooks = [self._register(o, n) for o, n in pieces]
        except VdevError:
            return 0
        return sum(1 for h in hooks if h is not None
                   and (h.on_write if write else h.on_read) is not None)

    # -- access plans: the checks and the hook lookup of one (offset, size), done once ---------
    def _plan_read(self, offset: int, size: int) -> ReadPlan:
        single = self._check(offset, size)
        if not self._read_spans or not self._reads_hooked(offset, offset + size):
            return self._read_plain
        if single:
            return self._read_register(offset, size)
        parts = [(o, n, self._read_register(o, n)) for o, n in self._pieces(offset, size)]
        return lambda _offset, _size: b"".join(read(o, n) for o, n, read in parts)

    def _plan_write(self, offset: int, size: int) -> WritePlan:
        single = self._check(offset, size)
        if not self._hooks or not self._overlapping(offset, offset + size):
            return self._write_plain
        if single:
            return self._write_register(offset, size)
        parts = [(o - offset, o, n, self._write_register(o, n)) for o, n in self._pieces(offset, size)]

        def write_pieces(_offset: int, data: bytes) -> None:
            for at, o, n, write in parts:
                write(o, data[at : at + n])

        return write_pieces

    def _plan_read_rep(self, offset: int, size: int) -> ReadPlan:
        unit = self._unit
        self._check_rep(offset, size)
        h = self._register(offset, unit)
        fast = h.rep_read(offset) if h is not None else None
        if fast is not None:
            return fast
        read = self._read_register(offset, unit)
        if read == self._read_plain:  # plain memory reads the same bytes again: one copy
            mem = self.mem
            return lambda _offset, _size: bytes(mem[offset : offset + unit]) * (size // unit)
        return lambda _offset, _size: b"".join(read(offset, unit) for _ in range(size // unit))

    def _plan_write_rep(self, offset: int, size: int) -> WritePlan:
        unit = self._unit
        self._check_rep(offset, size)
        h = self._register(offset, unit)
        fast = h.rep_write(offset) if h is not None else None
        if fast is not None:
            return fast
        write = self._write_register(offset, unit)
        if write == self._write_plain:  # plain memory keeps the last access: one copy
            return lambda _offset, data: self._write_plain(offset, data[-unit:]) if data else None

        def write_each(_offset: int, data: bytes) -> None:
            for i in range(0, len(data), unit):
                write(offset, data[i : i + unit])

        return write_each

    def _read_register(self, offset: int, size: int) -> ReadPlan:
        """One single access's read: its hook's, or the buffer's when it has none."""
        h = self._register(offset, size)
        if h is None or h.on_read is None:
            return self._read_plain
        return h.on_read

    def _write_register(self, offset: int, size: int) -> WritePlan:
        h = self._register(offset, size)
        if h is None or h.on_write is None:
            return self._write_plain
        return h.on_write

    def _read_plain(self, offset: int, size: int) -> bytes:
        return bytes(self.mem[offset : offset + size])

    def _write_plain(self, offset: int, data: bytes) -> None:
        self.mem[offset : offset + len(data)] = data

    def _check_rep(self, offset: int, size: int) -> None:
        unit = self._unit
        self._check_bounds(offset, unit if size > 0 else 0)
        if size % unit or (self.aligned and offset % unit):
            raise VdevError(
                ErrorCode.BAD_WIDTH,
                f"region {self.name!r}: repeated access of {size} bytes at {offset:#x} is not "
                f"a whole number of {unit}-byte accesses",
            )

    def peek(self, offset: int, size: int) -> bytes:
        """Read with no side effects (wait conditions, `vdevctl peek --raw`, tests)."""
        self._check_bounds(offset, size)
        h = self._hook_at(offset)
        if h is not None and h.peek is not None and offset + size <= h.end:
            return h.peek(offset, size)
        return bytes(self.mem[offset : offset + size])

    def get_peek(self, offset: int, size: int) -> int:
        """`peek` as an unsigned integer in the region's byte order."""
        plain = self._peek_plain.get((offset, size))
        if plain is None:  # checked once (bounds, hooks), as the host accesses' plans
            self._check_bounds(offset, size)
            h = self._hook_at(offset)
            plain = _keep(self._peek_plain, (offset, size),
                          h is None or h.peek is None or offset + size > h.end)
        if plain:
            return int.from_bytes(self.mem[offset:offset + size], self.endian)
        return int.from_bytes(self.peek(offset, size), self.endian)

    # -- typed access for the card's own firmware (no hooks, no checks beyond bounds) ----------
    def get(self, offset: int, size: int = 4, signed: bool = False) -> int:
        return int.from_bytes(self.mem[offset : offset + size], self.endian, signed=signed)

    def set(self, offset: int, value: int, size: int = 4) -> None:
        self.mem[offset : offset + size] = (value & ((1 << (8 * size)) - 1)).to_bytes(
            size, self.endian
        )

    def pack(self, offset: int, fmt: str, *values: object) -> None:
        struct.pack_into(self._prefix + fmt, self.buf, offset, *values)

    def unpack(self, offset: int, fmt: str) -> tuple[object, ...]:
        return struct.unpack_from(self._prefix + fmt, self.buf, offset)

    # -- internals -----------------------------------------------------------------------------
    def _check_bounds(self, offset: int, size: int) -> None:
        if size <= 0 or offset < 0 or offset + size > self.size:
            raise VdevError(
                ErrorCode.OUT_OF_RANGE,
                f"region {self.name!r}: access {offset:#x}+{size} outside 0..{self.size:#x}",
            )

    def _check(self, offset: int, size: int) -> bool:
        """Validate an access; True for a single access, False for a block access."""
        self._check_bounds(offset, size)
        if size in self.widths:
            if self.aligned and offset % size:
                raise VdevError(
                    ErrorCode.BAD_WIDTH,
                    f"region {self.name!r}: {size}-byte access at {offset:#x} is not aligned",
                )
            return True
        if not self.block or size % self._unit or (self.aligned and offset % self._unit):
            raise VdevError(
                ErrorCode.BAD_WIDTH,
                f"region {self.name!r}: {size}-byte access at {offset:#x} not allowed "
                f"(bus widths {sorted(self.widths)})",
            )
        return False

    def _overlapping(self, start: int, end: int) -> bool:
        i = bisect.bisect_left(self._starts, end)
        return i > 0 and self._hooks[i - 1].end > start

    def _reads_hooked(self, start: int, end: int) -> bool:
        i = bisect.bisect_left(self._read_spans, (end,))
        return i > 0 and self._read_spans[i - 1][1] > start

    def _hook_at(self, offset: int) -> Hook | None:
        i = bisect.bisect_right(self._starts, offset)
        if i and self._hooks[i - 1].end > offset:
            return self._hooks[i - 1]
        return None

    def _pieces(self, offset: int, size: int) -> list[tuple[int, int]]:
        """Split a block access: plain runs whole; a register the block covers whole, in one access
        of its size when the bus allows that width; other hooked spans in accesses of the bus
        unit."""
        pieces: list[tuple[int, int]] = []
        pos, end = offset, offset + size
        while pos < end:
            h = self._hook_at(pos)
            if h is not None:
                step = h.size if (pos == h.offset and h.end <= end and h.size in self.widths) \
                    else self._unit
                pieces.append((pos, step))
                pos += step
                continue
            i = bisect.bisect_right(self._starts, pos)
            stop = min(end, self._starts[i]) if i < len(self._starts) else end
            pieces.append((pos, stop - pos))
            pos = stop
        return pieces

    def _register(self, offset: int, size: int) -> Hook | None:
        """The hook a single access lands in; an access straddling a register's edge is refused."""
        i = bisect.bisect_left(self._starts, offset + size)
        h = self._hooks[i - 1] if i else None
        if h is None or h.end <= offset:
            return None
        if h.offset > offset or offset + size > h.end:
            raise VdevError(
                ErrorCode.BAD_WIDTH,
                f"region {self.name!r}: access {offset:#x}+{size} straddles a register",
            )
        return h



def passive_except(size: int, hooked: Iterable[tuple[int, int]]) -> list[tuple[int, int]]:
    """The (start, end) ranges of a `size`-byte region outside the `hooked` (offset, size) spans:
    the passive ranges of a region that is plain memory but for those registers."""
    ranges, pos = [], 0
    for offset, n in sorted(hooked):
        if offset > pos:
            ranges.append((pos, offset))
        pos = max(pos, offset + n)
    if pos < size:
        ranges.append((pos, size))
    return ranges


def _ranges(name: str, size: int, ranges: Iterable[tuple[int, int]]
            ) -> tuple[tuple[int, int], ...]:
    """Passive ranges sorted, with adjacent or overlapping ones merged; ValueError for an empty
    one or one outside the region."""
    merged: list[tuple[int, int]] = []
    for start, end in sorted(ranges):
        if not 0 <= start < end <= size:
            raise ValueError(f"region {name}: passive range {start:#x}..{end:#x} outside "
                             f"0..{size:#x} or empty")
        if merged and start <= merged[-1][1]:
            merged[-1] = (merged[-1][0], max(merged[-1][1], end))
        else:
            merged.append((start, end))
    return tuple(merged)


def _keep(plans: dict[Any, Any], key: tuple[int, ...], plan: Any) -> Any:
    """Remember `plan` for `key`, within MAX_PLANS (all are forgotten when full)."""
    if len(plans) >= MAX_PLANS:
        plans.clear()
    plans[key] = plan
    return plan


def _wrong_size(data: bytes, offset: int, size: int) -> VdevError:
    """A read whose hook, with a bug, gave the wrong number of bytes."""
    return VdevError(ErrorCode.INTERNAL, f"hook at {offset:#x} returned {len(data)} bytes "
                     f"for a {size}-byte read")
