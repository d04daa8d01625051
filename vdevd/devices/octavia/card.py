"""The DSP Control Group PCI Mx4 Octavia (type `dspcg-octavia`): README.md in this package.

One window, `dpr`: the 8 KiB dual-port RAM, which both sides poll (all of it passive but 1FFEh,
whose host access ends the interrupt [Ch6 Handling Interrupts]); the interrupt line `inta`; the
PCI `config` space. The firmware (firmware.py) runs one 200 us sample per tick and the card
publishes the DPR's state windows after the last sample of a batch.
"""

from __future__ import annotations

import asyncio
from collections.abc import Mapping
from typing import Any, ClassVar

import numpy as np
from vdevmaps.octavia import (
    CARD_TYPE,
    DPR,
    DPR_SIZE,
    FIRMWARE_OPTIONS,
    PCI_CLASS_CODE,
    PCI_DEVICE_ID,
    PCI_REVISION_ID,
    PCI_VENDOR_ID,
    SAMPLE_NS,
    Dpr,
)

from vdevd.devices.base import Card, CardContext, Option, control
from vdevd.devices.octavia import battery, cmd_dspl
from vdevd.devices.octavia.firmware import Firmware
from vdevd.devices.octavia.law import DAC_PER_VOLT, dac_to_volts
from vdevd.devices.rest import state_bytes
from vdevd.pci import Bar, PciIdentity
from vdevd.region import Region, passive_except

_HOSTINT = int(Dpr.HOSTINT1)
_RTC = int(Dpr.RTC)
#: IN lines the axis world drives (an assumption, README "Inputs"): axis k (1..8) has its
#: positive limit on IN(3k-3), negative limit on IN(3k-2), home on IN(3k-1); amplifier faults
#: on IN24..IN31
_LIMIT_POS, _LIMIT_NEG, _HOME, _AMP = 0, 1, 2, 24


def pci_identity(card: int) -> PciIdentity:
    """The configuration header (no IDs in the manual, spec Q-1: README "PCI identity"): the
    subsystem ID is the card number the client opens (0: by configuration order)."""
    return PciIdentity(vendor=PCI_VENDOR_ID, device=PCI_DEVICE_ID, revision=PCI_REVISION_ID,
                       class_code=PCI_CLASS_CODE, subsystem_vendor=PCI_VENDOR_ID,
                       subsystem=card, bars=(Bar(DPR_SIZE),))


