"""The DSP Control Group PCI Mx4 Octavia host library for the virtual `dspcg-octavia` card. The
manual names the Mx4 DLL but documents no signatures, so this is the API spec octavia.md §8.2
proposes: a generic layer over the DPR protocols (`rtc`, `parread`, `read_window`, `lock`,
`read_int`, `ack_int`, `ring_put`, `load_table`, `reset`, ...), one function per real-time command
named after its mnemonic (`AXMOVE(h, mask, acc, pos, vel)`, vdevclient._mx4_rtc), the unit
helpers, and the host procedures of §8.1 (`power_up_init`, `contour`, `load_table`,
`home_on_index`, `calibrate_offset`)::

    from vdevclient import mx4

    with mx4.open(card=1) as h:                   # the first Octavia at $VDEVD_ENDPOINT
        mx4.MAXACC(h, 0x01, mx4.acc_to_raw(0.05))
        mx4.CTRL(h, 0x01, ki=100, kp=4000, kf=3000, kd=2500)
        mx4.EN_MOTCP(h, 0x01)
        mx4.AXMOVE(h, 0x01, acc=0x150, pos=100_000, vel=mx4.vel_to_raw(32))
        mx4.wait_int(h, dspstat1=mx4.DspStat1.MOTCP, axes=0x01, timeout_ms=10_000)
        mx4.read_axes(h, mx4.Window.ACTPOS)[0]    # 100154: the servo plant settles after

Per-RTC functions take raw DPR units; per-axis arguments are sequences indexed by axis (index 0
= axis 1) of which only the masked axes are sent. Every call is one `batch` (PROTOCOL.md) with
server-side waits, never a polling loop over the network: an RTC post is [wait 3C2h = 00h, the
arguments at 3C3h, the code at 3C2h, wait 3C2h = 00h (the card has taken it), the status check]
in one round trip, two when the card reported on it. Errors are the card's reports, raised as
`Mx4Error` with the status bits named (`Mx4Timeout` when the card did not answer in time, card
time). Local clients read the DPR's passive bytes (signatures, ring pointers, INPUT) through the
daemon's shared memory (decision 0010).
"""

from __future__ import annotations

import struct
from dataclasses import dataclass

from vdevmaps.octavia import (
    ACTVEL_SCALE,
    ARG_BYTES,
    BANK2,
    BY_NAME,
    CARD_TYPE,
    DPR,
    NURBS_RTCS,
    RTCS,
    DisableBit,
    Dpr,
    DspStat1,
    DspStat2,
    HostInt,
    Window,
)
from vdevmaps.pci import SUBSYSTEM_ID

from vdevclient._mx4_bus import DEFAULT_TIMEOUT_MS, Mx4, acknowledged, expect
from vdevclient._mx4_codec import (
    IntStatus,
    Mx4Error,
    Mx4Timeout,
    PerAxis,
    Post,
    acc_to_raw,
    axes_text,
    bits_text,
    dac_to_volts,
    encode,
    ratio_to_raw,
    raw_to_acc,
    raw_to_ratio,
    raw_to_vel,
    source_offset,
    source_or_none,
    vel_to_raw,
    volts_to_dac,
)
from vdevclient._mx4_ring import contour, load_table, ring_free, ring_put
from vdevclient._mx4_rtc import *  # noqa: F403  (the per-RTC functions: their __all__)
from vdevclient._mx4_rtc import __all__ as _RTC_FUNCTIONS
from vdevclient.core import Rack, connect

#: a reset takes 50 ms on the card (spec Q-29): its waits allow more
RESET_TIMEOUT_MS = 1000
_NAMES = {r.code: r.name for r in (*RTCS, *NURBS_RTCS)} | {0x8E: "INT5MS/NOTCH/LOW_PASS"}
_I32X8 = struct.Struct("<8i")
_AXIS_WINDOWS = (Window.ACTPOS, Window.ACTVEL, Window.ERROR, Window.INDPOS, Window.PRB)


