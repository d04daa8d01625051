"""Quiet ticks in closed form give the replies and events of ticking every period (issue 17,
DESIGN.md "Time that costs nothing", decision 0008).

Each scenario runs twice against a real lockstep daemon with the embedded default rack (one card
of each kind): once with `[clock] skip_quiet = true` (the default: a card at rest runs its quiet
ticks in closed form) and once with `false` (every tick in full). Every reply a client receives
(through the vendor libraries, as an application sees them), every published event and the
final contents of every region are digested; the two digests must be equal, and the skipping run
must have skipped ticks (else the test proves nothing).
"""

from __future__ import annotations

import ctypes
import hashlib
from collections.abc import Callable, Iterator
from contextlib import contextmanager
from dataclasses import replace
from typing import Any

import msgpack
import pytest
import vdevclient
from vdevclient import core as client_core
from vdevclient import galil, maxk, pcomm
from vdevmaps import octavia
from vdevmaps.oms import RING_SIZE, Shm
from vdevmaps.pmac import HostIrq

from vdevd.config import Config, default_config
from vdevd.testing import DaemonThread

MS = 1_000_000
S = 1_000_000_000
#: the generic card's axis registers (README of the generic card)
AXIS_BASE, AXIS_STRIDE = 0x100, 0x40
COMMAND, TARGET, VMAX, ACC, DEC, POSITION = 0x00, 0x04, 0x08, 0x0C, 0x10, 0x1C
IRQ_ENABLE = 0x24
MOVE_ABS, JOG, STOP = 1, 3, 4
COMMAND_RING, COMMAND_PROCESS = int(Shm.COMMAND_RING), int(Shm.COMMAND_PROCESS)


def rack_config(skip: bool) -> Config:
    cfg = default_config()
    cfg.clock = "lockstep"
    cfg.skip_quiet = skip
    cfg.endpoint = cfg.events = "tcp://127.0.0.1:*"
    cfg.cards = [replace(spec, options={**spec.options, "ethernet": "tcp://127.0.0.1:*"})
                 if spec.options.get("ethernet") else spec for spec in cfg.cards]
    return cfg


class Recorder:
    """Every reply of every request the clients of this process make, in order (not `hello`
    and `stats`: endpoints and wall times differ from run to run)."""

    def __init__(self) -> None:
        self.digest = hashlib.sha256()
        self.count = 0

    def add(self, what: Any) -> None:
        self.digest.update(msgpack.packb(what, default=repr))
        self.count += 1


@contextmanager
def recorded(monkeypatch: pytest.MonkeyPatch, rec: Recorder) -> Iterator[None]:
    call = client_core.Rack.call

    def spy(self: client_core.Rack, message: Any, wait_s: float = 0.0) -> Any:
        try:
            result = call(self, message, wait_s)
        except vdevclient.VdevClientError as exc:
            rec.add(["error", str(exc)])
            raise
        op = message.get("op") if isinstance(message, dict) else None
        if op not in ("hello", "stats", "sync"):
            rec.add([op, result])
        return result

    with monkeypatch.context() as m:
        m.setattr(client_core.Rack, "call", spy)
        yield


def run(scenario: Callable[[DaemonThread, vdevclient.Rack, Recorder], None], skip: bool,
        monkeypatch: pytest.MonkeyPatch) -> tuple[str, int, dict[str, int]]:
    """(digest, replies recorded, quiet ticks skipped by card) of `scenario` on a fresh
    daemon."""
    rec = Recorder()
    monkeypatch.setenv("VDEVD_SHM", "0")  # every read a request, so that the spy sees it
    with DaemonThread(rack_config(skip)) as d, \
            vdevclient.connect(d.endpoint, d.events, timeout=20) as rack:
        subs = {c.name: rack.card(c.name).irq.subscribe() for c in rack.cards()}
        with recorded(monkeypatch, rec):
            scenario(d, rack, rec)
            for c in rack.cards():  # the final memory of every region
                for r in c.regions:
                    if r.name != "config":
                        rec.add([c.name, r.name, rack.card(c.name).region(r.name).read(0, 0)
                                 if r.size == 0 else _dump(rack, c.name, r.name, r.size)])
        for name, irq in subs.items():
            for event in irq.events(timeout_s=0.2):
                rec.add(["event", name, event])
        stats = rack.stats()
        skipped = {name: c["quiet_ticks"] for name, c in stats["cards"].items()}
        assert stats["scheduler"]["card_faults"] == 0
    return rec.digest.hexdigest(), rec.count, skipped


def _dump(rack: vdevclient.Rack, card: str, region: str, size: int) -> bytes:
    """A region's memory in reads of at most 4 KiB, by its smallest width where it has hooks
    (the same reads in both runs: their side effects are part of the scenario)."""
    reg = rack.card(card).region(region)
    out = bytearray()
    for off in range(0, min(size, 1 << 16), 4096):
        try:
            out += reg.read(off, min(4096, size - off))
        except vdevclient.VdevClientError as exc:  # a bus that allows no block reads
            out += str(exc).encode()
    return bytes(out)


