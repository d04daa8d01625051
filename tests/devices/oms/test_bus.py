"""The MAXk's host interface (vdevd/devices/oms/rings.py, mu.py, card.py): the command and response
rings with the message semaphore [S §3.4.6-3.4.7; spec oms.md §2.4-2.5], the capture ring
[S §3.7; spec §2.8], the message unit [S §3.4; spec §2.9, §3.2], the direct-command and
position-request mailboxes [S Table 3-1; spec §2.6-2.7] and INTA. Pure functions first, then a
real card on the lockstep clock."""

from __future__ import annotations

import re
import struct
from collections.abc import Iterator

import pytest
import vdevclient
from vdevmaps.oms import CAPTURE_SLOTS, SHM_SIZE, DirectCommand, MaxkDoorbell, Mu, Omisr, Shm

from tests.devices.oms.conftest import RING_SIZE, Maxk, card_config
from vdevd.devices.oms import rings
from vdevd.devices.oms.mu import MessageUnit
from vdevd.testing import DaemonThread

#: "MAXk-8000, Ver: x.xx, S/N: 000001, FPGA:20" [S §2.6; spec §4.2]
WY = re.compile(r"MAXk-([1-9A])000, Ver: \d+\.\d\d, S/N: (\d{6}), FPGA:20")


# -- the rings without I/O ---------------------------------------------------------------------------
def window() -> bytearray:
    return bytearray(SHM_SIZE)


def host_write(buf: bytearray, data: bytes) -> None:
    """[spec §2.4] steps 2-3: the bytes from 0x100 + put (wrapping), then put := the new index."""
    put = rings.u32(buf, Shm.COMMAND_INSERT)
    for c in data:
        buf[Shm.COMMAND_RING + put] = c
        put = (put + 1) % RING_SIZE
    rings.put_u32(buf, Shm.COMMAND_INSERT, put)


def host_read(buf: bytearray) -> bytes:
    """[spec §2.5]: the bytes between 0x0FC and 0x0F8 as one message; then 0x0FC := 0x0F8 and
    the semaphore 0."""
    start, end = rings.u32(buf, Shm.RESPONSE_PROCESS), rings.u32(buf, Shm.RESPONSE_INSERT)
    out = bytes(buf[Shm.RESPONSE_RING + (i % RING_SIZE)]
                for i in range(start, start + (end - start) % RING_SIZE))
    rings.put_u32(buf, Shm.RESPONSE_PROCESS, end)
    rings.put_u32(buf, Shm.MESSAGE_SEMAPHORE, 0)
    return out


def test_take_commands_returns_the_new_bytes_and_catches_up() -> None:
    buf = window()
    assert rings.take_commands(buf) == b""
    host_write(buf, b"AX VL5000;")
    assert rings.take_commands(buf) == b"AX VL5000;"
    assert rings.u32(buf, Shm.COMMAND_PROCESS) == rings.u32(buf, Shm.COMMAND_INSERT) == 10
    assert rings.take_commands(buf) == b""


def test_take_commands_across_the_end_of_the_ring() -> None:
    buf = window()
    rings.put_u32(buf, Shm.COMMAND_INSERT, 1020)
    rings.put_u32(buf, Shm.COMMAND_PROCESS, 1020)
    host_write(buf, b"AX MR100;")
    assert rings.u32(buf, Shm.COMMAND_INSERT) == 5
    assert rings.take_commands(buf) == b"AX MR100;"
    assert rings.u32(buf, Shm.COMMAND_PROCESS) == 5


def test_post_response_writes_text_advances_0x0f8_and_sets_the_semaphore() -> None:
    buf = window()
    assert rings.response_free(buf)
    rings.post_response(buf, b"1000\n")
    assert rings.u32(buf, Shm.RESPONSE_INSERT) == 5
    assert rings.u32(buf, Shm.MESSAGE_SEMAPHORE) == 1
    assert not rings.response_free(buf)
    assert host_read(buf) == b"1000\n"
    assert rings.response_free(buf)


