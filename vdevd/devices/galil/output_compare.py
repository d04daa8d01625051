"""OC, output compare: the CMP output pulses when a main encoder passes programmed positions
[M Ch3 §TTL Outputs: "an active low pulse (1usec) based on an incremental encoder value or to
activate once when an axis position has been passed"; spec §1 (OC)]. Plain state, no I/O.

The form is the Galil command reference's (the seed lacks it): `OCx=m,n`, m the absolute position
of the first pulse, n the distance between pulses (-65535..65535; its sign the expected direction
of motion), n = 0 one shot (the output goes low and stays low until the next OC), `OCX=0` off.
One compare for axes X-W (one CMP output). The reference's compare is 16 bits wide: a pulse is
due wherever the encoder's low 16 bits equal the compare register, which then advances by n;
moving against n's sign the pulses therefore come every 65536 - |n| counts, as the reference
says, and a first position farther than 65535 counts fires at the first reading congruent to it
(the reference requires it within 65535 counts). A redefinition of the position (DP, HM, FI)
makes the counter jump without passing the positions between.

A pulse is 1 µs, far shorter than a sample: the card counts them (`pulses`) and the firmware
reports those of each sample; an axis passing several positions within one sample gives as many
pulses, as the hardware's comparator would.
"""

from __future__ import annotations

WRAP = 65536  # the compare register's range
MAX_STEP = 65535


class OutputCompare:
    """The compare of the CMP output: the axis it watches, the next compare value, the step."""

    def __init__(self) -> None:
        self.axis = -1  # -1: off
        self.next = 0  # the position (congruent mod 65536) of the next pulse
        self.step = 0  # n: 0 one shot
        self.reading = 0  # the encoder at the last check
        self.pulses = 0  # CMP pulses since power-on / RS
        self.low = False  # a one shot fired: CMP held low until the next OC
        self.zero = 0.0  # the axis's redefinitions of position so far (MotionCore.zero)

    @property
    def armed(self) -> bool:
        return self.axis >= 0

    def arm(self, axis: int, position: int, step: int, reading: int, zero: float) -> None:
        """OCx=m,n with the axis's encoder now at `reading` and its zero at `zero`."""
        self.axis, self.next, self.step, self.reading = axis, position, step, reading
        self.zero, self.low = zero, False

    def off(self) -> None:
        """OCX=0."""
        self.axis = -1
        self.low = False

    def check(self, reading: int, zero: float) -> int:
        """The encoder now reads `reading`: the pulses of the positions passed since the last
        check, in (last, reading] moving forward, [reading, last) backward. A redefinition of
        the position (DP, HM, FI: `zero` moved) is no motion: the counter jumps, passing
        nothing."""
        last, self.reading = self.reading, reading
        if zero != self.zero:
            last += round(zero - self.zero)
            self.zero = zero
        if reading == last:
            return 0
        c, s = self.next, self.step
        if reading > last:
            first = last + (c - last - 1) % WRAP + 1
            if first > reading:
                return 0
            stride = s % WRAP
            count = 1 if s == 0 else (reading - first) // stride + 1
        else:
            first = last - (last - c - 1) % WRAP - 1
            if first < reading:
                return 0
            stride = -s % WRAP
            count = 1 if s == 0 else (first - reading) // stride + 1
        self.pulses += count
        if s == 0:  # one shot: low, and off until the next OC
            self.axis, self.low = -1, True
        else:
            self.next = c + count * s
        return count

    def state(self) -> bytes:
        """What a sample may change, for the card's rest bytes (decision 0008)."""
        return b"".join(int(v).to_bytes(9, "little", signed=True) for v in (
            self.axis, self.next, self.reading, self.pulses, self.low, round(self.zero)))
