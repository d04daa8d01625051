"""Turbo PMAC data memory: two 24-bit spaces X and Y at the same addresses [spec pmac.md §2.1].

Plain words live in two dicts (sparse: the Turbo map spans $000000-$07FFFF and a card uses a few
thousand words of it). Registers whose value belongs to the firmware (motor blocks, Servo IC
channels, global status, the DPRAM) are served by `Device`s mounted on address ranges: a read asks
the device, a write tells it. Values on this interface are unsigned 24-bit words; `L:` (48-bit
floating point) and `D:` (48-bit fixed point) are built from the X (high) and Y (low) words of one
address, except where a device keeps floats itself (P- and Q-variables, `read_float`).
"""

from __future__ import annotations

from bisect import bisect_right
from typing import Protocol

from vdevd.devices.pmac.numbers import from_pmac_float_words, pmac_float_words

WORD = 0xFFFFFF
TOP = 0x07FFFF  # the highest address a Turbo on-line access may name (ECT source field: 19 bits)


class Device(Protocol):
    """Registers mounted on [lo, hi] of both spaces. `space` is "X" or "Y"."""

    def read_word(self, space: str, addr: int) -> int: ...
    def write_word(self, space: str, addr: int, value: int) -> None: ...


class FloatDevice(Device, Protocol):
    """A device whose `L:` words are floats of the firmware (P- and Q-variables)."""

    def read_float(self, addr: int) -> float: ...
    def write_float(self, addr: int, value: float) -> None: ...


class Memory:
    """X/Y word memory with devices mounted on address ranges."""

    def __init__(self) -> None:
        self.x: dict[int, int] = {}
        self.y: dict[int, int] = {}
        self._lows: list[int] = []
        self._mounts: list[tuple[int, int, Device]] = []

    def mount(self, lo: int, hi: int, device: Device) -> None:
        """Serve addresses lo..hi (inclusive) from `device`; ranges must not overlap."""
        i = bisect_right(self._lows, lo)
        if (i and self._mounts[i - 1][1] >= lo) or (i < len(self._mounts) and self._mounts[i][0] <= hi):
            raise ValueError(f"${lo:06X}..${hi:06X} overlaps a mounted device")
        self._lows.insert(i, lo)
        self._mounts.insert(i, (lo, hi, device))

    def device(self, addr: int) -> Device | None:
        i = bisect_right(self._lows, addr) - 1
        if i >= 0:
            lo, hi, dev = self._mounts[i]
            if addr <= hi:
                return dev
        return None

    # -- 24-bit words ------------------------------------------------------------------------------
    def read(self, space: str, addr: int) -> int:
        dev = self.device(addr)
        if dev is not None:
            return dev.read_word(space, addr) & WORD
        return (self.x if space == "X" else self.y).get(addr, 0)

    def write(self, space: str, addr: int, value: int) -> None:
        value &= WORD
        dev = self.device(addr)
        if dev is not None:
            dev.write_word(space, addr, value)
        else:
            (self.x if space == "X" else self.y)[addr] = value

    # -- 48-bit forms ------------------------------------------------------------------------------
    def read_fixed(self, addr: int) -> int:
        """`D:` — X:Y as one signed 48-bit integer."""
        v = (self.read("X", addr) << 24) | self.read("Y", addr)
        return v - (1 << 48) if v >> 47 else v

    def write_fixed(self, addr: int, value: int) -> None:
        value &= (1 << 48) - 1
        self.write("X", addr, value >> 24)
        self.write("Y", addr, value & WORD)

    def read_float(self, addr: int) -> float:
        """`L:` — the 48-bit PMAC floating-point value at addr."""
        dev = self.device(addr)
        if dev is not None and hasattr(dev, "read_float"):
            return float(dev.read_float(addr))
        return from_pmac_float_words(self.read("X", addr), self.read("Y", addr))

    def write_float(self, addr: int, value: float) -> None:
        dev = self.device(addr)
        if dev is not None and hasattr(dev, "write_float"):
            dev.write_float(addr, value)
            return
        x, y = pmac_float_words(value)
        self.write("X", addr, x)
        self.write("Y", addr, y)

    def clear(self) -> None:
        """Power-on: plain words read 0 again (devices keep their own state)."""
        self.x.clear()
        self.y.clear()