def test_post_response_across_the_end_of_the_ring() -> None:
    buf = window()
    for offset in (Shm.RESPONSE_INSERT, Shm.RESPONSE_PROCESS):
        rings.put_u32(buf, offset, 1019)
    rings.post_response(buf, b"PNNN,PDNN\n")
    assert rings.u32(buf, Shm.RESPONSE_INSERT) == 5
    assert bytes(buf[Shm.RESPONSE_RING + 1019: Shm.RESPONSE_RING + 1024]) == b"PNNN,"
    assert bytes(buf[Shm.RESPONSE_RING: Shm.RESPONSE_RING + 5]) == b"PDNN\n"
    assert host_read(buf) == b"PNNN,PDNN\n"


@pytest.mark.parametrize(("semaphore", "process_caught_up"), [(1, True), (0, False), (1, False)])
def test_response_is_busy_until_both_halves_of_the_release(semaphore: int,
                                                           process_caught_up: bool) -> None:
    """spec §2.5: the next reply waits until the host wrote 0 to 0x094 and 0x0FC == 0x0F8."""
    buf = window()
    rings.post_response(buf, b"0\n")
    rings.put_u32(buf, Shm.MESSAGE_SEMAPHORE, semaphore)
    if process_caught_up:
        rings.put_u32(buf, Shm.RESPONSE_PROCESS, rings.u32(buf, Shm.RESPONSE_INSERT))
    assert not rings.response_free(buf)


def test_overlong_reply_fits_the_ring_with_its_lf() -> None:
    """A reply of 1024 bytes or more would be indistinguishable from none (insert == process):
    it is cut to 1023 bytes ending in LF."""
    buf = window()
    rings.post_response(buf, b"9" * 2000 + b"\n")
    text = host_read(buf)
    assert 0 < len(text) < RING_SIZE and text.endswith(b"\n")


def capture_entry(buf: bytearray, i: int) -> tuple[int, int, int, int, int]:
    """Table 3-5: encoder position (int32, MSB first), axis, home bits, rising, falling."""
    return struct.unpack_from(">iBBHH", buf, Shm.CAPTURE_ENTRIES + 10 * i)


def test_capture_entry_layout() -> None:
    """[S Table 3-5]: 10 bytes, big-endian; the insert index at 0x1540 advances."""
    buf = window()
    rings.push_capture(buf, -123456, axis=2, home_bits=0x01, rising=0x8001, falling=0x0100)
    assert capture_entry(buf, 0) == (-123456, 2, 0x01, 0x8001, 0x0100)
    assert bytes(buf[Shm.CAPTURE_ENTRIES: Shm.CAPTURE_ENTRIES + 4]) == (-123456).to_bytes(
        4, "big", signed=True)
    assert (buf[Shm.CAPTURE_INSERT], buf[Shm.CAPTURE_REMOVAL]) == (1, 0)


def test_capture_ring_wraps_at_55_entries() -> None:
    """[S §3.7]: 55 entries; the insert index goes 54 -> 0."""
    buf = window()
    buf[Shm.CAPTURE_INSERT] = buf[Shm.CAPTURE_REMOVAL] = 54
    rings.push_capture(buf, 7, 0, 0, 0, 0)
    assert capture_entry(buf, 54)[0] == 7
    assert buf[Shm.CAPTURE_INSERT] == 0 and buf[Shm.CAPTURE_REMOVAL] == 54
    rings.push_capture(buf, 8, 1, 0, 0, 0)
    assert capture_entry(buf, 0)[:2] == (8, 1)


def test_capture_overrun_pushes_the_removal_index() -> None:
    """[S §3.7] / spec §2.8: when the insert index reaches the removal index the oldest entry is
    lost (the removal index moves on); 54 entries stay readable."""
    buf = window()
    for i in range(CAPTURE_SLOTS - 1):
        rings.push_capture(buf, i, 0, 0, 0, 0)
    assert (buf[Shm.CAPTURE_INSERT], buf[Shm.CAPTURE_REMOVAL]) == (54, 0)
    rings.push_capture(buf, 54, 0, 0, 0, 0)
    assert (buf[Shm.CAPTURE_INSERT], buf[Shm.CAPTURE_REMOVAL]) == (0, 1)
    rings.push_capture(buf, 55, 0, 0, 0, 0)
    assert (buf[Shm.CAPTURE_INSERT], buf[Shm.CAPTURE_REMOVAL]) == (1, 2)
    removal, insert = buf[Shm.CAPTURE_REMOVAL], buf[Shm.CAPTURE_INSERT]
    readable = [capture_entry(buf, (removal + k) % 55)[0] for k in range((insert - removal) % 55)]
    assert readable == list(range(2, 56))