# -- opening ------------------------------------------------------------------------------------------
def open(card: int = 1, *, endpoint: str | None = None, name: str | None = None,
         timeout_ms: int = DEFAULT_TIMEOUT_MS, init: bool = True) -> Mx4:
    """Open Octavia `card` of the rack at `endpoint` ($VDEVD_ENDPOINT, else tcp://127.0.0.1:5555):
    the dspcg-octavia card whose card number (its `card` option, the PCI subsystem ID) is
    `card`, else the card-th Octavia of the configuration if it has no number (subsystem ID 0;
    the card README's "card" key); `name` opens a card by name instead. With `init`, the
    power-up procedure runs (`power_up_init`: clear "reset finished", check the signature, RESET
    on failure). `timeout_ms` is the default time the card is given to answer (card time)."""
    rack = connect(endpoint)
    try:
        h = Mx4(rack, _find_card(rack, card, name), timeout_ms=timeout_ms, owns_rack=True)
        h.irq_seq = rack.stats()["cards"].get(h.card, {}).get("irq_seq")
        if init:
            power_up_init(h)
        return h
    except BaseException:
        rack.close()
        raise


def close(h: Mx4) -> None:
    """Close the connection `open` made. Closing again does nothing."""
    h.close()


def _find_card(rack: Rack, number: int, name: str | None) -> str:
    cards = [c["name"] for c in rack.info["cards"] if c["type"] == CARD_TYPE]
    if name is not None:
        found = [c for c in cards if c == name]
    else:
        ops = [{"op": "read", "card": c, "region": "config", "offset": SUBSYSTEM_ID, "size": 2}
               for c in cards]
        numbers = [int.from_bytes(r, "little") for r in rack.call({"op": "batch", "ops": ops})] \
            if cards else []
        found = [c for c, k in zip(cards, numbers, strict=True) if k == number]
        if not found and 1 <= number <= len(cards) and numbers[number - 1] == 0:
            found = [cards[number - 1]]
    if not found:
        what = f"named {name!r}" if name is not None else f"number {number}"
        raise Mx4Error(f"no {CARD_TYPE} card {what} at {rack.endpoint} "
                       f"({CARD_TYPE} cards: {', '.join(cards) or 'none'})")
    return found[0]


# -- the generic layer (spec §8.2 layer 1) --------------------------------------------------------------
def rtc(h: Mx4, code: int, args: bytes = b"", *, timeout_ms: int | None = None) -> None:
    """Post one RTC as raw bytes: `args` from 3C3h (at most 57), `code` to 3C2h; returns when the
    card has taken it, raises its report of a discarded command (Mx4Error)."""
    if len(args) > ARG_BYTES:
        raise ValueError(f"{len(args)} argument bytes: the RTC window holds {ARG_BYTES}")
    h.send([Post(_NAMES.get(code, f"RTC {code:02X}h"), code, bytes(args))], timeout_ms=timeout_ms)


def wait_rtc_idle(h: Mx4, timeout_ms: int | None = None) -> None:
    """Wait (server side) until 3C2h reads 00h: the card has taken the last RTC."""
    t = h.timeout_ns(timeout_ms)
    if not h.batch([h.wait(Dpr.RTC, 0, t)], t)[0]["fired"]:
        raise Mx4Timeout(f"{h.card}: 3C2h did not read 00h within {t // 1_000_000} ms")


def lock(h: Mx4, window: Window, timeout_ms: int | None = None) -> None:
    """Take `window`: its host access byte to 01h, then wait until the card's reads 00h
    [Ch6 Communication Protocols Revisited]. The card then leaves the window alone (and holds
    its interrupt posts, for the status window) until `unlock`."""
    t = h.timeout_ns(timeout_ms)
    if not h.batch(h.lock(window, t), t)[1]["fired"]:
        unlock(h, window)
        raise Mx4Timeout(f"{h.card}: the card held the {window.name} window")


def unlock(h: Mx4, window: Window) -> None:
    """Release `window` (its host access byte to 00h)."""
    h.dpr.write(window.host_flag, b"\x00")


