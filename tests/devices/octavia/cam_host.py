"""A host on an in-process Octavia card, doing by hand what a host driver does through the DPR
[Ch6; spec octavia.md §2.5, §8.1]: post RTCs (poll 3C2h, arguments from 3C3h, code last, wait
for 00h), stage table data at 120h, read the protected windows under their access bytes, and
acknowledge interrupts. Time runs only when the test ticks the card (200 us a tick).
"""

from __future__ import annotations

import struct
from typing import Any

from vdevmaps.octavia import BANK2, Dpr

from vdevd.devices.base import CardContext
from vdevd.devices.octavia.card import OctaviaCard
from vdevd.nvram import NvramStore

CARD = "octavia0"
RTC_TICKS = 50  # a generous bound on one RTC's execution (the card polls every sample)

# RTC codes [Ch5; spec §4.2]
AXMOVE, STOP, VELMODE, MAXACC, RESET = 0x60, 0x6E, 0x70, 0x71, 0x72
EN_MOTCP, EN_PROBE, POS_PRESET, ESTOP_ACC, PARREAD = 0x65, 0x6C, 0x68, 0x86, 0x5E
CAM, CAM_POS, CAM_PROBE, CAM_OFF, CAM_OFF_ACC = 0xA4, 0xA5, 0xA6, 0xA7, 0xA8
CAM_POINT, LOAD_CAM_TABLE = 0xB3, 0xAA
GEAR, GEAR_POS, GEAR_PROBE, GEAR_OFF, GEAR_OFF_ACC = 0x9C, 0x9D, 0x9E, 0x9F, 0xA0
REL_AXMOVE_SLAVE = 0xAE
TABLE_SEL, LOAD_POS_TABLE, LOAD_VEL_TABLE = 0xA2, 0x9A, 0x9B
CLEAR_POS_TABLE, CLEAR_VEL_TABLE = 0x98, 0x99
LOAD_CUBIC_TABLE, CLEAR_CUBIC_TABLE = 0xAF, 0xB6
CHANGE_VAR, MONITOR_VAR = 0xAD, 0xB2
START_DSPL, SIGNAL_DSPL, CLEAR_DSPL, STOP_DSPL, DSPL_AUTOSTART = 0x91, 0x94, 0x95, 0x97, 0xA3


def mask(*axes: int) -> int:
    """The axis byte of axes 1..8 [Ch5 Command Listing Note 2]."""
    return sum(1 << (a - 1) for a in axes)


