"""The ADLINK APS library's structures (`type_def.h` [X3], spec adlink.md §2.19, §2.21, §4) as ctypes,
for the AMP-204C / AMP-208C client library.

`type_def.h` is compiled by MSVC with its default packing, so every member sits at its natural
alignment (F64 at 8, even on 32-bit Windows) and ctypes' default layout on a 64-bit host reproduces
it; the offsets are pinned by tests/client/test_aps_defs.py. ADLINK's `I32`/`U32` are Windows
`long`/`unsigned long`, i.e. 32 bits: they map to c_int32/c_uint32, never to c_long (64 bits on Linux).
A `HANDLE` is a pointer (c_void_p). A C NULL pointer argument is None at the call sites.
"""

from __future__ import annotations

import ctypes

from vdevmaps.aps_defs import (
    MAX_PT_DIM,
    MAX_SAMPL_CH,
    MAX_SAMPL_SRC,
    MAXARC2,
    MAXARC3,
    MAXHEXLIX,
    VAO_DATA_MAX_POINTS,
)

# -- the scalar types of type_def.h [X3] -------------------------------------------------------------
I8 = ctypes.c_int8
U8 = ctypes.c_uint8
I16 = ctypes.c_int16
U16 = ctypes.c_uint16
I32 = ctypes.c_int32
U32 = ctypes.c_uint32
F32 = ctypes.c_float
F64 = ctypes.c_double
HANDLE = ctypes.c_void_p


class ASYNCALL(ctypes.Structure):
    """The last argument of the "new interface" motion functions (spec §4): an event the library
    signals and the command's return code."""

    _fields_ = [("h_event", HANDLE), ("i32_ret", I32)]


# -- data sampling (spec §2.19) ----------------------------------------------------------------------
class STR_SAMP_DATA_4CH(ctypes.Structure):
    _fields_ = [("tick", I32), ("data", I32 * 4)]


class STR_SAMP_DATA_8CH(ctypes.Structure):
    _fields_ = [("tick", I32), ("data", I32 * 8)]


class SAMP_PARAM(ctypes.Structure):
    """APS_set_sampling_param_ex: sourceByCh[ch][0] = source (SAMP_*), [ch][1] = axis; an F64 source
    occupies two channels."""

    _fields_ = [
        ("rate", I32),
        ("edge", I32),
        ("level", I32),
        ("trigCh", I32),
        ("sourceByCh", (I32 * MAX_SAMPL_SRC) * MAX_SAMPL_CH),
    ]


# -- CPU load (spec §2.2) ----------------------------------------------------------------------------
class LPSTS(ctypes.Structure):
    _fields_ = [
        ("MotionLoopLoading", U32),
        ("HostLoopLoading", U32),
        ("MotionLoopLoadingMax", U32),
        ("HostLoopLoadingMax", U32),
    ]


# -- VAO (spec §2.17) --------------------------------------------------------------------------------
class VAO_DATA(ctypes.Structure):
    _fields_ = [
        ("outputType", I32),  # [0, 3]
        ("inputType", I32),  # [0, 1]
        ("config", I32),  # PWM configuration for the output type
        ("inputSrc", I32),  # axis bit mask [0, 0xF]
        ("minVel", I32),
        ("velInterval", I32),
        ("totalPoints", I32),  # [1, 32]
        ("mappingDataArr", I32 * VAO_DATA_MAX_POINTS),
    ]


# -- jog (spec §2.8; i16_dir: 0 positive, 1 negative per [X3], see spec Q6) ------------------------------
class JOG_DATA(ctypes.Structure):
    _fields_ = [
        ("i16_jogMode", I16),  # 0 free running, 1 step
        ("i16_dir", I16),
        ("i16_accType", I16),  # 0 T-curve, 1 S-curve
        ("i32_acc", I32),
        ("i32_dec", I32),
        ("i32_maxSpeed", I32),
        ("i32_offset", I32),
        ("i32_delayTime", I32),
    ]


# -- point table (spec §2.21) ------------------------------------------------------------------------
class PTSTS(ctypes.Structure):
    """BitSts: bit 0 working, bit 1 buffer full, bit 2 buffer empty (PTSTS_* in vdevmaps.aps_defs)."""

    _fields_ = [
        ("BitSts", U16),
        ("PntBufFreeSpace", U16),
        ("PntBufUsageSpace", U16),
        ("RunningCnt", U32),
    ]


class PTINFO(ctypes.Structure):
    _fields_ = [("Dimension", I32), ("AxisArr", I32 * MAX_PT_DIM)]


class PTDWL(ctypes.Structure):
    _fields_ = [("DwTime", F64)]  # ms


class PTLINE(ctypes.Structure):
    _fields_ = [("Dim", I32), ("Pos", F64 * MAX_PT_DIM)]


class PTA2CA(ctypes.Structure):
    _fields_ = [("Index", U8 * MAXARC2), ("Center", F64 * MAXARC2), ("Angle", F64)]


class PTA2CE(ctypes.Structure):
    _fields_ = [
        ("Index", U8 * MAXARC2),
        ("Center", F64 * MAXARC2),
        ("End", F64 * MAXARC2),
        ("Dir", I16),
    ]


class PTA3CA(ctypes.Structure):
    _fields_ = [
        ("Index", U8 * MAXARC3),
        ("Center", F64 * MAXARC3),
        ("Normal", F64 * MAXARC3),
        ("Angle", F64),
    ]


class PTA3CE(ctypes.Structure):
    _fields_ = [
        ("Index", U8 * MAXARC3),
        ("Center", F64 * MAXARC3),
        ("End", F64 * MAXARC3),
        ("Dir", I16),
    ]


class PTHCA(ctypes.Structure):
    _fields_ = [
        ("Index", U8 * MAXHEXLIX),
        ("Center", F64 * MAXHEXLIX),
        ("Normal", F64 * MAXHEXLIX),
        ("Angle", F64),
        ("DeltaH", F64),
        ("FinalR", F64),
    ]


class PTHCE(ctypes.Structure):
    _fields_ = [
        ("Index", U8 * MAXHEXLIX),
        ("Center", F64 * MAXHEXLIX),
        ("Normal", F64 * MAXHEXLIX),
        ("End", F64 * MAXHEXLIX),
        ("Dir", I16),
    ]


__all__ = [
    "ASYNCALL",
    "F32",
    "F64",
    "HANDLE",
    "I8",
    "I16",
    "I32",
    "JOG_DATA",
    "LPSTS",
    "PTA2CA",
    "PTA2CE",
    "PTA3CA",
    "PTA3CE",
    "PTDWL",
    "PTHCA",
    "PTHCE",
    "PTINFO",
    "PTLINE",
    "PTSTS",
    "SAMP_PARAM",
    "STR_SAMP_DATA_4CH",
    "STR_SAMP_DATA_8CH",
    "U8",
    "U16",
    "U32",
    "VAO_DATA",
]
