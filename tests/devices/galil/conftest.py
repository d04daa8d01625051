"""Fixtures of the DMC-13X8 acceptance tests: a real daemon (lockstep clock) holding one
`galil-dmc13x8` card, the Galil DMC library opened on it as controller 1, and the A16 window for
the register procedures of manual chapter 4.

`Dmc.cmd` sends a command line through `DMCCommand` and fails the test with the card's TC1 text
when it answers `?`; `Dmc.refused` expects the `?` and returns the TC code.
"""

from __future__ import annotations

import ctypes
import math
from collections.abc import Callable, Iterator
from typing import Any

import pytest
import vdevclient
from vdevclient import galil
from vdevmaps.galil import A16Reg, ControlStatus, SecondaryStatus

from vdevd.config import CardSpec, Config
from vdevd.devices import card_class
from vdevd.testing import DaemonThread

CARD = "galil0"
CARD_TYPE = "galil-dmc13x8"
LOOPBACK = "tcp://127.0.0.1:*"
MS = 1_000_000
TM_S = 0.001  # the default sample time, TM 1000 (us) [M Ch1 Introduction]
#: a command runs when its terminator arrives or at the next sample (the card's `decode` option),
#: motion starts at the sample after BG and a trippoint's reply leaves at the sample its condition
#: holds: a measured duration may exceed the profile's by a few samples
LATENCY_S = 3 * TM_S
#: DMCCommand's reply time-out (simulated ms): long enough for the slowest move here (HM)
TIMEOUT_MS = 20_000

# A16 window, offsets from the base N [M Ch4 §Communication Registers, §Overview of Secondary FIFO]
# (the register map of vdevmaps.galil, the one the daemon and the client use)
DATA = int(A16Reg.DATA)  # READ / WRITE
CONTROL = int(A16Reg.CONTROL)
FIFO2_DATA = int(A16Reg.SECONDARY_DATA)
FIFO2_STATUS = int(A16Reg.SECONDARY_STATUS)
WRITE_ALMOST_FULL = int(ControlStatus.WRITE_ALMOST_FULL)  # CONTROL bit 4 [M Ch4 §Simplified ...]
READ_EMPTY = int(ControlStatus.READ_EMPTY)  # CONTROL bit 5: 0 = data to be read
CLEARED = int(ControlStatus.CLEARED)  # "Read N+3 address (Bit 7 will be 1)" [M Ch4 §Clearing FIFO Buffer]
FIFO2_BUSY = int(SecondaryStatus.BUSY)
FIFO2_FREEZE = int(SecondaryStatus.FREEZE)
FIFO2_NOT_EMPTY = int(SecondaryStatus.NOT_EMPTY)


def card_config(**options: Any) -> Config:
    """One galil-dmc13x8 card `galil0` with its default options (4 axes, TM 1000, servo plant,
    IRQ level 5) unless told, on free loopback ports, lockstep clock."""
    defaults = {key: opt.default for key, opt in card_class(CARD_TYPE).options.items()}
    return Config(endpoint=LOOPBACK, events=LOOPBACK, clock="lockstep",
                  cards=[CardSpec(CARD_TYPE, CARD, {**defaults, **options})])


@pytest.fixture
def galil_daemon() -> Iterator[DaemonThread]:
    with DaemonThread(card_config()) as d:
        yield d


@pytest.fixture
def rack(galil_daemon: DaemonThread) -> Iterator[vdevclient.Rack]:
    """The backdoor (`rack.control`) and the clock (`rack.sim`) of the card's daemon."""
    with vdevclient.connect(galil_daemon.endpoint, galil_daemon.events, timeout=10) as r:
        yield r


@pytest.fixture
def a16(rack: vdevclient.Rack) -> vdevclient.Region:
    """The card's A16 short I/O window, region `a16` (offsets from N)."""
    return rack.card(CARD).region("a16")


