"""The state of a card's firmware objects as bytes, for `Card.rest_state` (decision 0008).

A card at rest is one whose state a tick leaves unchanged: the card compares its state around one
tick. Listing by hand what each firmware object keeps is how a field gets forgotten, so
`state_bytes` takes every numpy array and every plain number or flag an object holds (its
`vars`), minus the counters the card advances in closed form (`skip`): a field added later is in
the comparison by default, and a forgotten one can only make the card rest less often, never
wrongly.
"""

from __future__ import annotations

from collections.abc import Collection

import numpy as np


def ticks_before_multiple(count: int, every: int) -> int:
    """The ticks after tick `count` that come before the next one whose count is a multiple of
    `every` (a periodic event at every `every`-th tick): what a card at rest may skip."""
    return (-count - 1) % every


def state_bytes(*objs: object, skip: Collection[str] = ()) -> bytes:
    """Every array (its bytes) and every int, float or bool (its repr) of the objects' `vars`,
    in attribute order; the attributes named in `skip` are left out."""
    parts: list[bytes] = []
    add = parts.append
    for obj in objs:
        for name, value in vars(obj).items():
            if name in skip:
                continue
            if isinstance(value, np.ndarray):
                add(value.tobytes())
            elif isinstance(value, (int, float)):  # bool is an int
                add(repr(value).encode())
    return b"\0".join(parts)
