"""Home moves [M §4.3; spec adlink.md §2.6]."""

from __future__ import annotations

from typing import TYPE_CHECKING

from vdevmaps.aps_defs import ERR_FunctionNotAvailable

from vdevd.devices.adlink.errors import ApsError

if TYPE_CHECKING:
    from vdevd.devices.adlink.kernel import Kernel


def home_move(k: Kernel, a: int) -> None:
    """APS_home_move: not yet built."""
    k.check_axis(a)
    raise ApsError(ERR_FunctionNotAvailable, "homing is being built")