def test_capture_overrun_with_the_host_part_way() -> None:
    buf = window()
    buf[Shm.CAPTURE_INSERT], buf[Shm.CAPTURE_REMOVAL] = 9, 10  # full: the host's removal index is 10
    rings.push_capture(buf, 1, 0, 0, 0, 0)
    assert (buf[Shm.CAPTURE_INSERT], buf[Shm.CAPTURE_REMOVAL]) == (10, 11)


# -- the message unit without I/O --------------------------------------------------------------------
class Line:
    """The INTA levels a MessageUnit reports."""

    def __init__(self) -> None:
        self.levels: list[bool] = []
        self.inbound: list[int] = []


@pytest.fixture
def line() -> Line:
    return Line()


@pytest.fixture
def mu(line: Line) -> MessageUnit:
    return MessageUnit(on_line=line.levels.append, on_inbound=line.inbound.append)


def test_doorbell_bits_are_cleared_by_writing_ones(mu: MessageUnit) -> None:
    """[S §3.4.1-3.4.4]: "cleared when the host writes ONES"; other bits stay."""
    mu.ring(MaxkDoorbell.DONE_X | 1 << 9 | MaxkDoorbell.COMMAND_ERROR)
    assert mu.read(Mu.ODBR) == MaxkDoorbell.DONE_X | 1 << 9 | MaxkDoorbell.COMMAND_ERROR
    mu.write(Mu.ODBR, MaxkDoorbell.DONE_X | 1 << 20)
    assert mu.read(Mu.ODBR) == 1 << 9 | MaxkDoorbell.COMMAND_ERROR
    mu.write(Mu.ODBR, 0)
    assert mu.read(Mu.ODBR) == 1 << 9 | MaxkDoorbell.COMMAND_ERROR


def test_doorbell_reserved_bits_cannot_be_set(mu: MessageUnit) -> None:
    """spec §3.1: bits 29-31 are reserved on the MPC824x."""
    mu.ring(0xE0000000 | 1 << 26)
    assert mu.read(Mu.ODBR) == 1 << 26


def test_odi_mirrors_the_doorbell_and_is_read_only(mu: MessageUnit) -> None:
    """spec §2.9: OMISR bit 3 = ODBR != 0, a read-only mirror."""
    assert mu.read(Mu.OMISR) & Omisr.ODI == 0
    mu.ring(MaxkDoorbell.COMMAND_ERROR)
    assert mu.read(Mu.OMISR) & Omisr.ODI
    mu.write(Mu.OMISR, Omisr.ODI)
    assert mu.read(Mu.OMISR) & Omisr.ODI
    mu.write(Mu.ODBR, MaxkDoorbell.COMMAND_ERROR)
    assert mu.read(Mu.OMISR) & Omisr.ODI == 0


def test_outbound_messages_latch_om0i_and_om1i_until_cleared(mu: MessageUnit) -> None:
    """spec §2.9: OMR0 written (text reply) -> OM0I, OMR1 (capture, value 2 [S §3.7]) -> OM1I;
    the host clears each by writing a one."""
    mu.message(0, 5)
    mu.message(1, 2)
    assert (mu.read(Mu.OMR0), mu.read(Mu.OMR1)) == (5, 2)
    assert mu.read(Mu.OMISR) == 0b11
    mu.write(Mu.OMISR, Omisr.OM0I)
    assert mu.read(Mu.OMISR) == 0b10
    mu.write(Mu.OMISR, 0b10)
    assert mu.read(Mu.OMISR) == 0


def test_inta_follows_the_unmasked_sources(mu: MessageUnit, line: Line) -> None:
    """spec §3.2: INTA while OMISR & ~OMIMR & 0x2B; OMIMR 1 = masked."""
    mu.message(0, 3)
    assert line.levels == [True]
    mu.write(Mu.OMISR, Omisr.OM0I)
    assert line.levels == [True, False]
    mu.write(Mu.OMIMR, Omisr.OM0I)
    mu.message(0, 3)
    assert line.levels == [True, False]
    mu.write(Mu.OMIMR, 0)
    assert line.levels == [True, False, True]
    mu.write(Mu.OMIMR, Omisr.OM0I)
    assert line.levels == [True, False, True, False]