class Host:
    """One `dspcg-octavia` card (8 axes, ideal plant unless told) and a host on its DPR."""

    def __init__(self, store: NvramStore | None = None, **options: Any) -> None:
        self.card = OctaviaCard(CARD, {"plant": "ideal", **options},
                                CardContext(emit=lambda event: None, nvram=store))
        self.dpr = self.card.dpr

    # -- time and the backdoor ---------------------------------------------------------------
    def tick(self, n: int = 1) -> None:
        done = 0
        while done < n:
            done += self.card.tick(n - done)

    def control(self, action: str, **params: Any) -> Any:
        return self.card.control(action, params)

    def axis(self, axis: int) -> dict[str, Any]:
        return self.control("axis_state", axis=axis)

    # -- RTCs [Ch6 Real-Time Commands] ------------------------------------------------------------
    def rtc(self, code: int, args: bytes = b"") -> None:
        """Post one RTC and wait until the card cleared 3C2h."""
        self.wait(lambda: self.u8(Dpr.RTC) == 0, "3C2h to read 00h before posting")
        if args:
            self.dpr.write(Dpr.ARGMNTS, args)
        self.dpr.write(Dpr.RTC, bytes((code,)))
        self.wait(lambda: self.u8(Dpr.RTC) == 0, f"RTC {code:02X}h to complete")

    def wait(self, done: Any, what: str, ticks: int = RTC_TICKS) -> int:
        for i in range(ticks + 1):
            if done():
                return i
            self.tick()
        raise AssertionError(f"waited {ticks} samples for {what}")

    def stage(self, data: bytes) -> None:
        """Table data at the staging area 120h [Ch5 LOAD_*]."""
        assert len(data) <= 672
        self.dpr.write(Dpr.RINGBUF, data)

    # -- motion helpers (raw argument bytes in DPR order) --------------------------------------------
    def maxacc(self, acc: int, *axes: int) -> None:
        self.rtc(MAXACC, bytes((mask(*axes),)) + struct.pack("<H", acc) * len(axes))

    def axmove(self, axis: int, pos: int, vel: int = 0x20000, acc: int = 0x2000) -> None:
        """AXMOVE of one axis: acc 1.15, target, slew 16.16 (default 2 counts/sample)."""
        self.rtc(AXMOVE, bytes((mask(axis),)) + struct.pack("<HiI", acc, pos, vel))

    def velmode(self, axis: int, vel: int) -> None:
        self.rtc(VELMODE, bytes((mask(axis),)) + struct.pack("<i", vel))

    def settle(self, *axes: int, limit: int = 20000) -> None:
        """Tick until the axes' commands stand still (their moves, stops, catching up are
        over)."""
        before = None
        for _ in range(limit // 10):
            self.tick(10)
            now = [(self.axis(a)["cmd_pos"], self.axis(a)["cmd_vel"]) for a in axes]
            if now == before and all(v == 0 for _, v in now):
                return
            before = now
        raise AssertionError(f"axes {axes} still moving after {limit} samples")

    # -- reading the DPR --------------------------------------------------------------------------
    def u8(self, offset: int) -> int:
        return self.dpr.read(offset, 1)[0]

    def locked(self, host_flag: int, card_flag: int, offset: int, size: int) -> bytes:
        """Read a protected window: host flag 01h, poll the card flag for 00h, read, release
        [Ch6 Communication Protocols Revisited]."""
        self.dpr.write(host_flag, b"\x01")
        self.wait(lambda: self.u8(card_flag) == 0, "the card to release its window")
        data = self.dpr.read(offset, size)
        self.dpr.write(host_flag, b"\x00")
        return data

    def actpos(self, axis: int) -> int:
        """ACTPOS of axis 1..8 under 0CBh/0C3h [Table 6-5]."""
        base = Dpr.ACTPOS + 4 * ((axis - 1) % 4) + (BANK2 if axis > 4 else 0)
        raw = self.locked(Dpr.HOSTACC_ACTPOS, Dpr.M4ACC_ACTPOS, base, 4)
        return int(struct.unpack("<i", raw)[0])

    def camcount(self, axis: int) -> int:
        """CAMCOUNTx (484h + 2(x-1)) under 481h/480h (spec Q-24) [Table 6-10]."""
        raw = self.locked(Dpr.HOSTACC_COUNT, Dpr.MX4ACC_COUNT, Dpr.CAMCOUNT + 2 * (axis - 1), 2)
        return int(struct.unpack("<H", raw)[0])

    def status(self) -> dict[str, int]:
        """1FFEh, then under 3FDh/3FCh the status bytes 000h..00Fh [Ch6 Handling Interrupts]."""
        hostint = self.u8(Dpr.HOSTINT1)
        raw = self.locked(Dpr.HOSTACC_INT, Dpr.MINTACC, Dpr.DSPSTAT1, 16)
        return {"hostint": hostint, "dspstat1": raw[0], "src": raw[1:9].hex(),
                "dspstat2": raw[9], "encflt": raw[10], "dspl_int": raw[14], "dsplerr": raw[15],
                **{f"src{i}": raw[i] for i in range(1, 9)}}

    def ack(self) -> None:
        """Clear every status bit handled (the card never clears them)."""
        self.dpr.write(Dpr.HOSTACC_INT, b"\x01")
        self.wait(lambda: self.u8(Dpr.MINTACC) == 0, "MINTACC")
        self.dpr.write(Dpr.DSPSTAT1, bytes(16))
        self.dpr.write(Dpr.HOSTINT1, b"\x00")
        self.dpr.write(Dpr.HOSTACC_INT, b"\x00")

    def parread(self, m: int) -> bytes:
        """PARREAD [Ch5 PARREAD]: m at 3C3h, 00h at 0B7h, 5Eh at 3C2h, poll 0B7h, read 0B8h.."""
        self.dpr.write(Dpr.PARACC, b"\x00")
        self.rtc(PARREAD, bytes((m,)))
        self.wait(lambda: self.u8(Dpr.PARACC) == m, "the PARREAD echo")
        return self.dpr.read(Dpr.PARRDBK, 8) + self.dpr.read(Dpr.PARRDBK + BANK2, 8)


def cam_points(points: list[tuple[int, int, int]]) -> bytes:
    """LOAD_CAM_TABLE's 10-byte points: master i32, slave i32, ratio i16 (x128)."""
    return b"".join(struct.pack("<iih", m, s, r) for m, s, r in points)


def linear_table(count: int, master_step: int, slave_step: int) -> list[tuple[int, int, int]]:
    """A cam table of `count` points on a straight line, with its ratios (the last one 0)."""
    ratio = round(slave_step * 128 / master_step)
    return [(j * master_step, j * slave_step, ratio if j < count - 1 else 0)
            for j in range(count)]


def load_cam_table(host: Host, index: int, points: list[tuple[int, int, int]]) -> None:
    """Download `points` from table index `index` on, 67 points a LOAD_CAM_TABLE."""
    for first in range(0, len(points), 67):
        chunk = points[first:first + 67]
        host.stage(cam_points(chunk))
        host.rtc(LOAD_CAM_TABLE, struct.pack("<HH", index + first, len(chunk)))
