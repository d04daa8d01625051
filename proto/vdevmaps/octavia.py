"""The DSP Control Group PCI Mx4 Octavia host interface: the 8 KiB dual-port RAM map and the
real-time command (RTC) encoding that the daemon's `dspcg-octavia` card and the client's
`vdevclient.mx4` share [Ch6; spec octavia.md §2, §4].

Region `dpr` is the DPR, byte-addressed, multi-byte values little-endian ("LSB to MSB" [Ch6
Real-Time Commands rule 3]). Names follow the manual's tables (6-2 .. 6-11). The RTC table gives
each opcode's argument layout in DPR order [Ch5 listing, Ch6 encoding rules]; `pack`/`unpack`
encode and decode it. Pure constants and functions, nothing imported from the daemon or the
client.
"""

from __future__ import annotations

import enum
import struct
from collections.abc import Mapping, Sequence
from dataclasses import dataclass, field
from typing import Any

CARD_TYPE = "dspcg-octavia"
DPR = "dpr"  # the dual-port RAM, BAR0
DPR_SIZE = 0x2000  # "the 8K DPR" (Table 6-1's "2048 byte" is a manual error, spec Q-2)
MAX_AXES = 8
SAMPLE_NS = 200_000  # the servo and interpolation sample [Ch5 State Variables]
ARG_BYTES = 57  # the RTC argument window 3C3h..3FBh [Ch6 Table 6-8]
RING_SLOTS = 84  # 672 bytes of 8-byte slots [Ch6 Table 6-7]
SLOT_BYTES = 8
STAGING_BYTES = RING_SLOTS * SLOT_BYTES  # the table download area at 120h [Ch5 LOAD_*]
#: the PCI identity: the manual documents none (spec Q-1); assumed (card README): vendor 1234h,
#: device 4D58h ("MX"), class 088000h (system peripheral, other), one 8 KiB memory BAR0
PCI_VENDOR_ID, PCI_DEVICE_ID = 0x1234, 0x4D58
PCI_CLASS_CODE, PCI_REVISION_ID = 0x088000, 0x00
DPR_BAR = 0