class OctaviaCard(Card):
    type_name: ClassVar[str] = CARD_TYPE
    axis_base: ClassVar[int] = 1  # axes 1..8, as the manual numbers them
    default_period_ns: ClassVar[int] = SAMPLE_NS
    options: ClassVar[Mapping[str, Option]] = {
        "axes": Option(int, 8, min=5, max=8, help="5-8: the five- to eight-axis card [Ch1]"),
        "plant": Option(str, "servo", choices=("servo", "ideal"), help="servo or ideal"),
        "firmware": Option(str, "standard", choices=FIRMWARE_OPTIONS,
                           help="the firmware option that defines RTC 8Eh [Ch5 INT5MS, NOTCH, "
                                "LOW_PASS]"),
        "card": Option(int, 0, min=0, max=255,
                       help="card number the client opens (0: by configuration order)"),
        "gear_ratio_bits": Option(int, 7, choices=(7, 12),
                                  help="fraction bits of the GEAR ratios: 7 per the text (x128), "
                                       "12 per the examples (2000h = 2.0) [Ch5 GEAR; spec Q-5]"),
        "follow_master": Option(str, "actual", choices=("actual", "command"),
                                help="the master position cam and gear slaves follow: its "
                                     "encoder or its command [spec Q-21]"),
        "battery_backup": Option(bool, True,
                                 help="the battery-backed RAM option: tables, DSPL variables and "
                                      "autostart kept in the state directory [Ch8]"),
        "reset_clears_vars": Option(bool, False,
                                    help="RESET clears the DSPL variables too (default: they "
                                         "survive it, in the battery RAM) [spec Q-23]"),
    }

    def __init__(self, name: str, config: Mapping[str, Any], ctx: CardContext) -> None:
        super().__init__(name, config, ctx)
        self.n = n = self.opts.axes
        self.dpr = self.add_region(Region(
            DPR, DPR_SIZE, widths=(1, 2, 4), endian="little", aligned=False,
            description="dual-port RAM [Ch6 Table 6-1]",
            passive=passive_except(DPR_SIZE, [(_HOSTINT, 1)]), memory=ctx.memory))
        self.dpr.hook(_HOSTINT, 1, on_read=self._read_hostint, on_write=self._write_hostint,
                      peek=self._peek_hostint)
        self.inta = self.add_irq("inta")
        self.pci = self.add_config_space(pci_identity(self.opts.card), self.inta)
        self.fw = Firmware(self.dpr.buf, n, self.opts.plant, self.opts.firmware,
                           raise_line=self.inta.trigger,
                           gear_ratio_bits=self.opts.gear_ratio_bits,
                           follow_master=self.opts.follow_master,
                           reset_clears_vars=self.opts.reset_clears_vars)
        # the battery-backed RAM across daemon restarts (battery.py, README "Battery-backed RAM")
        store = ctx.nvram if self.opts.battery_backup else None
        self._battery = battery.Writer(store, name) if store is not None else None
        saved = store.load(name, battery.check_image) if store is not None else None
        if saved is not None:
            battery.restore(self.fw, saved)
        self.make_world(n)
        self._world_lines = 0  # the IN lines the axis world holds active (apply_world)
        self._ran = False  # a sample ran since the last publish
        self._world_changed()
        self.inta.clear()  # power-up: the reset-finished bit is posted, the line starts low

    # -- the interrupt mailbox [Ch6 Handling Interrupts] -----------------------------------------
    def _read_hostint(self, offset: int, size: int) -> bytes:
        """A host read of 1FFEh ends the interrupt; the bits stay."""
        self.inta.clear()
        return bytes(self.dpr.buf[_HOSTINT:_HOSTINT + 1])

    def _write_hostint(self, offset: int, data: bytes) -> None:
        """A host write of 1FFEh (clearing the bits it handled) ends the interrupt too."""
        self.dpr.buf[_HOSTINT] = data[0]
        self.inta.clear()

    def _peek_hostint(self, offset: int, size: int) -> bytes:
        return bytes(self.dpr.buf[offset:offset + size])

    # -- the firmware ----------------------------------------------------------------------------
    def step(self) -> None:
        if self.world.mechanical:
            self.sense_world()
        self.fw.cycle()
        self._ran = True

    def batch_done(self) -> None:
        """Publish the windows after a batch that ran a sample (a batch skipped at rest changed
        nothing; a host access to the DPR makes the next batch run, decision 0008); hand a
        changed battery image to its writer."""
        if self._ran or self.fw._deferred:
            self._ran = False
            self.fw.publish()
        if self.fw.nv_dirty:
            self.fw.nv_dirty = False
            if self._battery is not None:
                self._battery.submit(battery.image(self.fw))

    def nvram(self) -> dict[str, Any]:
        return battery.image(self.fw)

    async def close_services(self) -> None:
        """The daemon stops: the last battery image is written before it exits."""
        if self._battery is not None:
            await asyncio.to_thread(self._battery.close)

    def reset(self) -> None:
        self.fw.reset()

    def rest_state(self) -> bytes | None:
        """The firmware's state and the core's (None while a profile runs), the DPR, the
        line: all a sample may change but the counters. None at once while an RTC waits at
        3C2h (a command to serve: no state worth taking)."""
        fw = self.fw
        if self.dpr.buf[_RTC]:
            return None
        core = fw.core.rest_state()
        if core is None or fw.parread is not None or fw.mailbox.queue or fw._deferred:
            return None
        if fw.params.int5ms or fw.index_period is not None and fw.params.index_axis >= 0:
            return None
        if fw.contour.running or fw.cubic.running:  # a contour (CUBIC_INT: its 5 ms start)
            return None
        if fw.dspl.stale:  # a DSPL window refresh is due at the next 5 ms
            return None
        follow = fw.follow  # (its tables' copies are large: compared only while it follows)
        return (core + state_bytes(fw.params, fw, fw.filters, fw.dspl,
                                   skip=("sample", "rtc_count", "_mem8"))  # (the DPR: below)
                + (state_bytes(follow, follow.cam, follow.gears) if follow.active else b"")
                + bytes(self.dpr.buf) + bytes((self.inta.asserted,)))

    def polled_state(self) -> bytes:
        """The card polls the whole DPR (RTC byte, ring pointers, access bytes)."""
        return bytes(self.dpr.buf)

    def skip(self, k: int) -> None:
        fw = self.fw
        fw.core.skip(k)
        fw.sample += k
        super().skip(k)

    def quiet_ticks(self) -> int:
        """At rest the 5 ms housekeeping still refreshes SERVOCHK (to 0): it changes nothing
        once it ran, so rest may cross it."""
        return 1 << 62

    # -- the axis world and the backdoor ---------------------------------------------------------
    def push_axis(self, a: int, counts: float) -> None:
        """Backdoor `push`: the axis moved by hand (MotionCore.push)."""
        self.fw.core.push(a, counts)

    def physical_positions(self) -> np.ndarray:
        return self.fw.core.physical()

    def apply_world(self) -> None:
        """Limits and home switches on IN lines, amplifier faults on IN24..31 and on the motor,
        lost encoders on the core and ENCSTAT, index pulses, jams (README "Backdoor")."""
        w, fw, n = self.world, self.fw, self.n
        core = fw.core
        core.set_inputs(amp_fault=w.amp_fault, encoder_loss=w.encoder_loss)
        core.follow_jams(w.jammed)
        levels = fw.levels | self._world_lines
        active = 0
        for a in range(n):  # at most 8 axes, at command time
            base = 3 * a
            active |= (int(w.limit_pos[a]) << (base + _LIMIT_POS)
                       | int(w.limit_neg[a]) << (base + _LIMIT_NEG)
                       | int(w.home[a]) << (base + _HOME) | int(w.amp_fault[a]) << (_AMP + a))
        self._world_lines = active
        fw.levels = levels & ~active  # active low: a switch that is on pulls its line low
        fw.encstat = int(sum(int(v) << a for a, v in enumerate(w.encoder_loss)))
        fw.set_index_pulses(w.index_period, w.index_phase)
        fw.refresh_inputs()

    def drive_input(self, line: int, level: bool) -> None:
        """IN0..IN31 at +5 V (True: inactive for an active-low input) or 0 V [Ch2 Inputs]."""
        if isinstance(line, bool) or not isinstance(line, int) or not 0 <= line < 32:
            raise ValueError(f"line {line!r} outside 0..31 (IN0-IN31)")
        fw = self.fw
        fw.levels = fw.levels | 1 << line if level else fw.levels & ~(1 << line)
        fw.refresh_inputs()

    def drive_analog(self, channel: int, volts: float) -> None:
        """ADC1..ADC4 of the ACC4000 analog option: int16 codes, 7FFFh = +10 V, at 502h.. under
        the 500h/501h access bytes [Table 6-10]; beyond +-10 V the converter saturates."""
        if isinstance(channel, bool) or not isinstance(channel, int) or not 1 <= channel <= 4:
            raise ValueError(f"channel {channel!r} outside 1..4 (ADC1-ADC4)")
        self.fw.adc[channel - 1] = int(np.clip(np.rint(volts * DAC_PER_VOLT), -32768, 32767))
        self.fw.publish_adc()

    def drive_estop(self, active: bool) -> None:
        """*ESTOP (shared by all cards of the rack's sync chain)."""
        self.fw.set_estop(bool(active))

    @control()
    def set_probe(self, input: int, active: bool = True) -> None:
        """Drive *EXT1..4 (`input` 1..4) active or inactive; a going-active edge is what EN_PROBE
        (and CAM_PROBE, GEAR_PROBE) wait for [Ch2 General Purpose External Interrupt Inputs]."""
        if isinstance(input, bool) or not isinstance(input, int) or not 1 <= input <= 4:
            raise ValueError(f"input {input!r} outside 1..4 (*EXT1-4)")
        fw, bit = self.fw, 1 << (input - 1)
        was = fw.ext & bit
        fw.ext = fw.ext | bit if active else fw.ext & ~bit
        if active and not was:
            fw.probe_edge(bit)

    @control()
    def get_outputs(self) -> dict[str, Any]:
        """What the DPR does not show: the 8 DAC codes and volts, OUT0..31 (bit set: ON, driven
        low) and their levels."""
        fw = self.fw
        dac = fw.dac()
        return {"dac": [int(v) for v in dac], "dac_volts": [float(v) for v in dac_to_volts(dac)],
                "outputs": fw.params.outputs_on & 0xFFFFFFFF}

    @control()
    def set_amp_offset(self, axis: int, volts: float) -> None:
        """The input offset of axis 1..8's amplifier, in volts (+-10): the motor turns as if
        the DAC output that much more, which OFFSET measures and cancels [Ch5 OFFSET]."""
        a, v = self.axis_index(axis), float(volts)
        if not -10.0 <= v <= 10.0:
            raise ValueError(f"volts {volts!r} outside -10..10")
        fw = self.fw
        fw.amp_offset[a] = v * DAC_PER_VOLT
        fw.any_amp_offset = bool(fw.amp_offset.any())

    @control()
    def axis_state(self, axis: int) -> dict[str, Any]:
        """The motion core's state of axis 1..8 (floats, for tests and scopes)."""
        a = self.axis_index(axis)
        ax = self.fw.core.axes
        return {"cmd_pos": float(ax.cmd_pos[a]), "cmd_vel": float(ax.cmd_vel[a]),
                "pos": float(ax.pos[a]), "vel": float(ax.vel[a]), "encoder": int(ax.encoder[a]),
                "ferr": float(ax.ferr[a]), "out": float(ax.out[a]), "mode": int(self.fw.mode[a])}

    # -- DSPL and the board RAM (cmd_dspl.py, ram.py; README "DSPL") -------------------------------
    @control()
    def get_dspl(self) -> dict[str, Any]:
        """The DSPL program's state (autostart, loaded, running), SIGNAL_DSPLs received, the
        monitor slots' variables, the status words' line numbers, each axis's TABLE_SEL."""
        return cmd_dspl.report(self.fw)

    @control()
    def dspl_load(self, loaded: bool = True) -> None:
        """Mark a DSPL program loaded into the battery-backed RAM (or not): the download path
        the manual does not document."""
        cmd_dspl.load(self.fw, bool(loaded))

    @control()
    def dspl_host_interrupt(self, value: int = 1) -> None:
        """What a DSPL program's INT_HOST does: DSPSTAT2 b4, `value` (a byte) OR-ed into 00Eh,
        1FFEh b6 and the interrupt [Table 6-2]."""
        cmd_dspl.host_interrupt(self.fw, value)

    @control()
    def dspl_error(self, too_many: bool = False, not_found: bool = False) -> None:
        """A DSPL program running error: DSPSTAT2 b5 with 00Fh b0 (more than 3 programs) and/or
        b1 (cannot find the program to stop) [Table 6-2]."""
        cmd_dspl.program_error(self.fw, bool(too_many), bool(not_found))

    @control()
    def dspl_status(self, prg1: int | None = None, prg2: int | None = None,
                    plc: int | None = None) -> None:
        """The line numbers PRG1STAT (07Eh), PRG2STAT (080h) and PLCSTAT (084h) show from the next
        5 ms on [Table 6-3]."""
        cmd_dspl.set_status(self.fw, {"prg1": prg1, "prg2": prg2, "plc": plc})

    @control()
    def dspl_var(self, var: int, value: int | None = None) -> int:
        """VAR1..128's raw 48 bits (6 bytes, little-endian), set first to `value` if given, as a
        DSPL program would."""
        return cmd_dspl.variable(self.fw, var, value)

    @control()
    def read_ram(self, address: int, count: int = 1) -> list[int]:
        """`count` 16-bit words of the board RAM from word `address` (tables at 2000h..5FFFh,
        Ch8 Table 8-1)."""
        words = self.fw.ram.words
        if address < 0 or count < 0 or address + count > len(words):
            raise ValueError(f"RAM words {address:#x}+{count} outside 0..{len(words):#x}")
        return [int(w) for w in words[address:address + count]]
