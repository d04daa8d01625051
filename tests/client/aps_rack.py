"""A lockstep daemon with ADLINK cards, and the APS session on it, for the APS tests."""

from __future__ import annotations

import contextlib
import dataclasses
from collections.abc import Iterator
from ctypes import byref, c_int32
from typing import Any

import vdevclient
from vdevclient import aps

from tests.client.galil import card, rack_config
from vdevd.testing import DaemonThread

AMP = "adlink-amp20xc"
_LAST: dict[str, str] = {}
CYCLE_NS = 1_000_000


def amp(name: str = "amp0", **options: Any) -> Any:
    return card(AMP, name, **options)


@contextlib.contextmanager
def aps_session(*cards: Any, mode: int = 0, state_dir: str | None = None
                ) -> Iterator[tuple[DaemonThread, vdevclient.Rack]]:
    """A daemon with `cards` (one AMP-208C by default), APS_initial on it, and a rack client
    (for `sim.step` and the backdoor); APS_close at the end."""
    cfg = rack_config(*(cards or (amp(),)))
    if state_dir is not None:
        cfg = dataclasses.replace(cfg, state_dir=state_dir)
    with DaemonThread(cfg) as d, \
            vdevclient.connect(d.endpoint, d.events) as rack:
        _LAST["endpoint"] = d.endpoint
        bits = c_int32()
        assert aps.APS_initial(byref(bits), mode, endpoint=d.endpoint) == aps.ERR_NoError
        try:
            yield d, rack
        finally:
            aps.APS_close()


def _last_endpoint() -> str:
    """The endpoint of the daemon `aps_session` started last."""
    return _LAST["endpoint"]


def step_ms(rack: vdevclient.Rack, ms: float) -> None:
    rack.sim.step(ns=int(ms * 1_000_000))


def f64(getter: Any, axis: int) -> float:
    from ctypes import c_double
    v = c_double()
    assert getter(axis, byref(v)) == aps.ERR_NoError
    return v.value


def i32(getter: Any, axis: int) -> int:
    v = c_int32()
    assert getter(axis, byref(v)) == aps.ERR_NoError
    return v.value
