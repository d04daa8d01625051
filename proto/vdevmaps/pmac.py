"""The Turbo PMAC's bus maps: the DPRAM (ASCII handshake, reporting buffers) and the PCI host port
with its interrupt controller [spec pmac.md §2.10, §2.11; the card's README "The bus"].

Host byte offsets into the `dpram` region (little-endian, 16-bit control words) and the `host`
region (byte registers). The daemon (vdevd/devices/pmac) serves them, the client
(vdevclient.pcomm) drives them.
"""

from __future__ import annotations

import enum

CARD_TYPE = "pmac-turbo"
#: the card's regions and interrupt line
DPRAM, HOST, LINE = "dpram", "host", "inta"

# -- PCI configuration header (ASSUMPTION: no public source gives the Turbo PMAC PCI's IDs; README
# "PCI configuration space") ------------------------------------------------------------------------
#: vendor 1234 (unassigned, the ID emulators use), device 504D ("PM"), revision 01, class 1180
#: (other data acquisition and signal processing controller), subsystem 1234:0002
PCI_VENDOR_ID, PCI_DEVICE_ID, PCI_REVISION = 0x1234, 0x504D, 0x01
PCI_CLASS_CODE = 0x118000
PCI_SUBSYSTEM_VENDOR_ID, PCI_SUBSYSTEM_ID = 0x1234, 0x0002

# -- DPRAM [UM p.402] ---------------------------------------------------------------------------------
DPRAM_SIZE = 0x4000  # 8k x 16: ends at 0x3FFC
DPRAM_BASE = 0x060000  # PMAC address of host offset 0: A <-> 4 (A - DPRAM_BASE)
OPEN_USE = 0x1140  # variable-sized buffers and open-use space ($060450)

# -- the DPRAM ASCII handshake [EPICS-VME pmacDriver.c] -------------------------------------------------
#: host -> card: control word (1: a command is there), control character, the command, its length
CMD_CONTROL, CMD_CHAR, CMD_BUFFER, CMD_MAX = 0x0E9C, 0x0E9E, 0x0EA0, 160
#: card -> host: control word (terminator or error), characters + 1, the line, its length
RESP_CONTROL, RESP_COUNT, RESP_BUFFER, RESP_MAX = 0x0F40, 0x0F42, 0x0F44, 255
#: the response control word's low byte: a data line (CR) or the final acknowledgement (ACK); an
#: error is 0x80 | hundreds digit in the high byte, BCD tens and units in the low byte
CR, ACK, BELL = 0x0D, 0x06, 0x07
ERROR_FLAG = 0x8000

# -- the real-time (servo) motor data buffer, X:$06001A-$06019C [dprrtdbt.h realtTURBO] -----------------
RT_HOST_BUSY = 0x006A  # X:$06001A bit 15: the host is reading
RT_TIMER, RT_READY = 0x006C, 0x006E  # Y:$06001B timer bits 0-15; X:$06001B timer 16-23, bit 15 ready
RT_MASK = 0x0070  # L:$06001C: bit n-1 reports motor n (Y word motors 1-16, X word 17-32)
RT_MOTORS, RT_MOTOR = 0x0074, 48  # $06001D + 12(n-1): twelve 32-bit words per motor
#: word index in a motor record: following error (48-bit), previous DAC, servo status (word 1),
#: motor status (word 2), position bias (48-bit), filtered velocity, 2 spares, actual position
RT_FE, RT_DAC, RT_STATUS1, RT_STATUS2, RT_BIAS, RT_VEL, RT_ACTUAL = 0, 2, 3, 4, 5, 7, 10

# -- the background fixed data buffer, Y:$06019D-$0603A6 [dprbkg.h backgTURBO] --------------------------
BG_CS_COUNT = 0x0674  # Y:$06019D bits 0-7: coordinate systems reported (the host writes it)
BG_HOST_BUSY = 0x0676  # X:$06019D bit 15: the host is reading
BG_TIMER, BG_READY = 0x0678, 0x067A  # as RT_TIMER, RT_READY, at $06019E
BG_GLOBAL = 0x067C  # $06019F control panel, $0601A0 machine I/O, $0601A1 thumbwheel port
BG_STATUS = 0x0688  # L:$0601A2: global status, Y:$000006 (??? word 2) then X:$000006 (word 1)
BG_CS, BG_CS_SIZE = 0x069C, 128  # $0601A7 + $20(s-1): thirty-two 32-bit words per C.S.
#: word index in a C.S. record: feed rate/time (48-bit), time base, time-base pointer, status
#: (`??` word 3, word 1), 9 axis positions (48-bit), program status (`??` word 2), remaining
#: program lines, move time left, TA/TS time left, executing line, 3 spares
CS_FEED, CS_TIMEBASE, CS_STATUS3, CS_STATUS1, CS_STATUS2 = 0, 2, 4, 5, 24
#: the time-base pointer (bits 0-18 the address of the % source, 21 slewing, 22 feed hold), the
#: first axis position (A; Z at +16), lines remaining, move time left, TA/TS time left, executing
#: line [dprbkg.h backcTURBO fdptr, cpos, pr, timrem, tats, pe; bkfdptrTURBO]
CS_FDPTR, CS_AXES, CS_PR, CS_TIMREM, CS_TATS, CS_PE = 3, 6, 25, 26, 27, 28
FDPTR_SLEW, FDPTR_HOLD = 1 << 21, 1 << 22
CS_COUNT = 16
READY = 0x8000  # bit 15 of the host-busy and data-ready words

