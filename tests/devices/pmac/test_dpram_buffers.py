"""The DPRAM real-time (servo) and background fixed data buffers in the Turbo layout, switched on by
I47-I50 as a user does it (README "Reporting buffers"; PComm32 dprrtdbt.h `realtTURBO`, dprbkg.h
`backgTURBO`; EPICS tpmac drvPmac.c): records at the documented addresses, the I47/I50 rate,
the host-busy / data-ready handshake, and the PComm readers against `#nP`, `#n?`, `???`."""

from __future__ import annotations

import struct
from collections.abc import Iterator

import pytest
import vdevclient
from vdevclient import pcomm
from vdevmaps.pmac import (
    BG_CS,
    BG_CS_COUNT,
    BG_HOST_BUSY,
    BG_READY,
    BG_STATUS,
    BG_TIMER,
    READY,
    RT_HOST_BUSY,
    RT_MASK,
    RT_MOTORS,
    RT_READY,
    RT_TIMER,
)

from tests.devices.pmac.conftest import Pmac
from tests.devices.pmac.test_acceptance import pmac_pcomm

DEVICE = 0
SCALE = 96 * 32  # Ixx08 * 32, factory
JOG_PER_CYCLE = 32 * 3713707 / 8388608  # Ixx22 = 32 counts/ms at the factory servo period


@pytest.fixture
def card() -> Iterator[Pmac]:
    """A card of its own (plant `ideal`: actual = commanded) opened by PComm as device 0."""
    with pmac_pcomm() as host:
        yield host


def pc(line: str) -> list[str]:
    rc = pcomm.PmacGetResponseA(DEVICE, None, 0, line)
    assert pcomm.IS_COMM_EOT(rc), (line, rc.text)
    return rc.text.split("\r")[:-1]


def words(status: str) -> tuple[int, ...]:
    return tuple(int(status[k:k + 6], 16) for k in range(0, len(status), 6))


def timer(dpram: vdevclient.Region, at: int) -> tuple[int, bool]:
    """The 24-bit servo timer at `at` (Y word, X bits 0-7) and the data-ready bit (X bit 15)."""
    low, high = struct.unpack("<HH", dpram.read(at, 4))
    return low | (high & 0xFF) << 16, bool(high & READY)


def record(dpram: vdevclient.Region, motor: int) -> tuple[int, ...]:
    return struct.unpack("<12i", dpram.read(RT_MOTORS + 48 * (motor - 1), 48))


def join48(low: int, high: int) -> int:
    return high * (1 << 24) + (low & 0xFFFFFF)


def next_sample(card: Pmac, dpram: vdevclient.Region, ready_at: int, limit: int = 1000) -> int:
    """Request a sample (clear data ready) and step one servo cycle at a time until it is posted;
    the servo timer it carries."""
    dpram.write16(ready_at, 0)
    for _ in range(limit):
        card.step(1)
        cycle, ready = timer(dpram, ready_at - 2)
        if ready:
            return cycle
    raise AssertionError("no sample")


# -- real-time buffer -------------------------------------------------------------------------------
def test_realtime_samples_come_every_i47_servo_cycles_when_the_host_clears_data_ready(card: Pmac) -> None:
    dpram = card.card.region("dpram")
    dpram.write(RT_MASK, struct.pack("<I", 0b10))  # motor 2 only
    pc("I47=5 I48=1")
    cycles = [next_sample(card, dpram, RT_READY) for _ in range(4)]
    assert [b - a for a, b in zip(cycles, cycles[1:], strict=False)] == [5, 5, 5]
    assert all(c % 5 == 0 for c in cycles)


def test_a_jogging_motor_moves_by_its_jog_speed_times_i47_between_samples(card: Pmac) -> None:
    dpram = card.card.region("dpram")
    dpram.write(RT_MASK, struct.pack("<I", 0b10))
    pc("#2J+")
    card.step_ms(3000)  # past the acceleration: 32 cts/ms at Ixx19 = 0.015625 cts/ms^2 takes 2 s
    pc("I47=8 I48=1")
    first = next_sample(card, dpram, RT_READY)
    pos1 = join48(*record(dpram, 2)[10:12])
    second = next_sample(card, dpram, RT_READY)
    pos2 = join48(*record(dpram, 2)[10:12])
    assert second - first == 8
    assert (pos2 - pos1) / SCALE == pytest.approx(8 * JOG_PER_CYCLE, abs=1)  # whole encoder counts
    assert record(dpram, 1) == (0,) * 12  # not in the mask: never written


def test_a_motor_record_holds_status_position_error_and_velocity_as_the_card_reports_them(
        card: Pmac) -> None:
    dpram = card.card.region("dpram")
    dpram.write(RT_MASK, struct.pack("<I", 0b100))  # motor 3
    pc("#3J=1234")
    card.step_ms(3000)
    pc("I47=1 I48=1")
    next_sample(card, dpram, RT_READY)
    rec = record(dpram, 3)
    w1, w2 = words(pc("#3?")[0])
    assert (rec[3] & 0xFFFFFF, rec[4] & 0xFFFFFF) == (w1, w2)
    assert rec[3] < 0  # word 1 bit 23 (activated): 24-bit words are sign-extended [UM p.402]
    assert join48(rec[10], rec[11]) / SCALE == float(pc("#3P")[0]) == 1234
    assert join48(rec[0], rec[1]) == 0 and float(pc("#3F")[0]) == 0  # following error
    assert join48(rec[5], rec[6]) == 0 and rec[7] == 0  # position bias, filtered velocity
    assert rec[8:10] == (0, 0)  # spares


