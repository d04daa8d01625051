"""vdevclient: talk to a vdevd rack (`connect`) and, in the vendor modules, to its cards as the
vendor libraries do."""

from vdevclient.core import Card, CardInfo, Irq, Rack, Region, RegionInfo, Sim, connect
from vdevclient.errors import (
    ConfigurationError,
    DaemonGone,
    RackClosed,
    RemoteError,
    RequestTooLarge,
    VdevClientError,
    VdevTimeout,
)

__all__ = [
    "Card",
    "CardInfo",
    "ConfigurationError",
    "DaemonGone",
    "Irq",
    "Rack",
    "RackClosed",
    "Region",
    "RegionInfo",
    "RemoteError",
    "RequestTooLarge",
    "Sim",
    "VdevClientError",
    "VdevTimeout",
    "connect",
]
