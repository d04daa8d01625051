"""The ADLINK AMP-204C/208C host interface of vdevd: BAR0's layout (a kernel-command mailbox and
a status block) and the encoding of the kernel commands, shared by the daemon's `adlink-amp20xc`
card and the client's `vdevclient.aps`.

The manual documents no registers: the APS library talks to the DSP's motion kernel [M ch. 4].
This interface is vdevd's own (card README "Host interface"), built so that an APS call is one
round trip: the library writes a command's code and arguments into the mailbox and rings the
doorbell with a sequence number; the kernel runs the command at once (its host communication
[M §4.1.2.3]) and leaves the sequence number, the call's return code and its reply values in the
acknowledgement, which the library reads in the same batch. The status block holds what the
status calls read (motion status and motion I/O words, positions, counters, velocities, stop
codes, queue usage, DI/DO, trigger counts, interrupt flags), refreshed every motion cycle and
after every command, so a status call is one register read. Little-endian, like the PCI bus.

Arguments and replies are little-endian fields in the order of the command's `args`/`reply`
spec: `i` I32, `d` F64, `i*` and `d*` arrays (a U32 count, then the values), `b*` bytes (a U32
count, then the bytes). Pure constants and functions, nothing imported from either side.
"""

from __future__ import annotations

import enum
import struct
from collections.abc import Iterable, Sequence
from dataclasses import dataclass
from typing import Any

CARD_TYPE = "adlink-amp20xc"
BAR = "bar0"
BAR_SIZE = 0x4000
MAGIC = 0x4B4C4441  # "ADLK" little-endian
LAYOUT_VERSION = 1
MODELS = {"AMP-204C": 4, "AMP-208C": 8}
MAX_AXES = 8
#: the PCI identity: ADLINK's vendor ID 144Ah; the device IDs are vdevd's (README "PCI identity")
PCI_VENDOR_ID = 0x144A
PCI_DEVICE_IDS = {"AMP-204C": 0x7204, "AMP-208C": 0x7208}
PCI_CLASS_CODE, PCI_REVISION_ID = 0x118000, 0x00  # signal processing controller, other
#: the motion cycles the card offers [M §1.1 "500 us, 1 ms, 2 ms"]
CYCLES_US = (500, 1000, 2000)
INT_ITEMS = 11  # items 0-7 axes, 8 system, 9 DI rising, 10 DI falling [M §4.11]
INT_PER_BOARD = 352  # Int_No = board * 352 + item * 32 + factor (spec §2.23)
PT_TABLES = 2
TRG_CHANNELS = 4


