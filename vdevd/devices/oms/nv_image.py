"""The MAXk's stored power-up defaults (what APP writes, defaults.py) checked before a power-up,
RDP or RDF loads them (issue 22 §4): each parameter as its command takes it (params.py's ranges
[S §2.13-2.14]), flags, axis types, limit modes, home truth tables, and the I/O configuration as
BD/IO, HI/HS, CPH/CPR/CPF, ECA and #UR take it. A key this daemon does not know is ignored
(defaults.py); a known key of the wrong shape makes the archive bad: the image is set aside and
the card reports a checksum error (Table 3-4 bit 12) with its factory set."""

from __future__ import annotations

from typing import Any

from vdevmaps.oms import UPDATE_RATES

from vdevd import nvcheck
from vdevd.devices.oms.capture import HOME_EVENTS
from vdevd.devices.oms.defaults import IMAGE_FORMATS
from vdevd.devices.oms.params import AXIS_TYPES, PARAMS, defines_home, parse_home_pattern
from vdevd.devices.oms.ssi import CLOCKS, MAX_BITS

_FLAGS = ("limit_high", "home_high", "encoder_inverted", "servo_inverted", "closed_loop",
          "home_index")
_WORDS = {"capture_home": HOME_EVENTS, "capture_rising": 0xFFFF, "capture_falling": 0xFFFF,
          "ssi_bits": MAX_BITS}
_LIMIT_MODES = ("H", "S", "F")  # hard, soft, off [spec §8.11]


def check_image(n: int, image: dict[str, Any]) -> None:
    """`ImageError` naming the first entry of an `n`-axis card's image a command would refuse."""
    if image.get("format") not in IMAGE_FORMATS:
        raise nvcheck.ImageError(f"format: {image.get('format')!r} is not one of "
                                 f"{list(IMAGE_FORMATS)}")
    for name, values in nvcheck.mapping(image.get("values", {}), "values").items():
        param = PARAMS.get(name) if isinstance(name, str) else None
        if param is None:
            raise nvcheck.ImageError(f"values: {name!r} is no parameter")
        for a, v in enumerate(_axes(values, name, n)):
            if param.coerce(nvcheck.number(v, f"{name}[{a}]")) is None:
                raise nvcheck.ImageError(f"{name}[{a}]: {v!r} is outside {param.lo:g}.."
                                         f"{param.hi:g}")
    for name in _FLAGS:
        for a, v in enumerate(_axes(image.get(name), name, n)):
            nvcheck.flag(v, f"{name}[{a}]")
    for name, hi in _WORDS.items():
        for a, v in enumerate(_axes(image.get(name), name, n)):
            nvcheck.number(v, f"{name}[{a}]", 0, hi, integer=True)
    for a, v in enumerate(_axes(image.get("ssi_clock"), "ssi_clock", n)):
        if v != 0 and v not in CLOCKS:
            raise nvcheck.ImageError(f"ssi_clock[{a}]: {v!r} is not one of {list(CLOCKS)}")
    for name in ("ratio", "user_units"):
        for a, v in enumerate(_axes(image.get(name), name, n)):
            nvcheck.number(v, f"{name}[{a}]")
    for a, v in enumerate(_axes(image.get("ptype"), "ptype", n)):
        if v not in AXIS_TYPES.values():
            raise nvcheck.ImageError(f"ptype[{a}]: {v!r} is not one of {list(AXIS_TYPES.values())}")
    for a, v in enumerate(_axes(image.get("limit_mode"), "limit_mode", n)):
        if v not in _LIMIT_MODES:
            raise nvcheck.ImageError(f"limit_mode[{a}]: {v!r} is not one of {list(_LIMIT_MODES)}")
    for a, v in enumerate(_axes(image.get("home_pattern"), "home_pattern", n)):
        pattern = parse_home_pattern(nvcheck.text(v, f"home_pattern[{a}]", 16))
        if pattern is None or not defines_home(pattern):
            raise nvcheck.ImageError(f"home_pattern[{a}]: {v!r} is not a home truth table")
    if "gpio_dir" in image:
        nvcheck.number(image["gpio_dir"], "gpio_dir", 0, 0xFFFF, integer=True)
    if "update_hz" in image and image["update_hz"] not in UPDATE_RATES:
        raise nvcheck.ImageError(f"update_hz: {image['update_hz']!r} is not an update rate")


def _axes(values: Any, where: str, n: int) -> list[Any]:
    """A per-axis list of the card's n axes (an absent key: none)."""
    return [] if values is None else nvcheck.sequence(values, where, n)
