"""The battery-backed RAM option across daemon restarts [Ch7 Power-Up/Reset State, Ch8, Ch5
DSPL_AUTOSTART; spec octavia.md §1.5, §6.1]: what the card keeps when its power goes (the board
RAM's tables, the DSPL program's presence, the DSPL variables, the autostart flag) as one image
in the state directory (vdevd/nvram.py: written atomically).

RESET never clears it. A table-changing RTC marks it due (`Firmware.nv_dirty`); the card takes an
image after the batch of ticks that changed it and hands it to a `Writer`, whose thread saves it
(msgpack, fsync, rename), so the servo loop never waits for the disk: images that arrive while
one is being written replace each other (the last one is saved), and stopping the daemon saves
the last one before it exits. A daemon killed outright loses at most the changes of the moment
(the file holds the image before them, whole).
"""

from __future__ import annotations

import logging
import threading
import time
from typing import TYPE_CHECKING, Any

import numpy as np

from vdevd.devices.octavia.dspl import VAR_BYTES, VARIABLES
from vdevd.devices.octavia.ram import RAM_WORDS
from vdevd.nvram import NvramStore

if TYPE_CHECKING:
    from vdevd.devices.octavia.firmware import Firmware

log = logging.getLogger(__name__)

IMAGE_FORMAT = "octavia-battery-1"
#: how long the writer lets further images arrive before it writes (seconds, wall time)
COALESCE_S = 0.05


def image(fw: Firmware) -> dict[str, Any]:
    """The battery-backed state of the firmware, as the state file holds it."""
    return {"format": IMAGE_FORMAT, "ram": fw.ram.to_bytes(), "vars": fw.dspl.vars.tobytes(),
            "autostart": bool(fw.dspl.autostart), "loaded": bool(fw.dspl.loaded)}


def restore(fw: Firmware, saved: dict[str, Any]) -> bool:
    """Put a saved image back (at power-up); False, logged, when it is not one this firmware
    reads (the card then starts with a cleared RAM, as after a flat battery)."""
    ram, variables = saved.get("ram"), saved.get("vars")
    if (saved.get("format") != IMAGE_FORMAT or not isinstance(ram, bytes)
            or len(ram) != 2 * RAM_WORDS or not isinstance(variables, bytes)
            or len(variables) != VARIABLES * VAR_BYTES):
        log.warning("octavia: the battery-backed RAM image is not %s: the RAM starts cleared",
                    IMAGE_FORMAT)
        return False
    fw.ram.words[:] = np.frombuffer(ram, dtype="<u2")
    fw.dspl.vars[:] = np.frombuffer(variables, dtype=np.uint8).reshape(VARIABLES, VAR_BYTES)
    fw.dspl.autostart = bool(saved.get("autostart", False))
    fw.dspl.loaded = bool(saved.get("loaded", False))
    fw.follow.cam.refresh()
    fw.dspl.power_up()
    return True


class Writer:
    """Saves a card's images on a thread of its own, the last one submitted winning."""

    def __init__(self, store: NvramStore, card: str, coalesce_s: float = COALESCE_S) -> None:
        self.store, self.card, self.coalesce_s = store, card, coalesce_s
        self._cond = threading.Condition()
        self._pending: dict[str, Any] | None = None
        self._writing = False
        self._closed = False
        self._hurry = False  # a flush waits: write without coalescing
        self._thread: threading.Thread | None = None
        self.saved = 0  # images written (tests, stats)

    def submit(self, image: dict[str, Any]) -> None:
        """Save `image` soon; returns at once. Once closed (the daemon stopping), the image is
        dropped with a warning: a tick must not raise for it."""
        with self._cond:
            if self._closed:
                log.warning("%s: battery RAM changed after the writer closed: not saved", self.card)
                return
            self._pending = image
            if self._thread is None:
                self._thread = threading.Thread(target=self._run, daemon=True,
                                                name=f"vdevd-battery-{self.card}")
                self._thread.start()
            self._cond.notify_all()

    def _run(self) -> None:
        cond = self._cond
        while True:
            with cond:
                while self._pending is None and not self._closed:
                    cond.wait()
                if self._pending is None:
                    return
                deadline = time.monotonic() + self.coalesce_s
                while not (self._closed or self._hurry):  # a burst of downloads: one write
                    left = deadline - time.monotonic()
                    if left <= 0:
                        break
                    cond.wait(left)
                image, self._pending, self._writing = self._pending, None, True
            try:
                self.store.save(self.card, image)
            except Exception:  # a full or read-only disk must not stop the card
                log.exception("%s: saving the battery-backed RAM", self.card)
            with cond:
                self._writing = False
                self.saved += 1
                cond.notify_all()

    def flush(self, timeout: float | None = None) -> bool:
        """Wait until every image submitted is written; False on timeout."""
        with self._cond:
            if self._thread is None:
                return True
            self._hurry = True
            self._cond.notify_all()
            done = self._cond.wait_for(lambda: self._pending is None and not self._writing,
                                       timeout)
            self._hurry = False
            return done

    def close(self, timeout: float | None = 10.0) -> None:
        """Write what is pending and end the thread (the daemon stops)."""
        with self._cond:
            self._closed = True
            self._cond.notify_all()
            thread = self._thread
        if thread is not None:
            thread.join(timeout)