class Bar(enum.IntEnum):
    """Byte offsets of BAR0 (vdevd's layout, card README "Host interface")."""

    # identity
    MAGIC = 0x000  # U32 "ADLK"
    LAYOUT = 0x004  # U32 layout version
    MODEL = 0x008  # U32 204h / 208h
    AXES = 0x00C  # U32 4 / 8
    CARD_ID = 0x010  # U32 the DIP switch 0-15 [M §2.6.1]
    CYCLE_US = 0x014  # U32 the motion cycle
    CYCLE_COUNT = 0x018  # U32 motion cycles since power-up (wraps)
    # card status
    EMG = 0x020  # U32 bit 0: EMG active (after PRB_EMG_LOGIC)
    DI = 0x024  # U32 the DI word: bits 0-7 EDI, 8-23 TDI (after PRB_DI_LOGIC)
    DO = 0x028  # U32 the DO word as written (bits 0-7 EDO, 8-23 TDO)
    INT_MAIN = 0x02C  # U32 the interrupt main switch (APS_int_enable)
    TIMER = 0x030  # I32 timer 0 counter
    OVER_CYCLES = 0x034  # U32 over-cycle count
    LOAD = 0x038  # U32 x 4 LPSTS: motion, host, motion max, host max (0.01 %)
    TRG_COUNT = 0x048  # U32 x 4 pulses output on TRG0-3
    INT_ENABLE = 0x060  # U32 x 11: the factors enabled per item
    INT_SIGNAL = 0x090  # U32 x 11: the factors signaled per item (until APS_reset_int)
    PT_STATUS = 0x0C0  # 2 x 16: PTSTS {U16 BitSts, Free, Usage, pad; U32 RunningCnt} + U32
    SAMP_STATUS = 0x0F0  # U32 the sampling state (SampState bits)
    SAMP_COUNT = 0x0F4  # U32 records held: of the capture, or not yet read in auto sampling
    # the mailbox
    DOORBELL = 0x100  # U32 (hook): the host writes its sequence number; the kernel runs the command
    CODE = 0x108  # U32 the command's code (CODE and LENGTH: one aligned 8-byte field)
    LENGTH = 0x10C  # U32 the argument bytes
    ARGS = 0x110  # the arguments, up to ARGS_END
    ARGS_END = 0x1000
    ACK_SEQ = 0x1000  # U32 the sequence number of the last command run
    ACK_RC = 0x1004  # I32 its return code
    ACK_LENGTH = 0x1008  # U32 the reply bytes
    ACK_CODE = 0x100C  # U32 its code
    REPLY = 0x1010  # the reply values, up to REPLY_END
    REPLY_END = 0x2000
    AXIS = 0x2000  # AXIS_STRIDE bytes per axis (Axis)
    AXIS_END = 0x2400


class SampState(enum.IntFlag):
    """Bits of Bar.SAMP_STATUS (vdevd's; spec §2.19, Q28)."""

    ARMED = 0x01  # a trigger capture runs (APS_wait_trigger_sampling)
    TRIGGERED = 0x02  # its trigger came
    DONE = 0x04  # it holds its Length records
    AUTO = 0x08  # APS_auto_sampling runs
    LOST = 0x10  # auto sampling overwrote records not yet read (the ring is full)


#: records the card's sampling ring holds (a capture's Length at most)
SAMP_RING = 65536
#: I32 words of one record: tick + 8 channels
SAMP_WORDS = 9


ARGS_MAX = Bar.ARGS_END - Bar.ARGS
REPLY_MAX = Bar.REPLY_END - Bar.REPLY


def samp_records_per_reply(channels: int) -> int:
    """Sampling records (tick + `channels` I32) one mailbox reply carries, after an I32 status
    and an array's count."""
    return (REPLY_MAX - 8) // 4 // (1 + channels)

AXIS_STRIDE = 0x80
ACK_BYTES = Bar.REPLY - Bar.ACK_SEQ


class Axis(enum.IntEnum):
    """Offsets inside an axis's status record (Bar.AXIS + axis * AXIS_STRIDE)."""

    MSTS = 0x00  # I32 the motion status word [M §4.8.1]
    MIO = 0x04  # I32 the motion I/O word [M §4.1.1.4]
    STOP_CODE = 0x08  # I32 the last stop's code [M §4.10]
    CMD_COUNTER = 0x0C  # I32 the command (pulse) counter [M §4.2.1]
    ENCODER = 0x10  # I32 the encoder counter
    MQ_USAGE = 0x14  # I32 motion-queue entries used (of 10) [M §4.6.4]
    GEAR = 0x18  # I32 gear status: 0 off, 1 standard, 2 gantry [M §4.9.1]
    SERVO = 0x1C  # I32 SVON as commanded
    CMD_POS = 0x20  # F64 command position, user units
    FBK_POS = 0x28  # F64 feedback position
    TARGET = 0x30  # F64 target position
    ERR_POS = 0x38  # F64 command - feedback
    CMD_VEL = 0x40  # F64 command velocity, user units/s
    FBK_VEL = 0x48  # F64 feedback velocity


def axis_offset(axis: int, field: Axis) -> int:
    return Bar.AXIS + axis * AXIS_STRIDE + field


# -- the kernel commands ----------------------------------------------------------------------

