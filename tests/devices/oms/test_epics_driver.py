"""The oms-maxk card driven byte by byte the way the EPICS MAXv driver drives the shared window
(epics-motor/motorOms drvMAXv.cc: `send_mess`, `recv_mess`, `readbuf`, `motor_init`), with only
single register accesses (`Region.read8/write8/read32/write32`), no batch and no server-side wait.

The MAXv and the MAXk share the ring layout (spec oms.md §2.2); the port to the MAXk is what spec
§2.5 and §3 say: the MAXv's `status1_flag` becomes the message unit's ODBR (done X..S, over-travel,
slip, command error) and its `text_response` bit becomes OMISR bit 0. EPICS sleeps a quantum in
its polling loops; here a quantum is a step of the lockstep clock.
"""

from __future__ import annotations

import re
from collections.abc import Iterator
from dataclasses import dataclass, field

import pytest
import vdevclient
from vdevmaps.oms import FirmwareState, MaxkDoorbell, Mu, Omisr, Shm

from vdevd.config import CardSpec, Config
from vdevd.devices import card_class
from vdevd.testing import DaemonThread

CARD = "maxk0"
AXIS_TYPES = ["servo", "stepper_encoder", "stepper", "stepper"]
LETTERS = "XYZTUVRS"  # MAXv_axis[]
QUANTUM_NS = 10_000_000  # epicsThreadSleepQuantum(), 10 ms
FLUSH = -1
BUFFER_SIZE = 1024

# the driver's own names (drvMAXv.h struct MAXv_motor, the same offsets on the MAXk), so the
# code below reads as drvMAXv.cc; the values come from the card's map
CMD_POS = Shm.MOTOR_POSITION
ENC_POS = Shm.ENCODER_POSITION
FIRMWARE_STATUS = Shm.FIRMWARE_STATE
MSG_SEMAPHORE = Shm.MESSAGE_SEMAPHORE
OUT_PUT_INDEX = Shm.COMMAND_INSERT  # the host's insert index of the command ring
OUT_GET_INDEX = Shm.COMMAND_PROCESS
IN_PUT_INDEX = Shm.RESPONSE_INSERT  # the card's insert index of the response ring
IN_GET_INDEX = Shm.RESPONSE_PROCESS
OUT_BUFFER = Shm.COMMAND_RING
IN_BUFFER = Shm.RESPONSE_RING
RUNNING = FirmwareState.RUNNING  # firmware_status.Bits.running
# message unit (spec §2.9): where the MAXk moved status1_flag and text_response
OMISR = Mu.OMISR
OMIMR = Mu.OMIMR
ODBR = Mu.ODBR
TEXT_RESPONSE = Omisr.OM0I
DONE = 0xFF  # the eight done bits of ODBR
CMND_ERROR = MaxkDoorbell.COMMAND_ERROR

# drvOmsCom.h / drvMAXv.cc command strings
ERROR_CLEAR = "IC"
STOP_ALL = "AA SA"
GET_IDENT = "WY"
ALL_POS = "AA RP"
ENCODER_QUERY = "EA ID"
PID_QUERY = "?KA ID"
AXIS_INFO = "QA"
DONE_QUERY = "RA"


@dataclass
class AxisInfo:
    encoder_present: bool = False
    pid_present: bool = False
    type_id: str = ""  # PSO / PSE / PSM
    ps: str = ""  # what PS? answered (the asyn driver's probe)


