"""The application program buffer of the DMC-13X8: download, upload, listing, labels (spec
galil.md §1.5, §4.5 "Programming and flow"; [M Ch2 Ex11-14]).

Pure data, no I/O: `Program.download(text)` checks a whole download and replaces (or appends to)
the buffer only when every line is good; a bad one raises `GalilError` with the card's TC code and
leaves the buffer as it was. Each line is kept as written (upload gives it back) and split once
into its statements (`;` outside quotes; a `'` comment runs to the end of the line).

Limits (the seed has no chapter 7; spec §1.5 takes the Optima class, DMC-1700/1800): 1000 lines of
up to 80 characters, 254 labels of up to 7 characters after `#` (a letter, then letters and digits).
"""

from __future__ import annotations

import re
from dataclasses import dataclass, field

from vdevd.devices.galil import syntax
from vdevd.devices.galil.errors import TC, GalilError

MAX_LINES = 1000
MAX_LINE_LENGTH = 80
MAX_LABELS = 254
MAX_LABEL_LENGTH = 7
DOWNLOAD_END = b"\\"  # a download ends with a backslash [DMCLIB DMCDownloadFile]
UPLOAD_END = b"\x1a"  # an upload ends with ^Z [DMCLIB DMCUploadFile]
_LABEL = re.compile(r"#([A-Za-z][A-Za-z0-9]*)")


def statements(line: str) -> tuple[str, ...]:
    """The statements of one program line (`#A;DP0` -> `#A`, `DP0`); a bad one raises."""
    data = line.encode("latin-1") + b"\r"
    out: list[str] = []
    while data:
        frame, used = syntax.next_frame(data)
        if frame is None:
            break
        data = data[used:]
        if frame.binary:
            raise GalilError(TC.BINARY_NOT_IN_PROGRAM, repr(line))
        text = frame.data.decode("latin-1").strip(" ")
        if text:
            out.append(text)
    return tuple(out)


def label_of(line: str) -> str | None:
    """The label a line defines (`#LOOP;JP#LOOP` -> "LOOP"), None when it starts with none;
    a bad or too long name is TC 61 "Duplicate or bad label"."""
    text = line.lstrip(" ")
    if not text.startswith("#"):
        return None
    head = re.split(r"[;\s']", text, maxsplit=1)[0]
    match = _LABEL.fullmatch(head)
    if match is None or len(match.group(1)) > MAX_LABEL_LENGTH:
        raise GalilError(TC.BAD_LABEL, repr(head))
    return match.group(1)


