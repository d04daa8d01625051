"""PComm32's data gathering functions (Gather.h of PComm32: PmacSetGatherPeriod ...
PmacCollectGatherData, PmacGetGatherSamples) over the card's on-line commands: I5000 mode, I5001-
I5048 sources, I5049 period, I5050/I5051 masks, DEFINE GATHER, GATHER, ENDGATHER, LIST GATHER
(the card's README "Data gathering"). Re-exported from `vdevclient.pcomm`.

The digest's PComm32 table (spec pmac.md §3.1) lists no gather function; the names, arguments and
GATMODE values follow PComm32's Gather.h. ASSUMPTIONS (README "Data gathering"): `num`/`source`
are source numbers 0-47 (I5001 is source 0, as Gather.h's `bGatherEnabled[MAXGATHERS2]`);
PmacSetGather's text is `X:$addr`, `Y:$addr`, `D:$addr` (48-bit integer), `L:$addr` (48-bit
float) or the raw I50nn value `$8000B`; PmacStartGather/PmacStopGather answer 1 when the card
took the command, else 0; gathered values are the registers' own units (a 24-bit word as a signed
integer, a D: word as a signed 48-bit integer, an L: word as its float): Gather.h's
`dGatherScale` rules were not retrieved.

With I5000 = 2 or 3 (GAT_DPR_NOWRAP, GAT_DPR_WRAP) the card gathers into the DPRAM (its README
"Data gathering"): PmacInitGather sizes the buffer in 32-bit DPRAM words (no pad word) and
PmacCollectGatherData reads the samples from 0x1140 up to the next-item offset at 0x113E
(`_pcomm_dprgather.py`).
"""

from __future__ import annotations

import ctypes
import math
from dataclasses import dataclass, field
from typing import Any

from vdevclient._cargs import put_text as _put_text
from vdevclient._cargs import target as _target
from vdevclient._cargs import text as _text
from vdevclient._pcomm_codes import COMM_EOT
from vdevclient._pcomm_device import _Device, _guarded, _number
from vdevclient._pcomm_dprgather import dpram_samples
from vdevclient._pmac_bus import join48, pmac_float, sign24

MAXGATHERS2 = 48
GAT_RAM_NOWRAP, GAT_RAM_WRAP, GAT_DPR_NOWRAP, GAT_DPR_WRAP = range(4)  # GATMODE [Gather.h]
#: I5001-I5048 format digit <-> the M-variable style prefix PmacSetGather/PmacGetGather use
_PREFIX = {0x0: "Y", 0x4: "X", 0x8: "D", 0xC: "L"}
_DIGIT = {v: k for k, v in _PREFIX.items()}


@dataclass
class GatherData:
    """What PmacCollectGatherData uploaded: per gathered source number, its values."""

    samples: int = 0
    values: dict[int, list[float]] = field(default_factory=dict)


def _ok(dev: _Device, line: str) -> bool:
    return dev.response(line.encode("latin-1"))[1] == COMM_EOT


def _ivar(dev: _Device, n: int) -> int:
    number = _number(dev.get_variable("I", n))
    return int(number) if number is not None and math.isfinite(number) else 0


def _put_number(param: Any, value: float) -> None:
    dest = _target(param)
    if isinstance(dest, list):
        dest[:] = [value]
    elif dest is not None:
        dest.value = value


def _servo_ms(dev: _Device) -> float:
    """The servo period, ms: I10 / 2^23 [PMAC1-SRM p.46]."""
    return _ivar(dev, 10) / 8388608.0


def _mask(dev: _Device) -> int:
    return _ivar(dev, 5050) | _ivar(dev, 5051) << 24


def _enabled(dev: _Device) -> list[tuple[int, int]]:
    """(source number, I50nn value) of every enabled source, in source order."""
    mask = _mask(dev)
    return [(k, _ivar(dev, 5001 + k)) for k in range(MAXGATHERS2) if mask >> k & 1]


# -- configuration ---------------------------------------------------------------------------------
@_guarded(0)
def PmacGetGatherPeriod(dev: _Device) -> int:
    """I5049: servo cycles per sample."""
    return _ivar(dev, 5049)


