"""The OMS MAXk host interface: the register maps the daemon's `oms-maxk` card and the client's
`vdevclient.maxk` share [S ch. 3; spec oms.md §2-3].

Region `shm` (BAR2) is the 64 KiB dual-port RAM, 32-bit big-endian words (the PowerPC writes it,
"the host must byte-swap" [S §3.7]): Table 3-1 [S §3.6] as spec §2.2 reconstructs it. Region `mu`
(BAR4) is the MPC8245 message unit, little-endian PCI registers at the MPC824x offsets (spec §2.9,
an assumption: the seed names the registers, not their offsets). Names follow the manual's tables;
pure constants, nothing imported from the daemon or the client.
"""

from __future__ import annotations

import enum

CARD_TYPE = "oms-maxk"
SHM = "shm"  # BAR2, the dual-port RAM [S §3.2]
MU = "mu"  # BAR4, the MPC8245 message unit (spec §2.9)
SHM_SIZE = 0x10000  # "64 Kbytes of shared memory" [S §3.2]
MU_SIZE = 0x1000  # BAR4 (size an assumption, spec §2.1)
AXES = "XYZTUVRSWK"  # canonical axis order [S App C L1340]
MAX_AXES = len(AXES)
RING_SIZE = 1024  # the ASCII command and response rings [S Table 3-1]
MAX_MESSAGE = RING_SIZE - 1  # "drivers reject messages > 1023 bytes" (spec §2.4)
CAPTURE_SLOTS = 55  # entries of the real-time capture ring [S Table 3-5]
CAPTURE_ENTRY_SIZE = 10  # bytes of one entry [S Table 3-6]
CAPTURE_SIZE = 2 + CAPTURE_SLOTS * CAPTURE_ENTRY_SIZE  # from Shm.CAPTURE_INSERT [S Table 3-5]
UPDATE_RATES = (1024, 2048, 4096, 8192)  # Hz, as #UR sets them [S §2.13]
#: the PCI configuration header [S §3.2; spec §2.1]: Motorola's MPC8245 bridge (1057:0006), OMS
#: subsystem vendor 160C, subsystem 0010 + the J5 board number; the shared memory is BAR2 (0x018),
#: the message unit BAR4 (0x020)
PCI_VENDOR_ID, PCI_DEVICE_ID = 0x1057, 0x0006
PCI_SUBSYSTEM_VENDOR_ID, PCI_SUBSYSTEM_BASE = 0x160C, 0x0010
SHM_BAR, MU_BAR = 2, 4
#: neither source gives these (an assumption, the card's README): class 0B2000 (processor,
#: PowerPC: the bridge is the card's PowerPC in agent mode), revision 00
PCI_CLASS_CODE, PCI_REVISION_ID = 0x0B2000, 0x00


class Shm(enum.IntEnum):
    """Byte offsets in the shared memory [S Table 3-1; spec §2.2]; 32-bit big-endian words."""

    MOTOR_POSITION = 0x000  # X..S "axis motor position", int32 each
    ENCODER_POSITION = 0x020  # X..S "axis encoder position"
    LIMIT_SWITCH_STATUS = 0x040  # "Limit Switch status word", Table 3-2: raw input levels
    HOME_SWITCH_STATUS = 0x044  # "Home Switch status word", Table 3-3
    FIRMWARE_STATE = 0x048  # "Firmware State flags", Table 3-4
    DIRECT_COMMAND = 0x04C  # "Direct Command Mail Box" (spec §2.6): the card writes 0 back
    POSITION_REQUEST = 0x050  # "Position Request Mail Box" (spec §2.7): the card writes 0 back
    COHERENT_MOTOR_POSITION = 0x054  # X..S, the snapshot a position request takes
    COHERENT_ENCODER_POSITION = 0x074  # X..S
    MESSAGE_SEMAPHORE = 0x094  # spec §2.5: 1 = a reply is posted; the host writes 0 to release it
    GPIO_STATUS = 0x09C  # "General-purpose I/O bits status", bit n = IOn
    WK_MOTOR_POSITION = 0x0AC  # W, K
    WK_ENCODER_POSITION = 0x0B4  # W, K
    WK_COHERENT_MOTOR_POSITION = 0x0BC  # W, K
    WK_COHERENT_ENCODER_POSITION = 0x0C4  # W, K
    W_STATUS_FLAGS = 0x0CC  # "W axis status flags": ODBR-shaped (AxisFlags), host W1C (spec §3.1)
    K_STATUS_FLAGS = 0x0D0  # "K axis status flags"
    COMMAND_INSERT = 0x0F0  # "ASCII command buffer insert index": host, the text channel's doorbell
    COMMAND_PROCESS = 0x0F4  # "ASCII command buffer process index": firmware
    RESPONSE_INSERT = 0x0F8  # "ASCII response buffer insert index": firmware
    RESPONSE_PROCESS = 0x0FC  # "ASCII response buffer process index": host
    COMMAND_RING = 0x100  # "ASCII command ring buffer", RING_SIZE bytes
    RESPONSE_RING = 0x500  # "ASCII response ring buffer", RING_SIZE bytes
    UTILITY = 0x900  # "Utility transfer buffer"
    CAPTURE_INSERT = 0x1540  # real-time capture: the controller's insert index, one byte [S §3.7]
    CAPTURE_REMOVAL = 0x1541  # the host's removal index, one byte
    CAPTURE_ENTRIES = 0x1542  # CAPTURE_SLOTS entries of CAPTURE_ENTRY_SIZE bytes
    DAC = 0x2E80  # X..S DAC output
    COHERENT_DAC = 0x2EA0  # X..K, the snapshot a position request takes
    WK_DAC = 0x2EC8  # W, K
    SSI_POSITION = 0x3520  # X..K "absolute (SSI) encoder position"