@dataclass
class EpicsMaxvDriver:
    """drvMAXv.cc's host side for one card, over the card's `shm` and `mu` regions."""

    rack: vdevclient.Rack
    shm: vdevclient.Region
    mu: vdevclient.Region
    ident: str = ""
    fwver: float = 0.0
    axes: list[AxisInfo] = field(default_factory=list)
    flushed: list[str] = field(default_factory=list)  # what recv_mess(FLUSH) threw away
    acks: int = 0  # polls of the acknowledgement loop in the last send_mess

    def sleep(self) -> None:
        """epicsThreadSleep(quantum)."""
        self.rack.sim.step(ns=QUANTUM_NS)

    def send_mess(self, com: str, name: str | None = None) -> bool:
        if self.shm.read32(IN_GET_INDEX) != self.shm.read32(IN_PUT_INDEX):
            self.recv_mess(FLUSH)  # "see if junk at input port"
        cmndbuf = com if name is None else f"A{name} {com}"
        if not cmndbuf.endswith(";"):
            cmndbuf += ";"  # mod 25: every message ends in ';'
        put = self.shm.read32(OUT_PUT_INDEX)
        for c in cmndbuf.encode():
            self.shm.write8(OUT_BUFFER + put, c)
            put = (put + 1) % BUFFER_SIZE
        self.shm.write32(OUT_PUT_INDEX, put)  # "Message Sent"
        for self.acks in range(1000):  # the acknowledgement: the card took every byte
            if self.shm.read32(OUT_PUT_INDEX) == self.shm.read32(OUT_GET_INDEX):
                return True
            self.sleep()
        return False  # "communication timeout"

    def recv_mess(self, amount: int) -> str | None:
        if amount == FLUSH:
            if self.shm.read32(IN_GET_INDEX) != self.shm.read32(IN_PUT_INDEX):
                self.flushed.append(self.readbuf())
            return ""
        messages = []
        for _ in range(amount):
            waited = 0
            while not self.mu.read32(OMISR) & TEXT_RESPONSE and waited < 100_000_000:
                self.sleep()
                waited += QUANTUM_NS
            if not self.mu.read32(OMISR) & TEXT_RESPONSE:
                return None  # "Timeout occurred in recv_mess"
            messages.append(self.readbuf())
        return ",".join(messages)  # LF of all but the last replaced by ','

    def readbuf(self) -> str:
        """Copy process..insert as one message, LF -> NUL, then release the card's semaphore."""
        get, put = self.shm.read32(IN_GET_INDEX), self.shm.read32(IN_PUT_INDEX)
        if get < put:
            data = self.memcpy(IN_BUFFER + get, put - get)
        elif get == put:
            return ""  # "MAXv DPRAM input buffer empty"
        else:  # the message wraps around the end of the buffer
            data = self.memcpy(IN_BUFFER + get, BUFFER_SIZE - get)
            if put:
                data += self.memcpy(IN_BUFFER, put)
        assert data.endswith(b"\n"), data
        self.shm.write32(IN_GET_INDEX, put)
        self.mu.write32(OMISR, TEXT_RESPONSE)  # status1_flag written back: clear the notice
        self.shm.write32(MSG_SEMAPHORE, 0)
        return data[:-1].decode("latin-1")

    def memcpy(self, offset: int, size: int) -> bytes:
        """A copy out of the window: a block read, or bytes where 2 or 4 would be one
        misaligned access."""
        if size in (2, 4) and offset % size:
            return bytes(self.shm.read8(offset + i) for i in range(size))
        return self.shm.read(offset, size)

    def send_recv_mess(self, command: str, axis: str | None = None, n: int = 1) -> str | None:
        self.send_mess(command, axis)
        return self.recv_mess(n)

    def probe(self, command: str, a: int) -> bool:
        """`EA ID` / `?KA ID`: wait for the done flag ID sets, then a command error means the
        query was refused; else read its reply (motor_init). Waits for this axis's own done bit
        and clears the flags it read in both cases (the MAXv's readbuf cleared them all)."""
        self.send_mess(command, LETTERS[a])
        for _ in range(100):
            if self.mu.read32(ODBR) & (1 << a):
                break
            self.sleep()
        flags = self.mu.read32(ODBR)
        assert flags & (1 << a), f"{command} on axis {a}: no done flag"
        self.mu.write32(ODBR, flags)  # clear the command error (and the done flag)
        if flags & CMND_ERROR:
            return False
        assert self.recv_mess(1)
        return True

    def motor_init(self) -> None:
        status = self.shm.read32(FIRMWARE_STATUS)
        if not status & RUNNING:
            raise RuntimeError(f"MAXv card is NOT running, status = {status:#x}")
        self.mu.write32(ODBR, 0xFFFF_FFFF)  # status1_flag.All = 0xFFFFFFFF
        self.mu.write32(OMIMR, 0x0000_000B)  # disable all interrupts
        self.send_mess(ERROR_CLEAR)
        self.send_mess(STOP_ALL)
        ident = self.send_recv_mess(GET_IDENT)
        if ident is None:
            raise RuntimeError("MAXv card not responding to commands")
        self.ident = ident
        self.fwver = float(re.match(r"\s*([0-9.]+)", ident.split(":", 1)[1]).group(1))  # type: ignore[union-attr]
        if self.fwver >= 1.33:
            assert self.send_recv_mess("#WS") == "=0"  # the watchdog timeout counter
        axis_pos = self.send_recv_mess(ALL_POS)
        assert axis_pos is not None
        self.axes = [AxisInfo() for _ in axis_pos.split(",")]
        for a, info in enumerate(self.axes):
            info.encoder_present = self.probe(ENCODER_QUERY, a)
            info.pid_present = self.probe(PID_QUERY, a)
            info.type_id = "PSM" if info.pid_present else "PSE" if info.encoder_present else "PSO"
            info.ps = self.send_recv_mess("PS?", LETTERS[a]) or ""
            if self.fwver >= 1.30 and self.send_recv_mess("LM?", LETTERS[a]) == "=f":
                self.send_mess("LMH", LETTERS[a])  # limit mode off: set it to hard
        for a in range(len(self.axes)):
            self.send_recv_mess(DONE_QUERY, LETTERS[a])

    def wait_done(self, a: int, quanta: int = 1000) -> bool:
        """What motorIsr and the poller see: the axis's done bit in the doorbell."""
        for _ in range(quanta):
            if self.mu.read32(ODBR) & (1 << a):
                self.mu.write32(ODBR, 1 << a)
                return True
            self.sleep()
        return False

    def position(self, a: int) -> tuple[int, int]:
        """pmotor->cmndPos[a], pmotor->encPos[a]."""
        def s32(v: int) -> int:
            return v - (1 << 32) if v & 0x8000_0000 else v

        return s32(self.shm.read32(CMD_POS + 4 * a)), s32(self.shm.read32(ENC_POS + 4 * a))


