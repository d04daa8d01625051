"""Snapshots of every card type of the default rack (issue 23 §2): a scenario runs in lockstep
through the vendor client (the registers for the generic card), a snapshot is taken mid-motion,
then a fixed sequence of requests runs while a digest (SHA-256) of every reply is kept; the
snapshot is loaded and the same sequence gives the same digest. A reset rack running the same
sequence gives another digest: the replies depend on the state the snapshot brought back."""

from __future__ import annotations

import contextlib
import ctypes
import hashlib
from collections.abc import Callable, Iterator
from dataclasses import replace
from typing import Any

import msgpack
import pytest
import vdevclient
from vdevclient import aps, gclib, maxk, mx4, pcomm
from vdevclient.core import Prepared, Rack
from vdevclient.errors import RemoteError

from vdevd.config import default_config
from vdevd.testing import DaemonThread

LOOPBACK = "tcp://127.0.0.1:*"
PMAC_DEVICE = 0


def default_rack() -> DaemonThread:
    """The default rack (every card type), lockstep, its card ports (Galil and PMAC Ethernet)
    on free loopback ports."""
    cfg = default_config()
    cfg.clock = "lockstep"
    cfg.endpoint = cfg.events = LOOPBACK
    cfg.cards = [replace(spec, options={**spec.options, "ethernet": LOOPBACK})
                 if "ethernet" in spec.options else spec for spec in cfg.cards]
    return DaemonThread(cfg)


@contextlib.contextmanager
def digest(monkeypatch: pytest.MonkeyPatch) -> Iterator[Any]:
    """Every reply any client of this process receives, into one SHA-256: but `hello`'s, which
    names the endpoints and the shared segment, and of `stats` only what it says of the cards
    and the clock (the rest counts requests and wall time)."""
    h = hashlib.sha256()
    call = Rack.call

    def recorded(self: Rack, message: dict[str, Any] | Prepared, wait_s: float = 0.0) -> Any:
        op = message.op if isinstance(message, Prepared) else message["op"]
        try:
            result = call(self, message, wait_s)
        except RemoteError as exc:
            h.update(f"error {exc}".encode())
            raise
        if op == "stats":
            h.update(msgpack.packb([result["cards"], result["clock"]["now_ns"]]))
        elif op != "hello":
            h.update(msgpack.packb(result, use_bin_type=True))
        return result

    with monkeypatch.context() as m:
        m.setattr(Rack, "call", recorded)
        yield h


def dump_regions(d: DaemonThread, card: str) -> None:
    """Every region of `card` read whole through requests (into the digest)."""
    with vdevclient.connect(d.endpoint, shm=False) as rack:
        for region in rack.card(card).info["regions"]:
            with contextlib.suppress(RemoteError):  # a region read whole may be refused
                rack.request("read", card=card, region=region["name"], offset=0,
                             size=region["size"])


def step(d: DaemonThread, seconds: float) -> None:
    with vdevclient.connect(d.endpoint, shm=False) as rack:
        rack.sim.step(seconds=seconds)


# -- the scenarios: before the snapshot, and the sequence replayed after it ----------------------
GALIL_PROGRAM = "#A\nPR 40000,-20000\nBG XY\nAM XY\nMG \"DONE\"\nEN"


@contextlib.contextmanager
def galil_session(d: DaemonThread) -> Iterator[gclib.py]:
    g = gclib.py()
    g.GOpen(f"galil0 --endpoint {d.endpoint}")
    try:
        yield g
    finally:
        g.GClose()


def galil_before(d: DaemonThread) -> None:
    with vdevclient.connect(d.endpoint, shm=False) as rack:  # the host enables the line
        a16 = rack.card("galil0").region("a16")
        a16.write(3, b"\x02")
        a16.write(3, b"\x04")
    with galil_session(d) as g:
        g.GCommand("EI 15")  # an interrupt at each motion complete of X..W
        g.GCommand("SP 50000,50000;AC 200000,200000;DC 200000,200000")
        g.GProgramDownload(GALIL_PROGRAM)
        g.GCommand("XQ #A")
        g.GCommand("JG ,,5000;BG Z")
        g.GCommand("CM W;DT 5;CD 300;CD 300;CD 300;CD 300;CD 300;CD 300")  # a contour on W
    step(d, 0.1)


def galil_after(d: DaemonThread) -> None:
    with galil_session(d) as g:
        for _ in range(4):
            step(d, 0.05)
            g.GCommand("TP")
            g.GCommand("TE")
            g.GCommand("TS")
            g.GCommand("MG _BGX, _BGY, _RPZ")
        g.GCommand("ST Z")
        g.GCommand("UI 3")  # a user interrupt
        step(d, 0.5)
        g.GCommand("TP")
    with vdevclient.connect(d.endpoint, shm=False) as rack:  # the codes queued, popped
        a16 = rack.card("galil0").region("a16")
        for _ in range(4):
            a16.write(3, b"\x06")
            a16.read(3, 1)
    dump_regions(d, "galil0")