def test_doorbell_drives_inta_through_odi(mu: MessageUnit, line: Line) -> None:
    mu.write(Mu.OMIMR, Omisr.OM0I)
    mu.ring(MaxkDoorbell.DONE_X)
    mu.ring(MaxkDoorbell.DONE_X << 1)  # already asserted: no second edge
    assert line.levels == [True]
    mu.write(Mu.ODBR, 0b11)
    assert line.levels == [True, False]
    mu.write(Mu.OMIMR, Omisr.ODI)
    mu.ring(MaxkDoorbell.DONE_X)
    assert line.levels == [True, False]
    assert mu.read(Mu.OMIMR) == Omisr.ODI


def test_inbound_doorbell_kicks_the_firmware(mu: MessageUnit, line: Line) -> None:
    """spec §2.9: an IDBR write means "direct command mailbox written" (ASSUMPTION)."""
    mu.write(Mu.IDBR, 1)
    assert line.inbound == [1]


def test_message_unit_reset(mu: MessageUnit) -> None:
    mu.ring(MaxkDoorbell.COMMAND_ERROR)
    mu.message(0, 9)
    mu.write(Mu.OMIMR, 0xFF)
    mu.reset()
    assert [mu.read(r) for r in (Mu.OMISR, Mu.OMIMR, Mu.OMR0, Mu.ODBR)] == [0, 0, 0, 0]


# -- through the card: the text channel -------------------------------------------------------------
def test_wy_identifies_a_maxk_4000(maxk: Maxk) -> None:
    """[S §2.6]; spec §4.2: `MAXk-4000, Ver: x.xx, S/N: nnnnnn, FPGA:20` for 4 axes."""
    match = WY.fullmatch(maxk.query("WY;"))
    assert match is not None
    assert match.group(1) == "4"


def test_wy_of_a_ten_axis_card_with_its_serial() -> None:
    """spec §1.2: the model is MAXk-n000, "A" for 10 axes."""
    with DaemonThread(card_config(axes=10, serial=4711)) as d, \
            vdevclient.connect(d.endpoint, d.events, timeout=10) as rack:
        match = WY.fullmatch(Maxk(rack).query("WY;"))
        assert match is not None
        assert match.groups() == ("A", "004711")


def test_reply_is_text_and_one_lf_with_semaphore_om0i_and_omr0(maxk: Maxk) -> None:
    """spec §2.5: the reply, one LF; the semaphore 1 while posted; OMR0 written (OM0I) with the
    reply's byte count (ASSUMPTION, §2.9)."""
    maxk.send("AA RP;")
    raw = maxk.pending()
    assert raw == b"0,0,0,0\n"
    assert maxk.shm.read32(Shm.MESSAGE_SEMAPHORE) == 1
    assert maxk.mu.read32(Mu.OMISR) & Omisr.OM0I
    assert maxk.mu.read32(Mu.OMR0) == len(raw)
    maxk.release()
    assert maxk.shm.read32(Shm.MESSAGE_SEMAPHORE) == 0
    assert not maxk.mu.read32(Mu.OMISR) & Omisr.OM0I
    assert maxk.pending() == b""


def test_two_queries_in_one_string_give_two_replies_one_at_a_time(maxk: Maxk) -> None:
    """spec §2.5: "the firmware must not post a second reply until the host has released the
    previous one" (EPICS splits `QA EA` for this reason)."""
    maxk.send("AX LP11 AY LP22;")
    maxk.step(2)
    maxk.send("AX RP; AY RP;")
    assert maxk.pending() == b"11\n"
    maxk.step(5)
    assert maxk.pending() == b"11\n", "the second reply came before the release"
    maxk.release()
    assert maxk.pending() == b"22\n"
    assert maxk.shm.read32(Shm.MESSAGE_SEMAPHORE) == 1
    assert maxk.reply() == "22"
    assert maxk.reply() is None


@pytest.mark.parametrize("half", ["process index", "semaphore"])
def test_half_a_release_posts_nothing(maxk: Maxk, half: str) -> None:
    """spec §2.5: the next reply waits for 0x094 := 0 *and* 0x0FC == 0x0F8."""
    maxk.send("WY; #UR?;")
    posted = maxk.shm.read32(Shm.RESPONSE_INSERT)
    if half == "process index":
        maxk.shm.write32(Shm.RESPONSE_PROCESS, posted)
    else:
        maxk.shm.write32(Shm.MESSAGE_SEMAPHORE, 0)
    maxk.step(3)
    assert maxk.shm.read32(Shm.RESPONSE_INSERT) == posted
    maxk.release()
    assert maxk.reply() == "1024"


