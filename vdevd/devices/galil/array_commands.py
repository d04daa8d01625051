"""The commands of arrays, variables and record mode, over one card's firmware: DM DA LA LV QU QD
(arrays.py) and RA RD RC (recorder.py) [M Ch6 §Multiple Moves, §Teach; spec §4.5 "Arrays",
"RA / RD / RC"]. `Interpreter` binds them next to its own handlers (commands.py names them).
"""

from __future__ import annotations

import re
from collections.abc import Callable
from typing import TYPE_CHECKING

from vdevd.devices.galil.arrays import ArrayDownload, split_reference, split_references
from vdevd.devices.galil.errors import TC, GalilError
from vdevd.devices.galil.numbers import VARIABLE_FORMAT
from vdevd.devices.galil.recorder import MAX_RATE, MAX_RECORD_ARRAYS

if TYPE_CHECKING:
    from vdevd.devices.galil.firmware import Firmware

CRLF = "\r\n"
#: an RD source: an operand (`_TPX`, `_OP`, `_TI0`) or TIME
_SOURCE = re.compile(r"_[A-Za-z][A-Za-z0-9]*\Z|TIME\Z")
_COUNT_FORMAT = (4, 0)  # DM ? / DA ?: free elements / arrays
#: errors of record mode [spec §4.3]
RECORD_RUNNING = 80
NO_ARRAY_OR_SOURCE = 81
UNDEFINED_ARRAY = 82
TOO_MANY_ELEMENTS = 84