_SCALAR = {"i": struct.Struct("<i"), "d": struct.Struct("<d")}
_COUNT = struct.Struct("<I")


class CodecError(ValueError):
    """Arguments that do not match a command's spec (the kernel answers -10)."""


def encode(spec: Sequence[str], values: Sequence[Any]) -> bytes:
    """Fields in spec order: scalars packed, arrays and bytes count-prefixed."""
    if len(spec) != len(values):
        raise CodecError(f"{len(values)} values for {len(spec)} fields")
    out = bytearray()
    for kind, value in zip(spec, values, strict=True):
        if kind in _SCALAR:
            out += _SCALAR[kind].pack(value)
        elif kind == "b*":
            data = bytes(value)
            out += _COUNT.pack(len(data)) + data
        else:
            items = list(value)
            out += _COUNT.pack(len(items))
            out += struct.pack(f"<{len(items)}{kind[0]}", *items)
    return bytes(out)


def decode(spec: Sequence[str], data: bytes | memoryview) -> list[Any]:
    """The inverse of `encode`; CodecError when the bytes do not fit the spec exactly."""
    values: list[Any] = []
    pos, end = 0, len(data)
    try:
        for kind in spec:
            if kind in _SCALAR:
                s = _SCALAR[kind]
                values.append(s.unpack_from(data, pos)[0])
                pos += s.size
                continue
            (count,) = _COUNT.unpack_from(data, pos)
            pos += 4
            if kind == "b*":
                if pos + count > end:
                    raise CodecError("bytes past the end")
                values.append(bytes(data[pos:pos + count]))
                pos += count
                continue
            width = 4 if kind == "i*" else 8
            if pos + count * width > end:
                raise CodecError("array past the end")
            values.append(list(struct.unpack_from(f"<{count}{kind[0]}", data, pos)))
            pos += count * width
    except struct.error as exc:
        raise CodecError(str(exc)) from None
    if pos != end:
        raise CodecError(f"{end - pos} bytes beyond the fields")
    return values


@dataclass(frozen=True, slots=True)
class Call:
    """A kernel command: its code, argument and reply specs, and the manual section."""

    code: int
    name: str
    args: tuple[str, ...] = ()
    reply: tuple[str, ...] = ()
    section: str = ""


#: profile fields of the per-command variants (NaN: the axis parameter) [M §4.6.1]
PROFILE = ("d", "d", "d", "d", "d", "d")  # Vs, Vm, Ve, Acc, Dec, SFac


def _calls(entries: Iterable[tuple[int, str, str, str, str]]) -> tuple[Call, ...]:
    return tuple(Call(code, name, tuple(args.split()), tuple(reply.split()), section)
                 for code, name, args, reply, section in entries)