class Dpr(enum.IntEnum):
    """Byte offsets of the DPR [Ch6 Tables 6-2 .. 6-11; spec §2.3]."""

    DSPSTAT1 = 0x000  # interrupt types, Table 6-2 (DspStat1)
    INTAXIS_ERRHLT = 0x001  # axis masks: source of each DSPSTAT1 type
    INTAXIS_ERR = 0x002
    INTAXIS_INDEX = 0x003
    INTAXIS_POSBRK = 0x004
    INTAXIS_MOTCP = 0x005
    INTAXIS_PROBE = 0x006  # the EXT input's bit code (spec Q-12)
    INTAXIS_CONFLICT = 0x007
    INTAXIS_IGNORED = 0x008
    DSPSTAT2 = 0x009  # Table 6-2 (DspStat2)
    INTAXIS_ENCFLT = 0x00A
    INTAXIS_OFFSET = 0x00C
    INTAXIS_INP = 0x00D
    INTAXIS_DSPL = 0x00E  # DSPL INT_HOST value
    DSPLERR = 0x00F  # DsplErr bits
    STATUS_END = 0x066  # end of the status block 000h..065h
    DSPLVAR = 0x066  # four 6-byte monitor slots 066h..07Dh [Table 6-3]
    PRG1STAT = 0x07E
    PRG2STAT = 0x080
    PLCSTAT = 0x084
    HW_SIGNATURE = 0x086  # bus, option, revision [Table 6-4]
    VX4_VIEW = 0x08C  # 08Ch..093h, "Vx4++ variable viewing"
    INPUT = 0x094  # IN0..31 after polarity, set = active, 4 bytes
    PRB = 0x0A7  # probe-latched positions, int32 x 4 (bank 2 +800h)
    PARACC = 0x0B7  # PARREAD echo
    PARRDBK = 0x0B8  # PARREAD data, 8 bytes (bank 2 at 8B8h)
    M4ACC_ACTPOS = 0x0C3  # card access flags, one per window (Window)
    M4ACC_ACTVEL = 0x0C4
    M4ACC_ERROR = 0x0C5
    M4ACC_INDPOS = 0x0C6
    M4ACC_ENC = 0x0C7  # 08Ch..093h and 113h..114h
    M4ACC_PRB = 0x0C8
    M4ACC_DSPL = 0x0C9
    HOSTACC_ACTPOS = 0x0CB  # host access flags, same order
    HOSTACC_ACTVEL = 0x0CC
    HOSTACC_ERROR = 0x0CD
    HOSTACC_INDPOS = 0x0CE
    HOSTACC_ENC = 0x0CF
    HOSTACC_PRB = 0x0D0
    HOSTACC_DSPL = 0x0D1
    ACTPOS = 0x0D3  # int32 x 4 (bank 2 +800h)
    ACTVEL = 0x0E3  # int32 x 4, x208 (x204 with Vx4++)
    ERROR = 0x0F3  # following error, int32 x 4
    INDPOS = 0x103  # index-latched positions, int32 x 4
    ENCSTAT = 0x113  # encoder hardware failure, bit k = axis k+1
    SERVOCHK = 0x114  # index seen in the last 5 ms, bit k = axis k+1
    SIGNATURE = 0x115  # 'M' 'X' '4' v1 v1 '+' v2 v2 ['+' vx vx] [Table 6-6]
    RINGBUF = 0x120  # 84 slots of {pos i32, vel i32} [Table 6-7]
    INPTR = 0x3C0  # host: next slot it will write
    OUTPTR = 0x3C1  # card: next slot it will read
    RTC = 0x3C2  # command code; the card clears it when done [Table 6-8]
    ARGMNTS = 0x3C3  # 57 argument bytes
    MINTACC = 0x3FC  # card access flag of 000h..065h and 1FFEh [Table 6-9]
    HOSTACC_INT = 0x3FD  # host access flag of the same [Table 6-11]
    MX4ACC_COUNT = 0x480  # card access flag of 482h..493h (spec Q-24)
    HOSTACC_COUNT = 0x481
    ICUBCOUNT = 0x482  # internal cubic spline index, u16 [Table 6-10]
    CAMCOUNT = 0x484  # u16 x 8, slave axes 1..8
    MX4ACC_ADC = 0x500
    HOSTACC_ADC = 0x501
    ADC = 0x502  # ADC1..4, int16 each
    HOSTINT1 = 0x1FFE  # HostInt bits; the card's write raises the interrupt
    DSPINT = 0x1FFF  # host-to-card interrupt, unused


#: bank 2 (axes 5-8) of the per-axis windows and of PARRDBK [Table 6-10]
BANK2 = 0x800
#: NURBS rings in the staging area [Ch9]: control points (32 x XYZ float32), weights (32),
#: knots (36), and the knot ring's pointers (u16)
NURBS_CTRL, NURBS_WEIGHT, NURBS_KNOT = 0x120, 0x2A0, 0x320
NURBS_INPTR, NURBS_OUTPTR = 0x3B0, 0x3B2
NURBS_CTRL_POINTS, NURBS_KNOTS = 32, 36


def axis_offset(base: int, axis: int) -> int:
    """The address of `axis` (1..8) in a per-axis int32 window at `base` (ACTPOS, ACTVEL, ERROR,
    INDPOS, PRB): base + 4*((axis-1) % 4), +800h for axes 5-8 (spec §2.3.4)."""
    if not 1 <= axis <= MAX_AXES:
        raise ValueError(f"axis {axis} (1..8)")
    return base + 4 * ((axis - 1) % 4) + (BANK2 if axis > 4 else 0)


def slot_offset(slot: int) -> int:
    """The address of ring slot 0..83 [Ch6 Contouring]."""
    return Dpr.RINGBUF + SLOT_BYTES * (slot % RING_SLOTS)