@dataclass
class Program:
    """The program buffer: its lines, their statements and the label table."""

    lines: list[str] = field(default_factory=list)
    code: list[tuple[str, ...]] = field(default_factory=list)
    labels: dict[str, int] = field(default_factory=dict)
    #: the line of the last download error (`_ED`), as the card reports it for DMCError
    error_line: int = 0
    #: `PW` and `^L^K` (the Galil command reference; not in the seed): while locked, UL, LS, ED
    #: and TR are TC 106
    password: str = ""
    locked: bool = False

    def download(self, text: bytes, start: str | None = None) -> None:
        """Take a download: `text` is its lines (CR, LF or CR LF) without the final `\\`.
        `start` None replaces the buffer, "" appends (`DL#`), a label replaces from that label
        on (`DL#LABEL`). Errors (the buffer unchanged): a byte 0x80-0xFF TC 98, a line over 80
        characters or more than 1000 lines TC 60, a bad or duplicate label TC 61, more than 254
        labels TC 62, an undefined start label TC 10."""
        keep = self._kept(start)
        raw = text.replace(b"\r\n", b"\r").replace(b"\n", b"\r").split(b"\r")
        if raw and raw[-1] == b"":
            raw.pop()
        lines = list(self.lines[:keep])
        for k, chunk in enumerate(raw):
            self.error_line = keep + k
            if any(b & 0x80 for b in chunk):
                raise GalilError(TC.BINARY_NOT_IN_PROGRAM, f"line {keep + k}")
            line = chunk.decode("latin-1").rstrip(" ")
            if len(line) > MAX_LINE_LENGTH:
                raise GalilError(TC.DOWNLOAD_ERROR, f"line {keep + k}: {len(line)} characters")
            lines.append(line)
        if len(lines) > MAX_LINES:
            self.error_line = MAX_LINES
            raise GalilError(TC.DOWNLOAD_ERROR, f"{len(lines)} lines")
        code, labels = self._compile(lines)
        self.lines, self.code, self.labels = lines, code, labels
        self.error_line = 0

    def _kept(self, start: str | None) -> int:
        if start is None:
            return 0
        if start == "":
            return len(self.lines)
        if start not in self.labels:
            raise GalilError(TC.EMPTY_PROGRAM_LINE, "#" + start)
        return self.labels[start]

    def _compile(self, lines: list[str]) -> tuple[list[tuple[str, ...]], dict[str, int]]:
        code: list[tuple[str, ...]] = []
        labels: dict[str, int] = {}
        for n, line in enumerate(lines):
            self.error_line = n
            label = label_of(line)
            if label is not None:
                if label in labels:
                    raise GalilError(TC.BAD_LABEL, f"#{label} twice")
                if len(labels) >= MAX_LABELS:
                    raise GalilError(TC.TOO_MANY_LABELS, f"more than {MAX_LABELS}")
                labels[label] = n
            code.append(statements(line))
        return code, labels

    def erase(self) -> None:
        self.lines, self.code, self.labels = [], [], {}
        self.password, self.locked = "", False

    def load(self, lines: list[str]) -> None:
        """Restore lines burned with BP (checked as a download)."""
        self.download("\r".join(lines).encode("latin-1"))

    def upload(self) -> bytes:
        """UL: every line with CR LF, then ^Z [DMCLIB DMCUploadFile]."""
        return b"".join(line.encode("latin-1") + b"\r\n" for line in self.lines) + UPLOAD_END

    def listing(self, first: int = 0, last: int | None = None) -> bytes:
        """LS: lines `first`..`last` with their numbers (`000 #A`) [M Ch2 Ex11]."""
        end = len(self.lines) - 1 if last is None else min(last, len(self.lines) - 1)
        return b"".join(f"{n:03d} {self.lines[n]}\r\n".encode("latin-1")
                        for n in range(first, end + 1))

    def line_of(self, label: str) -> int:
        """The line of `#label`; TC 10 "undefined label" when there is none."""
        try:
            return self.labels[label]
        except KeyError:
            raise GalilError(TC.EMPTY_PROGRAM_LINE, "#" + label) from None


#: a download longer than the buffer can hold is refused at its end (TC 60); the bytes until the
#: `\\` are read and dropped, so what is kept stays bounded
DOWNLOAD_LIMIT = MAX_LINES * (MAX_LINE_LENGTH + 2)


class ProgramDownload:
    """DL's data phase on a command channel: the bytes that follow, up to `\\`, are the program
    (as `arrays.ArrayDownload` is QD's: `feed` takes what came and says how much it used)."""

    def __init__(self, program: Program, start: str | None) -> None:
        self.program = program
        self.start = start
        self.text = bytearray()

    def feed(self, data: bytes) -> tuple[int, int | None]:
        """(bytes used, None while the `\\` has not come; then 0 or the TC of the refusal)."""
        end = data.find(DOWNLOAD_END)
        chunk = data if end < 0 else data[:end]
        self.text += chunk[:max(DOWNLOAD_LIMIT + 1 - len(self.text), 0)]
        if end < 0:
            return len(data), None
        try:
            if len(self.text) > DOWNLOAD_LIMIT:
                raise GalilError(TC.DOWNLOAD_ERROR, "download too long")
            self.program.download(bytes(self.text), self.start)
        except GalilError as exc:
            return end + 1, exc.code
        return end + 1, 0
