"""The Galil DMC-13X8 VME card (type `galil-dmc13x8`): README.md in this package.

The card is the hardware around the firmware (firmware.py): the A16 window (bus.py, the register
map of `vdevmaps.galil`) behind region `a16`, the VME interrupt line `irq` at the jumpered level,
and the backdoor. Every servo sample it runs the firmware's `step()`; with `decode = "arrival"` a
host write that completes a command runs the firmware's `serve()` at once.
"""

from __future__ import annotations

from collections.abc import Mapping
from typing import Any, ClassVar

import numpy as np
from vdevmaps.galil import WINDOW_SIZE, A16Reg

from vdevd.devices.base import Card, CardContext, Option, axis_number, control
from vdevd.devices.galil.bus import FREEZE_MODES, A16Window
from vdevd.devices.galil.firmware import Firmware
from vdevd.devices.galil.params import COUNTS_PER_VOLT
from vdevd.devices.galil.syntax import AXIS_LETTERS
from vdevd.region import Region
from vdevd.rt import PlantKind

_DATA = int(A16Reg.DATA)  # a plain int: an enum member costs a lookup on every access


class GalilCard(Card):
    type_name: ClassVar[str] = "galil-dmc13x8"
    endian: ClassVar[str] = "big"
    options: ClassVar[Mapping[str, Option]] = {
        "axes": Option(int, 4, min=1, max=4, help="1-4: DMC-1318 ... DMC-1348"),
        "tm_us": Option(int, 1000, min=250, max=20000, help="sample time in us, as TM sets it"),
        "base": Option(int, 0xFFF0, min=0, max=0xFFF0, help="A16 base address (JP10)"),
        "irq_level": Option(int, 5, min=1, max=7, help="VME IRQ level (JP9/JP11)"),
        "plant": Option(str, "servo", choices=("servo", "stepper", "ideal"),
                        help="servo; stepper (SM jumpers installed); ideal"),
        "freeze_mode": Option(str, "toggle_n5", choices=FREEZE_MODES,
                              help="secondary FIFO freeze control (README.md)"),
        "record_endian": Option(str, "little", choices=("little", "big"),
                                help="byte order of the data record"),
        "decode": Option(str, "arrival", choices=("arrival", "sample"),
                         help="decode a command when its terminator arrives, or at the next sample"),
    }

    def __init__(self, name: str, config: Mapping[str, Any], ctx: CardContext) -> None:
        super().__init__(name, config, ctx)
        cfg = self.config
        self.n = int(cfg.get("axes") or 4)
        self.configured_tm_us = int(cfg.get("tm_us") or 1000)
        if not cfg.get("period_ns"):
            self.period_ns = self.configured_tm_us * 1000
        base = int(cfg.get("base", 0xFFF0))
        if base % WINDOW_SIZE:
            raise ValueError(f"base: {base:#x} is not a multiple of 16 (A4..A15 jumpers)")
        self.base = base
        self.irq_level = int(cfg.get("irq_level") or 5)
        self.plant = str(cfg.get("plant") or "servo")
        self.decode_on_arrival = str(cfg.get("decode") or "arrival") == "arrival"
        self.bus = A16Window(freeze_mode=str(cfg.get("freeze_mode") or "toggle_n5"))
        self.a16 = self.add_region(Region(
            "a16", WINDOW_SIZE, widths=(1,), endian="big", aligned=False,
            description="A16 short I/O, D08(O): FIFOs N+1, control N+3, secondary FIFO N+5/N+7"))
        self.a16.hook(0, WINDOW_SIZE, on_read=self._host_read, on_write=self._host_write,
                      peek=self._host_peek, on_read_rep=self._host_read_rep,
                      on_write_rep=self._host_write_rep)
        self.irq = self.add_irq("irq")
        self.firmware = Firmware(self.n, self.period_ns, self.plant, self.configured_tm_us, self.bus,
                                 raise_irq=self._raise_irq, clear_irq=self.irq.clear,
                                 clock=lambda: self.now_ns,
                                 record_endian=str(cfg.get("record_endian") or "little"))

    def reset(self) -> None:
        """Power-on: the window empty, the line released, the firmware reset."""
        self.bus.reset()
        self.irq.clear()
        self.firmware.reset()

    # -- the host's bus accesses -------------------------------------------------------------------
    def _host_read(self, offset: int, size: int) -> bytes:
        value = self.bus.read(offset)
        if self.irq.asserted and not self.bus.line_asserted:
            self.irq.clear()
        return bytes((value,))

    def _host_write(self, offset: int, data: bytes) -> None:
        self.bus.write(offset, data[0])
        if offset == _DATA and self.decode_on_arrival:
            self.firmware.serve()  # the command it completes is decoded at once
        elif self.irq.asserted and not self.bus.line_asserted:
            self.irq.clear()

    def _host_read_rep(self, offset: int, size: int) -> bytes:
        if offset == _DATA:
            return self.bus.read_data(size)
        return bytes(self._host_read(offset, 1)[0] for _ in range(size))

    def _host_write_rep(self, offset: int, data: bytes) -> None:
        if offset == _DATA:
            self.bus.write_data(data)
            if self.decode_on_arrival:
                self.firmware.serve()
        else:
            for b in data:
                self._host_write(offset, bytes((b,)))

    def _host_peek(self, offset: int, size: int) -> bytes:
        return bytes(self.bus.peek(o) for o in range(offset, offset + size))

    # -- the firmware ------------------------------------------------------------------------------
    def step(self) -> None:
        """One sample of the firmware: motion, interrupts, commands, the data record."""
        self.firmware.step()

    def _raise_irq(self, status: int) -> None:
        """The firmware queued `code | vector << 8` with the output enabled: the line asserts at
        the jumpered level (README.md "Interrupts")."""
        self.irq.trigger(status | self.irq_level << 16)

    # -- backdoor ----------------------------------------------------------------------------------
    def _axis(self, axis: str | int) -> int:
        return axis_number(axis, AXIS_LETTERS, self.n)

    @control()
    def set_switches(self, axis: str, forward_limit: bool | None = None,
                     reverse_limit: bool | None = None, home: int | None = None) -> None:
        """Limit switches (True = tripped) and the home input logic level of one axis."""
        a, m = self._axis(axis), self.firmware.motion
        self.firmware.set_limits(a, forward_limit, reverse_limit)
        if home is not None:
            m.set_home_edge(a, None)
            m.home_input[a] = bool(home)

    @control()
    def set_home_edge(self, axis: str, position: float | None = None) -> None:
        """A home switch at `position`: the input reads 1 below it and 0 above it (None: the
        level set by set_switches)."""
        self.firmware.motion.set_home_edge(self._axis(axis), position)

    @control()
    def set_index(self, axis: str, period: float = 4096, phase: float = 0) -> None:
        """Encoder index pulses at phase + k * period counts (default one per 4096 counts)."""
        if not period > 0:
            raise ValueError("period must be positive")
        a, m = self._axis(axis), self.firmware.motion
        m.index_period[a], m.index_phase[a] = float(period), float(phase)

    @control()
    def set_abort(self, active: bool) -> None:
        """The ABORT input: motion stops at once, OE1 axes turn off [M Ch3 §Abort Input]."""
        self.firmware.set_abort(active)

    @control()
    def set_input(self, input: int, level: int) -> None:
        """General input IN1..IN8 logic level; a falling edge latches an armed axis (IN1..IN4)
        and raises an enabled input interrupt (EI bit 15)."""
        if not 1 <= input <= 8:
            raise ValueError("input must be 1..8")
        self.firmware.set_input(input, level)

    @control()
    def set_analog(self, input: int, volts: float) -> None:
        """Analog input AN1..AN8 in volts (+-10 V, 12-bit)."""
        if not 1 <= input <= 8:
            raise ValueError("input must be 1..8")
        step = 20 / 4096  # 4096 levels from -10 V to 10 V - one step
        self.firmware.analog[input - 1] = min(max(round(float(volts) / step), -2048), 2047) * step

    @control()
    def set_amp_fault(self, axis: str, active: bool) -> None:
        """An amplifier fault: the amplifier stops driving the motor (it coasts), the card keeps
        servoing, so the position error grows until ER/OE act as on the real card."""
        a = self._axis(axis)
        core = self.firmware.motion.core
        if core.kinds[a] == PlantKind.SERVO:
            core.plant.set(a, peak_torque=1e-9 if active else np.inf)
        else:
            fault = core.amp_fault.copy()
            fault[a] = bool(active)
            core.set_inputs(amp_fault=fault)

    @control()
    def set_encoder_loss(self, axis: str, active: bool) -> None:
        """A lost encoder: the position reading freezes (the servo then runs away)."""
        a = self._axis(axis)
        core = self.firmware.motion.core
        loss = core.encoder_loss.copy()
        loss[a] = bool(active)
        core.set_inputs(encoder_loss=loss)

    @control()
    def set_friction(self, axis: str, volts: float) -> None:
        """Coulomb friction of a servo motor, as the DAC voltage it takes to overcome it."""
        if not volts >= 0:
            raise ValueError("volts must be >= 0")
        a = self._axis(axis)
        core = self.firmware.motion.core
        core.plant.set(a, coulomb=float(volts) * COUNTS_PER_VOLT * float(core.plant.amp_gain[a]))
