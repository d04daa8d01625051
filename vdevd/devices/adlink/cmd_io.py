"""Kernel commands of the digital I/O words [spec adlink.md §2.18, §4.6]: group 0 only; the DI
word bits 0-7 EDI, 8-23 TDI; the DO word bits 0-7 EDO, 8-23 TDO (bits 4-7 absent on the
AMP-204C). Writing the DO word re-gates the PWM outputs mapped to it [M §4.9.3.6]."""

from __future__ import annotations

from typing import TYPE_CHECKING

from vdevmaps.aps_defs import PRB_DO_LOGIC

from vdevd.devices.adlink import pwm
from vdevd.devices.adlink.errors import invalid

if TYPE_CHECKING:
    from vdevd.devices.adlink.kernel import Kernel

DO_CHANNELS = 24


def do_mask(k: Kernel) -> int:
    """The DO (and DI) bits the model has: EDO4-7 exist on the AMP-208C only (spec §1.1)."""
    return (1 << DO_CHANNELS) - 1 if k.n == 8 else 0xFFFF0F


def do_pins(k: Kernel) -> int:
    """The DO word at the connector: as written, inverted by PRB_DO_LOGIC [X2]."""
    word = k.do_word & do_mask(k)
    return word ^ do_mask(k) if k.board_params.values[PRB_DO_LOGIC] else word


def _group(group: int) -> None:
    if group != 0:
        raise invalid(f"I/O group {group}: the card has group 0")


def _channel(k: Kernel, ch: int) -> int:
    if not 0 <= ch < DO_CHANNELS or not do_mask(k) >> ch & 1:
        raise invalid(f"DO channel {ch}")
    return ch


def _set(k: Kernel, word: int) -> None:
    k.do_word = word & do_mask(k)
    pwm.unit(k).refresh()


def read_d_input(k: Kernel, group: int) -> int:
    """APS_read_d_input: the DI word after PRB_DI_LOGIC."""
    _group(group)
    return k.di_word()


def write_d_output(k: Kernel, group: int, word: int) -> None:
    """APS_write_d_output: bits the model lacks are ignored (they read back 0, ASSUMPTION)."""
    _group(group)
    _set(k, word)


def read_d_output(k: Kernel, group: int) -> int:
    """APS_read_d_output: the word as written (the connector sees it through PRB_DO_LOGIC)."""
    _group(group)
    return k.do_word & do_mask(k)


def write_d_channel_output(k: Kernel, group: int, ch: int, value: int) -> None:
    _group(group)
    _channel(k, ch)
    if value not in (0, 1):
        raise invalid(f"DO_Data {value}")
    _set(k, k.do_word | 1 << ch if value else k.do_word & ~(1 << ch))


def read_d_channel_output(k: Kernel, group: int, ch: int) -> int:
    _group(group)
    return k.do_word >> _channel(k, ch) & 1
