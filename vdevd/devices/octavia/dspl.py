"""The host-visible surface of DSPL, the card's on-board program language [Ch5 DSPL-related
RTCs, Ch6 Table 6-3; spec octavia.md §7]: the 128 variables, the four DPR monitor slots, the
program status words and the program's loaded / running / autostart state. No interpreter: the
DSPL Programmer's Guide and the download path are not in the manual (README "DSPL").

Assumptions (spec Q-23): a variable is 6 raw bytes (the 48-bit DSPL float's format is not given),
written by CHANGE_VAR and shown in a monitor slot byte for byte; the variables, like the program,
are in the battery-backed RAM and survive RESET; the monitor slots (066h..07Dh) and the status
words (07Eh..085h) are refreshed every 5 ms under the access bytes 0C9h/0D1h, deferred to the
next 5 ms while the host holds 0D1h.
"""

from __future__ import annotations

import numpy as np
from vdevmaps.octavia import Dpr, Window

from vdevd.devices.octavia.dpr import Windows

VARIABLES = 128  # VAR1..VAR128 [Ch5 CHANGE_VAR]
VAR_BYTES = 6  # 48-bit DSPL floating point
SLOTS = 4  # monitor 1..4 at 066h, 06Ch, 072h, 078h [Table 6-3]
WINDOW_BYTES = Dpr.PLCSTAT + 2 - Dpr.DSPLVAR  # 066h..085h
#: the status words: PRG1STAT (07Eh), PRG2STAT (080h), reserved (082h), PLCSTAT (084h)
STATUS_WORDS = ("prg1", "prg2", "reserved", "plc")


class Dspl:
    """DSPL variables, monitor slots, status words and program state."""

    def __init__(self) -> None:
        self.vars = np.zeros((VARIABLES, VAR_BYTES), dtype=np.uint8)
        self.monitor = np.zeros(SLOTS, dtype=np.int64)  # variable number per slot, 0: none
        self.shown = np.zeros(SLOTS * VAR_BYTES, dtype=np.uint8)  # what the slots show
        self.status = np.zeros(len(STATUS_WORDS), dtype=np.int64)  # program line numbers
        self.autostart = False  # DSPL_AUTOSTART 55h: non-volatile [Ch5 DSPL_AUTOSTART]
        self.loaded = False  # a program is in the board RAM (there is no download path)
        self.running = False
        self.signals = 0  # SIGNAL_DSPL received
        self.stale = True  # the window differs from what it should show (refresh due)

    def power_up(self) -> None:
        """Power-up and RESET: the monitor mapping and status words are parameters, cleared;
        the program starts if autostart is enabled and one is loaded [Ch5 DSPL_AUTOSTART]."""
        self.monitor[:] = 0
        self.shown[:] = 0
        self.status[:] = 0
        self.running = self.autostart and self.loaded
        self.stale = True

    def change(self, var: int, value: bytes) -> None:
        """CHANGE_VAR of VAR`var` (1..128) to 6 raw bytes."""
        self.vars[var - 1] = np.frombuffer(value, dtype=np.uint8)
        if var in self.monitor:
            self.stale = True

    def watch(self, slot: int, var: int) -> None:
        """MONITOR_VAR: slot 0..3 shows VAR`var` (0: the slot keeps what it shows)."""
        self.monitor[slot] = var
        self.stale = True

    def window(self) -> bytes:
        """The bytes of 066h..085h: the four slots, then the status words (u16 LE)."""
        for slot, var in enumerate(self.monitor.tolist()):
            if var:
                self.shown[slot * VAR_BYTES:(slot + 1) * VAR_BYTES] = self.vars[var - 1]
        return self.shown.tobytes() + (self.status & 0xFFFF).astype("<u2").tobytes()

    def refresh(self, windows: Windows) -> None:
        """Every 5 ms: write the window unless the host holds it (then at the next 5 ms)."""
        if windows.put_bytes(Window.DSPL, Dpr.DSPLVAR, self.window()):
            self.stale = False