@pytest.fixture
def daemon() -> Iterator[DaemonThread]:
    options = {key: opt.default for key, opt in card_class("oms-maxk").options.items()}
    options.update(board=1, axes=4, axis_types=AXIS_TYPES, plant="ideal")
    cfg = Config(endpoint="tcp://127.0.0.1:*", events="tcp://127.0.0.1:*", clock="lockstep",
                 cards=[CardSpec("oms-maxk", CARD, options)])
    with DaemonThread(cfg) as d:
        yield d


@pytest.fixture
def driver(daemon: DaemonThread) -> Iterator[EpicsMaxvDriver]:
    with vdevclient.connect(daemon.endpoint, daemon.events, timeout=10) as rack:
        card = rack.card(CARD)
        yield EpicsMaxvDriver(rack, card.region("shm"), card.region("mu"))


@pytest.fixture
def ready(driver: EpicsMaxvDriver) -> EpicsMaxvDriver:
    driver.motor_init()
    return driver


def test_motor_init_counts_the_axes_and_tells_the_motor_types(ready: EpicsMaxvDriver) -> None:
    assert ready.ident.startswith("MAXk-4000, Ver: ")
    assert ready.fwver >= 1.33
    assert len(ready.axes) == 4  # the fields of AA RP
    assert [info.type_id for info in ready.axes] == ["PSM", "PSE", "PSO", "PSO"]
    assert [info.ps for info in ready.axes] == ["=M", "=E", "=O", "=O"]
    assert ready.flushed == []  # every reply was read by its own recv_mess


def test_send_mess_fills_the_ring_byte_by_byte_and_the_card_acknowledges_at_once(
        driver: EpicsMaxvDriver) -> None:
    before = driver.shm.read32(OUT_PUT_INDEX)
    assert driver.send_mess("VL5000", "X")
    assert driver.acks == 0  # the card consumed the bytes on the index write
    assert driver.shm.read(OUT_BUFFER + before, 10) == b"AX VL5000;"
    assert driver.shm.read32(OUT_GET_INDEX) == before + 10


def test_a_move_sets_its_done_flag_and_rp_reads_the_target(ready: EpicsMaxvDriver) -> None:
    ready.send_mess("VB100 VL4000 AC19500 MA5100 GD ID", "Y")  # the mod-25 example string
    assert not ready.wait_done(1, quanta=10)  # 1.3 s of motion: not yet
    assert ready.wait_done(1)
    assert ready.send_recv_mess("RP", "Y") == "5100"
    assert ready.position(1) == (5100, 5100)  # a stepper with encoder, ideal plant
    qa = ready.send_recv_mess(AXIS_INFO, "Y")
    assert qa is not None and len(qa) == 4 and qa[1] == "D"  # struct axis_status
    ea = ready.send_recv_mess("EA", "Y")
    assert ea is not None and len(ea) == 5  # struct encoder_status
    assert ready.send_recv_mess("RV", "Y") == "0"
    assert ready.send_recv_mess(DONE_QUERY, "Y") == qa  # RA reports, then clears done
    assert ready.send_recv_mess(AXIS_INFO, "Y")[1] == "N"  # type: ignore[index]


def test_a_command_error_sets_odbr_bit_24_and_posts_no_reply(ready: EpicsMaxvDriver) -> None:
    replies = ready.shm.read32(IN_PUT_INDEX)
    ready.send_mess("XYZZY")
    assert ready.mu.read32(ODBR) & CMND_ERROR
    assert not ready.mu.read32(OMISR) & TEXT_RESPONSE
    assert ready.shm.read32(IN_PUT_INDEX) == replies
    assert ready.recv_mess(1) is None  # recv_mess times out after 0.1 s
    flags = ready.mu.read32(ODBR)  # motorIsr: report "Command Error", release the IRQ
    ready.mu.write32(ODBR, flags)
    assert ready.mu.read32(ODBR) == 0
    assert ready.send_recv_mess("RP", "X") == "0"


def test_a_reply_left_unread_is_flushed_by_the_next_send_mess(ready: EpicsMaxvDriver) -> None:
    ready.send_mess(GET_IDENT)  # its reply is not read
    assert ready.send_recv_mess("RP", "Z") == "0"
    assert len(ready.flushed) == 1 and ready.flushed[0].startswith("MAXk-4000")


def test_both_rings_wrap_byte_by_byte(ready: EpicsMaxvDriver) -> None:
    start = ready.shm.read32(OUT_PUT_INDEX)
    for _ in range(110):  # 110 x "AX VL5000;" = 1100 bytes
        assert ready.send_mess("VL5000", "X")
    assert ready.shm.read32(OUT_PUT_INDEX) == (start + 1100) % BUFFER_SIZE
    for _ in range(200):  # "=M\n": 600 bytes, past the end of the response ring
        assert ready.send_recv_mess("PS?", "X") == "=M"
    assert ready.send_recv_mess(ALL_POS) == "0,0,0,0"