def pmac_ask(command: str) -> str:
    out = ctypes.create_string_buffer(1024)
    pcomm.PmacGetResponseA(PMAC_DEVICE, out, 1024, command)
    return out.value.decode("latin-1")


@contextlib.contextmanager
def pmac_session(d: DaemonThread) -> Iterator[None]:
    assert pcomm.OpenPmacDevice(PMAC_DEVICE, endpoint=d.endpoint)
    try:
        yield
    finally:
        pcomm.ClosePmacDevice(PMAC_DEVICE)


PMAC_PROGRAM = ["&1#1->1000X#2->1000Y", "OPEN PROG 10 CLEAR", "LINEAR ABS TA50 TS10 F200",
                "X10 Y5", "X0 Y10", "X20 Y0", "CLOSE"]


def pmac_before(d: DaemonThread) -> None:
    with pmac_session(d):
        for line in PMAC_PROGRAM:
            pmac_ask(line)
        pmac_ask("#1$#2$#3$")  # enabled, the phase where the card has none to do
        step(d, 0.05)
        pmac_ask("&1B10R")
        pmac_ask("#3J+")
    step(d, 0.08)


def pmac_after(d: DaemonThread) -> None:
    with pmac_session(d):
        for _ in range(4):
            step(d, 0.04)
            pmac_ask("#1P#2P#3P")
            pmac_ask("#1V#2V#3F")
            pmac_ask("&1??")
        pmac_ask("#3J/")
        step(d, 0.5)
        pmac_ask("#1P#2P#3P")
    dump_regions(d, "pmac0")


def maxk_before(d: DaemonThread) -> None:
    with maxk.open(1, endpoint=d.endpoint, name="maxk0") as m:
        m.send_string("AX VL20000 AC100000 MR50000 GO")
        m.send_string("AY VL10000 MR-30000 GO ID")
        m.send_string("AZ JG3000")


def maxk_after(d: DaemonThread) -> None:
    with maxk.open(1, endpoint=d.endpoint, name="maxk0") as m:
        for _ in range(4):
            step(d, 0.1)
            m.send_and_get_string("AA RP")
            m.send_and_get_string("AA RE")
            m.send_and_get_string("AX QA")
            m.get_status_flags()
        m.send_string("AZ ST")
        step(d, 0.5)
        m.send_and_get_string("AA RP")
    dump_regions(d, "maxk0")


def octavia_before(d: DaemonThread) -> None:
    with mx4.open(0, endpoint=d.endpoint, name="octavia0") as h:
        mx4.MAXACC(h, 0x03, 0x150)
        mx4.CTRL(h, 0x03, ki=100, kp=4000, kf=3000, kd=2500)  # the manual's gains [Ch5 CTRL]
        mx4.KILIMIT(h, 0x03, 0)
        mx4.EN_MOTCP(h, 0x03)  # an interrupt at each motion complete
        mx4.AXMOVE(h, 0x03, 0x150, [0x00234567, 0x00112233], 0x00200000)
    step(d, 0.2)


def octavia_after(d: DaemonThread) -> None:
    with mx4.open(0, endpoint=d.endpoint, name="octavia0") as h:
        for _ in range(4):
            step(d, 0.1)
            mx4.read_axes(h, mx4.Window.ACTPOS)
            mx4.read_int(h)
        mx4.AXMOVE(h, 0x01, 0x150, [0], 0x00200000)
        step(d, 0.5)
        mx4.read_axes(h, mx4.Window.ACTPOS)
    dump_regions(d, "octavia0")


@contextlib.contextmanager
def aps_session(d: DaemonThread) -> Iterator[None]:
    bits = ctypes.c_int32()
    assert aps.APS_initial(ctypes.byref(bits), 0, endpoint=d.endpoint) == aps.ERR_NoError
    try:
        yield
    finally:
        aps.APS_close()


def adlink_before(d: DaemonThread) -> None:
    with aps_session(d):
        for axis in (0, 1):
            assert aps.APS_set_servo_on(axis, 1) == 0
        assert aps.APS_absolute_move(0, 50_000, 20_000) == 0
        assert aps.APS_relative_move(1, -30_000, 10_000) == 0
        for axis in (2, 3):
            assert aps.APS_set_servo_on(axis, 1) == 0
        assert aps.APS_line(2, [2, 3], 0, [3000.0, 4000.0], None) == 0  # interpolated
    step(d, 0.5)


def adlink_after(d: DaemonThread) -> None:
    with aps_session(d):
        for _ in range(4):
            step(d, 0.2)
            for axis in (0, 1, 2, 3):
                pos = ctypes.c_double()
                aps.APS_get_position_f(axis, ctypes.byref(pos))
                aps.APS_motion_status(axis)
        with vdevclient.connect(d.endpoint, shm=False) as rack:  # a limit switch meets axis 0
            rack.control("adlink0", "set_limit", axis=0, side="positive")
        assert aps.APS_absolute_move(1, 0, 10_000) == 0
        step(d, 1.0)
    dump_regions(d, "adlink0")