#: every kernel command (code, name, args, reply, manual section); the APS functions map onto them
CALLS: tuple[Call, ...] = _calls([
    # system and parameters [M §4.1]
    (0x01, "reset", "", "", "vdevd: power-up state"),
    (0x02, "set_board_param", "i i", "", "M 4.9.3.6"),
    (0x03, "get_board_param", "i", "i", "M 4.9.3.6"),
    (0x04, "set_axis_param", "i i i", "", "M 4.1.1.3"),
    (0x05, "get_axis_param", "i i", "i", "M 4.1.1.3"),
    (0x06, "set_axis_param_f", "i i d", "", "M 4.4"),
    (0x07, "get_axis_param_f", "i i", "d", "M 4.4"),
    (0x08, "save_parameter_to_flash", "", "", "X1"),
    (0x09, "load_parameter_from_flash", "", "", "X1"),
    (0x0A, "load_parameter_from_default", "", "", "X1"),
    (0x0B, "get_timing", "i", "i", "M 4.1.2"),
    (0x0C, "reset_timing", "i", "", "M 4.1.2"),
    (0x0D, "get_axis_param_table", "i", "i* d*", "X1 APS_save_param_to_file"),
    (0x0E, "get_board_param_table", "", "i* d*", "X1 APS_save_param_to_file"),
    # position, counters, servo [M §4.2.1, §4.1.1.4]
    (0x10, "set_servo_on", "i i", "", "M 4.1.1.4"),
    (0x11, "set_command_f", "i d", "", "M 4.2.1"),
    (0x12, "set_position_f", "i d", "", "M 4.2.1"),
    # single-axis motion [M §4.3-4.6]
    (0x20, "ptp", "i i d d d d d d d", "", "M 4.6.1"),  # axis, option, pos, PROFILE
    (0x21, "vel", "i i d d d d d d", "", "M 4.4"),  # axis, option, Vm (signed), Vs, Ve, Acc, Dec, SF
    (0x22, "stop_move", "i*", "", "M 4.4"),
    (0x23, "emg_stop", "i*", "", "M 4.4"),
    (0x24, "move_trigger", "i*", "", "M 4.9.5"),
    (0x25, "home_move", "i", "", "M 4.3"),
    (0x26, "jog_start", "i i", "", "M 4.5"),
    (0x27, "ptp_counts", "i i d d", "", "M 4.6.1"),  # axis, relative, counts, counts/s
    (0x28, "velocity_counts", "i d", "", "M 4.4"),
    # interpolation 0x30-0x4F [M §4.7]
    # dimension, axes, option, positions, TransPara, PROFILE
    (0x30, "line", "i i* i d* d d d d d d d", "", "M 4.7.1"),
    # axes, option, centre, angle, TransPara, PROFILE
    (0x31, "arc2_ca", "i* i d* d d d d d d d d", "", "M 4.7.2.2"),
    # axes, option, centre, end, Dir, TransPara, PROFILE
    (0x32, "arc2_ce", "i* i d* d* i d d d d d d d", "", "M 4.7.2.2"),
    # axes, option, centre, normal, angle, TransPara, PROFILE
    (0x33, "arc3_ca", "i* i d* d* d d d d d d d d", "", "M 4.7.2.1"),
    # axes, option, centre, end, Dir, TransPara, PROFILE
    (0x34, "arc3_ce", "i* i d* d* i d d d d d d d", "", "M 4.7.2.1"),
    # axes, option, centre, normal, angle, DeltaH, FinalR, TransPara, PROFILE
    (0x35, "spiral_ca", "i* i d* d* d d d d d d d d d d", "", "M 4.7.2.3"),
    # axes, option, centre, normal, end, Dir, TransPara, PROFILE
    (0x36, "spiral_ce", "i* i d* d* d* i d d d d d d d", "", "M 4.7.2.3"),
    # dimension, axes, relative, pulses, pulses/s (APS_absolute/relative_linear_move)
    (0x37, "linear_counts", "i i* i i* d", "", "M 4.7.1"),
    # -- end of interpolation
    # gearing and gantry 0x50-0x57 [M §4.9.1]
    (0x50, "start_gear", "i i", "", "M 4.9.1"),  # slave, mode 0 off / 1 standard / 2 gantry
    # -- end of gearing
    # compare trigger and timer 0x60-0x7F [M §4.9.2]
    (0x60, "set_trigger_param", "i i", "", "M 4.9.2"),
    (0x61, "get_trigger_param", "i", "i", "M 4.9.2"),
    (0x62, "set_trigger_manual", "i", "", "M 4.9.2.1"),  # TRG channels as a bit mask
    (0x63, "set_trigger_linear", "i i i i", "", "M 4.9.2.2.1"),  # LCmpCh, start, repeat, interval
    # TCmpCh, flags (1 first part: a new table, 2 last part: arm it), points (spec §2.16)
    (0x64, "set_trigger_table", "i i i*", "", "M 4.9.2.2.2"),
    (0x65, "get_trigger_linear_cmp", "i", "i", "X1"),
    (0x66, "get_trigger_table_cmp", "i", "i", "X1"),
    (0x67, "get_trigger_count", "i", "i", "X1"),
    (0x68, "reset_trigger_count", "i", "", "X1"),
    (0x69, "enable_trigger_fifo_cmp", "i i", "", "X1"),
    (0x6A, "get_trigger_fifo_status", "i", "i", "X1"),
    (0x6B, "set_trigger_fifo_data", "i i i*", "", "X1"),  # FCmpCh, ShiftFlag, points
    (0x6C, "get_timer_counter", "i", "i", "M 4.9.2"),
    (0x6D, "set_timer_counter", "i i", "", "M 4.9.2"),
    (0x6E, "start_timer", "i i", "", "X1"),
    # -- end of trigger
    # PWM and VAO 0x80-0x8F [M §4.9.3]
    (0x80, "set_vao_param", "i i", "", "M 4.9.3.5"),
    (0x81, "get_vao_param", "i", "i", "M 4.9.3.5"),
    (0x82, "set_vao_table", "i i i i*", "", "M 4.9.3.7"),  # table, MinVelocity, VelInterval, data
    (0x83, "switch_vao_table", "i", "", "M 4.9.3.7"),
    (0x84, "start_vao", "i i", "", "M 4.9.3.4"),  # Output_Ch bit mask (spec Q17), Enable
    (0x85, "get_vao_status", "", "i", "X1"),
    (0x86, "check_vao_param", "i", "i", "X1"),
    # table, output type, input type, config, source mask, MinVelocity, VelInterval, data
    (0x87, "set_vao_param_ex", "i i i i i i i i*", "", "X1"),
    (0x88, "get_vao_param_ex", "i", "i i i i i i i*", "X1"),
    (0x89, "set_pwm_frequency", "i i", "", "X5"),
    (0x8A, "get_pwm_frequency", "i", "i", "X5"),
    (0x8B, "set_pwm_width", "i i", "", "X5"),
    (0x8C, "get_pwm_width", "i", "i", "X5"),
    (0x8D, "set_pwm_on", "i i", "", "X5"),
    # -- end of PWM/VAO
    # digital I/O 0x90-0x97 (spec §2.18)
    (0x90, "read_d_input", "i", "i", "spec 2.18"),
    (0x91, "write_d_output", "i i", "", "spec 2.18"),
    (0x92, "read_d_output", "i", "i", "spec 2.18"),
    (0x93, "write_d_channel_output", "i i i", "", "spec 2.18"),
    (0x94, "read_d_channel_output", "i i", "i", "spec 2.18"),
    # -- end of digital I/O
    # interrupts 0x98-0x9F [M §4.11]
    (0x98, "int_enable", "i", "", "M 4.11"),  # main switch
    (0x99, "set_int_factor", "i i i", "", "M 4.11"),  # item, factor, enable
    (0x9A, "get_int_factor", "i i", "i", "M 4.11"),
    (0x9B, "reset_int", "i i", "", "M 4.11"),  # item, factor
    (0x9C, "set_int", "i i", "", "M 4.11"),
    # -- end of interrupts
    # data sampling 0xA0-0xAF [M §4.9.4]
    (0xA0, "set_sampling_param", "i i", "", "M 4.9.4"),  # ParaNum, ParaDat
    (0xA1, "get_sampling_param", "i", "i", "M 4.9.4"),
    (0xA2, "set_sampling_param_ex", "i i i i i*", "", "X3"),  # rate, edge, level, trigCh, 8x2
    (0xA3, "get_sampling_param_ex", "", "i i i i i*", "X3"),
    (0xA4, "start_trigger_sampling", "i i", "", "X1"),  # Length, PreTrgLen
    (0xA5, "stop_sampling", "", "", "X1"),
    (0xA6, "auto_sampling", "i", "", "X1"),  # StartStop
    (0xA7, "read_sampling", "i i i", "i*", "X1"),  # first record, count, channels: records
    (0xA8, "take_sampling", "i i", "i i*", "X1"),  # count, channels: status, records
    # -- end of sampling
    # point table 0xB0-0xCF [M §4.9.6]
    (0xB0, "pt_enable", "i i*", "", "M 4.9.6.2"),  # ptb, axes
    (0xB1, "pt_disable", "i", "", "M 4.9.6.2"),
    (0xB2, "pt_get_info", "i", "i i*", "X1"),  # -> dimension, axes
    (0xB3, "pt_start", "i", "", "M 4.9.6.2"),
    (0xB4, "pt_stop", "i", "", "M 4.9.6.2"),
    (0xB5, "pt_set_relative", "i i", "", "M 4.9.6.1"),  # ptb, 0 absolute / 1 relative
    (0xB6, "pt_set_profile", "i i d", "", "M 4.9.6.1"),  # ptb, PRA_VS/VM/VE/ACC/DEC/SF, value
    (0xB7, "pt_set_acc_dec", "i d", "", "M 4.9.6.1"),
    (0xB8, "pt_get_profile", "i i", "d", "X1"),  # ptb, PRA_* -> value
    (0xB9, "pt_set_trans", "i i d", "", "M 4.9.6.1"),  # ptb, ITP_OPT_BUFFERED/BLEND_*, Bp
    (0xBA, "pt_set_trans_inp", "i", "", "M 4.9.6.1"),
    (0xBB, "pt_ext_set_do_ch", "i i i", "", "M 4.9.6.1"),  # ptb, channel, OnOff
    (0xBC, "pt_ext_set_table_no", "i i i", "", "M 4.9.6.1"),  # ptb, CtrlNo, TableNo
    # the pushes answer the table's PTSTS: BitSts, free, usage, RunningCnt
    (0xBD, "pt_line", "i i d*", "i i i i", "M 4.9.6.1"),  # ptb, Dim, Pos
    (0xBE, "pt_arc2_ca", "i i* d*", "i i i i", "M 4.9.6.1"),  # ptb, Index, Center Angle
    (0xBF, "pt_arc2_ce", "i i* d* i", "i i i i", "M 4.9.6.1"),  # ptb, Index, Center End, Dir
    (0xC0, "pt_arc3_ca", "i i* d*", "i i i i", "M 4.9.6.1"),  # Center Normal Angle
    (0xC1, "pt_arc3_ce", "i i* d* i", "i i i i", "M 4.9.6.1"),  # Center End, Dir
    (0xC2, "pt_spiral_ca", "i i* d*", "i i i i", "M 4.9.6.1"),  # Center Normal Angle DeltaH FinalR
    (0xC3, "pt_spiral_ce", "i i* d* i", "i i i i", "M 4.9.6.1"),  # Center Normal End, Dir
    (0xC4, "pt_dwell", "i d", "i i i i", "M 4.9.6.1"),  # ptb, DwTime ms
    (0xC5, "reset_pt_buffer", "i", "", "X1"),
    (0xC6, "pt_roll_back", "i d", "", "X1"),  # ptb, Max_Speed
    (0xC7, "pt_get_error", "i", "i", "X1"),
    # -- end of point table
    # safety and watchdog 0xD0-0xDF [M §4.10]
    (0xD0, "wdt_start", "i i", "", "M 4.10.2.3"),  # timer, timeout ms
    (0xD1, "wdt_get_timeout_period", "i", "i", "M 4.10.2.3"),
    (0xD2, "wdt_reset_counter", "i", "", "M 4.10.2.3"),
    (0xD3, "wdt_get_counter", "i", "i", "X1"),
    (0xD4, "wdt_set_action_event", "i i", "", "M 4.10.2.3"),
    (0xD5, "wdt_get_action_event", "i", "i", "M 4.10.2.3"),
    # -- end of safety
])

BY_NAME: dict[str, Call] = {c.name: c for c in CALLS}
BY_CODE: dict[int, Call] = {c.code: c for c in CALLS}
assert len(BY_NAME) == len(BY_CODE) == len(CALLS), "kernel command codes and names are unique"
