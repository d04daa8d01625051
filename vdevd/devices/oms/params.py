"""Per-axis parameters of the MAXk: factory defaults, ranges (spec oms.md §1.4, §4.3, §4.4).

Numeric parameters are float arrays, one element per axis (`Params.values["VL"]`); the axis
configuration (type, polarities, limit mode, closed loop) is kept beside them as small arrays.
The home logic's truth table (`HT`/`EH`, `home_pattern`) is kept here too, beside the home switch
polarity. The whole set is, with the I/O configuration (defaults.py), what `APP` stores as the
power-up defaults and `RDF`/`RDP` restore [S §2.14].
User units (UU) and the encoder ratio (ER) change how operands and replies read (`scale`,
`format`); inside, everything stays in counts.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Any

import numpy as np


@dataclass(frozen=True)
class Param:
    """One numeric per-axis parameter: default and the accepted range (outside: command error)."""

    default: float
    lo: float
    hi: float
    integer: bool = False  # truncated toward zero (spec §4.1: `MR<n>.9`)

    def coerce(self, value: float) -> float | None:
        if not math.isfinite(value):
            return None
        if self.integer:
            value = float(math.trunc(value))
        return value if self.lo <= value <= self.hi else None


_GAIN = Param(0, 0, 32767)
#: the numeric parameters [S §1.4, §2.13-2.14; spec §4.3]
PARAMS: dict[str, Param] = {
    "VL": Param(200_000, 1, 4_194_303, integer=True),
    "VB": Param(0, 0, 4_194_303, integer=True),
    "AC": Param(2_000_000, 1, 8_000_000, integer=True),
    "KP": Param(10, 0, 32767),
    "KI": Param(1, 0, 32767),
    "KD": Param(160, 0, 32767),
    "KU": _GAIN,
    "KV": _GAIN,
    "KA": _GAIN,
    "KF": _GAIN,
    "KO": Param(0, -32767, 32767),
    "HD": Param(0, 0, 2_147_483_647, integer=True),
    "HG": Param(1, 1, 32000),
    "HV": Param(0, 0, 4_194_303, integer=True),
    "ES": Param(0, 0, 2_147_483_647, integer=True),  # slip tolerance (mnemonic assumed)
    "SE": Param(0, 0, 1000, integer=True),  # aux output settle time, ms (assumed)
}

#: axis types as PS? reports them [spec §4.2]: O open-loop stepper, E stepper + encoder, M servo
AXIS_TYPES = {"stepper": "O", "stepper_encoder": "E", "servo": "M"}
#: the velocity profiles of a move from rest [S §2.14, App C; spec §5.2, a per-axis attribute]
PROFILES = ("linear", "parabolic", "scurve")
#: the servo DAC output: +-10 V, or 0-10 V with the sign on the direction output [spec §5.3]
SERVO_OUTPUTS = ("bipolar", "unipolar")

#: commands whose operand is a position, velocity or acceleration, of the motor or (LPE) of the
#: encoder: in user units when UU is on [spec §4.1, §4.3 UU], and on a PSE axis with an encoder
#: ratio in encoder counts ("all distance, velocity and acceleration parameters being input in
#: encoder counts", spec §4.3 ER)
UNIT_OPERANDS = {
    **{m: "motor" for m in ("MA", "MR", "MT", "LP", "LO", "HM", "HR", "KM", "KR", "JG", "VL",
                            "VB", "HV", "AC")},
    "LPE": "encoder",
}


#: the terms of the home logic in the order `HT` takes them: encoder phase A, phase B, index, home
#: switch [S §4.3, §4.8]; `EH` takes the first three (the encoder's)
HOME_TERMS = ("A", "B", "index", "switch")
ENCODER_TERMS = 3
#: a term's entry in the truth table: 1 active (high), 0 inactive (low), 2 ignored
HOME_IGNORED = 2
#: "Home = Phase +A * Phase -B * Index * Home Switch (Default)" [S §4.8]
FACTORY_HOME_PATTERN = (1, 0, 1, 1)


def parse_home_pattern(text: str, terms: int = len(HOME_TERMS)) -> tuple[int, ...] | None:
    """A home truth table as `HT`/`EH` take it, `1,0,1,1` or `1011` (0, 1 or 2 per term), as a
    tuple of `terms` entries; None if malformed. An `X` cannot stand for "ignored": in the OMS
    syntax a letter starts the next command."""
    fields = text.split(",") if "," in text else list(text)
    if len(fields) != terms or any(f not in ("0", "1", "2") for f in fields):
        return None
    return tuple(int(f) for f in fields)


def format_home_pattern(pattern: np.ndarray) -> str:
    """`HT?`/`EH?` and the stored image: one digit per term, `1011`."""
    return "".join(str(int(t)) for t in pattern)


def defines_home(pattern: tuple[int, ...] | np.ndarray) -> bool:
    """A truth table with at least one term not ignored (all ignored would home anywhere)."""
    return any(int(t) != HOME_IGNORED for t in pattern)


class Params:
    """The working parameter set of one card."""

    def __init__(self, n: int, types: list[str]) -> None:
        self.n = n
        self.values: dict[str, np.ndarray] = {k: np.full(n, float(p.default)) for k, p in PARAMS.items()}
        self.ptype = list(types)  # "O" | "E" | "M" per axis
        self.limit_high = np.zeros(n, dtype=bool)  # LTH: limits active high (factory low)
        self.limit_mode = ["H"] * n  # H hard, S soft, F off [spec §8.11]
        self.home_high = np.zeros(n, dtype=bool)  # HH: home active high (factory low)
        # HT/EH: per axis the entries for A, B, index, switch (HOME_TERMS)
        self.home_pattern = np.tile(np.array(FACTORY_HOME_PATTERN, dtype=np.int8), (n, 1))
        self.encoder_inverted = np.zeros(n, dtype=bool)  # EDI
        self.servo_inverted = np.zeros(n, dtype=bool)  # SVP-
        # CL1 / HN; servo axes power up with the loop closed (README)
        self.closed_loop = np.array([t == "M" for t in types], dtype=bool)
        self.ratio = np.ones(n)  # ER a,b: a/b encoder counts per motor count
        self.user_units = np.zeros(n)  # UU factor; 0 = off
        self.soft_lo = np.full(n, -math.inf)
        self.soft_hi = np.full(n, math.inf)

    # -- units -----------------------------------------------------------------------------------
    def scale(self, a: int, kind: str = "motor") -> float:
        """Counts per operand unit on axis a: the UU factor (1 when off) and, for the motor of a
        PSE axis, 1/ER (its operands are encoder counts)."""
        factor = float(self.user_units[a]) or 1.0
        if kind == "motor" and self.ptype[a] == "E":
            factor /= float(self.ratio[a])
        return factor

    def format(self, a: int, counts: float, kind: str = "motor") -> str:
        """A position or velocity as RP/RE/RV reply it: whole counts; in user units when UU is
        on, fixed point with ceil(log10(UU)) decimals, 1 to 6 (at UU 1000 one count is 0.001)."""
        uu = float(self.user_units[a])
        if not uu and (kind != "motor" or self.ptype[a] != "E"):
            return str(int(round(counts)))  # scale 1: counts as they are
        value = counts / self.scale(a, kind)
        if not uu:
            return str(int(round(value)))
        decimals = min(6, max(1, math.ceil(math.log10(uu))))
        return f"{round(value, decimals) + 0.0:.{decimals}f}"  # + 0.0: no "-0.0"

    # -- the stored defaults -----------------------------------------------------------------------
    def image(self) -> dict[str, Any]:
        """The parameter part of what APP stores (msgpack-friendly, defaults.py)."""
        return {
            "values": {k: v.tolist() for k, v in self.values.items()},
            "ptype": list(self.ptype),  # a copy: later PS commands change the working list
            "limit_high": self.limit_high.tolist(),
            "limit_mode": list(self.limit_mode),
            "home_high": self.home_high.tolist(),
            "home_pattern": [format_home_pattern(row) for row in self.home_pattern],
            "encoder_inverted": self.encoder_inverted.tolist(),
            "servo_inverted": self.servo_inverted.tolist(),
            "closed_loop": self.closed_loop.tolist(),
            "ratio": self.ratio.tolist(),
            "user_units": self.user_units.tolist(),
        }

    def restore(self, image: dict[str, Any]) -> None:
        """Load an APP image; keys or axes it lacks keep their present values."""
        n = self.n
        for k, v in image.get("values", {}).items():
            if k in self.values:
                self.values[k][: min(n, len(v))] = v[:n]
        for name in ("limit_high", "home_high", "encoder_inverted", "servo_inverted",
                     "closed_loop", "ratio", "user_units"):
            if name in image:
                arr = getattr(self, name)
                v = image[name][:n]
                arr[: len(v)] = v
        for name in ("ptype", "limit_mode"):
            if name in image:
                lst = getattr(self, name)
                v = image[name][:n]
                lst[: len(v)] = v
        stored = image.get("home_pattern")
        for a, text in enumerate(stored[:n] if isinstance(stored, list) else []):
            pattern = parse_home_pattern(text) if isinstance(text, str) else None
            if pattern is not None and defines_home(pattern):
                self.home_pattern[a] = pattern
