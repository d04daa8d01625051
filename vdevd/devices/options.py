"""Card options, declared once (DESIGN.md "One card shape").

A card class declares its configuration keys as `Option`s (type, default, range or choices,
help). `parse_options` checks a `[[card]]` table against that declaration, fills the defaults and
returns one frozen `CardOptions` the card reads by attribute (`opts.axes`), so a legal 0 stays 0 and
nothing is parsed twice. The keys every card has beside its own: `period_ns` (None: the card's
own default) and `axis` (the `[[card.axis]]` tables of the axis world, vdevd/rt/world.py), at
most one per axis of the option that counts the card's axes (`Card.axes_option`), which also
sets the length of a `per_axis` list option. `vdevd types` prints the same declarations.
"""

from __future__ import annotations

from collections.abc import Iterator, Mapping
from dataclasses import dataclass
from fractions import Fraction
from types import MappingProxyType
from typing import Any

from vdevd.rt.world import AxisMechanics

#: most [[card.axis]] tables a card may have
MAX_AXIS_TABLES = 32


@dataclass(frozen=True)
class Option:
    """A card configuration key: its type, default and allowed range or choices. A list option
    has choices for its entries, no range; `per_axis`: one entry per axis of the card."""

    type: type | tuple[type, ...]
    default: Any = None
    min: float | None = None
    max: float | None = None
    choices: tuple[Any, ...] | None = None
    help: str = ""
    per_axis: bool = False

    def __post_init__(self) -> None:
        types = self.type if isinstance(self.type, tuple) else (self.type,)
        if list in types and (self.min is not None or self.max is not None):
            raise TypeError("a list option has no min or max (choices apply to its entries)")
        if self.per_axis and types != (list,):
            raise TypeError("a per_axis option is a list")

    def check(self, key: str, value: Any) -> Any:
        """Return the value if valid, else raise ValueError naming `key`."""
        types = self.type if isinstance(self.type, tuple) else (self.type,)
        ok_type = isinstance(value, self.type) and not (isinstance(value, bool)
                                                        and bool not in types)
        if not ok_type and self.type is float and isinstance(value, int):
            value, ok_type = float(value), not isinstance(value, bool)
        if not ok_type:
            raise ValueError(f"{key}: expected {_type_name(self.type)}, got {value!r}")
        if self.choices is not None:
            items = value if isinstance(value, list) else [value]
            bad = [v for v in items if v not in self.choices]
            if bad:
                raise ValueError(f"{key}: {bad[0]!r} is not one of {list(self.choices)}")
        if self.min is not None and value < self.min:
            raise ValueError(f"{key}: {value!r} is below the minimum {self.min:g}")
        if self.max is not None and value > self.max:
            raise ValueError(f"{key}: {value!r} is above the maximum {self.max:g}")
        return value

    def describe(self) -> str:
        """One line for `vdevd types`: type, range or choices, help."""
        parts = [_type_name(self.type)]
        if self.choices is not None:
            parts.append("one of " + ", ".join(map(str, self.choices)))
        if self.min is not None or self.max is not None:
            parts.append(f"{'' if self.min is None else f'{self.min:g}'}.."
                         f"{'' if self.max is None else f'{self.max:g}'}")
        return f"{'; '.join(parts)}  {self.help}".rstrip()


def _type_name(t: type | tuple[type, ...]) -> str:
    if isinstance(t, tuple):
        return " or ".join(x.__name__ for x in t)
    return t.__name__


#: the keys every [[card]] table may have beside its type's own (and `type`, `name`)
COMMON_OPTIONS: Mapping[str, Option] = {
    "period_ns": Option((int, Fraction), None, min=1,
                        help="servo period in ns (default: the card's own; exact as a Fraction)"),
}


class CardOptions(Mapping[str, Any]):
    """A card's configuration, checked and defaulted: read-only, by attribute or by key."""

    __slots__ = ("_values",)

    def __init__(self, values: Mapping[str, Any]) -> None:
        object.__setattr__(self, "_values", MappingProxyType(dict(values)))

    def __getattr__(self, name: str) -> Any:
        try:
            return self._values[name]
        except KeyError:
            raise AttributeError(f"no card option {name!r}") from None

    def __setattr__(self, name: str, value: Any) -> None:
        raise AttributeError("card options are read-only")

    def __getitem__(self, key: str) -> Any:
        return self._values[key]

    def __iter__(self) -> Iterator[str]:
        return iter(self._values)

    def __len__(self) -> int:
        return len(self._values)

    def __repr__(self) -> str:
        return f"CardOptions({dict(self._values)!r})"

    def __reduce__(self) -> tuple[type[CardOptions], tuple[dict[str, Any]]]:
        """Pickled as its values (a rack snapshot, vdevd/snapshot.py)."""
        return CardOptions, (dict(self._values),)

    @property
    def axis(self) -> tuple[AxisMechanics, ...]:
        """The `[[card.axis]]` tables, in the card's axis order."""
        return self._values["axis"]


def parse_options(declared: Mapping[str, Option], table: Mapping[str, Any], where: str = "card",
                  axes_option: str = "axes") -> CardOptions:
    """`table`'s keys checked against `declared` (and the common keys), defaults filled in.
    ValueError names the key (`card[1].axes: ...`); `type` and `name` are ignored here.
    `axes_option`: the declared key that counts the card's axes, which bounds the `axis`
    tables and sets the length of the `per_axis` options."""
    if isinstance(table, CardOptions):
        return table
    values: dict[str, Any] = {}
    for key, value in table.items():
        if key in ("type", "name"):
            continue
        if key == "axis":
            values[key] = _axis_tables(value, f"{where}.axis")
            continue
        opt = declared.get(key) or COMMON_OPTIONS.get(key)
        if opt is None:
            known = ", ".join(["type", "name", *COMMON_OPTIONS, "axis", *declared])
            raise ValueError(f"{where}.{key}: unknown key (keys: {known})")
        values[key] = None if value is None and opt.default is None else opt.check(
            f"{where}.{key}", value)
    for key, opt in (*COMMON_OPTIONS.items(), *declared.items()):
        values.setdefault(key, opt.default)
    values.setdefault("axis", ())
    if axes_option in declared:
        _check_axis_counts(declared, values, where, axes_option)
    return CardOptions(values)


def _check_axis_counts(declared: Mapping[str, Option], values: Mapping[str, Any], where: str,
                       axes_option: str) -> None:
    """At most one `[[card.axis]]` table per axis, one entry per axis in a `per_axis` list."""
    n = values[axes_option]
    if len(values["axis"]) > n:
        raise ValueError(f"{where}.axis: {len(values['axis'])} [[card.axis]] tables for {n} axes")
    for key, opt in declared.items():
        value = values[key]
        if opt.per_axis and value is not None and len(value) != n:
            raise ValueError(f"{where}.{key}: {len(value)} entries for {n} axes")


def _axis_tables(value: Any, where: str) -> tuple[AxisMechanics, ...]:
    if isinstance(value, tuple) and all(isinstance(m, AxisMechanics) for m in value):
        return value
    if not isinstance(value, list) or len(value) > MAX_AXIS_TABLES:
        raise ValueError(f"{where}: use [[card.axis]] tables, one per axis (at most "
                         f"{MAX_AXIS_TABLES})")
    return tuple(AxisMechanics.parse(t, f"{where}[{i}]") for i, t in enumerate(value))