class ArrayCommands:
    """Handlers of DM DA LA LV QU QD RA RD RC: a base of `Interpreter`, whose firmware,
    expressions and formats they use."""

    if TYPE_CHECKING:
        fw: Firmware

        def value(self, text: str) -> float: ...

        def fmt(self, value: float, digits: int, frac: int) -> str: ...

        @staticmethod
        def data(text: str) -> bytes: ...

    # -- arrays ------------------------------------------------------------------------------------
    def _dm(self, arg: str) -> bytes:
        """DM NAME[n],...: dimension arrays; `DM ?` the elements free [M Ch6 §Multiple Moves]."""
        if arg.strip() == "?":
            return self.data(self.fmt(self.fw.arrays.free_elements, *_COUNT_FORMAT))
        requests = []
        for name, size_text in split_references(arg):
            if not size_text:
                raise GalilError(TC.NOT_ENOUGH_FIELDS, f"{name}[]")
            size = self.value(size_text)
            if size != int(size):
                raise GalilError(TC.NUMBER_OUT_OF_RANGE, f"{name}[{size}]")
            requests.append((name, int(size)))
        self.fw.arrays.dimension(requests)
        return b":"

    def _da(self, arg: str) -> bytes:
        """DA: deallocate arrays (`NAME[]`, `*[]` every one) and variables (`NAME`, `*` every
        one), comma-separated; an array being recorded is TC 80 while RC runs [spec §4.5 (A)]."""
        if arg.strip() == "?":
            return self.data(self.fmt(self.fw.arrays.free_arrays, *_COUNT_FORMAT))
        fw = self.fw
        arrays: list[str] = []
        variables: list[str] = []
        for item in (i.strip(" ") for i in arg.split(",")):
            if "[" in item:
                name, _, rest = split_reference(item)
                if rest.strip(" "):
                    raise GalilError(TC.UNRECOGNIZED_COMMAND, repr(item))
                arrays.append(name)
            elif item == "*" or re.fullmatch(r"[A-Za-z][A-Za-z0-9]{0,7}", item):
                variables.append(item)
            elif item:
                raise GalilError(TC.VARIABLE_ERROR, repr(item))
        if not arrays and not variables:
            raise GalilError(TC.NOT_ENOUGH_FIELDS, "DA")
        recorded = set(fw.recorder.arrays) if fw.recorder.active else set()
        if recorded and any(a == "*" or a in recorded for a in arrays):
            raise GalilError(RECORD_RUNNING, "DA of an array being recorded")
        for name in arrays:
            fw.arrays.deallocate(name)
        for name in variables:
            if name == "*":
                fw.variables.clear()
            else:
                fw.variables.pop(name, None)
        return b":"

    def _la(self, arg: str) -> bytes:
        """LA: every array with its size, `NAME[n]` a line, in alphabetical order."""
        return "".join(line + CRLF for line in self.fw.arrays.listing()).encode() + b":"

    def _lv(self, arg: str) -> bytes:
        """LV: every variable, `NAME = value` (the variable format) a line, alphabetically."""
        variables = self.fw.variables
        lines = [f"{name} = {self.fmt(variables[name], *VARIABLE_FORMAT)}"
                 for name in sorted(variables)]
        return "".join(line + CRLF for line in lines).encode() + b":"

    def _fields(self, rest: str, count: int) -> list[float | None]:
        """The `,first,last[,delim]` after `NAME[]` of QU/QD: values or None for omitted ones."""
        rest = rest.strip(" ")
        if not rest:
            return [None] * count
        if not rest.startswith(","):
            raise GalilError(TC.UNRECOGNIZED_COMMAND, repr(rest))
        texts = [t.strip(" ") for t in rest[1:].split(",")]
        if len(texts) > count:
            raise GalilError(TC.UNRECOGNIZED_COMMAND, "too many fields")
        values = [self.value(t) if t else None for t in texts]
        return values + [None] * (count - len(values))

    def _qu(self, arg: str) -> bytes:
        """QU NAME[],first,last,delim: the elements first..last (default the whole array) in the
        variable format, separated by CR (delim 0, the default) or a comma (1); then CR LF ':'
        (DMCArrayUpload; gclib GArrayUpload)."""
        name, _, rest = split_reference(arg)
        first, last, delim = self._fields(rest, 3)
        if delim not in (None, 0, 1):
            raise GalilError(TC.NUMBER_OUT_OF_RANGE, f"delimiter {delim}")
        elements, lo, hi = self.fw.arrays.span(name, first, last)
        fmt = self.fmt
        text = ("," if delim == 1 else "\r").join(
            [fmt(v, *VARIABLE_FORMAT) for v in elements[lo:hi + 1].tolist()])
        return self.data(text)

    def _qd(self, arg: str) -> ArrayDownload:
        """QD NAME[],first,last: the data that follows the command (numbers separated by commas
        or CR, ended by a backslash or ^Z) goes into elements first..last (DMCArrayDownload;
        gclib GArrayDownload); the card answers when the data has ended. A refused QD (no
        such array, a bad range) takes its data all the same and answers '?' after it: the
        host has sent it behind the command, and it must not run as commands."""
        try:
            name, _, rest = split_reference(arg)
            first, last = self._fields(rest, 2)
            elements, lo, hi = self.fw.arrays.span(name, first, last)
        except GalilError as exc:
            return ArrayDownload.refused(exc.code)
        return ArrayDownload(elements, lo, hi)

    # -- record mode [M Ch6 §Teach] ------------------------------------------------------------------
    def _ra(self, arg: str) -> bytes:
        """RA NAME[],...: the arrays of the automatic record, up to 4 (defined: TC 82)."""
        fw = self.fw
        if fw.recorder.active:
            raise GalilError(RECORD_RUNNING)
        names = [name for name, _ in split_references(arg)] if arg.strip() else []
        if len(names) > MAX_RECORD_ARRAYS:
            raise GalilError(TC.NUMBER_OUT_OF_RANGE, f"more than {MAX_RECORD_ARRAYS} arrays")
        for name in names:
            fw.arrays.array(name, UNDEFINED_ARRAY)
        fw.recorder.arrays = names
        return b":"

    def _rd(self, arg: str) -> bytes:
        """RD source,...: what each RA array records, an operand (`_TPX`, `_TEX`, `_TTX`, `_RPX`,
        `_OP`, `_TI0` ...) or TIME, up to 4; an unknown operand is refused as in an expression."""
        fw = self.fw
        if fw.recorder.active:
            raise GalilError(RECORD_RUNNING)
        sources = [s.strip(" ") for s in arg.split(",")] if arg.strip() else []
        if len(sources) > MAX_RECORD_ARRAYS:
            raise GalilError(TC.NUMBER_OUT_OF_RANGE, f"more than {MAX_RECORD_ARRAYS} sources")
        for source in sources:
            if not _SOURCE.match(source):
                raise GalilError(TC.BAD_FUNCTION, repr(source))
            self._reader(source)()  # refused here, not in the sample
        fw.recorder.sources = sources
        return b":"

    def _reader(self, source: str) -> Callable[[], float]:
        """The function the sample calls for an RD source."""
        operand = self.fw.env.operand
        name = "TIME" if source == "TIME" else source[1:]
        return lambda: operand(name)

    def _rc(self, arg: str) -> bytes:
        """RC n,m: record every 2^n samples (n 1..8), m records (omitted or 0: the smallest RA
        array; negative: circularly into |m| elements); RC 0 stops; `RC ?` 1 while recording."""
        fw, rec = self.fw, self.fw.recorder
        text = arg.strip(" ")
        if text == "?":
            return self.data(self.fmt(int(rec.active), 1, 0))
        fields = [t.strip(" ") for t in text.split(",")] if text else ["0"]
        if len(fields) > 2 or not fields[0]:
            raise GalilError(TC.NOT_ENOUGH_FIELDS if not fields[0] else TC.UNRECOGNIZED_COMMAND)
        rate = self.value(fields[0])
        if rate != int(rate) or not 0 <= rate <= MAX_RATE:
            raise GalilError(TC.NUMBER_OUT_OF_RANGE, f"RC {rate}")
        if rate == 0:
            rec.stop()
            return b":"
        if rec.active:
            raise GalilError(RECORD_RUNNING)
        if not rec.arrays or len(rec.arrays) != len(rec.sources):
            raise GalilError(NO_ARRAY_OR_SOURCE)
        targets = [fw.arrays.array(name, UNDEFINED_ARRAY) for name in rec.arrays]
        room = min(len(t) for t in targets)
        count = self.value(fields[1]) if len(fields) > 1 and fields[1] else 0
        if count != int(count):
            raise GalilError(TC.NUMBER_OUT_OF_RANGE, f"RC ,{count}")
        if abs(count) > room:
            raise GalilError(TOO_MANY_ELEMENTS, f"{abs(count)} records into {room} elements")
        rec.start(fw.ticks, int(rate), int(count) or room, targets,
                  [self._reader(s) for s in rec.sources])
        return b":"
