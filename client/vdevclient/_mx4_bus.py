"""The Mx4 Octavia's host protocols over one `batch` each (spec octavia.md §2.5, §8.1): an open
card (`Mx4`), its DPR accesses as batch ops, the RTC post with the card's acknowledge and its
report, the access-byte locks, and the locked read-modify-write of the interrupt registers.

Every call is one round trip; one the card answers with a report to clear is two: the second
finishes a read-modify-write under the status lock that the first left held (see `Mx4.send`).
`vdevclient.mx4` builds the vendor API on this.
"""

from __future__ import annotations

from collections.abc import Callable, Sequence
from typing import Any

from vdevmaps.octavia import DPR, Dpr, DspStat1, DspStat2, HostInt, Window

from vdevclient._mx4_codec import (
    REFUSED,
    STATUS_SIZE,
    IntStatus,
    Mx4Timeout,
    Post,
    cleared,
    refused,
    source_or_none,
)
from vdevclient.core import Rack

#: the card takes an RTC within a sample (200 us); PARREAD echoes within 5 ms [Ch5 PARREAD]
DEFAULT_TIMEOUT_MS = 100
_NS_PER_MS = 1_000_000
#: a batch op: a map, or a compact access [kind, card, region, offset, size|data] (PROTOCOL.md)
Op = dict[str, Any] | list[Any]
_RTC, _ARGS, _HOSTINT = int(Dpr.RTC), int(Dpr.ARGMNTS), int(Dpr.HOSTINT1)
_LOCK, _UNLOCK = b"\x01", b"\x00"
_ALL64 = (1 << 64) - 1
_REFUSED = int(REFUSED)
#: a change of the interrupt registers (see `acknowledged`)
Change = Callable[[IntStatus], IntStatus]


