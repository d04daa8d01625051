"""Host interrupts: the main switch, the factors of the 11 items, and the signaled flags the
host waits on [M §4.11; spec adlink.md §2.23].

The kernel (`Kernel.events`) sets a factor's flag in Bar.INT_SIGNAL on the rising edge of its
condition while the factor is enabled and the main switch is on, and asserts `inta`; a flag
stays set until APS_reset_int. The client waits on these words in the daemon (a `wait` op), so
Int_No (board x 352 + item x 32 + factor, spec §2.23 ASSUMPTION) is the client's to compute:
the kernel speaks items and factors.
"""

from __future__ import annotations

from typing import TYPE_CHECKING

from vdevmaps.aps_defs import (
    INT_DI_COUNT,
    INT_ITEM_COUNT,
    INT_ITEM_DI_FALLING,
    INT_ITEM_DI_RISING,
    INT_ITEM_SYSTEM,
    IPOSTD,
    ERR_InterruptNotEnable,
)

from vdevd.devices.adlink.errors import ApsError, invalid

if TYPE_CHECKING:
    from vdevd.devices.adlink.kernel import Kernel

#: the factors an axis item has; 7, 14, 17 and 20-31 are reserved [M §4.11, L3355]
AXIS_FACTORS = frozenset(range(IPOSTD + 1)) - {7, 14, 17}
#: the system item's: IEMG, ILCF0/1, IFCF0/1, IMOV, IHOV; 7+ reserved [M §4.11, L3391]
SYSTEM_FACTORS = frozenset(range(7))


def valid_factors(k: Kernel, item: int) -> frozenset[int]:
    """The factors `item` has on this card (-10 for an item it has not): axis items 0..n-1
    (4-7 are reserved on the AMP-204C), the system item, the DI items (EDI4-7 absent on the
    204C, as in its DI word)."""
    if isinstance(item, bool) or not 0 <= item < INT_ITEM_COUNT:
        raise invalid(f"item {item} outside 0..{INT_ITEM_COUNT - 1}")
    if item < INT_ITEM_SYSTEM:
        if item >= k.n:
            raise invalid(f"item {item}: the card has axes 0..{k.n - 1}")
        return AXIS_FACTORS
    if item == INT_ITEM_SYSTEM:
        return SYSTEM_FACTORS
    assert item in (INT_ITEM_DI_RISING, INT_ITEM_DI_FALLING)
    lines = range(INT_DI_COUNT) if k.n == 8 else [*range(4), *range(8, INT_DI_COUNT)]
    return frozenset(lines)


def _bit(k: Kernel, item: int, factor: int) -> int:
    if factor not in valid_factors(k, item):
        raise invalid(f"factor {factor} of item {item} is reserved")
    return 1 << factor


def int_enable(k: Kernel, enable: int) -> None:
    """APS_int_enable: the main switch; while it is off no event is signaled. The flags already
    signaled stay (an event is only reset by APS_reset_int) [M §4.11]."""
    if enable not in (0, 1):
        raise invalid(f"Enable {enable} not 0 or 1")
    k.int_main = bool(enable)


def set_int_factor(k: Kernel, item: int, factor: int, enable: int) -> None:
    """APS_set_int_factor: enable (1) or close (0) one event. Closing also clears its flag, so
    a factor enabled again starts non-signaled. A condition already true when the factor is
    enabled fires at its next rising edge only (spec §2.23 ASSUMPTION)."""
    bit = _bit(k, item, factor)
    if enable not in (0, 1):
        raise invalid(f"Enable {enable} not 0 or 1")
    if enable:
        k.int_enable[item] |= bit
    else:
        k.int_enable[item] &= ~bit & 0xFFFFFFFF
        k.reset_signal(item, bit)


def get_int_factor(k: Kernel, item: int, factor: int) -> int:
    return int(bool(int(k.int_enable[item]) & _bit(k, item, factor)))


def reset_int(k: Kernel, item: int, factor: int) -> None:
    """APS_reset_int: the event back to non-signaled [M §4.11 step (4)]."""
    k.reset_signal(item, _bit(k, item, factor))


def set_int(k: Kernel, item: int, factor: int) -> None:
    """APS_set_int: signal an event by software; it must be open (enabled), else -8 (the DLL
    has no event object for a closed factor) [M §4.11]."""
    bit = _bit(k, item, factor)
    if not int(k.int_enable[item]) & bit:
        raise ApsError(ERR_InterruptNotEnable, f"factor {factor} of item {item} is closed")
    k.signal(item, bit)