class Window(enum.Enum):
    """The access-byte protected windows [Ch6 Table 6-11]: (card flag, host flag, ranges)."""

    STATUS = (Dpr.MINTACC, Dpr.HOSTACC_INT, ((0x000, 0x066), (0x1FFE, 0x1FFF)))
    VX4 = (Dpr.M4ACC_ENC, Dpr.HOSTACC_ENC, ((0x08C, 0x094), (0x88C, 0x894)))
    ACTPOS = (Dpr.M4ACC_ACTPOS, Dpr.HOSTACC_ACTPOS, ((0x0D3, 0x0E3), (0x8D3, 0x8E3)))
    ACTVEL = (Dpr.M4ACC_ACTVEL, Dpr.HOSTACC_ACTVEL, ((0x0E3, 0x0F3), (0x8E3, 0x8F3)))
    ERROR = (Dpr.M4ACC_ERROR, Dpr.HOSTACC_ERROR, ((0x0F3, 0x103), (0x8F3, 0x903)))
    INDPOS = (Dpr.M4ACC_INDPOS, Dpr.HOSTACC_INDPOS, ((0x103, 0x113), (0x903, 0x913)))
    ENC = (Dpr.M4ACC_ENC, Dpr.HOSTACC_ENC, ((0x113, 0x115),))
    PRB = (Dpr.M4ACC_PRB, Dpr.HOSTACC_PRB, ((0x0A7, 0x0B7), (0x8A7, 0x8B7)))
    DSPL = (Dpr.M4ACC_DSPL, Dpr.HOSTACC_DSPL, ((0x066, 0x086), (0x866, 0x886)))
    COUNTERS = (Dpr.MX4ACC_COUNT, Dpr.HOSTACC_COUNT, ((0x482, 0x494),))
    ADC = (Dpr.MX4ACC_ADC, Dpr.HOSTACC_ADC, ((0x502, 0x50A),))

    @property
    def card_flag(self) -> int:
        return int(self.value[0])

    @property
    def host_flag(self) -> int:
        return int(self.value[1])


class DspStat1(enum.IntFlag):
    """DSPSTAT1 (000h) [Table 6-2]; each type's source mask is at 000h + bit + 1."""

    ERR_HALT = 1 << 0  # following error + halt
    ERR = 1 << 1  # following error
    INDEX = 1 << 2
    POSBRK = 1 << 3  # position breakpoint
    MOTCP = 1 << 4  # motion complete
    PROBE = 1 << 5  # external probe signal
    CONFLICT = 1 << 6  # conflicting commands: the new motion command ignored
    IGNORED = 1 << 7  # RTC ignored: STOP (halt) in progress


class DspStat2(enum.IntFlag):
    """DSPSTAT2 (009h) [Table 6-2]."""

    ENCFLT = 1 << 0  # encoder fault (the EN_ENCFLT text says b4: spec Q-9)
    OFFSET = 1 << 2  # offset cancel finished
    INP = 1 << 3  # input-programmed interrupt
    DSPL_INT = 1 << 4  # DSPL host interrupt
    DSPL_ERR = 1 << 5  # DSPL program running error (00Fh)
    INT5MS = 1 << 6


class DsplErr(enum.IntFlag):
    """DSPLERR (00Fh) [Table 6-2]."""

    TOO_MANY = 1 << 0  # more than 3 programs at once
    NOT_FOUND = 1 << 1  # cannot find the program to stop


class HostInt(enum.IntFlag):
    """HOSTINT1 (1FFEh) [Table 6-9]."""

    BUFBRK = 1 << 0  # buffer breakpoint
    STAT1 = 1 << 1  # see DSPSTAT1
    ESTOP = 1 << 2  # ESTOP detected
    VECCHG_OVERFLOW = 1 << 3  # vector-change buffer overflow
    RESET_DONE = 1 << 4  # reset finished
    RUN_OUT = 1 << 5  # data run-out in the ring buffer
    STAT2 = 1 << 6  # see DSPSTAT2
    NURBS_BUFBRK = 1 << 7  # "unused" in Table 6-9: the NURBS buffer breakpoint (an assumption)


class DisableBit(enum.IntFlag):
    """DISABL_INT (64h) mask bits, one byte per axis [Ch5 DISABL_INT]; DISABL2_INT b0 is the
    encoder fault."""

    BUFBRK = 1 << 0
    ERR_HALT = 1 << 1
    ERR = 1 << 2
    POSBRK = 1 << 3
    PROBE = 1 << 4
    INDEX = 1 << 5
    MOTCP = 1 << 6


RESET_ARGS = b"\xaa\xaa"  # RESET's two signature bytes [Ch5 RESET]
AUTOSTART_ENABLE = 0x55  # DSPL_AUTOSTART x [Ch5 DSPL_AUTOSTART]
LOW_PASS_HZ = (0,) + tuple(50 + 25 * i for i in range(19)) + tuple(550 + 50 * i for i in range(27))
NOTCH_MAX_HZ = 1544
ACTVEL_SCALE = 208  # ACTVEL / 208 = counts per sample (204 with Vx4++) [Table 6-5]


