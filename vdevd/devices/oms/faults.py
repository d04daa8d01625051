"""What the firmware does when an axis slips, stalls, runs away or its amplifier faults
[S §3.4.3, §4.7, §2.13 L451; spec oms.md §3.4, §5.3-5.4].

All of them are reported as an encoder slip: EA char 3 'S' (until IC), the ODBR slip bit
16 + axis (for W/K the W/K status word bit 16 and ODBR bit 25/26), and the axis's queue flushed
so a pending ID never sets done.
- Slip (PSE) or stall (PSM) beyond ES: the axis is killed (stops at once), its loop stays
  as it was.
- Servo runaway (|error| > 32768 counts): the PID is disabled (CL0: the output is KO), which
  also stops the trajectory.
- Amplifier fault (backdoor, servo axes): the core aborts the axis and opens its loop; the
  firmware records the loop as open (CL? off), so CL1 is needed once the fault has cleared.
"""

from __future__ import annotations

from typing import TYPE_CHECKING

from vdevmaps.oms import AxisFlags

from vdevd.rt.axes import AxisFlag

if TYPE_CHECKING:
    from vdevd.devices.oms.firmware import Firmware

#: the core events this module reacts to
FAULT_EVENTS = int(AxisFlag.FE_TRIP | AxisFlag.AMP_FAULT)


def react_to_faults(fw: Firmware, events: int) -> None:
    """The slips, stalls, runaways and amplifier faults the core reported in `events`."""
    enc = fw.motion.encoders
    if events & AxisFlag.FE_TRIP:
        for a in enc.new_trips().tolist():
            if enc.runaway(a):
                fw.flush(a)
                fw.set_closed_loop(a, False)
            else:
                fw.kill([a])
            _report(fw, a)
    if events & AxisFlag.AMP_FAULT:
        for a in enc.new_amp_faults().tolist():
            fw.flush(a)
            fw.set_closed_loop(a, False)
            _report(fw, a)


def _report(fw: Firmware, a: int) -> None:
    fw.slip[a] = True
    fw.flag(a, AxisFlags.SLIP)