# -- the background variable read and write buffers, I55 [UM p.407-410; EPICS tpmac drvPmac.c
# drvPmacVarSetup/drvPmacVarRead; PComm32 dprbkg.h `backgvar`, `backgvarwrite`] --------------------
#: read buffer: Y:$060411 control (bit 0 data ready, bit 8 multi-user mode), X:$060411 servo timer,
#: Y:$060412 number of entries (1-128, 0 off), X:$060412 start (PMAC words from $060450)
VB_CONTROL, VB_TIMER, VB_SIZE, VB_START = 0x1044, 0x1046, 0x1048, 0x104A
VB_READY, VB_MULTI_USER, VB_ENTRY_READY = 0x0001, 0x0100, 0x8000
VB_MAX_ENTRIES = 128
#: write buffer: Y:$060413 entries to write (1-32; the card writes 0 when done), X:$060413 start
VBW_SIZE, VBW_START = 0x104C, 0x104E
VBW_MAX_ENTRIES = 32
#: an address specification's second word: bits 0-2 address bits 16-18, bits 4-5 the register
#: [EPICS drvPmac.c PMAC_VARTYP_Y/L/X = 0x00/0x10/0x20]
VB_TYPE_Y, VB_TYPE_L, VB_TYPE_X = 0x00, 0x10, 0x20
#: where vdevclient.pcomm puts the tables (ASSUMPTION: PComm32's placement was not retrieved):
#: the read buffer in the last 384 words of the open-use space (128 specifications and 256 data
#: words), the write buffer's 32 six-word entries below it; the gather buffer has the rest
VB_CLIENT_START = (0x4000 - 0x1140) // 4 - 3 * VB_MAX_ENTRIES
VBW_CLIENT_START = VB_CLIENT_START - 3 * VBW_MAX_ENTRIES

# -- the binary rotary program buffer, I45 [PComm32 dpr.h `struct rotbuf` (its Turbo notes); PMAC1
# DPRAM UM p.30 "DPRAM Binary Rotary Program Buffer"; Turbo UM p.45, p.402] ---------------------------
#: Y:$060414 status (bits 0-7 error number, bit 14 the card's rotary buffer full, bit 15 error),
#: X:$060414 coordinate system, Y:$060415 host index, X:$060415 PMAC index (32-bit words from the
#: ring's start), Y:$060416 ring size (words), X:$060416 ring start (PMAC words from $060450)
ROT_STATUS, ROT_CS, ROT_HOST, ROT_PMAC, ROT_SIZE, ROT_START = (0x1050, 0x1052, 0x1054, 0x1056,
                                                                0x1058, 0x105A)
ROT_BUSY, ROT_ERROR = 0x4000, 0x8000
#: the end-of-buffer word the host leaves at its index after each transfer ($0800, $FFFF)
ROT_END = 0xFFFF0800
#: the smallest ring [PMAC1 DPRAM UM p.30: six words]
ROT_MIN_SIZE = 6
#: where vdevclient.pcomm puts its ring (ASSUMPTION, as VB_CLIENT_START): 256 words below the
#: variable write table
ROT_CLIENT_SIZE = 256
ROT_CLIENT_START = VBW_CLIENT_START - ROT_CLIENT_SIZE


def rot_line_words(text: str) -> list[int]:
    """A program line as the binary rotary ring carries it here (ASSUMPTION: Delta Tau's binary
    command coding was not published): a header word with its length in characters (1-255),
    then its ASCII text four characters a 32-bit word, little-endian, NUL-padded."""
    data = text.encode("latin-1")[:255]
    n = len(data)
    data += bytes(-n % 4)
    return [n] + [int.from_bytes(data[i:i + 4], "little") for i in range(0, len(data), 4)]

# -- DPRAM data gathering, I5000 = 2 or 3 [UM p.422; Turbo SRM DEFINE GATHER; PMAC1 DPRAM UM p.26;
# PComm32 dpr.h `gatbuf`] -----------------------------------------------------------------------------
#: Y:$06044F buffer size (32-bit words), X:$06044F the offset (words) where the next item goes;
#: the buffer itself from $060450
GAT_SIZE, GAT_INDEX, GAT_BUFFER = 0x113C, 0x113E, OPEN_USE
#: 32-bit words from $060450 to the end of the 8k x 16 DPRAM ($060FFF)
OPEN_USE_WORDS = (DPRAM_SIZE - OPEN_USE) // 4

# -- the host port and interrupt controller (ASSUMPTION, §2.11: DSP563xx HI08 convention) ----------------
HOST_SIZE = 16
#: interface status (RXDF: a character from the card waits, TXDE: the host may write), the data
#: byte characters pass through, the interrupt status (write 1 to clear) and enable mask
ISR, DATA, IR_STATUS, IR_MASK = 2, 7, 8, 9
RXDF, TXDE = 0x01, 0x02


class HostIrq(enum.IntFlag):
    """Interrupt controller bits IR0-IR7 (ASSUMPTION, the proposed model of §2.11)."""

    IN_POSITION = 1 << 0
    BUFFER_REQUEST = 1 << 1
    FATAL_FOLLOWING_ERROR = 1 << 2
    WARNING_FOLLOWING_ERROR = 1 << 3
    ASCII_READY = 1 << 4
    COMPARE_EQU1 = 1 << 5
    COMPARE_EQU5 = 1 << 6
    DPRAM = 1 << 7