@pytest.mark.parametrize("decode", ["arrival", "cycle"])
def test_process_index_catches_up_within_one_update_cycle(decode: str) -> None:
    """spec §2.4 step 4: the host waits until 0x0F4 == 0x0F0; the firmware advances it "within one
    update cycle"."""
    with DaemonThread(card_config(decode=decode)) as d, \
            vdevclient.connect(d.endpoint, d.events, timeout=10) as rack:
        maxk = Maxk(rack)
        maxk.send("AX VL5000 AC50000;")
        maxk.step(1)
        assert maxk.shm.read32(Shm.COMMAND_PROCESS) == maxk.shm.read32(Shm.COMMAND_INSERT) == 18
        assert maxk.query("WY;").startswith("MAXk-4000")


def test_command_straddling_the_end_of_the_command_ring(maxk: Maxk) -> None:
    """The ring wraps at 1024 (Table 3-1): `#UR2048;` written across 1023 -> 0 is one command."""
    maxk.send(" " * 1000)
    maxk.send(" " * 20)
    assert maxk.shm.read32(Shm.COMMAND_INSERT) == 1020
    maxk.send("#UR2048;")
    assert maxk.shm.read32(Shm.COMMAND_INSERT) == 4
    maxk.step(1)
    assert maxk.shm.read32(Shm.COMMAND_PROCESS) == 4
    assert maxk.query("#UR?;") == "2048"
    assert not maxk.command_error()


def test_both_rings_wrap_over_many_writes(maxk: Maxk) -> None:
    """Over 1024 bytes of commands and of replies, in 60 writes of 25 bytes (one straddles the
    end of the ring): every WY is answered whole."""
    identity = maxk.query("WY;")
    for i in range(60):
        text = f"AX;AY;AZ;AT;  VL{4000 + i:05d} WY;"[-25:]
        assert maxk.query(text) == identity, f"write {i}"
    assert not maxk.command_error()
    assert maxk.shm.read32(Shm.COMMAND_PROCESS) == maxk.shm.read32(Shm.COMMAND_INSERT) == (
        (3 + 60 * 25) % RING_SIZE)
    assert maxk.shm.read32(Shm.RESPONSE_INSERT) == 61 * (len(identity) + 1) % RING_SIZE


# -- the mailboxes ------------------------------------------------------------------------------------
def test_direct_kill_all_motion(maxk: Maxk) -> None:
    """[S §3.3] "Direct Commands = {Kill all motion}"; spec §2.6: code 2 stops every axis without
    deceleration and flushes the queues; the card writes 0 back."""
    maxk.send("AA VL50000,50000; MR100000,-100000; GO; ID;")
    maxk.step(100)
    assert maxk.query("AA RV;") != "0,0,0,0"
    maxk.shm.write32(Shm.DIRECT_COMMAND, DirectCommand.KILL_ALL_MOTION)
    maxk.step(1)
    assert maxk.shm.read32(Shm.DIRECT_COMMAND) == 0
    stopped = maxk.query("AA RP;")
    assert maxk.query("AA RV;") == "0,0,0,0"
    assert maxk.query("RQC;") == "2559,2559,2559,2559"
    maxk.step(200)
    assert maxk.query("AA RP;") == stopped
    assert maxk.odbr() & 0xFF == 0, "the queued ID was flushed"


def test_direct_controller_id_query_posts_wy(maxk: Maxk) -> None:
    """spec §2.6 code 1 (ASSUMPTION): the WY string goes to the response ring."""
    maxk.shm.write32(Shm.DIRECT_COMMAND, DirectCommand.CONTROLLER_ID_QUERY)
    maxk.step(1)
    assert maxk.shm.read32(Shm.DIRECT_COMMAND) == 0
    reply = maxk.reply()
    assert reply is not None and WY.fullmatch(reply)


def coherent(maxk: Maxk, base: int) -> list[int]:
    return [maxk.word(base + 4 * a) for a in range(4)]