#: the generic servo card's registers (vdevd/devices/generic/README.md): axis 0 and 1
TARGET, COMMAND, POSITION, IRQ_ENABLE, AXIS = 0x104, 0x100, 0x11C, 0x24, 0x40


def generic_before(d: DaemonThread) -> None:
    with vdevclient.connect(d.endpoint, shm=False) as rack:
        bar = rack.card("servo0").region("bar0")
        bar.write32(IRQ_ENABLE, 1)  # an interrupt at each move's end
        for axis, target in ((0, 40_000), (1, -25_000)):
            bar.write32(TARGET + axis * AXIS, target & 0xFFFFFFFF)
            bar.write32(COMMAND + axis * AXIS, 1)
        rack.control("servo0", "set_home", axis=1)
        rack.request("scope", card="servo0", action="arm", axes=[0, 1],  # a recording under way
                     signals=["position", "command", "error"], samples=400, every=2)
        rack.sim.step(seconds=0.05)


def generic_after(d: DaemonThread) -> None:
    with vdevclient.connect(d.endpoint, shm=False) as rack:
        bar = rack.card("servo0").region("bar0")
        for _ in range(4):
            rack.sim.step(seconds=0.1)
            bar.read32(POSITION)
            bar.read32(POSITION + AXIS)
        rack.card("servo0").irq.wait(timeout_s=5.0)
        rack.sim.step(seconds=2.0)
        start = None if rack.request("scope", card="servo0", action="status")[
            "state"] == "idle" else 0
        while start is not None:  # the recording, begun before the snapshot
            start = rack.request("scope", card="servo0", action="read", start=start)["next"]
    dump_regions(d, "servo0")


def moving(d: DaemonThread, kind: str) -> bool:
    """The scenario's axes are moving (the snapshot is taken mid-motion)."""
    if kind == "generic":
        with vdevclient.connect(d.endpoint, shm=False) as rack:
            return 0 < rack.card("servo0").region("bar0").read32(POSITION) < 40_000
    if kind == "galil":
        with galil_session(d) as g:
            return "1.0000" in g.GCommand("MG _BGX, _BGY, _BGZ")
    if kind == "pmac":
        with pmac_session(d):
            return bool(int(pmac_ask("&1??")[:6], 16) & 1)  # the program runs
    if kind == "maxk":
        with maxk.open(1, endpoint=d.endpoint, name="maxk0") as m:
            return m.get_status_flags().done == 0
    if kind == "octavia":
        with mx4.open(0, endpoint=d.endpoint, name="octavia0") as h:
            first = mx4.read_axes(h, mx4.Window.ACTPOS)
            step(d, 0.001)
            return mx4.read_axes(h, mx4.Window.ACTPOS) != first
    with aps_session(d):
        return any(not aps.APS_motion_status(a) & aps.MTS_MDN_V for a in (0, 1, 2, 3))


#: the cards whose scenario raises interrupts after the snapshot (their irq_seq is in the digest)
INTERRUPTING = {"galil": "galil0", "generic": "servo0"}


def irq_seq(d: DaemonThread, card: str) -> int:
    with vdevclient.connect(d.endpoint, shm=False) as rack:
        return int(rack.stats()["cards"][card]["irq_seq"])


SCENARIOS: dict[str, tuple[Callable[[DaemonThread], None], Callable[[DaemonThread], None]]] = {
    "generic": (generic_before, generic_after),
    "galil": (galil_before, galil_after),
    "pmac": (pmac_before, pmac_after),
    "maxk": (maxk_before, maxk_after),
    "octavia": (octavia_before, octavia_after),
    "adlink": (adlink_before, adlink_after),
}


@pytest.mark.parametrize("kind", list(SCENARIOS))
def test_a_snapshot_replays_byte_identical_replies(kind: str,
                                                   monkeypatch: pytest.MonkeyPatch) -> None:
    before, after = SCENARIOS[kind]
    with default_rack() as d:
        before(d)
        assert moving(d, kind)
        with vdevclient.connect(d.endpoint, shm=False) as rack:
            snap = rack.snapshot()
            taken_ns = rack.sim.now_ns()
        seq = irq_seq(d, INTERRUPTING[kind]) if kind in INTERRUPTING else 0
        with digest(monkeypatch) as first:
            after(d)
        if kind in INTERRUPTING:  # the sequence met interrupts
            assert irq_seq(d, INTERRUPTING[kind]) > seq
        with vdevclient.connect(d.endpoint, shm=False) as rack:
            assert rack.sim.now_ns() > taken_ns
            assert rack.restore(snap)["now_ns"] == taken_ns
            assert rack.sim.now_ns() == taken_ns
        with digest(monkeypatch) as second:
            after(d)
        assert second.hexdigest() == first.hexdigest()
        d.reset()  # the same requests on a rack at power-on: other replies
        with digest(monkeypatch) as fresh:
            after(d)
        assert fresh.hexdigest() != first.hexdigest()
