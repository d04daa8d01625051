"""The filter options and offset calibration [Ch5 NOTCH, LOW_PASS, OFFSET; spec §5.2]: NOTCH
and LOW_PASS share opcode 8Eh with INT5MS, one firmware option at a time (spec Q-4)."""

from __future__ import annotations

from typing import TYPE_CHECKING, Any

from vdevd.devices.octavia import filters

if TYPE_CHECKING:
    from vdevd.devices.octavia.firmware import Firmware

Groups = list[tuple[int, dict[str, Any]]]


def _single_axis(fw: Firmware, mask: int) -> int | None:
    """The one axis an RTC "bit coding the ONLY axis involved" names (several: the lowest)."""
    axes = fw.mask(mask)
    return axes[0] if axes else None


def notch(fw: Firmware, head: dict[str, Any], groups: Groups) -> None:
    """A notch at `freq` Hz (0..1544; 0 removes it), quality code q (00h ~25 %, 01h ~10 %
    bandwidth) on one axis's output [Ch5 NOTCH]; out of range: ignored (logged)."""
    a = _single_axis(fw, head["n"])
    if a is None:
        return
    try:
        coeffs = filters.notch(head["freq"], head["q"])
    except ValueError as exc:
        fw.refuse("NOTCH", exc)
        return
    fw.set_filter(a, coeffs)


def low_pass(fw: Firmware, head: dict[str, Any], groups: Groups) -> None:
    """A second-order low-pass (damping 0.6) at the frequency of table index idx (0 removes it)
    on one axis's output [Ch5 LOW_PASS]; an index beyond 46: ignored (logged)."""
    a = _single_axis(fw, head["n"])
    if a is None:
        return
    try:
        coeffs = filters.low_pass(filters.low_pass_frequency(head["idx"]))
    except ValueError as exc:
        fw.refuse("LOW_PASS", exc)
        return
    fw.set_filter(a, coeffs)


def offset(fw: Firmware, head: dict[str, Any], groups: Groups) -> None:
    """Amplifier offset cancellation on one axis: the integral channel zeroes the position
    error, the DAC voltage that holds it becomes the axis's offset compensation, and the card
    reports completion (DSPSTAT2 b2, 00Ch, 1FFEh b6) [Ch5 OFFSET]; the run itself is
    `Firmware.calibrate_offset`, every sample."""
    a = _single_axis(fw, head["n"])
    if a is not None:
        fw.start_offset(a)
