"""Checks of a saved card image (vdevd/nvram.py) before a card restores it: each value as strict
as the command that sets it, each raising `ImageError` naming the entry (`vmax[0]: -1 is below
0`), so an image of the wrong shape is set aside instead of stopping the daemon (issue 22 §4)."""

from __future__ import annotations

import math
from collections.abc import Collection, Mapping
from typing import Any


class ImageError(ValueError):
    """A saved image its card does not read back; the message names the entry."""


def only(image: Mapping[Any, Any], keys: Collection[str], where: str = "image") -> None:
    """No entry of `image` but `keys`."""
    extra = [k for k in image if k not in keys]
    if extra:
        raise ImageError(f"{where}: unknown entry {extra[0]!r}")


def mapping(value: Any, where: str) -> dict[Any, Any]:
    if not isinstance(value, dict):
        raise ImageError(f"{where}: {_short(value)} is not a map")
    return value


def sequence(value: Any, where: str, length: int | None = None,
             most: int | None = None) -> list[Any]:
    """A list, of exactly `length` or at most `most` entries when given."""
    if not isinstance(value, list):
        raise ImageError(f"{where}: {_short(value)} is not a list")
    if length is not None and len(value) != length:
        raise ImageError(f"{where}: {len(value)} entries, not {length}")
    if most is not None and len(value) > most:
        raise ImageError(f"{where}: {len(value)} entries, more than {most}")
    return value


def number(value: Any, where: str, lo: float = -math.inf, hi: float = math.inf,
           integer: bool = False) -> float:
    """A finite int or float (not a bool) in lo..hi; a whole number when `integer`."""
    if isinstance(value, bool) or not isinstance(value, (int, float)):
        raise ImageError(f"{where}: {_short(value)} is not a number")
    if integer and not isinstance(value, int):
        raise ImageError(f"{where}: {value!r} is not a whole number")
    if not math.isfinite(value):
        raise ImageError(f"{where}: {value!r} is not finite")
    if value < lo:
        raise ImageError(f"{where}: {value!r} is below {lo:g}")
    if value > hi:
        raise ImageError(f"{where}: {value!r} is above {hi:g}")
    return value


def index(key: Any, where: str, lo: int, hi: int) -> int:
    """A map key that is a whole number lo..hi, as an int or its decimal text."""
    if isinstance(key, str) and key.strip().lstrip("-").isdigit():
        key = int(key)
    if isinstance(key, bool) or not isinstance(key, int) or not lo <= key <= hi:
        raise ImageError(f"{where}: key {_short(key)} is not a whole number {lo}..{hi}")
    return int(key)


def text(value: Any, where: str, most: int | None = None) -> str:
    if not isinstance(value, str):
        raise ImageError(f"{where}: {_short(value)} is not text")
    if most is not None and len(value) > most:
        raise ImageError(f"{where}: {len(value)} characters, more than {most}")
    return value


def flag(value: Any, where: str) -> bool:
    """A bool, or 0 or 1."""
    if isinstance(value, bool) or (isinstance(value, int) and value in (0, 1)):
        return bool(value)
    raise ImageError(f"{where}: {_short(value)} is not a flag")


def _short(value: Any) -> str:
    text = repr(value)
    return text if len(text) <= 40 else text[:37] + "..."