# -- the RTC table -------------------------------------------------------------------------------
@dataclass(frozen=True)
class Rtc:
    """One real-time command's argument layout in DPR order [Ch5 listing; spec §4.2]: `head`
    fields, then one `group` per axis bit set in the field `mask` names (or `count` groups: the
    value of the field `count` names), in increasing axis order. Fields are (name, struct code):
    B/H/I unsigned 8/16/32, h/i signed, f float32, 6s raw bytes."""

    code: int
    name: str
    head: tuple[tuple[str, str], ...] = ()
    group: tuple[tuple[str, str], ...] = ()
    mask: str | None = None
    count: str | None = None
    section: str = ""
    host_only: bool = False
    #: the firmware option that defines it, for the codes several options share (8Eh)
    option: str | None = None
    _head_fmt: str = field(init=False, repr=False, compare=False)
    _group_fmt: str = field(init=False, repr=False, compare=False)
    #: the head's and a group's size and field names (`unpack` runs at every RTC the card takes)
    _head_size: int = field(init=False, repr=False, compare=False)
    _group_size: int = field(init=False, repr=False, compare=False)
    _head_names: tuple[str, ...] = field(init=False, repr=False, compare=False)
    _group_names: tuple[str, ...] = field(init=False, repr=False, compare=False)

    def __post_init__(self) -> None:
        object.__setattr__(self, "_head_fmt", "<" + "".join(c for _, c in self.head))
        object.__setattr__(self, "_group_fmt", "<" + "".join(c for _, c in self.group))
        object.__setattr__(self, "_head_size", struct.calcsize(self._head_fmt))
        object.__setattr__(self, "_group_size", struct.calcsize(self._group_fmt))
        object.__setattr__(self, "_head_names", tuple(n for n, _ in self.head))
        object.__setattr__(self, "_group_names", tuple(n for n, _ in self.group))

    @property
    def head_size(self) -> int:
        return self._head_size

    @property
    def group_size(self) -> int:
        return self._group_size

    def groups(self, head: Mapping[str, int]) -> list[int]:
        """The axes (1..8) the groups belong to, or 1..count for a counted list."""
        if self.mask is not None:
            return list(_MASK_AXES[int(head[self.mask]) & 0xFF])
        if self.count is not None:
            return list(range(1, int(head[self.count]) + 1))
        return []

    def size(self, head: Mapping[str, int]) -> int:
        return self.head_size + len(self.groups(head)) * self.group_size


#: an axis mask -> its axes (1..8, increasing)
_MASK_AXES = [tuple(a + 1 for a in range(8) if m >> a & 1) for m in range(0x100)]


class Truncated(ValueError):
    """The argument bytes end before the layout does."""


def unpack(rtc: Rtc, args: bytes | memoryview) -> tuple[dict[str, Any], list[tuple[int, dict[str, Any]]]]:
    """Decode `args` (the bytes from 3C3h on): the head fields and (axis, group fields) per
    group. Truncated when `args` is too short."""
    hs, size = rtc._head_size, len(args)
    if size < hs:
        raise Truncated(f"{rtc.name}: {size} argument bytes, the head needs {hs}")
    head = dict(zip(rtc._head_names, struct.unpack_from(rtc._head_fmt, args), strict=True))
    axes = rtc.groups(head)
    gs = rtc._group_size
    need = hs + len(axes) * gs
    if size < need:
        raise Truncated(f"{rtc.name}: {size} argument bytes, {len(axes)} groups need {need}")
    names, fmt = rtc._group_names, rtc._group_fmt
    groups = []  # (a loop: the card unpacks every RTC it takes)
    at = hs
    for a in axes:
        groups.append((a, dict(zip(names, struct.unpack_from(fmt, args, at), strict=True))))
        at += gs
    return head, groups


def pack(rtc: Rtc, head: Mapping[str, Any], groups: Sequence[Mapping[str, Any]] = ()) -> bytes:
    """Encode the head fields and one mapping of group fields per group (in axis order)."""
    want = len(rtc.groups(head))
    if len(groups) != want:
        raise ValueError(f"{rtc.name}: {len(groups)} groups for {want} selected")
    out = struct.pack(rtc._head_fmt, *(head[n] for n, _ in rtc.head))
    for g in groups:
        out += struct.pack(rtc._group_fmt, *(g[n] for n, _ in rtc.group))
    return out


