"""One command channel of the card besides its command FIFO: an Ethernet connection (README.md
"Ethernet command channel"). Sans-I/O: bytes in, reply bytes out.

The FIFO channel (`Firmware.serve`) and every connection share the firmware and its interpreter
(one card: one set of variables, one error code for TC, one motion). What the interpreter holds
per channel lives here: the input not yet decoded and the held trippoint. A trippoint (AM, MC,
WT) holds the channel that sent it, as it holds the command FIFO (spec §5.7); the other channels
keep being served. The card checks a held trippoint at every sample (`serve`).
"""

from __future__ import annotations

import re
from functools import lru_cache

from vdevmaps.galil import FIFO_SIZE

from vdevd.devices.galil import syntax
from vdevd.devices.galil.arrays import ArrayDownload
from vdevd.devices.galil.errors import TC, GalilError
from vdevd.devices.galil.firmware import Firmware
from vdevd.devices.galil.interpreter import OK, Trippoint
from vdevd.devices.galil.program import ProgramDownload

#: the longest command (text between terminators) a channel takes: what the command FIFO holds;
#: a longer one is answered `?`, TC 5 "Input buffer full", and dropped through its terminator
MAX_COMMAND = FIFO_SIZE
#: input kept behind a held trippoint before the connection stops reading (TCP flow control)
MAX_INPUT = 64 * 1024
#: commands decoded per `serve`: a client sending many at once gets them run in turns, the
#: daemon's other work (samples, other clients) running between them
MAX_BATCH = 64

_next_frame = lru_cache(maxsize=256)(syntax.next_frame)
_TERMINATOR = re.compile(rb"[\r;]")


class CommandChannel:
    """The command stream of one connection over the card's firmware `fw`."""

    def __init__(self, fw: Firmware) -> None:
        self.fw = fw
        self._in = bytearray()
        self._trip: Trippoint | None = None
        self._dropping = False  # inside an overlong command: dropped through its terminator
        #: QD or DL taking its data from this connection
        self._sink: ArrayDownload | ProgramDownload | None = None
        self.more = False  # the last `serve` stopped at MAX_BATCH with input left to decode

    @property
    def held(self) -> bool:
        """A trippoint holds the channel: the card checks it every sample (not at rest)."""
        return self._trip is not None

    @property
    def input_full(self) -> bool:
        """MAX_INPUT bytes wait behind a trippoint: read no more until they are decoded."""
        return len(self._in) >= MAX_INPUT

    def receive(self, data: bytes) -> bytes:
        """Bytes from the host; the replies of the commands they complete."""
        self._in += data
        return self.serve()

    def reset(self) -> None:
        """RS: a held trippoint goes (as the FIFO channel's does); input stays to be decoded."""
        self._trip = None
        self._sink = None

    def close(self) -> None:
        """The connection went: a held trippoint and a command cut mid-line go."""
        self._trip = None
        self._sink = None
        self._in.clear()
        self._dropping = False

    def serve(self) -> bytes:
        """Decode what the input holds until a trippoint holds the channel, at most MAX_BATCH
        commands (`more` tells whether input is left); the replies."""
        out = bytearray()
        self.more = False
        budget = MAX_BATCH
        while True:
            if not budget:
                self.more = bool(self._in)
                break
            trip = self._trip
            if trip is not None:
                if not trip.ready():
                    break
                self._trip = None
                out += OK
            if self._sink is not None:  # QD's data, not commands (as Firmware.serve)
                used, code = self._sink.feed(bytes(self._in))
                del self._in[:used]
                if code is None:
                    break
                self._sink = None
                self.fw.error_code = code or self.fw.error_code
                out += b"?" if code else OK
                continue
            if self._dropping and not self._drop():
                break
            window = bytes(self._in[: MAX_COMMAND + 1])
            frame, used = _next_frame(window)
            if frame is None and not used and len(window) > MAX_COMMAND:
                self.fw.error_code = int(TC.INPUT_BUFFER_FULL)
                out += b"?"
                self._dropping = True
                continue
            if used:
                del self._in[:used]
            if frame is None:
                if used:
                    continue
                break
            budget -= 1
            result = self._execute(frame)
            if isinstance(result, Trippoint):
                self._trip = result
            elif isinstance(result, (ArrayDownload, ProgramDownload)):
                self._sink = result
            else:
                out += result
        return bytes(out)

    def _drop(self) -> bool:
        """Drop an overlong command through its terminator; whether it ended."""
        found = _TERMINATOR.search(self._in)
        if found is None:
            self._in.clear()
            return False
        del self._in[: found.end()]
        self._dropping = False
        return True

    def _execute(self, frame: syntax.Frame) -> bytes | Trippoint | ArrayDownload | ProgramDownload:
        """A command as the FIFO channel runs it (Firmware._execute), without echo and without
        the VME command-done interrupt (both belong to the bus)."""
        interp = self.fw.interp
        if not frame.binary:
            return interp.execute(frame.data.decode("latin-1"))
        try:
            text = syntax.binary_to_ascii(syntax.decode_binary(frame.data))
        except GalilError as exc:
            self.fw.error_code = exc.code
            return b"?"
        return interp.execute(text)