# -- the DMC library --------------------------------------------------------------------------------
class Dmc:
    """Controller 1 opened with `DMCOpen`, and the clock of its daemon."""

    def __init__(self, handle: ctypes.c_long, rack: vdevclient.Rack) -> None:
        self.handle = handle
        self.rack = rack
        self._buf = ctypes.create_string_buffer(4096)

    def command(self, text: str | bytes) -> tuple[int, str]:
        """DMCCommand's return code and the reply, as the card sent it."""
        rc = galil.DMCCommand(self.handle, text, self._buf, ctypes.sizeof(self._buf))
        return rc, self._buf.value.decode("latin-1")

    def cmd(self, text: str | bytes) -> str:
        """Send a command line; its data without the final ':' and CR LF. A '?' fails the test
        with the card's reason (TC1)."""
        rc, reply = self.command(text)
        if rc == galil.DMCERROR_COMMAND:
            pytest.fail(f"{text!r} answered {reply!r}: {self.error_text(rc)}")
        assert rc == galil.DMCNOERROR, f"{text!r}: DMCCommand returned {rc}, reply {reply!r}"
        assert reply.endswith(":"), f"{text!r} answered {reply!r}"
        return reply[:-1].strip("\r\n")

    def error_text(self, rc: int) -> str:
        buf = ctypes.create_string_buffer(256)
        galil.DMCError(self.handle, rc, buf, ctypes.sizeof(buf))
        return buf.value.decode("latin-1")

    def refused(self, text: str | bytes) -> int:
        """Send a command the card must refuse: it answers '?'; the TC code (from DMCError)."""
        rc, reply = self.command(text)
        assert rc == galil.DMCERROR_COMMAND, f"{text!r} was accepted: {reply!r}"
        assert reply.endswith("?"), f"{text!r} answered {reply!r}"
        return int(self.error_text(rc).split()[0])

    def binary(self, hex_bytes: str) -> tuple[int, str]:
        """DMCBinaryCommand with the bytes written as in the manual ("A7 02 00 05 ...")."""
        data = bytes.fromhex(hex_bytes)
        rc = galil.DMCBinaryCommand(self.handle, data, len(data), self._buf, ctypes.sizeof(self._buf))
        return rc, self._buf.value.decode("latin-1")

    def values(self, text: str) -> list[float]:
        """The numbers of a report (`TP` -> [0.0, 2000.0, ...])."""
        return [float(v) for v in self.cmd(text).split(",")]

    def value(self, text: str) -> float:
        (v,) = self.values(text)
        return v

    def now_s(self) -> float:
        return self.rack.sim.now_ns() / 1e9

    def timed(self, text: str) -> float:
        """Send a line (e.g. "BGX;AMX") and return the simulated seconds until its reply."""
        start = self.rack.sim.now_ns()
        self.cmd(text)
        return (self.rack.sim.now_ns() - start) / 1e9

    def step(self, seconds: float) -> None:
        self.rack.sim.step(seconds=seconds)

    def record(self) -> bytes:
        """A fresh data record (DMCRefreshDataRecord, then DMCCopyDataRecord)."""
        size = ctypes.c_ushort()
        assert galil.DMCGetDataRecordSize(self.handle, ctypes.byref(size)) == galil.DMCNOERROR
        assert galil.DMCRefreshDataRecord(self.handle, 0) == galil.DMCNOERROR
        buf = (ctypes.c_ubyte * size.value)()
        assert galil.DMCCopyDataRecord(self.handle, buf) == galil.DMCNOERROR
        return bytes(buf)

    def control(self, action: str, **params: Any) -> Any:
        """A backdoor action on the card."""
        return self.rack.control(CARD, action, **params)


OpenDmc = Callable[..., Dmc]


@pytest.fixture
def open_dmc(galil_daemon: DaemonThread, rack: vdevclient.Rack,
             monkeypatch: pytest.MonkeyPatch) -> Iterator[OpenDmc]:
    """`open_dmc(hwnd=0)`: DMCOpen(1, hwnd, &handle) on the daemon at $VDEVD_ENDPOINT."""
    monkeypatch.setenv("VDEVD_ENDPOINT", galil_daemon.endpoint)
    handles: list[ctypes.c_long] = []

    def open_(hwnd: int = 0) -> Dmc:
        handle = ctypes.c_long()
        assert galil.DMCOpen(1, hwnd, ctypes.byref(handle)) == galil.DMCNOERROR
        handles.append(handle)
        assert galil.DMCSetTimeout(handle, TIMEOUT_MS) == galil.DMCNOERROR
        return Dmc(handle, rack)

    yield open_
    for handle in handles:
        galil.DMCClose(handle)


@pytest.fixture
def dmc(open_dmc: OpenDmc) -> Dmc:
    """Controller 1, interrupts not enabled (hwnd 0)."""
    return open_dmc()


# -- the manual's numbers ---------------------------------------------------------------------------
def stored_acc(value: float) -> int:
    """AC/DC as the card keeps them: rounded down to a multiple of 1024 counts/s^2 (spec §1.3)."""
    return int(value) // 1024 * 1024


def stored_speed(value: float) -> int:
    """SP/JG as the card keeps them: even values (resolution 2 counts/s, spec §1.3)."""
    return int(value) // 2 * 2


def move_time(distance: float, speed: float, acc: float, dec: float) -> float:
    """Seconds of a trapezoidal profile (triangular when the distance is too short to reach
    `speed`) [M Ch6 §Independent Axis Positioning]."""
    d = abs(distance)
    ramps = speed**2 / (2 * acc) + speed**2 / (2 * dec)
    if d >= ramps:
        return speed / acc + speed / dec + (d - ramps) / speed
    peak = math.sqrt(2 * d * acc * dec / (acc + dec))
    return peak / acc + peak / dec


def stop_distance(speed: float, dec: float) -> float:
    """Counts travelled while decelerating from `speed` to 0 at `dec`."""
    return speed**2 / (2 * dec)


# -- the register procedures of chapter 4, for tests that talk to the window directly ---------------
def host_send(a16: vdevclient.Region, data: bytes) -> None:
    """[M Ch4 §Write Procedure]: read N+3; while bit 4 is 0 write up to 16 characters to N+1."""
    sent = 0
    while sent < len(data):
        assert not a16.read8(CONTROL) & WRITE_ALMOST_FULL, "the command FIFO stays almost full"
        for b in data[sent:sent + 16]:
            a16.write8(DATA, b)
        sent += 16


def host_receive(a16: vdevclient.Region) -> bytes:
    """[M Ch4 §Read Procedure]: check bit 5 for every character, read N+1 until it signifies empty."""
    out = bytearray()
    while not a16.read8(CONTROL) & READ_EMPTY:
        out.append(a16.read8(DATA))
    return bytes(out)


def host_command(a16: vdevclient.Region, line: bytes, replies: int = 1) -> bytes:
    """Send a command line and read until `replies` ':' or '?' have come (the card answers at the
    sample after the line arrived: wait on bit 5, which lets lockstep time run)."""
    host_send(a16, line)
    got = b""
    while got.count(b":") + got.count(b"?") < replies:
        assert a16.wait_value(CONTROL, 0, mask=READ_EMPTY, size=1, timeout_s=1.0) is not None, \
            f"no reply to {line!r} (so far {got!r})"
        got += host_receive(a16)
    return got
