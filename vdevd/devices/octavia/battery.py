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
from typing import TYPE_CHECKING, Any

import numpy as np

from vdevd import nvcheck
from vdevd.devices.octavia.dspl import VAR_BYTES, VARIABLES
from vdevd.devices.octavia.ram import RAM_WORDS
from vdevd.nvram import NvramWriter as Writer  # noqa: F401  (the card's writer)

if TYPE_CHECKING:
    from vdevd.devices.octavia.firmware import Firmware

log = logging.getLogger(__name__)

IMAGE_FORMAT = "octavia-battery-1"
def image(fw: Firmware) -> dict[str, Any]:
    """The battery-backed state of the firmware, as the state file holds it."""
    return {"format": IMAGE_FORMAT, "ram": fw.ram.to_bytes(), "vars": fw.dspl.vars.tobytes(),
            "autostart": bool(fw.dspl.autostart), "loaded": bool(fw.dspl.loaded)}


def check_image(saved: dict[str, Any]) -> None:
    """`ImageError` naming what makes `saved` no image of this RAM (issue 22 §4): another
    format, RAM or variables of another size, flags that are not flags, an unknown entry."""
    nvcheck.only(saved, ("format", "ram", "vars", "autostart", "loaded"))
    if saved.get("format") != IMAGE_FORMAT:
        raise nvcheck.ImageError(f"format: {saved.get('format')!r}, not {IMAGE_FORMAT!r}")
    for key, size in (("ram", 2 * RAM_WORDS), ("vars", VARIABLES * VAR_BYTES)):
        value = saved.get(key)
        if not isinstance(value, bytes) or len(value) != size:
            raise nvcheck.ImageError(f"{key}: not {size} bytes")
    for key in ("autostart", "loaded"):
        nvcheck.flag(saved.get(key, False), key)


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


