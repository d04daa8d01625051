"""Galil's `gclib` Python module for vdevd's virtual cards: a drop-in for an unchanged script.

Put this directory first on the module path and `import gclib` finds this module instead of
Galil's (which loads libgclib)::

    PYTHONPATH=$(vdevctl dropin-path) python their_script.py

    g = gclib.py()
    g.GOpen("192.168.0.42 --direct -s ALL")  # the galil-dmc13x8 card whose `address` this is,
    print(g.GInfo())                         # on the daemon at $VDEVD_ENDPOINT
    print(g.GCommand("MG _TPX"))

`py` is `vdevclient._gclib_dropin.py` (GOpen by address, GInfo, GAddresses) over
`vdevclient.gclib.py`; every other name of `vdevclient.gclib` (GclibError, the G_ codes) is this
module's too, those added there later included.
"""

from __future__ import annotations

from typing import Any

from vdevclient import gclib as _gclib
from vdevclient._gclib_dropin import py
from vdevclient.gclib import GclibError

__all__ = ["GclibError", "py", *sorted(n for n in vars(_gclib) if n.startswith("G_"))]


def __getattr__(name: str) -> Any:
    """Any other name of vdevclient.gclib (PEP 562)."""
    try:
        return getattr(_gclib, name)
    except AttributeError:
        raise AttributeError(f"module 'gclib' has no attribute {name!r}") from None
