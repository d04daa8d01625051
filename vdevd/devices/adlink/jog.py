"""Jog moves [M §4.5; spec adlink.md §2.8]."""

from __future__ import annotations

from typing import TYPE_CHECKING

from vdevmaps.aps_defs import ERR_FunctionNotAvailable

from vdevd.devices.adlink.errors import ApsError

if TYPE_CHECKING:
    from vdevd.devices.adlink.kernel import Kernel


def jog_start(k: Kernel, a: int, on: int) -> None:
    """APS_jog_start: not yet built."""
    k.check_axis(a)
    raise ApsError(ERR_FunctionNotAvailable, "jogging is being built")