def read_window(h: Mx4, which: Window, timeout_ms: int | None = None) -> bytes:
    """The bytes of a protected window read under its access bytes, bank 1 then bank 2 (32 bytes
    for a per-axis window). Reading the status window reads 1FFEh, which ends the interrupt."""
    t = h.timeout_ns(timeout_ms)
    ranges = which.value[2]
    res = h.batch([*h.lock(which, t), *(h.read(a, b - a) for a, b in ranges), h.unlock(which)], t)
    if not res[1]["fired"]:
        unlock(h, which)
        raise Mx4Timeout(f"{h.card}: the card held the {which.name} window")
    return b"".join(res[2:2 + len(ranges)])


def read_axes(h: Mx4, which: Window = Window.ACTPOS, timeout_ms: int | None = None) -> tuple[int, ...]:
    """The eight int32 of a per-axis window (ACTPOS, ACTVEL, ERROR, INDPOS, PRB), axis 1 first;
    ACTVEL is counts/sample x ACTVEL_SCALE (208) [Ch6 Table 6-5]."""
    if which not in _AXIS_WINDOWS:
        raise ValueError(f"{which.name} is not a per-axis window")
    return _I32X8.unpack(read_window(h, which, timeout_ms))


def read_inputs(h: Mx4) -> int:
    """IN0..IN31 after their polarity, bit set = active (INPUT, 094h) [Ch6 Table 6-5]."""
    return int.from_bytes(h.dpr.read(Dpr.INPUT, 4), "little")


def read_int(h: Mx4, timeout_ms: int | None = None) -> IntStatus:
    """The interrupt service's reads [Ch6 Handling Interrupts]: 1FFEh (which ends the
    interrupt), then under the status lock DSPSTAT1/2 and their sources."""
    t = h.timeout_ns(timeout_ms)
    return h.status_from(h.batch(h.status_ops(t), t), 0)


def ack_int(h: Mx4, hostint_bits: int = 0, dspstat1_bits: int = 0, dspstat2_bits: int = 0,
            src_clear: int | bool = True, *, timeout_ms: int | None = None) -> IntStatus:
    """Clear the interrupt bits the host handled, under the status lock: the 1FFEh bits, the
    DSPSTAT1 and DSPSTAT2 types, and with `src_clear` their source bytes (True: all of them; an
    axis mask: those axes, a type bit going once its sources are empty); 1FFEh b1/b6 go once
    DSPSTAT1/DSPSTAT2 are empty. Returns the registers as found. One round trip after a
    `read_int` that saw them as they are, else two."""
    change = acknowledged(hostint_bits, dspstat1_bits, dspstat2_bits, src_clear)
    return h.acknowledge(change, h.timeout_ns(timeout_ms))


def wait_int(h: Mx4, *, hostint: int = 0, dspstat1: int = 0, dspstat2: int = 0, axes: int = 0xFF,
             any_axis: bool = False, ack: bool = True, timeout_ms: int | None = None) -> IntStatus:
    """Wait (server side) for an interrupt report: one DSPSTAT1 or DSPSTAT2 type whose source
    byte has every bit of `axes` (`any_axis`: one of them), several types of one register (any
    of them), or one of the 1FFEh bits `hostint`. Then, in the same batch, the status is read
    and (`ack`) what was waited for is acknowledged (those axes' sources, the type once its
    sources are empty, the 1FFEh bits). Returns the registers as found (before the
    acknowledge). Mx4Timeout when the report does not come within the time-out."""
    if [bool(hostint), bool(dspstat1), bool(dspstat2)].count(True) != 1:
        raise ValueError("wait_int waits for one of hostint, dspstat1, dspstat2")
    t = h.timeout_ns(timeout_ms)
    stat1, stat2 = dspstat1 & 0xFF, dspstat2 & 0xFF
    types = DspStat1(stat1) if stat1 else DspStat2(stat2)
    one = int(types).bit_count() == 1 and source_or_none(types) is not None
    sources: int | bool
    if hostint:
        wait = h.wait(Dpr.HOSTINT1, 0, t, mask=hostint & 0xFF, equal=False)
        what, sources = f"1FFEh {bits_text(HostInt(hostint & 0xFF))}", True
    elif one:
        mask = axes & 0xFF
        wait = h.wait(source_offset(types), 0 if any_axis else mask, t, mask=mask, equal=not any_axis)
        what, sources = f"{type(types).__name__.upper()} {bits_text(types)} of {axes_text(mask)}", mask
    else:
        wait = h.wait(Dpr.DSPSTAT1 if stat1 else Dpr.DSPSTAT2, 0, t, mask=int(types), equal=False)
        what, sources = f"{type(types).__name__.upper()} {bits_text(types)}", True
    if not ack:
        res = h.batch([wait, *h.status_ops(t)], 2 * t)
        h.fired(res[0], what, t)
        return h.status_from(res, 1)
    change = acknowledged(hostint, stat1, stat2, sources)
    known, h.status = h.status, expect(h.status, hostint, stat1, stat2, sources)
    res = h.batch([wait, *h.ack_ops(change, t)], 2 * t)
    if not res[0]["fired"]:
        h.status = known  # nothing was reported: the registers as they were
    h.fired(res[0], what, t)
    return h.ack_results(res, 1, change)


