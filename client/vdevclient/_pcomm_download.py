"""PComm32's PmacDownloadA (spec pmac.md §3.1): a file of on-line commands preprocessed (`#define`,
`#undef`, `#ifdef`, `#include`, comments) and sent line by line through the DPRAM ASCII
handshake, batched. Re-exported from `vdevclient.pcomm`."""

from __future__ import annotations

import ctypes
import logging
from collections.abc import Callable
from pathlib import Path
from typing import Any

from vdevmaps.pmac import CMD_MAX, CR

from vdevclient._cargs import text as _text
from vdevclient._pcomm_codes import COMM_EOT, MAX_COMM_BUFFER
from vdevclient._pcomm_device import _Device, _guarded, _reply
from vdevclient._pmac_bus import PreprocessError, parse_slot, preprocess

log = logging.getLogger("vdevclient.pcomm")  # the public module's logger

DOWNLOAD_CHUNK = 32  # download lines sent per batch


@_guarded(0)
def PmacDownloadA(dev: _Device, msgproc: Any, getproc: Any, progress: Any, filename: Any,
                  macro: bool = True, map: bool = False, log: bool = False, dnld: bool = True) -> int:
    """Download a file of on-line commands: preprocess it (comments after `;` or `//`, blank
    lines, `#define NAME value` replaced as whole words when `macro`), then send it line by line
    when `dnld`; stop at the first ERRnnn. 1 when every line was accepted, 0 otherwise.

    `msgproc(str, newline)` receives the error ("file:line: text: ERRnnn") and a closing
    message, `progress(percent)` the progress after each batch. With an empty `filename`, lines
    come from `getproc(index, buffer, maxlen)` (a ctypes buffer it fills; 0 ends) instead.
    `#include "file"` (relative to the downloaded file's folder; not from getproc), `#undef`
    and `#ifdef`/`#ifndef`/`#else`/`#endif` as PComm's preprocessor does them. Not supported
    (PreprocessError, reported through msgproc): `#if`/`#elif` expressions, macros with
    arguments. `map` and `log` (the map and log files PComm
    writes) are ignored. Lines go DOWNLOAD_CHUNK to a batch; a line that answers data or an
    error ends its batch early (a zero-time `wait` for the ACK gates the next line)."""
    name = _text(filename).decode("latin-1")
    say = _messenger(msgproc)
    try:
        if name:
            path = Path(name)
            source = path.read_text(encoding="latin-1")
            lines = preprocess(source, bool(macro), _read_include, str(path.resolve()))
        else:
            lines = preprocess(_from_getproc(getproc), bool(macro))
    except (OSError, PreprocessError) as exc:
        say(f"{name or 'download'}: {exc}")
        return 0
    if not dnld:
        return 1
    i = 0
    while i < len(lines):
        chunk = lines[i:i + DOWNLOAD_CHUNK]
        ops = dev.begin()
        marks = []
        for _, text, _ in chunk:
            dev.command_ops(text.encode("latin-1")[:CMD_MAX - 1], ops)
            marks.append(len(ops))
            ops += (dev.slot, dev.gate, dev.ack)
        res = dev.batch(ops)
        for k, at in enumerate(marks):
            if res[at + 1] is not None and res[at + 1]["fired"]:
                continue
            first = parse_slot(res[at])  # this line answered data, an error or nothing yet
            if first is not None and first.terminator != CR:
                posted, done = [first], True
                dev.pending.append(dev.ack)
            else:
                posted, done = dev.collect([], None, [first] if first else [], need_ack=first is not None)
            data, status = _reply(posted, done)
            if status != COMM_EOT:
                number, text, inner = chunk[k]
                what = data.decode("latin-1").strip("\x07\r").split("\r")[-1] or "no response"
                say(f"{inner or name or 'download'}:{number}: {text}: {what}")
                return 0
            i += k + 1
            break
        else:
            i += len(chunk)
        if progress is not None:
            progress(100 * i // len(lines))
    say(f"{name or 'download'}: {len(lines)} lines downloaded")
    return 1


#: the largest file #include reads (bounded input)
MAX_INCLUDE_BYTES = 16 << 20


def _read_include(name: str, where: str) -> tuple[str, str]:
    """An #include's text and resolved path: `name` relative to the including file's folder
    (`where`, a file's resolved path), as PComm's preprocessor looks for it first."""
    path = (Path(where).parent / name).resolve()
    if path.stat().st_size > MAX_INCLUDE_BYTES:
        raise OSError(f"larger than {MAX_INCLUDE_BYTES} bytes")
    return path.read_text(encoding="latin-1"), str(path)


def _messenger(msgproc: Any) -> Callable[[str], None]:
    def say(text: str) -> None:
        log.info("PmacDownloadA: %s", text)
        if msgproc is not None:
            # a ctypes callback (it has argtypes) takes LPSTR as bytes, a Python one a str
            msgproc(text.encode("latin-1") if hasattr(msgproc, "argtypes") else text, True)

    return say


def _from_getproc(getproc: Any) -> str:
    if getproc is None:
        return ""
    out = []
    buf = ctypes.create_string_buffer(MAX_COMM_BUFFER)
    for index in range(1 << 20):
        if getproc(index, buf, MAX_COMM_BUFFER) <= 0:
            break
        out.append(buf.value.decode("latin-1"))
    return "\n".join(out)