_N = (("n", "B"),)
_NM = (("n", "B"), ("m", "B"))
_MOVE = (("acc", "H"), ("pos", "i"), ("vel", "I"))
_MOVE_T = (("acc", "H"), ("pos", "i"), ("tm", "I"))


def _axes(code: int, name: str, group: tuple[tuple[str, str], ...], section: str,
          head: tuple[tuple[str, str], ...] = _N, mask: str = "n") -> Rtc:
    return Rtc(code, name, head, group, mask=mask, section=section)


#: every RTC of the manual [Ch5; spec §4.2], the three 8Eh variants apart (`RTC_8E`); the NURBS
#: RTCs have no code in the manual: vdevd assigns them (card README)
RTCS: tuple[Rtc, ...] = (
    Rtc(0x55, "OUTP_OFF", (("outp1", "H"), ("outp2", "H")), section="Ch5 OUTP_OFF"),
    Rtc(0x56, "OUTP_ON", (("outp1", "H"), ("outp2", "H")), section="Ch5 OUTP_ON"),
    _axes(0x58, "EN_ENCFLT", (("fer", "H"),), "Ch5 EN_ENCFLT", head=(("m", "B"), ("n", "B"))),
    _axes(0x59, "CTRL_KA", (("ka", "H"),), "Ch5 CTRL_KA"),
    _axes(0x5A, "DISABL2_INT", (("mask", "B"),), "Ch5 DISABL2_INT"),
    _axes(0x5B, "TRQ_LIMIT", (("val", "H"),), "Ch5 TRQ_LIMIT"),
    _axes(0x5D, "POS_SHIFT", (("psft", "i"),), "Ch5 POS_SHIFT"),
    Rtc(0x5E, "PARREAD", (("m", "B"),), section="Ch5 PARREAD", host_only=True),
    Rtc(0x5F, "OFFSET", _N, section="Ch5 OFFSET"),
    _axes(0x60, "AXMOVE", _MOVE, "Ch5 AXMOVE"),
    Rtc(0x61, "EN_BUFBRK", (("buffbrk", "B"),), section="Ch5 EN_BUFBRK"),
    _axes(0x62, "CTRL", (("ki", "H"), ("kp", "H"), ("kf", "H"), ("kd", "H")), "Ch5 CTRL"),
    _axes(0x63, "DDAC", (("val", "h"),), "Ch5 DDAC"),
    _axes(0x64, "DISABL_INT", (("mask", "B"),), "Ch5 DISABL_INT"),
    Rtc(0x65, "EN_MOTCP", _N, section="Ch5 EN_MOTCP"),
    _axes(0x66, "EN_ERRHLT", (("fer", "H"),), "Ch5 EN_ERRHLT"),
    _axes(0x67, "EN_ERR", (("fer", "H"),), "Ch5 EN_ERR"),
    _axes(0x68, "POS_PRESET", (("pset", "i"),), "Ch5 POS_PRESET"),
    Rtc(0x69, "EN_INDEX", _N, section="Ch5 EN_INDEX"),
    _axes(0x6B, "EN_POSBRK", (("pos", "i"),), "Ch5 EN_POSBRK"),
    Rtc(0x6C, "EN_PROBE", (("m", "B"),), section="Ch5 EN_PROBE"),
    Rtc(0x6D, "START", _N, section="Ch5 START"),
    Rtc(0x6E, "STOP", _N, section="Ch5 STOP"),
    Rtc(0x6F, "VECCHG", _NM, section="Ch5 VECCHG"),
    _axes(0x70, "VELMODE", (("vel", "i"),), "Ch5 VELMODE"),
    _axes(0x71, "MAXACC", (("acc", "H"),), "Ch5 MAXACC"),
    Rtc(0x72, "RESET", (("sig1", "B"), ("sig2", "B")), section="Ch5 RESET"),
    Rtc(0x73, "BTRATE", (("m", "B"),), section="Ch5 BTRATE"),
    _axes(0x74, "KILIMIT", (("val", "B"),), "Ch5 KILIMIT"),
    _axes(0x75, "REL_AXMOVE_S", _MOVE, "Ch5 REL_AXMOVE_S"),
    _axes(0x78, "REL_AXMOVE_T", _MOVE_T, "Ch5 REL_AXMOVE_T"),
    _axes(0x7D, "POSBRK_OUT", (("on1", "H"), ("on2", "H"), ("off1", "H"), ("off2", "H")),
          "Ch5 POSBRK_OUT"),
    _axes(0x81, "OUTGAIN", (("m", "B"),), "Ch5 OUTGAIN"),
    _axes(0x82, "AXMOVE_S", _MOVE, "Ch5 AXMOVE_S"),
    _axes(0x86, "ESTOP_ACC", (("acc", "H"),), "Ch5 ESTOP_ACC"),
    Rtc(0x87, "SYNC", (("m", "B"),), section="Ch5 SYNC"),
    Rtc(0x8B, "OVERRIDE", (("val", "i"),), section="Ch5 OVERRIDE"),
    Rtc(0x8D, "STEPPER_ON", _N, section="Ch5 STEPPER_ON"),
    _axes(0x8F, "AXMOVE_T", _MOVE_T, "Ch5 AXMOVE_T"),
    Rtc(0x91, "START_DSPL", section="Ch5 START_DSPL", host_only=True),
    Rtc(0x94, "SIGNAL_DSPL", section="Ch5 SIGNAL_DSPL", host_only=True),
    Rtc(0x95, "CLEAR_DSPL", section="Ch5 CLEAR_DSPL", host_only=True),
    Rtc(0x97, "STOP_DSPL", section="Ch5 STOP_DSPL", host_only=True),
    Rtc(0x98, "CLEAR_POS_TABLE", _N, section="Ch5 CLEAR_POS_TABLE", host_only=True),
    Rtc(0x99, "CLEAR_VEL_TABLE", _N, section="Ch5 CLEAR_VEL_TABLE", host_only=True),
    Rtc(0x9A, "LOAD_POS_TABLE", (("table", "B"), ("index", "H"), ("num", "H")),
        section="Ch5 LOAD_POS_TABLE", host_only=True),
    Rtc(0x9B, "LOAD_VEL_TABLE", (("table", "B"), ("index", "H"), ("num", "H")),
        section="Ch5 LOAD_VEL_TABLE", host_only=True),
    _axes(0x9C, "GEAR", (("r", "h"),), "Ch5 GEAR", head=_NM, mask="m"),
    _axes(0x9D, "GEAR_POS", (("r", "h"), ("tp", "i")), "Ch5 GEAR_POS", head=_NM, mask="m"),
    _axes(0x9E, "GEAR_PROBE", (("r", "h"),), "Ch5 GEAR_PROBE",
          head=(("n", "B"), ("m", "B"), ("q", "B")), mask="m"),
    Rtc(0x9F, "GEAR_OFF", _N, section="Ch5 GEAR_OFF"),
    Rtc(0xA0, "GEAR_OFF_ACC", _N, section="Ch5 GEAR_OFF_ACC"),
    Rtc(0xA1, "CUBIC_RATE", (("m", "H"),), section="Ch5 CUBIC_RATE"),
    _axes(0xA2, "TABLE_SEL", (("tb", "B"),), "Ch5 TABLE_SEL"),
    Rtc(0xA3, "DSPL_AUTOSTART", (("x", "B"),), section="Ch5 DSPL_AUTOSTART", host_only=True),
    _axes(0xA4, "CAM", (("tablestart", "H"), ("tablesize", "H")), "Ch5 CAM", head=_NM, mask="m"),
    _axes(0xA5, "CAM_POS", (("masterpos", "i"), ("tablestart", "H"), ("tablesize", "H")),
          "Ch5 CAM_POS", head=_NM, mask="m"),
    _axes(0xA6, "CAM_PROBE", (("tablestart", "H"), ("tablesize", "H")), "Ch5 CAM_PROBE",
          head=(("n", "B"), ("m", "B"), ("q", "B")), mask="m"),
    Rtc(0xA7, "CAM_OFF", _N, section="Ch5 CAM_OFF"),
    Rtc(0xA8, "CAM_OFF_ACC", _N, section="Ch5 CAM_OFF_ACC"),
    Rtc(0xAA, "LOAD_CAM_TABLE", (("index", "H"), ("numpts", "H")), section="Ch5 LOAD_CAM_TABLE",
        host_only=True),
    Rtc(0xAD, "CHANGE_VAR", (("m", "B"),), (("var", "B"), ("value", "6s")), count="m",
        section="Ch5 CHANGE_VAR", host_only=True),
    _axes(0xAE, "REL_AXMOVE_SLAVE", (("acc", "H"), ("rel_pos", "i"), ("rel_vel", "i")),
          "Ch5 REL_AXMOVE_SLAVE"),
    Rtc(0xAF, "LOAD_CUBIC_TABLE", (("index", "H"), ("num", "H")), section="Ch5 LOAD_CUBIC_TABLE",
        host_only=True),
    _axes(0xB0, "CUBIC_SCALE", (("pos_mult", "h"), ("pos_shift", "i")), "Ch5 CUBIC_SCALE"),
    Rtc(0xB1, "CUBIC_INT", (("m", "H"), ("si", "H"), ("n", "H"), ("ax", "B")),
        section="Ch5 CUBIC_INT"),
    Rtc(0xB2, "MONITOR_VAR", (("m", "B"),), (("var", "B"),), mask="m", section="Ch5 MONITOR_VAR"),
    Rtc(0xB3, "CAM_POINT", (("tablestart", "H"), ("tablesize", "H"), ("index", "H"),
                            ("masterpos", "i"), ("slavepos", "i")), section="Ch5 CAM_POINT"),
    Rtc(0xB4, "INP_STATE", (("inp1", "H"), ("inp2", "H")), section="Ch5 INP_STATE"),
    Rtc(0xB6, "CLEAR_CUBIC_TABLE", section="Ch5 CLEAR_CUBIC_TABLE"),
    _axes(0xB7, "REL_AXMOVE", _MOVE, "Ch5 REL_AXMOVE"),
)

