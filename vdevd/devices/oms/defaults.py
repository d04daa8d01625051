"""The user default configuration [S §2.14; spec oms.md §1.4, §2.3]: the image `APP` stores in
flash, and the part of it a power-up, `RDP` and `RDF` load beside the parameter set.

Format 2 holds the parameter set (params.py) and the card's I/O configuration: GPIO directions
(BD, IO), home modes (HI/HS), capture triggers (CPH, CPR, CPF), SSI encoders (ECA) and the
update rate `#UR` reports. Output levels (BH/BL/BW, AO, AN/AF) are not configuration and are not
stored: §2.14 lists how outputs behave (aux settle time, automatic aux control; KO only as a
servo's zero offset), never a level an output is set to (README). A format-1 image (before the
I/O configuration was stored) still loads: what an image lacks takes its factory value. Any
other format is a checksum error (card.py). The home truth tables (HT/EH, `home_pattern` in the
parameter part) were added to format 2 as an optional key rather than as a format 3: a format-2
image without them loads with the factory table, and a daemon that does not know the key
ignores it.
"""

from __future__ import annotations

from typing import TYPE_CHECKING, Any

from vdevmaps.oms import UPDATE_RATES

from vdevd.devices.oms.capture import HOME_EVENTS
from vdevd.devices.oms.ssi import CLOCKS, MAX_BITS

if TYPE_CHECKING:
    from vdevd.devices.oms.firmware import Firmware

IMAGE_FORMAT = 2  # the layout APP writes
IMAGE_FORMATS = (1, 2)  # the layouts a power-up reads
GPIO_OUTPUTS = 0xFF00  # factory: IO0-7 inputs, IO8-15 outputs [S §4.4; spec §8.18]


def image(fw: Firmware) -> dict[str, Any]:
    """What APP stores (msgpack-friendly): the parameters and the I/O configuration."""
    cap, ssi = fw.capture, fw.ssi
    return {
        **fw.params.image(),
        "format": IMAGE_FORMAT,
        "gpio_dir": fw.gpio_dir,
        "update_hz": fw.update_hz,
        "home_index": fw.motion.home_index.tolist(),
        "capture_home": cap.home.tolist(),
        "capture_rising": cap.rising.tolist(),
        "capture_falling": cap.falling.tolist(),
        "ssi_bits": ssi.bits.tolist(),
        "ssi_clock": ssi.clock.tolist(),
    }


def _word(value: Any, limit: int) -> int | None:
    """A stored whole number in 0..limit, else None (the factory value applies)."""
    return value if isinstance(value, int) and 0 <= value <= limit else None


def _per_axis(image: dict[str, Any], key: str, n: int, limit: int) -> list[int]:
    """The stored values of `key` for n axes; 0 (factory) for axes or values it lacks."""
    stored = image.get(key)
    values = list(stored[:n]) if isinstance(stored, list) else []
    return [(_word(v, limit) or 0) for v in values] + [0] * (n - len(values))


def load_io(fw: Firmware, image: dict[str, Any] | None) -> None:
    """The I/O configuration into working memory: the factory one (IO0-7 inputs and IO8-15
    outputs, HS homing, no capture, no SSI, `#UR` reporting the card's update rate), with what
    `image` holds over it (None: the factory configuration alone)."""
    image = image or {}
    n, m, cap = fw.n, fw.motion, fw.capture
    gpio_dir = _word(image.get("gpio_dir"), 0xFFFF)
    fw.gpio_dir = GPIO_OUTPUTS if gpio_dir is None else gpio_dir
    hz = image.get("update_hz")
    fw.set_update_rate(hz if hz in UPDATE_RATES else fw.factory_hz)
    for a, index in enumerate(_per_axis(image, "home_index", n, 1)):
        m.set_home_mode(a, bool(index))
    cap.home[:] = _per_axis(image, "capture_home", n, HOME_EVENTS)
    cap.rising[:] = _per_axis(image, "capture_rising", n, 0xFFFF)
    cap.falling[:] = _per_axis(image, "capture_falling", n, 0xFFFF)
    cap.configure(fw)
    bits = _per_axis(image, "ssi_bits", n, MAX_BITS)
    clocks = _per_axis(image, "ssi_clock", n, CLOCKS[-1])
    for a in range(n):
        on = bits[a] and clocks[a] in CLOCKS
        fw.ssi.configure(a, bits[a] if on else 0, clocks[a] if on else 0)