def test_position_request_snapshots_every_axis(maxk: Maxk) -> None:
    """[S Table 3-1] "17 words ... used to capture coherent snapshots of axis position"; spec §2.7:
    motor positions to 0x054.., encoder positions to 0x074.., then 0 to 0x050."""
    maxk.send("AA LP100,-200,300,-400;")
    maxk.step(2)
    maxk.shm.write32(Shm.POSITION_REQUEST, 1)
    maxk.step(1)
    assert maxk.shm.read32(Shm.POSITION_REQUEST) == 0
    assert coherent(maxk, Shm.COHERENT_MOTOR_POSITION) == [100, -200, 300, -400]
    assert coherent(maxk, Shm.COHERENT_ENCODER_POSITION) == [int(v) for v in maxk.query("AA RE;").split(",")]


def test_position_request_while_moving_is_from_one_cycle(maxk: Maxk) -> None:
    """spec §2.7: all from the same cycle; the snapshot equals the live words published with it."""
    maxk.send("AM VL50000,50000,50000,50000; MR100000,-100000,50000,-50000; GO;")
    maxk.step(50)
    maxk.shm.write32(Shm.POSITION_REQUEST, 1)
    while maxk.shm.read32(Shm.POSITION_REQUEST):
        maxk.step(1)
    snap = coherent(maxk, Shm.COHERENT_MOTOR_POSITION)
    assert snap == coherent(maxk, 0x000)
    assert snap[0] == -snap[1] and snap[2] == -snap[3] and snap[0] > 0


# -- INTA ---------------------------------------------------------------------------------------------
@pytest.fixture
def inta(maxk: Maxk) -> Iterator[vdevclient.Irq]:
    """A subscription to the card's published interrupt events."""
    irq = maxk.card.irq.subscribe()
    yield irq
    irq.close()


def next_event(irq: vdevclient.Irq) -> dict[str, object]:
    for event in irq.events(timeout_s=10):  # a guard only: the event was published already
        return event
    raise AssertionError("no interrupt event published")


def irq_seq(maxk: Maxk) -> int:
    return int(maxk.rack.stats()["cards"][maxk.card.name]["irq_seq"])


def test_reply_raises_inta_when_om0i_is_unmasked(maxk: Maxk, inta: vdevclient.Irq) -> None:
    """[S §3.4.7] a reply is notified "using OMR"; spec §3.2: OM0I drives INTA unless masked."""
    assert maxk.mu.read32(Mu.OMIMR) == 0
    maxk.send("WY;")
    event = next_event(inta)
    assert (event["line"], event["card"]) == ("inta", maxk.card.name)
    assert int(event["status"]) & Omisr.OM0I  # type: ignore[call-overload]
    maxk.release()


def test_no_inta_while_om0i_is_masked(maxk: Maxk, inta: vdevclient.Irq) -> None:
    """OMIMR bit 0 set: replies are posted (OM0I still latches) but publish no interrupt; the
    first event seen is the one after unmasking."""
    maxk.mu.write32(Mu.OMIMR, Omisr.OM0I)
    before = irq_seq(maxk)
    for _ in range(3):
        maxk.send("WY;")
        assert maxk.mu.read32(Mu.OMISR) & Omisr.OM0I
        assert maxk.reply() is not None
    assert irq_seq(maxk) == before
    maxk.mu.write32(Mu.OMIMR, 0)
    maxk.send("WY;")
    event = next_event(inta)
    assert event["seq"] == before + 1
    assert int(event["status"]) & Omisr.OM0I  # type: ignore[call-overload]


def test_done_doorbell_raises_inta_through_odi(maxk: Maxk, inta: vdevclient.Irq) -> None:
    """[S §3.4.1]: "The host responds to the door bell interrupt"; ID -> ODBR bit 0 -> ODI."""
    maxk.mu.write32(Mu.OMIMR, Omisr.OM0I)
    maxk.send("AX MR100; GO; ID;")
    maxk.step(100)
    event = next_event(inta)
    assert int(event["status"]) & Omisr.ODI  # type: ignore[call-overload]
    assert maxk.odbr() == MaxkDoorbell.DONE_X
    maxk.clear_odbr(MaxkDoorbell.DONE_X)
    assert not maxk.mu.read32(Mu.OMISR) & Omisr.ODI