@_guarded(0)
def PmacSetGatherPeriod(dev: _Device, period: int) -> int:
    """I5049 := period; the period the card holds."""
    _ok(dev, f"I5049={int(period)}")
    return _ivar(dev, 5049)


@_guarded(0.0)
def PmacGetGatherSampleTime(dev: _Device) -> float:
    """The time between samples, ms: I5049 (0 counts as 1) servo periods."""
    return max(_ivar(dev, 5049), 1) * _servo_ms(dev)


@_guarded(0.0)
def PmacSetGatherSampleTime(dev: _Device, msec: float) -> float:
    """I5049 := the servo cycles nearest `msec` (at least 1); the sample time that gives, ms."""
    servo = _servo_ms(dev)
    period = max(round(float(msec) / servo), 1) if servo > 0 else 1
    _ok(dev, f"I5049={period}")
    return period * servo


@_guarded(False)
def PmacGetGatherEnable(dev: _Device, num: int) -> bool:
    """Source `num` (0-47) enabled in I5050/I5051."""
    return 0 <= int(num) < MAXGATHERS2 and bool(_mask(dev) >> int(num) & 1)


@_guarded(False)
def PmacSetGatherEnable(dev: _Device, num: int, ena: Any) -> bool:
    """Enable or disable source `num` (0-47) in I5050/I5051."""
    num = int(num)
    if not 0 <= num < MAXGATHERS2:
        return False
    n, bit = (5050, num) if num < 24 else (5051, num - 24)
    value = _ivar(dev, n)
    value = value | 1 << bit if ena else value & ~(1 << bit)
    return _ok(dev, f"I{n}=${value:X}")


@_guarded(False)
def PmacSetGather(dev: _Device, num: int, str_: Any, ena: Any) -> bool:
    """Source `num` (0-47) := `str_` (`D:$8B`, `X:$9D`, `Y:$...`, `L:$6001` or `$80008B`), and
    enabled or disabled; False when the card refuses the address (ERR003)."""
    num = int(num)
    spec = _text(str_).decode("latin-1").strip().upper().replace(" ", "")
    if not 0 <= num < MAXGATHERS2 or not spec:
        return False
    if spec[0] in _DIGIT and spec[1:2] == ":":
        addr = spec[2:]
        value = _DIGIT[spec[0]] << 20 | (int(addr[1:], 16) if addr.startswith("$") else int(addr))
    else:
        value = int(spec[1:], 16) if spec.startswith("$") else int(spec)
    return _ok(dev, f"I{5001 + num}=${value:X}") and PmacSetGatherEnable(dev.number, num, ena)


@_guarded(False)
def PmacGetGather(dev: _Device, num: int, s: Any, maxchar: int) -> bool:
    """Source `num`'s address as `D:$00008B` into `s`."""
    num = int(num)
    if not 0 <= num < MAXGATHERS2:
        return False
    value = _ivar(dev, 5001 + num)
    text = f"{_PREFIX.get(value >> 20, '?')}:${value & 0xFFFFF:06X}".encode()
    _put_text(s, maxchar, text)
    return True


@_guarded(GAT_RAM_NOWRAP)
def PmacGetGatherMode(dev: _Device) -> int:
    """I5000 as GATMODE."""
    return _ivar(dev, 5000)


@_guarded(False)
def PmacSetGatherMode(dev: _Device, mode: int) -> bool:
    """I5000 := mode (0-3: GAT_RAM_NOWRAP ... GAT_DPR_WRAP)."""
    return _ok(dev, f"I5000={int(mode)}")


@_guarded(False)
def PmacInitGather(dev: _Device, size: int, msec: float) -> bool:
    """A buffer for `size` samples of the enabled sources (DELETE GATHER, DEFINE GATHER in 48-bit
    words: each sample padded to whole 48-bit words) and the sample time nearest `msec`."""
    words = sum(2 if v >> 23 else 1 for _, v in _enabled(dev))
    if not words or int(size) < 1:
        return False
    PmacSetGatherSampleTime(dev.number, msec)
    reserve = words * int(size) if _ivar(dev, 5000) >= 2 else (words + 1) // 2 * int(size)
    return _ok(dev, "DELETE GATHER") and _ok(dev, f"DEFINE GATHER {reserve}")