class Mu(enum.IntEnum):
    """Message-unit registers, MPC824x offsets [UB-I2O]; 32-bit little-endian accesses (spec §2.9)."""

    OMISR = 0x030  # outbound message interrupt status
    OMIMR = 0x034  # outbound message interrupt mask
    IMR0 = 0x050  # inbound message registers (stored, unused by the MAXk)
    IMR1 = 0x054
    OMR0 = 0x058  # outbound message 0: a text reply is posted
    OMR1 = 0x05C  # outbound message 1: real-time capture data
    ODBR = 0x060  # outbound doorbell (MaxkDoorbell)
    IDBR = 0x068  # inbound doorbell: a write kicks the direct-command mailbox


class Omisr(enum.IntFlag):
    """Outbound message interrupt status (W1C for OM0I/OM1I); OMIMR has the same bits, 1 = masked
    (spec §2.9)."""

    OM0I = 1 << 0  # OMR0 written: a text reply is posted
    OM1I = 1 << 1  # OMR1 written: real-time capture data
    ODI = 1 << 3  # ODBR != 0 (read-only)


#: the OMISR bits that drive INTA (spec §3.2)
INTA_SOURCES = int(Omisr.OM0I | Omisr.OM1I | Omisr.ODI)
#: the OMR1 value of new capture data: "bit number 1, or hexadecimal value 0x00000002" [S §3.7]
CAPTURE_MESSAGE = 0x00000002


class MaxkDoorbell(enum.IntFlag):
    """Outbound doorbell register (ODBR) [S §3.4.1-3.4.5; spec §3.1]; the host clears bits by
    writing 1s."""

    DONE_X = 1 << 0
    DONE_Y = 1 << 1
    DONE_Z = 1 << 2
    DONE_T = 1 << 3
    DONE_U = 1 << 4
    DONE_V = 1 << 5
    DONE_R = 1 << 6
    DONE_S = 1 << 7
    OVERTRAVEL_X = 1 << 8
    OVERTRAVEL_Y = 1 << 9
    OVERTRAVEL_Z = 1 << 10
    OVERTRAVEL_T = 1 << 11
    OVERTRAVEL_U = 1 << 12
    OVERTRAVEL_V = 1 << 13
    OVERTRAVEL_R = 1 << 14
    OVERTRAVEL_S = 1 << 15
    SLIP_X = 1 << 16
    SLIP_Y = 1 << 17
    SLIP_Z = 1 << 18
    SLIP_T = 1 << 19
    SLIP_U = 1 << 20
    SLIP_V = 1 << 21
    SLIP_R = 1 << 22
    SLIP_S = 1 << 23
    COMMAND_ERROR = 1 << 24
    W_NOTIFICATION = 1 << 25  # details in Shm.W_STATUS_FLAGS
    K_NOTIFICATION = 1 << 26  # details in Shm.K_STATUS_FLAGS


class AxisFlags(enum.IntFlag):
    """The W and K status-flag words: the ODBR layout with the axis in the X slot (spec §3.1, §8
    q.4); an X..S axis's event is this bit shifted by the axis's index in ODBR."""

    DONE = 1 << 0
    OVERTRAVEL = 1 << 8
    SLIP = 1 << 16


class FirmwareState(enum.IntFlag):
    """The firmware state word at Shm.FIRMWARE_STATE [S Table 3-4; spec §2.3]."""

    NOT_DOWNLOADED = 1 << 0
    INITIALIZING = 1 << 1
    RUNNING = 1 << 2
    APPLICATION_CHECKSUM_ERROR = 1 << 8
    APPLICATION_PROGRAMMING_ERROR = 1 << 9
    DEFAULTS_CHECKSUM_ERROR = 1 << 12
    DEFAULTS_PROGRAMMING_ERROR = 1 << 13
    ALTERNATE_CHECKSUM_ERROR = 1 << 14
    ALTERNATE_PROGRAMMING_ERROR = 1 << 15
    POWER_UP_SET = 1 << 16
    ALTERNATE_SET = 1 << 17
    FACTORY_SET = 1 << 18


#: "has not completed power up initialization" [S Table 3-4], read as 0xFFFFFFFF (spec §2.3)
POWERING_UP = 0xFFFFFFFF


class DirectCommand(enum.IntEnum):
    """Codes of the direct-command mailbox Shm.DIRECT_COMMAND [SLAC-MAXv `enum directCommand`;
    spec §2.6]."""

    CONTROLLER_ID_QUERY = 1
    KILL_ALL_MOTION = 2
    RESET_CONTROLLER = 3
    SOFTBOOT_CONTROLLER = 4


class HomeEvent(enum.IntFlag):
    """Byte 5 of a capture entry: what triggered it [S Table 3-6; spec §2.8]."""

    SWITCH_RISING = 0x01  # positive-edge home switch
    ENCODER_HOME = 0x02  # encoder home event
    SWITCH_FALLING = 0x04  # negative-edge home switch