#: opcode 8Eh by firmware option [Ch5 INT5MS, NOTCH, LOW_PASS; spec Q-4]
RTC_8E: dict[str, Rtc] = {
    "int5ms": Rtc(0x8E, "INT5MS", (("m", "B"),), section="Ch5 INT5MS", option="int5ms"),
    "notch": Rtc(0x8E, "NOTCH", (("n", "B"), ("freq", "H"), ("q", "B")), section="Ch5 NOTCH",
                 option="notch"),
    "low_pass": Rtc(0x8E, "LOW_PASS", (("n", "B"), ("idx", "B")), section="Ch5 LOW_PASS",
                    option="low_pass"),
}
FIRMWARE_OPTIONS = ("standard", "notch", "low_pass", "int5ms")

#: the three NURBS RTCs, which the manual names without codes or layouts [Ch9; spec Q-27]:
#: vdevd's assumption (the card README), B8h..BAh, the first codes above the documented ones;
#: FeedRate in counts/sample, NURBSRate in ms, the knots' parameter values, IEEE float32
NURBS_RTCS: tuple[Rtc, ...] = (
    Rtc(0xB8, "NURBS", (("feed", "f"), ("rate", "f"), ("first", "f"), ("last", "f"),
                        ("npts", "f")), section="Ch9"),
    Rtc(0xB9, "NURBS_BUFBRK", (("threshold", "B"),), section="Ch9"),
    Rtc(0xBA, "NURBS_FEEDRATE", (("feed", "f"),), section="Ch9"),
)

BY_NAME: dict[str, Rtc] = {r.name: r for r in (*RTCS, *RTC_8E.values(), *NURBS_RTCS)}


def table_for(firmware: str) -> dict[int, Rtc]:
    """The opcodes the card runs with `firmware` (8Eh only in the option defining it)."""
    if firmware not in FIRMWARE_OPTIONS:
        raise ValueError(f"firmware {firmware!r} (one of {', '.join(FIRMWARE_OPTIONS)})")
    table = {r.code: r for r in (*RTCS, *NURBS_RTCS)}
    if firmware in RTC_8E:
        table[0x8E] = RTC_8E[firmware]
    return table


# -- numeric formats [Ch5 State Variables; spec §1.3] ---------------------------------------------
def vel_from_raw(raw: int) -> float:
    """A velocity word: 25-bit two's complement 16.16 (bits 25..31 ignored, spec Q-38), in counts
    per sample."""
    v = raw & 0x1FFFFFF
    if v & 0x1000000:
        v -= 0x2000000
    return v / 65536.0


def acc_from_raw(raw: int) -> float:
    """An acceleration word: unsigned 1.15, counts per sample^2."""
    return (raw & 0xFFFF) / 32768.0