def wait_irq(h: Mx4, timeout_ms: int | None = None) -> IntStatus:
    """Wait (server side) for the next assertion of the card's interrupt line after the last
    one this handle returned (or after `open`), then read the status as `read_int` does."""
    t = h.timeout_ns(timeout_ms)
    res = h.batch([h.wait_irq(t), *h.status_ops(t)], 2 * t)
    h.fired(res[0], "interrupt", t)
    h.irq_seq = res[0]["event"]["seq"]
    return h.status_from(res, 1)


def parread(h: Mx4, m: int, *, timeout_ms: int | None = None) -> bytes:
    """PARREAD m (10h..27h): the 16 bytes the card writes, 0B8h..0BFh (axes 1-4) then
    8B8h..8BFh (axes 5-8), after the echo of m at 0B7h [Ch5 PARREAD; spec §2.5.3]: 0B7h := 00h,
    3C3h := m, 3C2h := 5Eh, wait (server side) for 0B7h = m, read; one round trip."""
    if not 0x10 <= m <= 0x27:
        raise ValueError(f"PARREAD {m:#x} outside 10h..27h")
    t = h.timeout_ns(timeout_ms)
    res = h.batch([h.wait(Dpr.RTC, 0, t), h.write(Dpr.PARACC, b"\x00"), h.write(Dpr.ARGMNTS, bytes((m,))),
                   h.write(Dpr.RTC, bytes((BY_NAME["PARREAD"].code,))), h.wait(Dpr.PARACC, m, t),
                   h.read(Dpr.PARRDBK, 8), h.read(Dpr.PARRDBK + BANK2, 8)], 2 * t)
    if not res[0]["fired"]:
        raise Mx4Timeout(f"{h.card}: 3C2h did not read 00h: PARREAD {m:02X}h not posted")
    if not res[4]["fired"]:
        raise Mx4Timeout(f"{h.card}: PARREAD {m:02X}h: no echo at 0B7h within {t // 1_000_000} ms")
    return bytes(res[5] + res[6])


def PARREAD(h: Mx4, m: int) -> bytes:
    """5Eh: parameter readback, see `parread` [Ch5 PARREAD]."""
    return parread(h, m)


# -- reset and signatures [Ch6 Power-Up/Reset Software Initialization; Tables 6-4, 6-6] ---------------
@dataclass(frozen=True)
class Signature:
    """The card's signatures: "MX4" with the DSP1 and DSP2 software versions (integer, decimal
    part) and the Vx4++ one if fitted (115h..11Fh); bus, option, revision (086h..088h)."""

    dsp1: tuple[int, int]
    dsp2: tuple[int, int]
    vx4: tuple[int, int] | None
    bus: str
    option: str
    revision: str

    def __str__(self) -> str:
        text = f"MX4 {self.dsp1[0]}.{self.dsp1[1]}+{self.dsp2[0]}.{self.dsp2[1]}"
        return text + (f"+{self.vx4[0]}.{self.vx4[1]}" if self.vx4 else "")


_HW_SIG = (int(Dpr.HW_SIGNATURE), 6)
_SIG = (int(Dpr.SIGNATURE), 11)


