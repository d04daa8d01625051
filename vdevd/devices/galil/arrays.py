"""Arrays of the DMC-13X8: the array table (DM, DA, LA, elements in expressions) and the array
transfer commands QU and QD, with no I/O [M Ch6 §Multiple Moves, §Teach; spec §4.5 "Arrays"].

`DM VX[750],VY[750]` dimensions arrays whose elements, 0-based, start at 0; `VX[COUNT]=N` writes
one and `VX[COUNT]` reads it in an expression. The seed gives no memory limits (spec §1.5, open
question 7): the table takes the Optima-class figures the digest proposes, 30 arrays and 8000
elements in all, names of up to 8 characters starting with a letter. `QU`/`QD` are the
commands Galil's libraries send for DMCArrayUpload/DMCArrayDownload (spec §6.2) and gclib's
GArrayUpload/GArrayDownload.
"""

from __future__ import annotations

import re

import numpy as np

from vdevd.devices.galil.errors import TC, GalilError
from vdevd.devices.galil.numbers import MAX_VALUE, MIN_VALUE, fixed

MAX_ARRAYS = 30  # spec §1.5 ASSUMPTION (Optima class)
MAX_ELEMENTS = 8000  # elements of all arrays together, spec §1.5 ASSUMPTION
MAX_NAME_LENGTH = 8  # spec §1.5 ASSUMPTION, as variables

#: `NAME[index text]`, `NAME []`, `*[]` (DA): the array reference of DM, DA, RA, QU and QD
_REFERENCE = re.compile(r" *([A-Za-z][A-Za-z0-9]*|\*) *\[([^\]]*)\] *")
_NAME = re.compile(r"[A-Za-z][A-Za-z0-9]*\Z")


def split_reference(text: str) -> tuple[str, str, str]:
    """`NAME[index]rest` -> (NAME, index text, the text after ']'); TC 55 without brackets,
    TC 9 for a name longer than 8 characters."""
    match = _REFERENCE.match(text)
    if match is None:
        if "[" not in text:
            raise GalilError(TC.MISSING_BRACKET, repr(text))
        raise GalilError(TC.BAD_FUNCTION, repr(text))
    name = match.group(1)
    if len(name) > MAX_NAME_LENGTH:
        raise GalilError(TC.VARIABLE_ERROR, f"{name!r} is longer than {MAX_NAME_LENGTH} characters")
    return name, match.group(2).strip(" "), text[match.end():]


def split_references(text: str) -> list[tuple[str, str]]:
    """The comma-separated references of `DM A[10],B[20]` / `RA A[],B[]` as (NAME, index)."""
    refs: list[tuple[str, str]] = []
    rest = text
    while True:
        name, index, rest = split_reference(rest)
        refs.append((name, index))
        rest = rest.lstrip(" ")
        if not rest:
            return refs
        if not rest.startswith(","):
            raise GalilError(TC.UNRECOGNIZED_COMMAND, repr(text))
        rest = rest[1:]