@_guarded(False)
def PmacInitPlotGather(dev: _Device, size: int, period: int) -> bool:
    """As PmacInitGather with the period in servo cycles."""
    PmacSetGatherPeriod(dev.number, period)
    return bool(PmacInitGather(dev.number, size, PmacGetGatherSampleTime(dev.number)))


@_guarded(None)
def PmacClearGather(dev: _Device) -> None:
    """Gathering off, no source enabled, the buffer deleted, the uploaded data dropped."""
    _ok(dev, "ENDGATHER I5050=0 I5051=0 DELETE GATHER")
    dev.gather = None


@_guarded(0)
def PmacStartGather(dev: _Device) -> int:
    """GATHER: 1 when the card started gathering, 0 when it refused (no buffer, no source)."""
    return int(_ok(dev, "GATHER"))


@_guarded(0)
def PmacStopGather(dev: _Device) -> int:
    """ENDGATHER: 1 when the card took it."""
    return int(_ok(dev, "ENDGATHER"))


# -- upload ----------------------------------------------------------------------------------------
def _decode(fmt: int, words: list[int]) -> float:
    if fmt == 0xC:
        return pmac_float(words[0], words[1])
    if fmt == 0x8:
        return float(join48(words[0], words[1]))
    return float(sign24(words[0]))


@_guarded(False)
def PmacCollectGatherData(dev: _Device, sources: Any, samples: Any) -> bool:
    """Upload the buffer (LIST GATHER) and split it by the enabled sources; the number of
    sources and of samples into `sources` and `samples` (c_uint, byref, or a list)."""
    enabled = _enabled(dev)
    sizes = [2 if v >> 23 else 1 for _, v in enabled]
    if not enabled:
        return False
    if _ivar(dev, 5000) >= 2:  # the DPRAM buffer: no pad word
        per_sample = sum(sizes)
        stream = dpram_samples(dev, per_sample)
    else:
        data, status = dev.response(b"LIST GATHER")
        if status != COMM_EOT:
            return False
        stream = [int(part, 16) for tok in data.decode("latin-1").split()
                  for part in (tok[6:], tok[:6])]
        per_sample = sum(sizes) + sum(sizes) % 2
    count = len(stream) // per_sample
    values: dict[int, list[float]] = {k: [] for k, _ in enabled}
    for i in range(count):
        at = i * per_sample
        for (k, v), size in zip(enabled, sizes, strict=True):
            values[k].append(_decode(v >> 20, stream[at:at + size]))
            at += size
    dev.gather = GatherData(count, values)
    _put_number(sources, len(enabled))
    _put_number(samples, count)
    return True


def _data(dev: _Device) -> GatherData:
    got = dev.gather
    return got if isinstance(got, GatherData) else GatherData()


@_guarded(0)
def PmacGetNumGatherSources(dev: _Device) -> int:
    return len(_data(dev).values)


@_guarded(0)
def PmacGetNumGatherSamples(dev: _Device) -> int:
    return _data(dev).samples


@_guarded(False)
def PmacGetGatherSamples(dev: _Device, source: int, samples: Any, p: Any, max_: int) -> bool:
    """Source `source`'s uploaded values, at most `max_`, into `p` (a ctypes double array or a
    list); their number into `samples`. False for a source that was not gathered."""
    values = _data(dev).values.get(int(source))
    if values is None:
        return False
    got = values[:max(int(max_), 0)]
    dest = _target(p)
    if isinstance(dest, list):
        dest[:] = got
    elif dest is not None:
        for i, v in enumerate(got[:len(dest)] if isinstance(dest, ctypes.Array) else got):
            dest[i] = v
    _put_number(samples, len(got))
    return True


@_guarded(False)
def PmacGetGatherPoint(dev: _Device, source: int, sample: int, p: Any) -> bool:
    """One uploaded value into `p` (c_double, byref, or a list)."""
    values = _data(dev).values.get(int(source))
    if values is None or not 0 <= int(sample) < len(values):
        return False
    _put_number(p, values[int(sample)])
    return True


@_guarded(None)
def PmacClearGatherData(dev: _Device) -> None:
    """Drop the uploaded data."""
    dev.gather = None