def both_ways(scenario: Callable[[DaemonThread, vdevclient.Rack, Recorder], None], card: str,
              monkeypatch: pytest.MonkeyPatch) -> None:
    fast, n_fast, skipped = run(scenario, True, monkeypatch)
    full, n_full, skipped_full = run(scenario, False, monkeypatch)
    assert not any(skipped_full.values())
    assert skipped[card] > 0, f"the scenario never let {card} rest: it proves nothing"
    assert n_fast == n_full and n_fast > 20
    assert fast == full


# -- scenarios ---------------------------------------------------------------------------------------
def generic_scenario(d: DaemonThread, rack: vdevclient.Rack, rec: Recorder) -> None:
    """Moves, a jog and its stop, interrupts, backdoor inputs at scheduled times, reads after
    steps of odd lengths (batch boundaries fall anywhere)."""
    card = rack.card("servo0")
    bar = card.region("bar0")
    bar.write32(IRQ_ENABLE, 0xFFFF_FFFF)
    for axis, target in enumerate((5000, -3000, 12000, 1)):
        base = AXIS_BASE + AXIS_STRIDE * axis
        bar.write32(base + TARGET, target & 0xFFFF_FFFF)
        bar.write32(base + COMMAND, MOVE_ABS)
    for ns in (3 * MS + 17, 400 * MS, 2 * S + 123_457, 7, 5 * S):
        rack.sim.step(ns=ns)
        rec.add([bar.read32(AXIS_BASE + AXIS_STRIDE * a + POSITION) for a in range(4)])
    rec.add(card.irq.wait(1.0))
    bar.write32(AXIS_BASE + TARGET, 20_000)
    bar.write32(AXIS_BASE + COMMAND, JOG)
    rack.control("servo0", "set_limit", after_ns=700 * MS, axis=0, side="positive")
    rack.sim.step(seconds=3.3)
    rec.add(card.irq.wait(1.0))
    rack.control("servo0", "set_limit", axis=0, side="positive", active=False)
    rec.add(card.control("axis_state", axis=0))
    rack.sim.step(seconds=4.0)
    rec.add(card.control("axis_state", axis=0))


def galil_scenario(d: DaemonThread, rack: vdevclient.Rack, rec: Recorder) -> None:
    """Commands, a trippoint, the data record every 2^8 samples, TIME, a jog and its stop, a
    move of the virtual axis N."""
    h = ctypes.c_long()
    assert galil.DMCOpen(1, 0, ctypes.byref(h), endpoint=d.endpoint, events=d.events) == 0
    buf = ctypes.create_string_buffer(512)

    def cmd(text: str) -> None:
        rc = galil.DMCCommand(h, text, buf, 512)
        rec.add([text, rc, buf.value])

    for text in ("TP", "MG TIME", "PR 1000,-2000,3000,4", "SP 20000,20000,20000,20000",
                 "BG ABCD", "AM", "TP", "MG TIME", "WT 777", "MG TIME", "TE", "DR 8",
                 "JG 5000", "BG A"):
        cmd(text)
    rack.sim.step(seconds=1.7)
    cmd("TV")
    cmd("ST A")
    rack.sim.step(seconds=2.0)
    for text in ("TP", "MG TIME", "DR 0", "MG TIME"):
        cmd(text)
    rack.sim.step(ns=3 * S + 1)
    cmd("MG TIME")
    cmd("TD")
    cmd("PRN=30000;SPN=20000;BGN")  # the virtual axis N moving: not at rest
    rack.sim.step(seconds=0.8)
    cmd("MG _RPN,_BGN")
    rack.sim.step(seconds=2.0)
    cmd("MG _RPN,_BGN,TIME")
    cmd("DR 7")  # at rest: a record every 128 samples, the one read after each step
    record = ctypes.create_string_buffer(1024)
    for ns in (S + 17, 333 * MS, 7 * MS):
        rack.sim.step(ns=ns)
        rec.add([galil.DMCRefreshDataRecord(h, 0), galil.DMCCopyDataRecord(h, record),
                 record.raw])
    cmd("DR 0")
    galil.DMCClose(h)


def galil_program_scenario(d: DaemonThread, rack: vdevclient.Rack, rec: Recorder) -> None:
    """An application program: a loop with a move, a wait and messages, then a card at rest."""
    h = ctypes.c_long()
    assert galil.DMCOpen(1, 0, ctypes.byref(h), endpoint=d.endpoint, events=d.events) == 0
    buf = ctypes.create_string_buffer(512)
    program = "#A\nN=0\n#L\nPR 1000\nBGX\nAMX\nWT 333\nMG N,_TPX\nN=N+1\nJP #L,N<4\nEN"
    rec.add(galil.DMCDownloadFromBuffer(h, program, None))
    for text in ("XQ #A", "MG _XQ0"):
        rec.add([galil.DMCCommand(h, text, buf, 512), buf.value])
    for ns in (S + 17, 777 * MS, 3 * S, 10 * S + 3):
        rack.sim.step(ns=ns)
        rec.add([galil.DMCCommand(h, "MG TIME,_XQ0,N", buf, 512), buf.value])
        rec.add([galil.DMCGetUnsolicitedResponse(h, buf, 512), buf.value])
    galil.DMCClose(h)