class Mx4:
    """One open Octavia: card `card` of `rack` (`vdevclient.mx4.open` makes it). Use it from one
    thread at a time, as `Rack`. `timeout_ms` is the default time-out of the card's answers, in
    card time (lockstep: time runs only until then)."""

    def __init__(self, rack: Rack, card: str, *, timeout_ms: int = DEFAULT_TIMEOUT_MS,
                 owns_rack: bool = False) -> None:
        self.rack = rack
        self.card = card
        self.timeout_ms = timeout_ms
        self._owns_rack = owns_rack
        #: the DPR as a Region: its passive bytes go through the daemon's shared memory when mapped
        self.dpr = rack.card(card).region(DPR)
        self._compact = bool(getattr(rack, "compact", False))
        self._where: dict[str, Any] = {"card": card, "region": DPR}
        #: the interrupt registers as last read (the expected value of the next acknowledge)
        self.status: IntStatus | None = None
        #: the `seq` of the last interrupt assertion `wait_irq` returned
        self.irq_seq: int | None = None
        self._check_cache: dict[int, list[Op]] = {}
        self._idle_cache: dict[int, dict[str, Any]] = {}

    # -- ops --------------------------------------------------------------------------------------
    def read(self, offset: int, size: int) -> Op:
        if self._compact:
            return ["r", self.card, DPR, int(offset), size]
        return {"op": "read", "offset": int(offset), "size": size, **self._where}

    def write(self, offset: int, data: bytes) -> Op:
        if self._compact:
            return ["w", self.card, DPR, int(offset), bytes(data)]
        return {"op": "write", "offset": int(offset), "data": bytes(data), **self._where}

    def wait(self, offset: int, value: int, timeout_ns: int, *, mask: int = 0xFF, size: int = 1,
             equal: bool = True) -> dict[str, Any]:
        """Fires when (the DPR's `size` bytes at `offset`, little-endian) & mask == value (or
        != with equal=False), read without side effects (1FFEh too)."""
        return {"op": "wait", "on": "value", "offset": int(offset), "size": size, "mask": mask,
                "value": value, "cmp": "eq" if equal else "ne", "timeout_ns": timeout_ns,
                **self._where}

    def guard(self, offset: int, value: int, *, mask: int = 0xFF, size: int = 1) -> dict[str, Any]:
        """A wait that does not wait: the ops after it run only if the condition holds now."""
        return self.wait(offset, value, 0, mask=mask, size=size)

    def wait_irq(self, timeout_ns: int) -> dict[str, Any]:
        """Fires at the next assertion of `inta` after the last one `wait_irq` returned."""
        op: dict[str, Any] = {"op": "wait", "on": "irq", "card": self.card, "line": "inta",
                              "timeout_ns": timeout_ns}
        if self.irq_seq is not None:
            op["after_seq"] = self.irq_seq
        return op

    def lock(self, window: Window, timeout_ns: int) -> list[Op]:
        """The host's access byte of `window` to 01h, then a wait for the card's to read 00h
        [Ch6 Communication Protocols Revisited]."""
        return [self.write(window.host_flag, _LOCK), self.wait(window.card_flag, 0, timeout_ns)]

    def unlock(self, window: Window) -> Op:
        return self.write(window.host_flag, _UNLOCK)

    def fired(self, result: Any, what: str, timeout_ns: int) -> None:
        """Mx4Timeout unless the wait whose result this is fired (None: it did not run)."""
        if not result or not result["fired"]:
            raise Mx4Timeout(f"{self.card}: no {what} within {timeout_ns // _NS_PER_MS} ms")

    def timeout_ns(self, timeout_ms: int | None = None) -> int:
        return (self.timeout_ms if timeout_ms is None else timeout_ms) * _NS_PER_MS

    def batch(self, ops: Sequence[Op], wait_ns: int = 0) -> list[Any]:
        """One round trip; `wait_ns`, the time-outs of its waits, extends the wall allowance."""
        return self.rack.call({"op": "batch", "ops": list(ops)}, wait_ns / 1e9)

    # -- real-time commands [Ch6 Real-Time Commands; spec §2.5.2] ------------------------------------
    def post_ops(self, posts: Sequence[Post], timeout_ns: int) -> list[Op]:
        """For each post: wait until 3C2h reads 00h (the card took the last RTC: a table load has
        copied its data out), its data at 120h (a table load), its arguments from 3C3h, its
        code to 3C2h (last); then a wait for the card to clear 3C2h (it has
        executed the last one). Waits: len(posts) + 1."""
        ops: list[Op] = []
        idle = self._idle_cache.get(timeout_ns)  # (the same op in every post: made once)
        if idle is None:
            idle = self._idle_cache[timeout_ns] = self.wait(_RTC, 0, timeout_ns)
        for p in posts:
            ops.append(idle)
            if p.stage:
                ops.append(self.write(Dpr.RINGBUF, p.stage))
            if p.args:
                ops.append(self.write(_ARGS, p.args))
            ops.append(self.write(_RTC, bytes((p.code,))))
        ops.append(idle)
        return ops

    def check_ops(self, timeout_ns: int) -> list[Op]:
        """The report check after an RTC: a read of 000h..00Fh. No status lock: the ops of a batch
        run atomically between two of the card's samples (PROTOCOL.md "batch"), so the card
        cannot post between its bytes; the lock is taken only to clear a report (`checked`)."""
        ops = self._check_cache.get(timeout_ns)
        if ops is None:
            ops = self._check_cache[timeout_ns] = [self.read(Dpr.DSPSTAT1, STATUS_SIZE)]
        return ops

    def send(self, posts: Sequence[Post], *, timeout_ms: int | None = None,
             check: bool = True) -> None:
        """Post `posts` in one batch and wait for the card to have executed the last; with
        `check`, raise the card's report of a discarded command as Mx4Error (see `checked`)."""
        t = self.timeout_ns(timeout_ms)
        ops = self.post_ops(posts, t)
        n = len(ops)
        if check:
            ops += self.check_ops(t)
        res = self.batch(ops, t * (len(posts) + 2))
        self.taken(res, posts)
        if check:
            self.checked(res, n, posts, t)

    def taken(self, res: list[Any], posts: Sequence[Post]) -> None:
        """Mx4Timeout unless the card took every post: one of the waits of `post_ops` (results
        from 0) ran out."""
        k = 0
        for r in res:
            if isinstance(r, dict) and "fired" in r:
                if not r["fired"]:
                    if k == 0:
                        raise Mx4Timeout(f"{self.card}: 3C2h never read 00h: the card did not "
                                         f"take the RTC before {posts[0].name}")
                    raise Mx4Timeout(f"{self.card}: {posts[k - 1].name} (code {posts[k - 1].code:02X}h)"
                                     " was not taken: 3C2h did not return to 00h")
                k += 1
                if k > len(posts):
                    return

    def checked(self, res: list[Any], at: int, posts: Sequence[Post], timeout_ns: int) -> None:
        """Interpret `check_ops` (results from `at`). The card ORs "conflicting commands" (b6) or
        "RTC ignored" (b7) into DSPSTAT1 and the axes into 007h/008h when it discards a motion
        command [Ch7 Table 7-1]; it never clears them. Found set: under the status lock
        (3FDh/3FCh), guarded by the bytes read (the card may have posted since), clear those two
        types and their sources and release the lock (the second round trip; a third when the
        guard found them changed), and raise them as Mx4Error. The summary bit 1FFEh b1 stays
        for the host's interrupt routine (the card asserted the line)."""
        hostint = self.status.hostint if self.status is not None else None  # not read: kept
        status = self.status = IntStatus(res[at], hostint)
        if not status.raw[0] & _REFUSED:  # (DSPSTAT1's byte: no flag object in every post)
            return
        while True:
            new = cleared(status.raw, status.dspstat1 & REFUSED, 0, True)
            done = self.batch([
                *self.lock(Window.STATUS, timeout_ns),
                self.guard(0, int.from_bytes(status.raw[:8], "little"), mask=_ALL64, size=8),
                self.guard(8, int.from_bytes(status.raw[8:], "little"), mask=_ALL64, size=8),
                self.write(Dpr.DSPSTAT1, bytes(new[:9])), self.unlock(Window.STATUS),
                self.read(Dpr.DSPSTAT1, STATUS_SIZE)], timeout_ns)
            if not done[1]["fired"]:
                self.batch([self.unlock(Window.STATUS)])
                raise Mx4Timeout(f"{self.card}: the card held the status window (3FCh) for "
                                 f"{timeout_ns // _NS_PER_MS} ms")
            if done[2]["fired"] and done[3]["fired"]:
                break
            self.batch([self.unlock(Window.STATUS)])  # changed meanwhile: again, from now
            status = IntStatus(self.batch([self.read(Dpr.DSPSTAT1, STATUS_SIZE)])[0], hostint)
        self.status = IntStatus(bytes(new), hostint)
        raise refused(_names(posts), IntStatus(res[at], hostint))

    # -- the interrupt registers [Ch6 Handling Interrupts; spec §2.5.5] ---------------------------
    def status_ops(self, timeout_ns: int) -> list[Op]:
        """Read 1FFEh (which ends the interrupt) and, under the status lock, 000h..00Fh."""
        return [self.read(_HOSTINT, 1), *self.lock(Window.STATUS, timeout_ns),
                self.read(Dpr.DSPSTAT1, STATUS_SIZE), self.unlock(Window.STATUS)]

    def status_from(self, res: list[Any], at: int) -> IntStatus:
        """The IntStatus of `status_ops` whose results start at `at`."""
        if not res[at + 2]["fired"]:
            self.batch([self.unlock(Window.STATUS)])
            raise Mx4Timeout(f"{self.card}: the card held the status window (3FCh)")
        self.status = IntStatus(res[at + 3], HostInt(res[at][0]))
        return self.status

    def acknowledge(self, change: Change, timeout_ns: int) -> IntStatus:
        """Apply `change` (see `acknowledged`) to the interrupt registers: one round trip, two if
        they changed since they were last read (`ack_ops`). Returns them as found."""
        return self.ack_results(self.batch(self.ack_ops(change, timeout_ns), timeout_ns), 0, change)

    def ack_ops(self, change: Change, timeout_ns: int) -> list[Op]:
        """A locked read-modify-write of the interrupt registers: the status lock (3FDh, 3FCh),
        a read of 000h..00Fh and of 1FFEh (which ends the interrupt), then, computed by `change`
        from the registers last read (`status`), guards that they still hold those values, the
        new values, the release. A guard that fails leaves the lock held and stops the batch:
        `ack_results` then writes what `change` makes of the values read. The batch must end
        with these ops."""
        ops: list[Op] = [*self.lock(Window.STATUS, timeout_ns),
                         self.read(Dpr.DSPSTAT1, STATUS_SIZE), self.read(_HOSTINT, 1)]
        known = self.status
        if known is not None and known.hostint is not None:
            new = change(known)
            ops += [self.guard(0, int.from_bytes(known.raw[:8], "little"), mask=_ALL64, size=8),
                    self.guard(8, int.from_bytes(known.raw[8:], "little"), mask=_ALL64, size=8),
                    self.guard(_HOSTINT, int(known.hostint)), *self._writes(new)]
        return ops

    def ack_results(self, res: list[Any], at: int, change: Change) -> IntStatus:
        """Finish `ack_ops` (results from `at`, the last ops of their batch): the registers as
        found; when a guard failed, the second round trip writes the change of them."""
        if not res[at + 1]["fired"]:
            self.batch([self.unlock(Window.STATUS)])
            raise Mx4Timeout(f"{self.card}: the card held the status window (3FCh)")
        found = IntStatus(res[at + 2], HostInt(res[at + 3][0]))
        guards = res[at + 4:at + 7]
        self.status = change(found)
        if not (len(guards) == 3 and all(isinstance(g, dict) and g["fired"] for g in guards)):
            self.batch(self._writes(self.status))
        return found

    def _writes(self, new: IntStatus) -> list[Op]:
        return [self.write(Dpr.DSPSTAT1, new.raw), self.write(_HOSTINT, bytes((int(new.hostint or 0),))),
                self.unlock(Window.STATUS)]

    # -- closing ----------------------------------------------------------------------------------
    def close(self) -> None:
        """Close the connection if `open` made it. Closing again does nothing."""
        if self._owns_rack:
            self.rack.close()

    def __enter__(self) -> Mx4:
        return self

    def __exit__(self, *exc: object) -> None:
        self.close()


