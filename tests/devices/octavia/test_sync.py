"""Two Octavias in one rack, a real daemon: SYNC master and slave share the sample [Ch5 SYNC;
spec §5.8], RTCs posted to both in one batch start on the same sample; each card's own number
is found through its PCI subsystem ID."""

from __future__ import annotations

import struct

import vdevclient
from vdevmaps.octavia import BY_NAME, Dpr, axis_offset, pack
from vdevmaps.pci import SUBSYSTEM_ID

from vdevd.config import CardSpec, Config
from vdevd.devices import card_class
from vdevd.testing import DaemonThread

LOOPBACK = "tcp://127.0.0.1:*"


def rack_config() -> Config:
    defaults = {k: o.default for k, o in card_class("dspcg-octavia").options.items()}
    return Config(endpoint=LOOPBACK, events=LOOPBACK, clock="lockstep", cards=[
        CardSpec("dspcg-octavia", "oct0", {**defaults, "plant": "ideal", "card": 1}),
        CardSpec("dspcg-octavia", "oct1", {**defaults, "plant": "ideal", "card": 2}),
    ])


def post_ops(dpr: vdevclient.Region, name: str, head: dict[str, int],
             groups: list[dict[str, int]] | None = None) -> list[dict[str, object]]:
    """One RTC as batch ops: the arguments, then the code [Ch6 Real-Time Commands]."""
    rtc = BY_NAME[name]
    return [dpr.write_op(Dpr.ARGMNTS, pack(rtc, head, groups or [])),
            dpr.write_op(Dpr.RTC, bytes((rtc.code,)))]


def test_sync_master_and_slave_move_on_the_same_samples() -> None:
    with DaemonThread(rack_config()) as d, vdevclient.connect(d.endpoint, d.events) as rack:
        dprs = [rack.card(n).region("dpr") for n in ("oct0", "oct1")]
        rack.batch(post_ops(dprs[0], "SYNC", {"m": 0}) + post_ops(dprs[1], "SYNC", {"m": 1}))
        rack.sim.step(ns=400_000)
        move = {"n": 0x01}, [{"acc": 0x150, "pos": 50_000, "vel": 0x200000}]
        ops = post_ops(dprs[0], "AXMOVE", *move) + post_ops(dprs[1], "AXMOVE", *move)
        rack.batch(ops)
        for ns in (200_000 * 37, 123_456_789, 3_000_017):
            rack.sim.step(ns=ns)
            a, b = (struct.unpack("<i", r.read(axis_offset(Dpr.ACTPOS, 1), 4))[0] for r in dprs)
            assert a == b and a > 0
        assert [r.read(Dpr.RTC, 1) for r in dprs] == [b"\x00", b"\x00"]
        for r in dprs:  # PARREAD 21h: 00h master, 11h slave
            rack.batch([r.write_op(Dpr.PARACC, b"\x00"), *post_ops(r, "PARREAD", {"m": 0x21})])
        rack.sim.step(ns=5_000_000)
        assert [r.read(Dpr.PARRDBK, 1) for r in dprs] == [b"\x00", b"\x11"]
        subsystem = [int.from_bytes(rack.card(n).region("config").read(SUBSYSTEM_ID, 2),
                                    "little") for n in ("oct0", "oct1")]
        assert subsystem == [1, 2]