def galil_io_scenario(d: DaemonThread, rack: vdevclient.Rack, rec: Recorder) -> None:
    """An armed output compare, analog feedback on Y, extended outputs and formats: moves, then a
    card at rest with the compare still armed."""
    h = ctypes.c_long()
    assert galil.DMCOpen(1, 0, ctypes.byref(h), endpoint=d.endpoint, events=d.events) == 0
    buf = ctypes.create_string_buffer(512)
    rack.control("galil0", "set_analog", channel=2, volts=1.5)
    for text in ("OCX=100,250", "AF ,1", "CO 1", "SB 17", "PF 6.1", "PR 3000,-200",
                 "SP 20000,5000", "BG XY"):
        rec.add([text, galil.DMCCommand(h, text, buf, 512), buf.value])
    for ns in (77 * MS, S + 17, 3 * S, 10 * S + 3):
        rack.sim.step(ns=ns)
        rec.add([galil.DMCCommand(h, "TP;TI 2;MG TIME", buf, 512), buf.value,
                 rack.control("galil0", "compare_pulses")])
    rec.add([galil.DMCCommand(h, "JG -20000;BG X", buf, 512), buf.value])
    rack.sim.step(ns=S)
    rec.add([galil.DMCCommand(h, "ST X;TP", buf, 512), buf.value,
             rack.control("galil0", "compare_pulses")])
    rack.sim.step(ns=5 * S)
    rec.add([galil.DMCCommand(h, "TP;MG TIME", buf, 512), buf.value,
             rack.control("galil0", "compare_pulses")])
    galil.DMCClose(h)


def maxk_scenario(d: DaemonThread, rack: vdevclient.Rack, rec: Recorder) -> None:
    """Moves on servo and stepper axes, done flags, positions, a jog and its stop."""
    with maxk.open(1, endpoint=d.endpoint) as m:
        rec.add(m.send_and_get_string("WY"))
        m.send_string("AX VL20000 AC200000 MR5000 GO ID; AY MR-3000 GO ID; AU MR700 GO ID;")
        rec.add(str(m.wait_done(0x13, timeout_ms=10_000)))
        rec.add(str(m.get_positions()))
        rack.sim.step(seconds=1.3)
        rec.add(m.send_and_get_string("AA RP"))
        m.send_string("AZ JG4000;")
        rack.sim.step(seconds=0.9)
        rec.add(str(m.get_positions()))
        m.send_string("AZ ST;")
        rack.sim.step(seconds=2.0)
        rec.add(str(m.get_positions()))
        rec.add(str(m.get_status_flags()))
        rec.add(m.send_and_get_string("AA RP"))