def _signature(hw: bytes, sig: bytes) -> Signature | None:
    if sig[:3] != b"MX4" or sig[5:6] != b"+":
        return None
    vx4 = (sig[9], sig[10]) if sig[8:9] == b"+" else None
    return Signature((sig[3], sig[4]), (sig[6], sig[7]), vx4, chr(hw[0]), chr(hw[1]), chr(hw[2]))


def check_signature(h: Mx4) -> Signature:
    """The card's signatures; Mx4Error if the "MX4" signature is incomplete ("present if the
    card is operating correctly" [Table 6-6])."""
    hw, sig = (h.dpr.read(*_HW_SIG), h.dpr.read(*_SIG)) if h.dpr.is_mapped(*_SIG) \
        else h.batch([h.read(*_HW_SIG), h.read(*_SIG)])
    found = _signature(hw, sig)
    if found is None:
        raise Mx4Error(f"{h.card}: no signature at 115h: {bytes(sig).hex(' ')}")
    return found


def power_up_init(h: Mx4, *, wait_reset: bool = False, retries: int = 2,
                  timeout_ms: int = RESET_TIMEOUT_MS) -> Signature:
    """The power-up/reset initialization [Ch6 Power-Up/Reset Software Initialization]: (with
    `wait_reset`, wait server side for "reset finished", 1FFEh b4), clear b4 under the status
    lock, check the signature; if it is incomplete, `reset` (RESET and the same again), up to
    `retries` times. One batch (two at a first acknowledge)."""
    t = h.timeout_ns(timeout_ms)
    wait = [h.wait(Dpr.HOSTINT1, 0, t, mask=int(HostInt.RESET_DONE), equal=False)] if wait_reset else []
    if h.status is None or h.status.hostint is None:
        h.status = IntStatus(bytes(16), HostInt.RESET_DONE)  # a card as it powers up
    change = acknowledged(int(HostInt.RESET_DONE), 0, 0, True)
    ops = [*wait, h.read(*_HW_SIG), h.read(*_SIG), *h.ack_ops(change, t)]
    res = h.batch(ops, 2 * t)
    if wait:
        h.fired(res[0], "reset finished (1FFEh b4)", t)
    at = len(wait)
    h.ack_results(res, at + 2, change)
    if _signature(res[at], res[at + 1]) is None:
        return reset(h, retries=retries, timeout_ms=timeout_ms)
    return check_signature(h)


def reset(h: Mx4, timeout_ms: int = RESET_TIMEOUT_MS, *, retries: int = 2) -> Signature:
    """RESET (72h AAh AAh) and the initialization after it in one batch: wait (server side) for
    the card to take it and report "reset finished" (1FFEh b4), clear b4 under the status lock,
    read the signatures; again while the signature is incomplete, `retries` more times."""
    t = h.timeout_ns(timeout_ms)
    change = acknowledged(int(HostInt.RESET_DONE), 0, 0, True)
    reset_post = encode("RESET", {"sig1": 0xAA, "sig2": 0xAA})
    sig: bytes = b""
    for _ in range(retries + 1):
        h.status = IntStatus(bytes(16), HostInt.RESET_DONE)  # the DPR after a reset
        ops = [*h.post_ops(reset_post, t),
               h.wait(Dpr.HOSTINT1, 0, t, mask=int(HostInt.RESET_DONE), equal=False),
               h.read(*_HW_SIG), h.read(*_SIG), *h.ack_ops(change, t)]
        res = h.batch(ops, 4 * t)
        h.taken(res, reset_post)
        h.fired(res[4], "reset finished (1FFEh b4)", t)
        h.ack_results(res, 7, change)
        sig = res[6]
        found = _signature(res[5], sig)
        if found is not None:
            return found
    raise Mx4Error(f"{h.card}: no signature after {retries + 1} resets: {bytes(sig).hex(' ')}")