def acknowledged(hostint: int, stat1: int, stat2: int, sources: int | bool) -> Change:
    """The change an acknowledge makes: the types and their sources cleared (`cleared`), the
    1FFEh bits `hostint`, and the summary bits b1/b6 once DSPSTAT1/DSPSTAT2 are empty."""

    def change(s: IntStatus) -> IntStatus:
        raw = cleared(s.raw, stat1, stat2, sources)
        h = int(s.hostint or 0) & ~hostint
        if not raw[0]:
            h &= ~int(HostInt.STAT1)
        if not raw[9] & 0x7D:
            h &= ~int(HostInt.STAT2)
        return IntStatus(bytes(raw), HostInt(h & 0xFF))

    return change


def expect(known: IntStatus | None, hostint: int, stat1: int, stat2: int,
           sources: int | bool) -> IntStatus | None:
    """The registers as a report of these types would leave `known`: what an acknowledge
    made in the batch that waits for the report guards on (None: not known)."""
    if known is None or known.hostint is None:
        return known
    raw = bytearray(known.raw)
    h = int(known.hostint) | hostint | (int(HostInt.STAT1) if stat1 else 0) | (
        int(HostInt.STAT2) if stat2 else 0)
    raw[0] |= stat1
    raw[9] |= stat2
    if isinstance(sources, int) and not isinstance(sources, bool):
        for bit in [DspStat1(1 << b) for b in range(8) if stat1 >> b & 1] + \
                [DspStat2(1 << b) for b in range(8) if stat2 >> b & 1]:
            offset = source_or_none(bit)
            if offset is not None:
                raw[offset] |= sources
    return IntStatus(bytes(raw), HostInt(h & 0xFF))


def _names(posts: Sequence[Post]) -> str:
    return "/".join(dict.fromkeys(p.name for p in posts))

