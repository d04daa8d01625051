"""CO (extended I/O banks), OC (output compare) and AF (analog feedback): a base of
`Interpreter`, over the firmware's `ext` (extended_io.py), `compare` (output_compare.py) and
`motion.analog_feedback` (analog_feedback.py) [M Ch1 §General I/O, §Encoder; M Ch3 §TTL
Outputs; spec §1 (CO, OC, AF)]."""

from __future__ import annotations

from collections.abc import Callable
from typing import TYPE_CHECKING

import numpy as np

from vdevd.devices.galil import syntax
from vdevd.devices.galil.errors import TC, GalilError
from vdevd.devices.galil.output_compare import MAX_STEP

if TYPE_CHECKING:
    from vdevd.devices.galil.firmware import Firmware


class IoCommands:
    """Handlers of CO, OC and AF."""

    if TYPE_CHECKING:
        fw: Firmware
        n: int

        def value(self, text: str) -> float: ...

        def fmt(self, value: float, digits: int, frac: int) -> str: ...

        def _setter(self, name: str, arg: str, apply: Callable[[list[int], list[float]], None],
                    query: Callable[[], np.ndarray], digits: int | Callable[[float], str],
                    frac: int, check: Callable[[float], float | None] | None = None) -> bytes: ...

        @staticmethod
        def data(text: str) -> bytes: ...

    def co(self, arg: str) -> bytes:
        """CO n: bit k of n makes bank k+2 (points 17+8k..24+8k) outputs; `CO ?` reports n."""
        if arg.strip() == "?":
            return self.data(self.fmt(self.fw.ext.config, 3, 0))
        v = self.value(arg) if arg.strip() else 0
        if v != int(v):
            raise GalilError(TC.NUMBER_OUT_OF_RANGE, f"CO {v}")
        self.fw.ext.configure(int(v))
        return b":"

    def _integer(self, text: str, lo: float, hi: float) -> int:
        v = self.value(text)
        if v != int(v) or not lo <= v <= hi:
            raise GalilError(TC.NUMBER_OUT_OF_RANGE, text)
        return int(v)

    def _axis_fields(self, name: str, arg: str) -> tuple[int, list[str | None]]:
        """`OCX=m,n` or `OC m,n` (X): the axis and the fields after it."""
        text = arg.strip()
        axis = 0
        if text[:1].isalpha() and "=" in text:
            letter, _, text = text.partition("=")
            axis = syntax.axis_index(letter.strip().upper(), self.n)
        fields = syntax.parse_fields(text, 2)
        if any(f is syntax.QUERY for f in fields):
            raise GalilError(TC.QUESTION_MARK_NOT_VALID, name)
        return axis, [None if f is None else str(f) for f in fields]

    def oc(self, arg: str) -> bytes:
        """OCx=m,n: CMP pulses from the main encoder of x at m, then every n counts (n 0 or
        omitted: once); `OCX=0` turns the compare off (output_compare.py)."""
        axis, fields = self._axis_fields("OC", arg)
        if not fields or fields[0] is None:
            raise GalilError(TC.NOT_ENOUGH_FIELDS, "OC")
        m = self._integer(fields[0], -(2**31), 2**31 - 1)
        step = 0 if len(fields) < 2 or fields[1] is None else self._integer(
            fields[1], -MAX_STEP, MAX_STEP)
        compare = self.fw.compare
        if m == 0 and len(fields) == 1:
            compare.off()
            return b":"
        motion = self.fw.motion
        compare.arm(axis, m, step, int(motion.position()[axis]), float(motion.core.zero[axis]))
        return b":"

    def af(self, arg: str) -> bytes:
        """AF n per axis: 1 the axis reads its analog input (AN of its number), 0 its encoder
        (analog_feedback.py); `AF ?` reports them."""
        fw = self.fw
        return self._setter("AF", arg, fw.set_analog_feedback, lambda: fw.af_on.astype(float),
                            1, 0, lambda v: v if v in (0.0, 1.0) else None)