class ArrayTable:
    """The arrays in memory: name -> its elements (float64 holding 32.16 values)."""

    def __init__(self, max_arrays: int = MAX_ARRAYS, max_elements: int = MAX_ELEMENTS) -> None:
        self.max_arrays = max_arrays
        self.max_elements = max_elements
        self.arrays: dict[str, np.ndarray] = {}
        self.used = 0  # elements allocated

    @property
    def free_elements(self) -> int:
        """`_DM`: the array elements still available."""
        return self.max_elements - self.used

    @property
    def free_arrays(self) -> int:
        """`_DA`: the arrays still available."""
        return self.max_arrays - len(self.arrays)

    def check_dimension(self, requests: list[tuple[str, int]]) -> None:
        """Refuse a DM line before any of it applies: a bad name (TC 9 / 57), a size not a whole
        number 1..8000 (TC 6), an existing array of another size (TC 57), more than 30 arrays
        (TC 67), more elements than are free (TC 66)."""
        arrays, used = dict.fromkeys(self.arrays), self.used
        for name, size in requests:
            if not _NAME.match(name):
                raise GalilError(TC.BAD_FUNCTION, repr(name))
            if not 1 <= size <= self.max_elements:
                raise GalilError(TC.NUMBER_OUT_OF_RANGE, f"{name}[{size}]")
            if name in self.arrays and len(self.arrays[name]) != size:
                raise GalilError(TC.BAD_FUNCTION, f"{name} is dimensioned [{len(self.arrays[name])}]")
            if name in arrays:
                continue
            if len(arrays) >= self.max_arrays:
                raise GalilError(67, f"more than {self.max_arrays} arrays")
            if used + size > self.max_elements:
                raise GalilError(66, f"{name}[{size}]: {self.max_elements - used} elements free")
            arrays[name] = None
            used += size

    def dimension(self, requests: list[tuple[str, int]]) -> None:
        """DM: new arrays of zeros; one already there with the same size keeps its elements."""
        self.check_dimension(requests)
        for name, size in requests:
            if name not in self.arrays:
                self.arrays[name] = np.zeros(size)
                self.used += size

    def deallocate(self, name: str) -> None:
        """DA NAME[]: the array goes (an undefined one is no error: gclib's GArrayDownloadFile
        deallocates before it dimensions); DA *[]: every array."""
        if name == "*":
            self.arrays.clear()
            self.used = 0
            return
        gone = self.arrays.pop(name, None)
        if gone is not None:
            self.used -= len(gone)

    def array(self, name: str, code: int = TC.BAD_FUNCTION) -> np.ndarray:
        """The elements of array `name`; GalilError `code` if there is none."""
        try:
            return self.arrays[name]
        except KeyError:
            raise GalilError(code, f"no array {name}") from None

    def read(self, name: str, index: int) -> float:
        """NAME[index] in an expression: TC 57 for no such array, TC 56 outside 0..size-1."""
        elements = self.array(name)
        if not 0 <= index < len(elements):
            raise GalilError(TC.ARRAY_INDEX_INVALID, f"{name}[{index}]")
        return float(elements[index])

    def write(self, name: str, index: int, value: float) -> None:
        """NAME[index]=value (the value already a checked 32.16 number)."""
        elements = self.array(name)
        if not 0 <= index < len(elements):
            raise GalilError(TC.ARRAY_INDEX_INVALID, f"{name}[{index}]")
        elements[index] = value

    def span(self, name: str, first: float | None, last: float | None) -> tuple[np.ndarray, int, int]:
        """The elements and the range first..last of QU/QD (whole array when omitted): TC 82
        for no such array, TC 56 for a range outside it or backwards."""
        elements = self.array(name, 82)
        lo = 0 if first is None else first
        hi = len(elements) - 1 if last is None else last
        if lo != int(lo) or hi != int(hi) or not 0 <= lo <= hi < len(elements):
            raise GalilError(TC.ARRAY_INDEX_INVALID, f"{name}[{lo}..{hi}]")
        return elements, int(lo), int(hi)

    def listing(self) -> list[str]:
        """LA: `NAME[size]` of every array, in alphabetical order."""
        return [f"{name}[{len(self.arrays[name])}]" for name in sorted(self.arrays)]


# -- QD: array data from the host ------------------------------------------------------------------
#: what ends QD's data: a backslash (gclib) or ^Z (the DMC library's DMCArrayDownload)
QD_TERMINATORS = b"\\\x1a"
_SEPARATORS = b",\r\n"
_MAX_TOKEN = 32  # a number longer than this is no number (the data is bounded as it arrives)
_QD_NUMBER = re.compile(rb"[-+]?(\d+\.?\d*|\.\d+)\Z")


class ArrayDownload:
    """QD's data phase: the bytes after the QD command, numbers separated by commas, CR or LF
    (spaces ignored), stored into `elements[first..last]` as they come, until a backslash or ^Z.
    The card then answers ':' or, after a malformed number (TC 83), one out of the 32.16 range
    (TC 6) or more numbers than the range holds (TC 56, the extra ones dropped), '?'."""

    def __init__(self, elements: np.ndarray, first: int, last: int) -> None:
        self.elements = elements
        self.next = first
        self.last = last
        self.token = bytearray()
        self.error = 0

    @classmethod
    def refused(cls, code: int) -> ArrayDownload:
        """The data phase of a refused QD: the data is read and dropped, then '?' with `code`."""
        download = cls(np.zeros(0), 0, -1)
        download.error = code
        return download

    def feed(self, data: bytes) -> tuple[int, int | None]:
        """Take bytes of the command FIFO: (bytes used, None while the data goes on, else the
        error code to answer, 0 for ':')."""
        for i, byte in enumerate(data):
            if byte in QD_TERMINATORS:
                self._end_token()
                return i + 1, self.error
            if byte in _SEPARATORS:
                self._end_token()
            elif byte != 0x20:
                if len(self.token) < _MAX_TOKEN:
                    self.token.append(byte)
                elif not self.error:
                    self.error = TC.NOT_A_VALID_NUMBER
        return len(data), None

    def _end_token(self) -> None:
        token, self.token = bytes(self.token), bytearray()
        if not token:
            return
        if not _QD_NUMBER.match(token):
            self.error = self.error or TC.NOT_A_VALID_NUMBER
            return
        value = fixed(float(token))
        if not MIN_VALUE <= value <= MAX_VALUE:
            self.error = self.error or TC.NUMBER_OUT_OF_RANGE
            return
        if self.next > self.last:
            self.error = self.error or TC.ARRAY_INDEX_INVALID
            return
        self.elements[self.next] = value
        self.next += 1