# -- homing and offset calibration [Ch5 EN_INDEX, POS_SHIFT, OFFSET; spec §8.1] -------------------------
def home_on_index(h: Mx4, axis: int, vel: int | None = None, *, position: int = 0,
                  timeout_ms: int = 10_000) -> int:
    """Home `axis` (1..8) on its encoder index: clear a stale index report, EN_INDEX (and, with
    `vel`, VELMODE at vel, 16.16, which needs MAXACC), wait server side for the index interrupt,
    stop (VELMODE 0), read INDPOS (all axes latched at the edge), then POS_SHIFT the axis so that
    the index is at `position`. Returns the axis's INDPOS before the shift. Four round trips.
    Mx4Timeout (the axis stopped) when no index comes within `timeout_ms`."""
    if not 1 <= axis <= 8:
        raise ValueError(f"axis {axis} outside 1..8")
    bit, t = 1 << (axis - 1), h.timeout_ns(timeout_ms)
    ack_int(h, dspstat1_bits=DspStat1.INDEX, src_clear=bit)
    h.send([*encode("EN_INDEX", {"n": bit}),
            *(encode("VELMODE", {"n": bit}, vel=vel) if vel is not None else [])])
    stop = encode("VELMODE", {"n": bit}, vel=0) if vel is not None else []
    rtc_ns = h.timeout_ns()
    change = acknowledged(0, int(DspStat1.INDEX), 0, bit)
    h.status = expect(h.status, 0, int(DspStat1.INDEX), 0, bit)
    stop_ops = h.post_ops(stop, rtc_ns) if stop else []
    lock_at = 1 + len(stop_ops)
    head = [h.wait(source_offset(DspStat1.INDEX), bit, t, mask=bit), *stop_ops,
            *h.lock(Window.INDPOS, rtc_ns), *(h.read(a, b - a) for a, b in Window.INDPOS.value[2]),
            h.unlock(Window.INDPOS)]
    res = h.batch([*head, *h.ack_ops(change, rtc_ns)], t + 4 * rtc_ns)
    if not res[0]["fired"] and stop:
        h.send(stop)  # no index: the axis does not run on
    h.fired(res[0], f"index pulse of axis {axis} (DSPSTAT1 b2, 003h)", t)
    if stop:
        h.taken(res[1:], stop)
    if not res[lock_at + 1]["fired"]:
        unlock(h, Window.INDPOS)
        raise Mx4Timeout(f"{h.card}: the card held the INDPOS window")
    indpos = _I32X8.unpack(res[lock_at + 2] + res[lock_at + 3])
    h.ack_results(res, len(head), change)
    found = indpos[axis - 1]
    h.send(encode("POS_SHIFT", {"n": bit}, psft=position - found))
    return found


def calibrate_offset(h: Mx4, axis: int, *, timeout_ms: int = 10_000) -> IntStatus:
    """Offset calibration of `axis` [Ch5 OFFSET]: (the axis at rest, closed loop with Ki != 0)
    clear a stale report, OFFSET, wait server side for "offset cancel finished" (DSPSTAT2 b2,
    00Ch) and acknowledge it; the card gives an axis that cannot settle 10 s."""
    if not 1 <= axis <= 8:
        raise ValueError(f"axis {axis} outside 1..8")
    bit = 1 << (axis - 1)
    ack_int(h, dspstat2_bits=DspStat2.OFFSET, src_clear=bit)
    h.send(encode("OFFSET", {"n": bit}))
    return wait_int(h, dspstat2=DspStat2.OFFSET, axes=bit, timeout_ms=timeout_ms)


__all__ = [
    "ACTVEL_SCALE", "DEFAULT_TIMEOUT_MS", "DPR", "RESET_TIMEOUT_MS", "DisableBit", "Dpr", "DspStat1",
    "DspStat2", "HostInt", "IntStatus", "Mx4", "Mx4Error", "Mx4Timeout", "PARREAD", "PerAxis", "Post",
    "Signature", "Window", "acc_to_raw", "ack_int", "calibrate_offset", "check_signature", "close",
    "contour", "dac_to_volts", "encode", "home_on_index", "load_table", "lock", "open", "parread",
    "power_up_init", "ratio_to_raw", "raw_to_acc", "raw_to_ratio", "raw_to_vel", "read_axes",
    "read_inputs", "read_int", "read_window", "reset", "ring_free", "ring_put", "rtc", "unlock",
    "vel_to_raw", "volts_to_dac", "wait_int", "wait_irq", "wait_rtc_idle", *_RTC_FUNCTIONS,
]