def test_no_new_sample_while_data_ready_is_set_or_the_host_is_busy(card: Pmac) -> None:
    dpram = card.card.region("dpram")
    dpram.write(RT_MASK, struct.pack("<I", 1))
    pc("I47=2 I48=1")
    held = next_sample(card, dpram, RT_READY)
    card.step(20)
    assert timer(dpram, RT_TIMER) == (held, True)  # the sample stays until the host takes it
    dpram.write16(RT_HOST_BUSY, READY)  # host busy, X:$06001A bit 15
    dpram.write16(RT_READY, 0)
    card.step(20)
    assert timer(dpram, RT_TIMER) == (held, False)
    dpram.write16(RT_HOST_BUSY, 0)
    card.step(2)
    later, ready = timer(dpram, RT_TIMER)
    assert ready and later > held + 20 and later % 2 == 0


def test_i48_0_stops_the_samples(card: Pmac) -> None:
    dpram = card.card.region("dpram")
    pc("I47=1 I48=1")
    held = next_sample(card, dpram, RT_READY)
    pc("I48=0")
    dpram.write16(RT_READY, 0)
    card.step(10)
    assert timer(dpram, RT_TIMER) == (held, False)


# -- background buffer ----------------------------------------------------------------------------------
def test_background_gives_global_and_the_requested_coordinate_systems_every_i49_cycles(
        card: Pmac) -> None:
    dpram = card.card.region("dpram")
    card.control("set_phase_clock_error", active=True)
    dpram.write16(BG_CS_COUNT, 2)
    pc("&2%25 I50=3 I49=1")
    cycles = [next_sample(card, dpram, BG_READY) for _ in range(3)]
    assert [b - a for a, b in zip(cycles, cycles[1:], strict=False)] == [3, 3]
    y_word, x_word = struct.unpack("<ii", dpram.read(BG_STATUS, 8))
    first, second = words(pc("???")[0])
    assert (x_word & 0xFFFFFF, y_word & 0xFFFFFF) == (first, second) and first & 1 << 3
    for cs in (1, 2):
        rec = struct.unpack("<32i", dpram.read(BG_CS + 128 * (cs - 1), 128))
        w1, w2, w3 = words(pc(f"&{cs}??")[0])
        assert (rec[5] & 0xFFFFFF, rec[24] & 0xFFFFFF, rec[4] & 0xFFFFFF) == (w1, w2, w3)
        assert rec[2] == round(3713707 * (0.25 if cs == 2 else 1.0))  # time base, I10 units
    assert dpram.read(BG_CS + 128 * 2, 128) == bytes(128)  # C.S. 3: not requested


def test_background_waits_for_the_host_like_the_real_time_buffer(card: Pmac) -> None:
    dpram = card.card.region("dpram")
    pc("I50=1 I49=1")
    held = next_sample(card, dpram, BG_READY)
    dpram.write16(BG_HOST_BUSY, READY)
    dpram.write16(BG_READY, 0)
    card.step(10)
    assert timer(dpram, BG_TIMER) == (held, False)
    dpram.write16(BG_HOST_BUSY, 0)
    card.step(1)
    assert timer(dpram, BG_TIMER)[1]


# -- PComm readers ----------------------------------------------------------------------------------------
def test_pcomm_realtime_readers_give_what_p_f_v_and_status_give(card: Pmac) -> None:
    assert pcomm.PmacDPRRealTimeEx(DEVICE, 0b101, 1, 1)  # motors 1 and 3
    assert struct.unpack("<I", card.card.region("dpram").read(RT_MASK, 4))[0] == 0b101
    pc("#3J+")
    card.step_ms(3000)  # at speed
    jogging = pcomm.PmacDPRGetVel(DEVICE, 3, 1.0)
    assert jogging == pytest.approx(float(pc("#3V")[0]), abs=0.05 + 1 / SCALE)
    pc("#3J/")
    card.step_ms(3000)  # stopped
    assert pcomm.PmacDPRPosition(DEVICE, 3, 1.0) == float(pc("#3P")[0]) > 0
    assert pcomm.PmacDPRPosition(DEVICE, 3, 0.5) == float(pc("#3P")[0]) / 2
    # F rounds to 1/32 count [SRM]; the buffer has the register's 1/(Ixx08*32)
    assert pcomm.PmacDPRFollowError(DEVICE, 3, 1.0) == pytest.approx(float(pc("#3F")[0]), abs=1 / 64)
    assert pcomm.PmacDPRMotorServoStatusTurbo(DEVICE, 3) == words(pc("#3?")[0])[0]
    assert pcomm.PmacDPRPosition(DEVICE, 2, 1.0) == 0.0  # not in the mask
    assert pcomm.PmacDPRRealTimeEx(DEVICE, 0b101, 1, 0)


def test_pcomm_data_ready_bit_follows_the_card(card: Pmac) -> None:
    assert pcomm.PmacDPRRealTimeEx(DEVICE, 1, 4, 1)
    card.step(4)
    assert pcomm.PmacDPRGetDataReadyBit(DEVICE) == 1
    pcomm.PmacDPRResetDataReadyBit(DEVICE)
    assert pcomm.PmacDPRGetDataReadyBit(DEVICE) == 0
    card.step(4)
    assert pcomm.PmacDPRGetDataReadyBit(DEVICE) == 1


def test_pcomm_global_status_is_the_dpram_order_of_the_triple_question_mark_words(card: Pmac) -> None:
    card.control("set_phase_clock_error", active=True)
    assert pcomm.PmacDPRBackgroundEx(DEVICE, 1, 2, 4)
    assert card.card.region("dpram").read16(BG_CS_COUNT) == 4
    first, second = words(pc("???")[0])
    assert pcomm.PmacDPRGetGlobalStatus(DEVICE) == (second, first)
    assert pcomm.PmacDPRBackgroundEx(DEVICE, 0, 2, 4)