def pmac_scenario(d: DaemonThread, rack: vdevclient.Rack, rec: Recorder) -> None:
    """Jogs and moves, on-line queries, the real-time and background reporting buffers."""
    assert pcomm.OpenPmacDevice(0, endpoint=d.endpoint)
    buf = ctypes.create_string_buffer(pcomm.MAX_COMM_BUFFER)

    def ask(text: str) -> None:
        r = pcomm.PmacGetResponseA(0, buf, pcomm.MAX_COMM_BUFFER, text)
        rec.add([text, int(r), buf.value])

    try:
        for text in ("#1P", "I10", "#1J=5000", "#2J:-3000", "#3J+"):
            ask(text)
        rack.sim.step(seconds=1.1)
        ask("#1P#2P#3P")
        ask("#3J=0")  # J/ would stop between two counts, where the servo hunts for ever
        pcomm.PmacDPRRealTimeEx(0, 0xFF, 50, 1)
        pcomm.PmacDPRBackgroundEx(0, 1, 30, 2)
        rack.sim.step(seconds=2.3)
        ask("#1P#2P#3P")
        dpram = rack.card("pmac0").region("dpram")
        for ns in (97 * MS + 13, S + 7, 333 * MS):  # one sample each, at its multiple of I47
            pcomm.PmacDPRResetDataReadyBit(0)
            rack.sim.step(ns=ns)
            rec.add(dpram.read(0, 4096))
        rec.add([pcomm.PmacDPRPosition(0, 1, 1.0), pcomm.PmacDPRGetVel(0, 3, 1.0)])
        rack.sim.step(ns=4 * S + 99)
        rec.add([pcomm.PmacDPRPosition(0, 3, 1.0), pcomm.PmacDPRGetGlobalStatus(0)])
        ask("#1P#2P#3P")
        # at rest: the clock register (1/1024 s at Y:$000017) and the servo cycle counter
        ask("M100->Y:$17,0,24")
        ask("M101->X:$0,0,24")
        for ns in (S // 2 + 3, 1234 * MS):
            rack.sim.step(ns=ns)
            ask("M100 M101")
        # the in-position interrupt after Ixx88 + 1 scans in position: its edge at its cycle
        pmac = rack.card("pmac0")
        pmac.region("host").write8(9, int(HostIrq.IN_POSITION))  # IR mask
        ask("I188=200")
        rack.sim.step(seconds=1.0)
        rec.add(rack.stats()["cards"]["pmac0"]["irq_seq"])
        ask("I188=0")
        ask("#1J=1500")
        rec.add(pmac.irq.wait(5.0))
    finally:
        pcomm.ClosePmacDevice(0)


def pmac_gather_scenario(d: DaemonThread, rack: vdevclient.Rack, rec: Recorder) -> None:
    """Data gathering (the card's README "Data gathering"): the servo cycle counter and motor 1's
    position every 7 cycles while a motor moves and after it stopped, until the buffer is full;
    then the card rests again."""
    assert pcomm.OpenPmacDevice(0, endpoint=d.endpoint)
    buf = ctypes.create_string_buffer(pcomm.MAX_COMM_BUFFER)

    def ask(text: str) -> None:
        r = pcomm.PmacGetResponseA(0, buf, pcomm.MAX_COMM_BUFFER, text)
        rec.add([text, int(r), buf.value])

    try:
        rack.sim.step(seconds=0.3)
        ask("I5001=$400000 I5002=$80008B I5050=3 I5049=7 DEFINE GATHER 1800 #1J=2000 GATHER")
        rack.sim.step(seconds=1.5)
        ask("??? #1P")
        rack.sim.step(seconds=2.5)  # 900 samples x 7 cycles: full after 2.8 s, at rest after
        ask("??? LIST GATHER")
        sources, samples = ctypes.c_uint(), ctypes.c_uint()
        rec.add(pcomm.PmacCollectGatherData(0, ctypes.byref(sources), ctypes.byref(samples)))
        rec.add([sources.value, samples.value])
        assert (sources.value, samples.value) == (2, 900)
        values: list[float] = []
        pcomm.PmacGetGatherSamples(0, 1, None, values, 1000)
        rec.add(values)
    finally:
        pcomm.ClosePmacDevice(0)


def pmac_program_scenario(d: DaemonThread, rack: vdevclient.Rack, rec: Recorder) -> None:
    """A motion program (the card's README "Motion programs"): LINEAR moves with a DWELL and a
    WHILE loop over a P-variable; positions and C.S. status read while it runs and after it
    ended, when the card rests again."""
    assert pcomm.OpenPmacDevice(0, endpoint=d.endpoint)
    buf = ctypes.create_string_buffer(pcomm.MAX_COMM_BUFFER)

    def ask(text: str) -> None:
        r = pcomm.PmacGetResponseA(0, buf, pcomm.MAX_COMM_BUFFER, text)
        rec.add([text, int(r), buf.value])

    try:
        rack.sim.step(seconds=0.3)
        ask("&1#1->1000X &1#2->1000Y #1J/#2J/ I116=1000 I117=10 I216=1000 I217=10")
        for line in ("OPEN PROG 1 CLEAR", "LINEAR INC TA50 TS10 F20 P1=0",
                     "WHILE (P1 < 3) X1 Y-1 DWELL20 P1=P1+1 ENDWHILE", "CLOSE"):
            ask(line)
        rack.sim.step(seconds=0.2)
        ask("&1B1R")
        rack.sim.step(seconds=0.13)
        ask("&1?? #1P #2P P1")
        rack.sim.step(seconds=2.0)
        ask("&1?? #1P #2P P1")
        rack.sim.step(seconds=1.0)
        ask("???")
    finally:
        pcomm.ClosePmacDevice(0)


def octavia_scenario(d: DaemonThread, rack: vdevclient.Rack, rec: Recorder) -> None:
    """RTCs through the DPR: gains, moves with motion complete, PARREAD's 5 ms echo, INT5MS
    is off (standard firmware), an index search, reads after steps of odd lengths."""
    dpr = rack.card("octavia0").region("dpr")

    def rtc(name: str, head: dict[str, int], groups: list[dict[str, int]] | None = None) -> None:
        r = octavia.BY_NAME[name]
        assert dpr.wait_value(octavia.Dpr.RTC, 0, size=1, timeout_s=1.0) == 0
        args = octavia.pack(r, head, groups or [])
        if args:
            dpr.write(octavia.Dpr.ARGMNTS, args)
        dpr.write8(octavia.Dpr.RTC, r.code)
        rec.add([name, dpr.wait_value(octavia.Dpr.RTC, 0, size=1, timeout_s=1.0)])

    def state() -> None:
        rec.add([dpr.read(0, 0x120), dpr.read(0x1FFE, 1), dpr.read(0x8B8, 0x60)])

    gains = {"ki": 100, "kp": 4000, "kf": 3000, "kd": 2500}
    rtc("CTRL", {"n": 0x0F}, [gains] * 4)
    rtc("MAXACC", {"n": 0x0F}, [{"acc": 0x150}] * 4)
    rtc("EN_MOTCP", {"n": 0x0F})
    rtc("AXMOVE", {"n": 0x0B}, [{"acc": 0x150, "pos": p, "vel": 0x100000}
                                for p in (20_000, -7_000, 3)])
    for ns in (3 * MS + 17, 400 * MS, 2 * S + 123_457, 7, 3 * S):
        rack.sim.step(ns=ns)
        state()
    dpr.write8(octavia.Dpr.PARACC, 0)
    rtc("PARREAD", {"m": 0x10})
    rec.add(dpr.wait_value(octavia.Dpr.PARACC, 0x10, size=1, timeout_s=1.0))
    rack.control("octavia0", "set_index", axis=3, period=4096, phase=10)
    rtc("EN_INDEX", {"n": 0x04})
    rtc("VELMODE", {"n": 0x04}, [{"vel": 0x40000}])
    rack.sim.step(seconds=1.1)
    state()
    rtc("VELMODE", {"n": 0x04}, [{"vel": 0}])
    rack.sim.step(seconds=2.5)
    state()
    # a stop ends between two counts, where the integrator hunts for ever: a whole count
    rtc("AXMOVE", {"n": 0x04}, [{"acc": 0x150, "pos": 30_000, "vel": 0x100000}])
    rack.sim.step(seconds=9.0)  # the integrators settle the servos: the card rests
    state()
    rack.sim.step(ns=S + 13)
    state()
    rec.add(rack.card("octavia0").control("axis_state", axis=3))


def adlink_scenario(d: DaemonThread, rack: vdevclient.Rack, rec: Recorder) -> None:
    """APS calls: servo on, T- and S-curve moves, a buffered queue, a velocity move and its
    stop, the status block after steps of odd lengths, an index mark crossed, a limit set at a
    scheduled time."""
    from vdevclient import aps

    bits = ctypes.c_int32()
    assert aps.APS_initial(ctypes.byref(bits), 0, endpoint=d.endpoint) == 0
    bar = rack.card("adlink0").region("bar0")
    try:
        def state() -> None:
            rec.add([bar.read(0, 0x100), bar.read(0x2000, 0x400)])

        for a in range(8):
            rec.add(aps.APS_set_servo_on(a, 1))
        rec.add(aps.APS_ptp_all(0, 0, 20_000.0, 0, 5000, 0, 1e5, 1e5, 0, None))
        rec.add(aps.APS_ptp_all(1, 0, -7_000.0, 100, 3000, 0, 5e4, 2e5, 0.7, None))
        rec.add(aps.APS_ptp(2, aps.PTP_OPT_BUFFERED, 300.0, None))
        rec.add(aps.APS_ptp(2, aps.PTP_OPT_BLEND_HIGH, 900.0, None))
        for ns in (3 * MS + 17, 400 * MS, 2 * S + 123_457, 7, 3 * S):
            rack.sim.step(ns=ns)
            state()
        rack.control("adlink0", "set_index", axis=3, period=4096, phase=10)
        rec.add(aps.APS_vel(3, 0, 20_000.0, None))
        rack.control("adlink0", "set_limit", after_ns=700 * MS, axis=3, side="positive")
        rack.sim.step(seconds=1.1)
        state()
        rack.control("adlink0", "set_limit", axis=3, side="positive", active=False)
        rec.add(aps.APS_vel(3, 0, -5_000.0, None))
        rack.sim.step(seconds=0.5)
        rec.add(aps.APS_stop_move(3))
        rack.sim.step(seconds=2.5)
        state()
        rack.sim.step(ns=S + 13)
        state()
    finally:
        aps.APS_close()


def adlink_units_scenario(d: DaemonThread, rack: vdevclient.Rack, rec: Recorder) -> None:
    """Every unit of the kernel that works between commands, each one let come to rest: a
    compare on the timer (the timer running, then stopped with points pending), the watchdog
    counting to its timeout, auto sampling, a triggered capture, a point table with a dwell, a
    gear pair, a line and an arc, interrupt waits, the whole BAR read after steps of odd
    lengths (decision 0008: a unit whose state a tick changes while `busy()` is False would
    make the card skip ticks wrongly)."""
    from vdevclient import aps

    bits = ctypes.c_int32()
    assert aps.APS_initial(ctypes.byref(bits), 0, endpoint=d.endpoint) == 0
    card = rack.card("adlink0")
    bar = card.region("bar0")
    out, i32 = ctypes.c_int32(), ctypes.c_int32()

    def state() -> None:
        rec.add([bar.read(off, 0x1000) for off in range(0, 0x4000, 0x1000)])
        rec.add(card.control("get_outputs"))

    def steps(*ns: int) -> None:
        for n in ns:
            rack.sim.step(ns=n)
            state()

    def call(fn: Any, *args: Any) -> None:
        rec.add([fn.__name__, fn(*args)])

    try:
        for a in range(8):
            call(aps.APS_set_servo_on, a, 1)
        call(aps.APS_int_enable, 0, 1)
        for a in range(8):
            call(aps.APS_set_int_factor, 0, a, aps.IMDN, 1)
        call(aps.APS_set_int_factor, 0, aps.INT_ITEM_SYSTEM, aps.ILCF0, 1)
        # the timer: a linear compare on it, the timer stopped with points pending, restarted
        for no, v in ((aps.TGR_LCMP0_SRC, aps.TGR_CMP_SRC_TIMER0), (aps.TGR_TRG_EN, 0b11),
                      (aps.TGR_TRG0_SRC, aps.TGR_SRC_LCMP0), (aps.TGR_TRG1_SRC,
                                                              aps.TGR_SRC_LCMP1),
                      (aps.TGR_LCMP1_SRC, 5), (aps.TIMR_ITV, 10_000)):
            call(aps.APS_set_trigger_param, 0, no, v)
        call(aps.APS_set_timer_counter, 0, 0, 0)
        call(aps.APS_set_trigger_linear, 0, 0, 0, 6, 250)
        call(aps.APS_set_trigger_linear, 0, 1, 100, 3, 400)  # on axis 5's encoder
        call(aps.APS_set_trigger_param, 0, aps.TIMR_EN, 1)
        steps(617 * MS + 3, 7)
        call(aps.APS_set_trigger_param, 0, aps.TIMR_EN, 0)  # 3 points left, the timer still
        steps(S + 333, 13 * MS)
        call(aps.APS_get_timer_counter, 0, 0, ctypes.byref(out))
        rec.add(out.value)
        call(aps.APS_set_trigger_param, 0, aps.TIMR_EN, 1)
        steps(900 * MS + 1)
        call(aps.APS_set_trigger_param, 0, aps.TIMR_EN, 0)
        rec.add(aps.APS_wait_single_int(0 * aps.INT_NO_PER_BOARD + aps.INT_ITEM_SYSTEM * 32
                                        + aps.ILCF0, 10))
        call(aps.APS_ptp, 5, 0, 1500.0, None)  # LCMP1 on axis 5's counter
        # the watchdog: counting, then expired (DO off) and waiting for its kick
        call(aps.APS_write_d_output, 0, 0, 0x5A)
        call(aps.APS_wdt_set_action_event, 0, 0, 2)
        call(aps.APS_wdt_start, 0, 0, 301)
        steps(151 * MS + 9, 211 * MS)
        call(aps.APS_wdt_get_counter, 0, 0, ctypes.byref(out))
        rec.add(out.value)
        steps(2 * S + 5)
        # auto sampling, then a capture that a move triggers
        for no, v in ((aps.SAMP_PA_RATE, 3), (aps.SAMP_PA_SRC_CH0, aps.SAMP_SRC_COM_POS | 4 << 8),
                      (aps.SAMP_PA_SRC_CH1, aps.SAMP_SRC_MSTS_MDN | 4 << 8)):
            call(aps.APS_set_sampling_param, 0, no, v)
        call(aps.APS_auto_sampling, 0, 1)
        call(aps.APS_ptp, 4, 0, 3000.0, None)
        steps(123 * MS + 5, 77 * MS)
        length, status = ctypes.c_int32(100), ctypes.c_int32()
        data = (aps.STR_SAMP_DATA_4CH * 100)()
        call(aps.APS_get_sampling_data, 0, ctypes.byref(length), data, ctypes.byref(status))
        rec.add([length.value, status.value, bytes(data)])
        steps(S + 3)  # auto sampling while every axis stands
        call(aps.APS_get_sampling_count, 0, ctypes.byref(out))
        rec.add(out.value)
        call(aps.APS_auto_sampling, 0, 0)
        steps(S + 1)
        for no, v in ((aps.SAMP_PA_RATE, 1), (aps.SAMP_PA_LEVEL, 1000), (aps.SAMP_PA_EDGE, 1),
                      (aps.SAMP_PA_TRIGCH, 0)):
            call(aps.APS_set_sampling_param, 0, no, v)
        capture = (aps.STR_SAMP_DATA_4CH * 40)()
        call(aps.APS_wait_trigger_sampling_async, 0, 40, 10, 5000, capture)
        steps(50 * MS + 3)
        call(aps.APS_ptp, 4, 0, 0.0, None)
        steps(777 * MS, 3)
        call(aps.APS_get_sampling_count, 0, ctypes.byref(out))
        rec.add([out.value, bytes(capture)])
        # a point table with a dwell and a DO at its point, on axes 2 and 3
        arr = (aps.I32 * 2)(2, 3)
        call(aps.APS_pt_enable, 0, 0, 2, arr)
        call(aps.APS_pt_set_absolute, 0, 0)
        call(aps.APS_pt_set_trans_buffered, 0, 0)
        call(aps.APS_pt_set_acc_dec, 0, 0, 1e5)
        call(aps.APS_pt_set_vm, 0, 0, 4e3)
        call(aps.APS_pt_set_ve, 0, 0, 0.0)
        call(aps.APS_pt_set_vs, 0, 0, 0.0)
        st = aps.PTSTS()
        for pos in ((500.0, 250.0), (800.0, -100.0)):
            prof = aps.PTLINE()
            prof.Dim = 2
            prof.Pos[0], prof.Pos[1] = pos
            call(aps.APS_pt_line, 0, 0, ctypes.byref(prof), ctypes.byref(st))
            dw = aps.PTDWL()
            dw.DwTime = 137.0
            call(aps.APS_pt_ext_set_do_ch, 0, 0, 3, 1)
            call(aps.APS_pt_dwell, 0, 0, ctypes.byref(dw), ctypes.byref(st))
        call(aps.APS_pt_start, 0, 0)
        steps(211 * MS + 1, 97 * MS, S + 7)
        call(aps.APS_get_pt_status, 0, 0, ctypes.byref(st))
        rec.add(bytes(st))
        call(aps.APS_pt_disable, 0, 0)
        # a gear pair: the slave follows the master's move, then lets go
        call(aps.APS_set_axis_param, 7, aps.PRA_GEAR_MASTER, 6)
        call(aps.APS_set_axis_param_f, 7, aps.PRA_GEAR_RATIO, -0.5)
        call(aps.APS_set_axis_param_f, 7, aps.PRA_GEAR_ENGAGE_RATE, 1e9)
        call(aps.APS_start_gear, 7, aps.GEAR_STANDARD)
        call(aps.APS_ptp, 6, 0, 4321.0, None)
        steps(333 * MS + 17, S)
        call(aps.APS_start_gear, 7, aps.GEAR_DISABLE)
        steps(S // 3)
        # a line and an arc on axes 0 and 1, waited on by interrupt
        call(aps.APS_line, 2, [0, 1], 0, [3000.0, 4000.0], None)
        rec.add(aps.APS_wait_single_int(0 * 32 + aps.IMDN, 5000))
        rec.add(rack.sim.now_ns())
        call(aps.APS_reset_int, 0 * 32 + aps.IMDN)
        call(aps.APS_arc2_ca, [0, 1], 0, [0.0, 0.0], 1.5, None)
        rec.add(aps.APS_wait_multiple_int(2, [0 * 32 + aps.IMDN, 1 * 32 + aps.IMDN], 1,
                                          10_000))
        rec.add(rack.sim.now_ns())
        steps(7, 1234 * MS + 1, S + 13)
        for a in range(8):
            rec.add([aps.APS_motion_status(a), aps.APS_get_position(a, ctypes.byref(i32)),
                     i32.value])
    finally:
        aps.APS_close()


@pytest.mark.parametrize(("scenario", "card"), [
    (generic_scenario, "servo0"), (galil_scenario, "galil0"), (galil_program_scenario, "galil0"),
    (galil_io_scenario, "galil0"), (maxk_scenario, "maxk0"),
    (pmac_scenario, "pmac0"), (pmac_gather_scenario, "pmac0"), (pmac_program_scenario, "pmac0"),
    (octavia_scenario, "octavia0"),
    (adlink_scenario, "adlink0"), (adlink_units_scenario, "adlink0")],
    ids=["generic", "galil", "galil-program", "galil-io", "maxk", "pmac", "pmac-gather",
         "pmac-program", "octavia",
         "adlink", "adlink-units"])
def test_skipping_quiet_ticks_changes_no_reply(scenario: Callable[..., None], card: str,
                                              monkeypatch: pytest.MonkeyPatch) -> None:
    both_ways(scenario, card, monkeypatch)


def test_a_card_proven_at_rest_skips_small_batches_until_an_input_changes() -> None:
    """Realtime passes run a tick or two per card: once a card proved itself at rest it skips
    them without looking again, until something touches it (a host access, a backdoor action,
    a new period); then it runs and looks again (decision 0008)."""
    from vdevd.devices.base import CardContext
    from vdevd.devices.generic.card import GenericServoCard

    card = GenericServoCard("servo0", {}, CardContext(emit=lambda e: None))
    for _ in range(10):
        card.tick(2)
    skipped = card.quiet_skipped
    assert skipped > 0
    card.tick(1)
    assert card.quiet_skipped == skipped + 1  # no look, no tick: skipped
    card.control("set_gains", {"axis": 0, "kp": 0.5})
    card.tick(1)
    assert card.quiet_skipped == skipped + 1  # touched: this tick ran
    card.regions["bar0"].read(0, 4)
    card.tick(2)
    assert card.quiet_skipped == skipped + 2  # read: the first tick ran, the second is skipped
    assert card.ticks == 10 * 2 + 1 + 1 + 2


def through_the_mapping(scenario: Callable[[DaemonThread, vdevclient.Rack], list[Any]],
                        maxk_decode: str = "arrival") -> None:
    """Run `scenario` (it writes passive memory through the shared mapping) both ways; its
    results must be equal (a card proven at rest reads such memory at its ticks: it must not
    go on skipping past a change, decision 0008 `polled_state`)."""
    runs = []
    for skip in (True, False):
        cfg = rack_config(skip)
        cfg.cards = [replace(s, options={**s.options, "decode": maxk_decode})
                     if s.type == "oms-maxk" else s for s in cfg.cards]
        with DaemonThread(cfg) as d, vdevclient.connect(d.endpoint, d.events, timeout=20) as rack:
            assert rack.shm is not None, "no shared mapping: the test proves nothing"
            runs.append(scenario(d, rack))
    assert runs[0] == runs[1]


def test_pmac_feedback_read_from_dpram_written_through_the_mapping() -> None:
    """Ixx03 at a DPRAM word: motor 1 reads its position from it at every servo cycle [SRM
    Ixx03]; a local client writes it through the mapping while the card rests."""
    def scenario(d: DaemonThread, rack: vdevclient.Rack) -> list[Any]:
        assert pcomm.OpenPmacDevice(0, endpoint=d.endpoint)
        buf = ctypes.create_string_buffer(pcomm.MAX_COMM_BUFFER)
        out: list[Any] = []
        try:
            pcomm.PmacGetResponseA(0, buf, pcomm.MAX_COMM_BUFFER, "I103=$60100")
            rack.sim.step(seconds=0.5)
            dpram = rack.card("pmac0").region("dpram")
            assert dpram.is_mapped(0x400, 4)
            dpram.write32(0x400, 0x1234 << 16)
            rack.sim.step(seconds=0.1)
            pcomm.PmacGetResponseA(0, buf, pcomm.MAX_COMM_BUFFER, "#1P")
            out.append(buf.value)
        finally:
            pcomm.ClosePmacDevice(0)
        return out

    through_the_mapping(scenario)


def test_maxk_decoding_at_the_cycle_reads_its_ring_indices_written_through_the_mapping() -> None:
    """decode = "cycle": the card polls the command ring at every update cycle [S §2.4]; the
    text and the process index are written through the mapping while the card rests."""
    def scenario(d: DaemonThread, rack: vdevclient.Rack) -> list[Any]:
        shm = rack.card("maxk0").region("shm")
        rack.sim.step(seconds=0.5)
        text = b"AX MR5000 GO;"
        start = -len(text) % RING_SIZE  # the insert index of a fresh card is 0
        for i, b in enumerate(text):
            shm.write8(COMMAND_RING + (start + i) % RING_SIZE, b)
        assert shm.is_mapped(COMMAND_PROCESS, 4)
        shm.write32(COMMAND_PROCESS, start)
        rack.sim.step(seconds=1.0)
        with maxk.open(1, endpoint=d.endpoint) as m:
            return [str(m.get_positions())]

    through_the_mapping(scenario, maxk_decode="cycle")


def test_polled_memory_that_changes_and_changes_back_still_ends_a_proven_rest() -> None:
    """A MAXk decoding at the cycle, proven at rest, gets a command through the mapping (no
    touch); within one batch it runs it and its ring indices come back to what they were.
    The card must prove rest again, not go on skipping from the old proof while its servo
    settles (decision 0008 `polled_state`; the bug showed as 4997 for 5000 beside a 200 us
    card, whose ticks cut the batches there)."""
    from vdevd.devices.base import CardContext
    from vdevd.devices.oms.card import MaxkCard

    def run(skip: bool) -> tuple[int, list[int]]:
        card = MaxkCard("maxk0", {"decode": "cycle"}, CardContext(emit=lambda e: None))
        card.skip_quiet = skip
        for _ in range(8):
            card.tick(64)
        text = b"AX MR5000 GO;"
        start = -len(text) % RING_SIZE  # the insert index of a fresh card is 0
        for i, b in enumerate(text):
            card.mem[COMMAND_RING + (start + i) % RING_SIZE] = b
        card.mem[Shm.COMMAND_PROCESS:Shm.COMMAND_PROCESS + 4] = start.to_bytes(4, "big")
        card.tick(204)  # the move runs; the process index is back at the insert index, 0
        quiet = card.quiet_skipped
        card.tick(50)
        settling = card.quiet_skipped - quiet
        for _ in range(20):
            card.tick(64)
        return settling, card.fw.motion.core.axes.encoder.tolist()

    settling, skipped = run(True)
    assert settling == 0  # still moving: every tick ran
    assert skipped == run(False)[1]
    assert skipped[0] == 5000
