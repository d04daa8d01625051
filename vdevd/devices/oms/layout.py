"""The MAXk's PCI windows: the shared memory (BAR2) and the message unit (BAR4).

Offsets of the shared memory are Table 3-1 [S §3.6] as reconstructed in spec oms.md §2.2; the
message-unit offsets are those of the MPC824x (spec §2.9, an assumption: the seed names the
registers, not their offsets). Shared memory is big-endian (the PowerPC writes it), the message
unit little-endian (PCI-native registers).
"""

from __future__ import annotations

import enum

import numpy as np

SHM_SIZE = 0x10000  # "64 Kbytes of shared memory" [S §3.2]
MU_SIZE = 0x1000  # BAR4 (size an assumption)
RING_SIZE = 1024  # the ASCII command and response rings [S Table 3-1]
CAPTURE_ENTRIES = 55  # [S Table 3-5]
CAPTURE_ENTRY = 10
AXIS_LETTERS = "XYZTUVRSWK"  # canonical order [S App C]
MAX_AXES = 10
UPDATE_RATES = (1024, 2048, 4096, 8192)  # Hz, as #UR sets them [S §2.13]


class Shm(enum.IntEnum):
    """Byte offsets in the shared window [S Table 3-1; spec §2.2]."""

    MOTOR_POS = 0x000  # X..S, int32 each
    ENCODER_POS = 0x020  # X..S
    LIMITS = 0x040  # Table 3-2: raw input levels
    HOMES = 0x044  # Table 3-3
    FIRMWARE = 0x048  # Table 3-4
    DIRECT_COMMAND = 0x04C
    POSITION_REQUEST = 0x050
    COHERENT_MOTOR = 0x054  # X..S
    COHERENT_ENCODER = 0x074  # X..S
    SEMAPHORE = 0x094  # message semaphore
    GPIO = 0x09C  # bit n = IOn
    MOTOR_POS_WK = 0x0AC  # W, K
    ENCODER_POS_WK = 0x0B4
    COHERENT_MOTOR_WK = 0x0BC
    COHERENT_ENCODER_WK = 0x0C4
    W_FLAGS = 0x0CC  # ODBR-shaped status of W (spec §3.1, assumption)
    K_FLAGS = 0x0D0
    CMD_INSERT = 0x0F0  # host's write index of the command ring
    CMD_PROCESS = 0x0F4  # firmware's read index
    RSP_INSERT = 0x0F8  # firmware's write index of the response ring
    RSP_PROCESS = 0x0FC  # host's read index
    CMD_RING = 0x100
    RSP_RING = 0x500
    UTILITY = 0x900
    CAPTURE = 0x1540  # byte insert index, byte removal index, 55 x 10-byte entries
    DAC = 0x2E80  # X..S
    COHERENT_DAC = 0x2EA0  # X..K
    DAC_WK = 0x2EC8
    SSI = 0x3520  # X..K


class Mu(enum.IntEnum):
    """Message-unit registers of the MPC8245 (spec §2.9)."""

    OMISR = 0x030
    OMIMR = 0x034
    IMR0 = 0x050
    IMR1 = 0x054
    OMR0 = 0x058
    OMR1 = 0x05C
    ODBR = 0x060
    IDBR = 0x068


class Omisr(enum.IntFlag):
    """Outbound message interrupt status [spec §2.9]."""

    OM0I = 1 << 0  # OMR0 written: a text reply is available
    OM1I = 1 << 1  # OMR1 written: real-time capture data
    ODI = 1 << 3  # the outbound doorbell is not zero (read-only)


#: the OMISR bits that drive INTA (spec §3.2)
INTA_SOURCES = int(Omisr.OM0I | Omisr.OM1I | Omisr.ODI)
CAPTURE_MESSAGE = 0x00000002  # OMR1 value "bit number 1" [S §3.7]


class Doorbell:
    """Outbound doorbell bits [S §3.4.1-3.4.5]."""

    DONE = 0  # + axis X..S
    OVERTRAVEL = 8
    SLIP = 16
    COMMAND_ERROR = 1 << 24
    W_NOTIFY = 1 << 25
    K_NOTIFY = 1 << 26


class Firmware(enum.IntFlag):
    """Firmware state flags [S Table 3-4]."""

    NOT_DOWNLOADED = 1 << 0
    INITIALIZING = 1 << 1
    RUNNING = 1 << 2
    FLASH_CHECKSUM = 1 << 8
    FLASH_PROGRAMMING = 1 << 9
    DEFAULTS_CHECKSUM = 1 << 12
    DEFAULTS_PROGRAMMING = 1 << 13
    ALTERNATE_CHECKSUM = 1 << 14
    ALTERNATE_PROGRAMMING = 1 << 15
    POWER_UP_SET = 1 << 16
    ALTERNATE_SET = 1 << 17
    FACTORY_SET = 1 << 18


POWERING_UP = 0xFFFFFFFF  # "has not completed power up initialization" [S Table 3-4]


class DirectCommand(enum.IntEnum):
    """Codes of the direct-command mailbox (SLAC MAXv driver; spec §2.6)."""

    CONTROLLER_ID_QUERY = 1
    KILL_ALL_MOTION = 2
    RESET_CONTROLLER = 3
    SOFTBOOT_CONTROLLER = 4


def _word_index(x_to_s: int, w_k: int) -> np.ndarray:
    """Word indices (offset / 4) of a per-axis field: 8 words from x_to_s, then 2 from w_k."""
    return np.array([x_to_s // 4 + i for i in range(8)] + [w_k // 4, w_k // 4 + 1])


#: per-axis word indices, X..K, into the shared window viewed as big-endian int32
MOTOR_WORDS = _word_index(Shm.MOTOR_POS, Shm.MOTOR_POS_WK)
ENCODER_WORDS = _word_index(Shm.ENCODER_POS, Shm.ENCODER_POS_WK)
COHERENT_MOTOR_WORDS = _word_index(Shm.COHERENT_MOTOR, Shm.COHERENT_MOTOR_WK)
COHERENT_ENCODER_WORDS = _word_index(Shm.COHERENT_ENCODER, Shm.COHERENT_ENCODER_WK)
DAC_WORDS = _word_index(Shm.DAC, Shm.DAC_WK)
COHERENT_DAC_WORDS = np.arange(10) + Shm.COHERENT_DAC // 4
SSI_WORDS = np.arange(10) + Shm.SSI // 4


def limit_word(negative: np.ndarray, positive: np.ndarray) -> int:
    """Table 3-2 from per-axis input levels: X..S negative in bits 0-7, positive in 8-15,
    W/K negative in 16-17, positive in 24-25."""
    word = 0
    for a, (lo, hi) in enumerate(zip(negative.tolist(), positive.tolist(), strict=True)):
        shift = a if a < 8 else a + 8  # W/K: 16, 17
        word |= int(lo) << shift | int(hi) << (shift + 8)
    return word


def home_word(levels: np.ndarray) -> int:
    """Table 3-3: X..S in bits 0-7, W/K in bits 8-9."""
    return sum(int(v) << a for a, v in enumerate(levels.tolist()))
