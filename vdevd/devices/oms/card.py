"""The OMS MAXk PCI card (type `oms-maxk`): README.md in this package.

Two windows: `shm` (BAR2, the 64 KiB shared memory, big-endian) and `mu` (BAR4, the message unit,
little-endian). A host write of the command ring's insert index hands the new bytes to the
firmware at once (`decode = "arrival"`, default) or at the next update cycle (`"cycle"`); replies
go out one at a time through the response ring and the message semaphore; every update cycle the
firmware advances its queues and the motion core and publishes positions and status words.
"""

from __future__ import annotations

import math
import struct
from collections.abc import Mapping
from fractions import Fraction
from typing import Any, ClassVar

import numpy as np
from vdevmaps.oms import (
    AXES,
    CAPTURE_MESSAGE,
    CARD_TYPE,
    MU,
    MU_BAR,
    MU_SIZE,
    PCI_CLASS_CODE,
    PCI_DEVICE_ID,
    PCI_REVISION_ID,
    PCI_SUBSYSTEM_BASE,
    PCI_SUBSYSTEM_VENDOR_ID,
    PCI_VENDOR_ID,
    SHM,
    SHM_BAR,
    SHM_SIZE,
    UPDATE_RATES,
    DirectCommand,
    FirmwareState,
    Shm,
)

from vdevd.devices.base import Card, CardContext, CardOptions, Option, control
from vdevd.devices.oms import rings
from vdevd.devices.oms.encoder import DEFAULT_INDEX
from vdevd.devices.oms.firmware import Firmware
from vdevd.devices.oms.layout import (
    COHERENT_DAC_WORDS,
    COHERENT_ENCODER_WORDS,
    COHERENT_MOTOR_WORDS,
    DAC_WORDS,
    ENCODER_WORDS,
    MOTOR_WORDS,
    SSI_WORDS,
    home_word,
)
from vdevd.devices.oms.mu import MessageUnit
from vdevd.devices.oms.nv_image import check_image
from vdevd.devices.oms.params import AXIS_TYPES, PROFILES, SERVO_OUTPUTS
from vdevd.devices.rest import state_bytes
from vdevd.pci import Bar, PciIdentity
from vdevd.region import Region, passive_except
from vdevd.rt import wrap_int32
from vdevd.rt.axes import AxisFlag

VERSION = "1.50"
_SEMAPHORE = int(Shm.MESSAGE_SEMAPHORE)
_CMD_INSERT, _RSP_PROCESS = int(Shm.COMMAND_INSERT), int(Shm.RESPONSE_PROCESS)


def pci_identity(board: int) -> PciIdentity:
    """The configuration header [S §3.2; spec oms.md §2.1]: vdevmaps.oms's IDs, subsystem 0010
    + the J5 board number, the shared memory as BAR2 and the message unit as BAR4; BAR0, 1, 3
    and 5 not implemented (the seed names only the two)."""
    bars: list[Bar | None] = [None] * 6
    bars[SHM_BAR], bars[MU_BAR] = Bar(SHM_SIZE), Bar(MU_SIZE)
    return PciIdentity(vendor=PCI_VENDOR_ID, device=PCI_DEVICE_ID, revision=PCI_REVISION_ID,
                       class_code=PCI_CLASS_CODE, subsystem_vendor=PCI_SUBSYSTEM_VENDOR_ID,
                       subsystem=PCI_SUBSYSTEM_BASE + board, bars=tuple(bars))


class _Applied:
    """The index pulses apply_world last gave the encoders, per axis."""

    def __init__(self, n: int) -> None:
        self.index_period = np.full(n, np.nan)  # none yet: every axis's pulses get placed
        self.index_phase = np.full(n, np.nan)


def _default_types(n: int) -> list[str]:
    """Servo on the first four axes, steppers after (the issue's default)."""
    return ["servo" if a < 4 else "stepper" for a in range(n)]


def _per_axis(key: str, values: list[Any] | None, n: int, default: list[str]) -> list[str]:
    """A per-axis list option: one entry per axis, or `default` when not given (None)."""
    out = default if values is None else [str(v) for v in values]
    if len(out) != n:
        raise ValueError(f"{key}: {len(out)} entries for {n} axes")
    return out


def _travel_limits(values: list[Any] | None, n: int) -> list[tuple[float, float] | None]:
    """Option `travel_limits`: per axis [low, high] in counts, or [] for none (the factory
    setting, "Software (soft) over-travel: disabled" [S §2.14])."""
    out: list[tuple[float, float] | None] = []
    for a, pair in enumerate([[]] * n if values is None else values):
        if pair in ([], None):
            out.append(None)
            continue
        if (not isinstance(pair, list) or len(pair) != 2
                or not all(isinstance(v, int) and not isinstance(v, bool) for v in pair)
                or not -2**31 <= pair[0] < pair[1] < 2**31):
            raise ValueError(f"travel_limits: axis {a + 1}: [low, high] whole counts, low < high"
                             f" (or [] for none), got {pair!r}")
        out.append((float(pair[0]), float(pair[1])))
    if len(out) != n:
        raise ValueError(f"travel_limits: {len(out)} entries for {n} axes")
    return out


class MaxkCard(Card):
    type_name: ClassVar[str] = CARD_TYPE
    endian: ClassVar[str] = "big"
    runs_ticks: ClassVar[bool] = True  # cycles of the motion core alone (`run`)
    options: ClassVar[Mapping[str, Option]] = {
        "board": Option(int, 1, min=1, max=8, help="board number (J5 jumpers, 1-8)"),
        "axes": Option(int, 8, min=1, max=10, help="1-10: MAXk-1000 ... MAXk-A000"),
        "axis_types": Option(list, None, choices=tuple(AXIS_TYPES), per_axis=True,
                             help="per axis stepper | stepper_encoder | servo"),
        "update_hz": Option(int, 1024, choices=UPDATE_RATES, help="update rate, as #UR sets it"),
        "plant": Option(str, "model", choices=("model", "ideal"),
                        help="model: stepper and servo plants; ideal: axes follow exactly"),
        "decode": Option(str, "arrival", choices=("arrival", "cycle"),
                         help="parse commands when the insert index is written, or next cycle"),
        "serial": Option(int, 1, min=0, max=999999, help="serial number WY reports"),
        "ssi_code": Option(str, "binary", choices=("binary", "gray"),
                           help="the code the SSI encoders (ECA) send: binary or Gray"),
        "profiles": Option(list, None, choices=PROFILES, per_axis=True,
                           help="per axis velocity profile: linear | parabolic | scurve"),
        "servo_output": Option(list, None, choices=SERVO_OUTPUTS, per_axis=True,
                               help="per axis servo DAC output: bipolar | unipolar"),
        "travel_limits": Option(list, None, per_axis=True, help="per axis software travel limits [low, high]"
                                                 " in counts, [] for none (the factory setting)"),
    }

    #: the period at the factory update rate, 1024 Hz (the card runs at 1/update_hz)
    default_period_ns: ClassVar[int | Fraction] = Fraction(10**9, 1024)
    period_from: ClassVar[str | None] = "update_hz sets it, then #UR"
    #: the backdoor names axes as the manual does (X Y Z T U V R S W K, any case) or 0..n-1
    axis_letters: ClassVar[str] = AXES
    #: set_input's `line` was called `bit` before the shared vocabulary
    control_params: ClassVar[Mapping[str, Mapping[str, str]]] = {"set_input": {"bit": "line"}}

    @classmethod
    def check_options(cls, opts: CardOptions, where: str) -> None:
        """The update period is 1/update_hz, the rate `#UR` reports and sets [S §2.13]: a
        `period_ns` of its own would run the card at a rate it does not report."""
        if opts.period_ns is not None:
            raise ValueError(f"{where}.period_ns: an oms-maxk runs at 1/update_hz; set update_hz "
                             f"({', '.join(map(str, UPDATE_RATES))}) instead")

    def __init__(self, name: str, config: Mapping[str, Any], ctx: CardContext) -> None:
        super().__init__(name, config, ctx)
        opts = self.opts
        self.board = opts.board
        self.n = opts.axes
        types = _per_axis("axis_types", opts.axis_types, self.n, _default_types(self.n))
        self.types = [AXIS_TYPES[t] for t in types]
        self.update_hz = opts.update_hz
        #: the update period at power-up: the configured rate's, exact (1024 Hz: 976562.5 ns)
        self.start_period = Fraction(10**9, self.update_hz)
        self.ideal = opts.plant == "ideal"
        self.decode_on_arrival = opts.decode == "arrival"
        self.serial = opts.serial
        self.ssi_gray = opts.ssi_code == "gray"  # the encoders attached, not a setting
        self.profiles = _per_axis("profiles", opts.profiles, self.n, ["linear"] * self.n)
        self.servo_outputs = _per_axis("servo_output", opts.servo_output, self.n,
                                       ["bipolar"] * self.n)
        self.travel_limits = _travel_limits(opts.travel_limits, self.n)
        self._make_world()

        hooks = ((Shm.DIRECT_COMMAND, self._direct_command),
                 (Shm.POSITION_REQUEST, self._position_request),
                 (Shm.MESSAGE_SEMAPHORE, self._semaphore_written),
                 (Shm.W_STATUS_FLAGS, self._wk_clear), (Shm.K_STATUS_FLAGS, self._wk_clear),
                 (Shm.COMMAND_INSERT, self._commands_written),
                 (Shm.RESPONSE_PROCESS, self._response_released))
        # passive (decision 0010): all but the mailbox and index words, which have hooks
        self.shm = self.add_region(Region(
            SHM, SHM_SIZE, widths=(1, 2, 4), endian="big",
            description="BAR2 shared memory: positions, status, rings, capture (Table 3-1)",
            passive=passive_except(SHM_SIZE, [(offset, 4) for offset, _ in hooks]),
            memory=ctx.memory))
        self.mem = self.shm.buf
        self.words = np.frombuffer(self.mem, dtype=">i4")
        for offset, fn in hooks:
            self.shm.hook(offset, 4, on_write=fn)
        self.mu_region = self.add_region(Region(
            MU, MU_SIZE, widths=(4,), endian="little",
            description="BAR4 message unit: OMISR, OMIMR, OMR0/1, ODBR, IDBR (MPC8245)"))
        self.mu_region.hook(0, MU_SIZE, on_read=self._mu_read, on_write=self._mu_write,
                            peek=self._mu_peek)
        self.inta = self.add_irq("inta")
        self.pci = self.add_config_space(pci_identity(self.board), self.inta)
        self.mu = MessageUnit(on_line=self._line, on_inbound=self._inbound)
        self.saved, self.archive_error = self._load_defaults()
        self.fault: str | None = None  # backdoor firmware state (no firmware, checksum error)
        self.powered = False  # power_up has built the firmware once
        self.power_up()

    def period_changed(self, period: Fraction) -> None:
        """The first cycle at a new update rate (`#UR`) begins: the firmware runs at it."""
        self.fw.set_period(float(period))

    # -- power-up -------------------------------------------------------------------------------------
    def power_up(self) -> None:
        """Firmware start [S §2.14; spec §2.3]: positions 0, outputs off, the working parameters
        and I/O configuration from the power-up defaults `APP` stored when their archive is
        valid, else the factory set."""
        # the stage stays where it is: the new counters read 0 there (physical_positions)
        stage = self.physical_positions() if self.powered else np.zeros(self.n)
        self.mem[:] = bytes(SHM_SIZE)
        self.mu.reset()
        self.inta.clear()
        image = None if self.defaults_bad() else self.saved
        self.set_period(self.start_period)  # a #UR not stored is gone at a restart
        self.fw = Firmware(self.n, self.types, float(self.period), update_hz=self.update_hz,
                           ideal=self.ideal, ring=self.mu.ring, version=VERSION,
                           serial=self.serial, save=self._save_defaults, saved=image,
                           profiles=self.profiles, servo_outputs=self.servo_outputs,
                           travel_limits=self.travel_limits, retime=self.set_period)
        self.fw.now_ns = self.now_ns
        self.fw.on_type_change = self.apply_world
        core = self.fw.motion.core
        core.zero[:] = -stage
        self.fw.motion.encoders.enc_zero[:] = -stage * core.encoder_scale
        self._applied = _Applied(self.n)
        self._probe_from = stage
        self.powered = True
        self._world_changed()

    def reset(self) -> None:
        self.power_up()

    @property
    def running(self) -> bool:
        """The application runs (it does not without firmware or with a bad flash image)."""
        return self.fault not in ("no_firmware", "flash_checksum")

    def defaults_bad(self) -> bool:
        """A checksum error in the power-up parameter archive (Table 3-4 bit 12)."""
        return self.archive_error or self.fault == "defaults_checksum"

    def _load_defaults(self) -> tuple[dict[str, Any] | None, bool]:
        """The stored power-up defaults and whether their archive is damaged: a file that
        cannot be read, or an image this firmware does not read back (of another format, or a
        value no command would set: nv_image.py; set aside as `.corrupt`), is a checksum error
        (bit 12)."""
        store = self.ctx.nvram
        if store is None:
            return None, False
        existed = store.path(self.name).exists()
        image = store.load(self.name, lambda image: check_image(self.n, image))
        if image is None:
            return None, existed
        return image, False

    def _save_defaults(self, image: dict[str, Any]) -> None:
        """APP: the image goes to the state directory atomically (vdevd/nvram.py); a good
        archive clears an earlier checksum error at the next power-up."""
        self.saved = image
        self.archive_error = False
        if self.ctx.nvram is not None:
            self.ctx.nvram.save(self.name, image)

    def nvram(self) -> dict[str, Any]:
        return self.saved or {}

    def firmware_state(self) -> int:
        """Table 3-4: not downloaded (bit 0, with bit 8 for a flash checksum error), else
        running (bit 2), an archive checksum error (bit 12) and which parameter set is in
        working memory: the power-up set (bit 16) or the factory set (bit 18)."""
        if self.fault == "no_firmware":
            return int(FirmwareState.NOT_DOWNLOADED)
        if self.fault == "flash_checksum":
            return int(FirmwareState.NOT_DOWNLOADED | FirmwareState.APPLICATION_CHECKSUM_ERROR)
        state = int(FirmwareState.RUNNING)
        if self.defaults_bad():
            state |= int(FirmwareState.DEFAULTS_CHECKSUM_ERROR)
        state |= int(FirmwareState.POWER_UP_SET if self.fw.loaded == "power_up"
                     else FirmwareState.FACTORY_SET)
        return state

    # -- the host's accesses to the shared memory ----------------------------------------------------
    def _store(self, offset: int, data: bytes, base: int) -> int | None:
        """Store a (possibly partial) write of the word at `base`; its value once the write
        reached the word's last byte, else None."""
        size = len(data)
        self.mem[offset: offset + size] = data
        if size == 4:  # the whole word (a 4-byte access is aligned, so at `base`)
            return int.from_bytes(data, "big")
        if offset + size < base + 4:
            return None
        return rings.u32(self.mem, base)

    def _commands_written(self, offset: int, data: bytes) -> None:
        if self._store(offset, data, _CMD_INSERT) is not None and self.decode_on_arrival:
            self._serve()

    def _semaphore_written(self, offset: int, data: bytes) -> None:
        """The host releases the semaphore: the next reply may go out (spec §2.5)."""
        if self._store(offset, data, _SEMAPHORE) is not None:
            self._post_reply()

    def _response_released(self, offset: int, data: bytes) -> None:
        """The host has read up to its new process index 0x0FC (spec §2.5)."""
        if self._store(offset, data, _RSP_PROCESS) is not None:
            self._post_reply()

    def _wk_clear(self, offset: int, data: bytes) -> None:
        """W/K status words: the host clears bits by writing ones."""
        base = Shm.W_STATUS_FLAGS if offset < Shm.K_STATUS_FLAGS else Shm.K_STATUS_FLAGS
        i = 0 if base == Shm.W_STATUS_FLAGS else 1
        old = self.fw.wk_flags[i]
        value = self._store(offset, data, base)
        if value is not None:
            self.fw.wk_flags[i] = old & ~value
            rings.put_u32(self.mem, base, self.fw.wk_flags[i])

    def _direct_command(self, offset: int, data: bytes) -> None:
        code = self._store(offset, data, Shm.DIRECT_COMMAND)
        if code is None or code == 0 or not self.running:
            return
        fw = self.fw
        if code == DirectCommand.KILL_ALL_MOTION:
            fw.kill(list(range(self.n)))
        elif code == DirectCommand.CONTROLLER_ID_QUERY:
            fw.replies.append(fw.identity().encode() + b"\n")
            self._post_reply()
        elif code in (DirectCommand.RESET_CONTROLLER, DirectCommand.SOFTBOOT_CONTROLLER):
            self.power_up()
            return
        rings.put_u32(self.mem, Shm.DIRECT_COMMAND, 0)

    def _position_request(self, offset: int, data: bytes) -> None:
        value = self._store(offset, data, Shm.POSITION_REQUEST)
        if value:
            self.snapshot()
            rings.put_u32(self.mem, Shm.POSITION_REQUEST, 0)

    # -- the message unit -------------------------------------------------------------------------------
    def _mu_read(self, offset: int, size: int) -> bytes:
        return self.mu.read(offset).to_bytes(4, "little")

    def _mu_peek(self, offset: int, size: int) -> bytes:
        words = b"".join(struct.pack("<I", self.mu.read(o)) for o in range(offset & ~3,
                                                                           offset + size, 4))
        skip = offset & 3
        return words[skip: skip + size]

    def _mu_write(self, offset: int, data: bytes) -> None:
        self.mu.write(offset, int.from_bytes(data, "little"))

    def _line(self, level: bool) -> None:
        if level:
            self.inta.trigger(self.mu.omisr & ~self.mu.omimr)
        else:
            self.inta.clear()

    def _inbound(self, value: int) -> None:
        """IDBR: "direct command mailbox written" (spec §2.9, assumption)."""
        code = rings.u32(self.mem, Shm.DIRECT_COMMAND)
        if code:
            self._direct_command(Shm.DIRECT_COMMAND, struct.pack(">I", code))

    # -- the firmware ----------------------------------------------------------------------------------
    def _serve(self) -> None:
        """Parse the new bytes of the command ring, then post a reply if the host is free.
        Without a running application nothing takes the bytes (0x0F4 stays)."""
        if not self.running:
            return
        data = rings.take_commands(self.mem)
        fw = self.fw
        if data:
            fw.now_ns = self.now_ns
            fw.feed(data)
            if fw.reset_requested:
                self.power_up()
                return
        if fw.replies:
            self._post_reply()

    def _post_reply(self) -> None:
        fw = self.fw
        if fw.replies and rings.response_free(self.mem):
            text = fw.replies.popleft()
            rings.post_response(self.mem, text)
            self.mu.message(0, len(text))

    def step(self) -> None:
        if not self.running:
            return
        fw = self.fw
        fw.now_ns = self.now_ns
        if not self.decode_on_arrival:
            self._serve()
        fw.cycle()
        self._after_cycle()

    def _after_cycle(self) -> None:
        """Captures and a reply the cycle has for the host."""
        fw = self.fw
        if fw.capture.pending:
            self._post_captures()
        if fw.replies:
            self._post_reply()

    def run(self, room: int) -> int:
        """Update cycles that are the motion core's tick alone run as a loop of core ticks
        (`_run_core`): not while the firmware has more to do at a cycle than its motion's tick
        (Firmware.motion_only), decodes at the cycle, has captures or replies for the host, or
        its application does not run."""
        if not self.running or not self.decode_on_arrival:
            return 0
        fw = self.fw
        if fw.capture.pending or fw.replies or not fw.motion_only():
            return 0
        return self._run_core(room)

    def _run_core(self, room: int) -> int:
        """Up to `room` cycles of the motion core's tick alone (`run`); the first that
        reports motion events runs the rest of its cycle and ends the run. The count run."""
        fw = self.fw
        core_tick = fw.motion.core.tick
        for k in range(1, room + 1):
            events = core_tick()
            if events:
                self.ticks_run(k)
                fw.now_ns = self.now_ns
                fw.after_motion(fw.motion.after_core(events))
                self._after_cycle()
                return k
        self.ticks_run(room)
        fw.now_ns = self.now_ns
        return room

    def batch_done(self) -> None:
        """The host reads the cycle's words only between batches of ticks: they are published
        once, after the last tick of a batch (decision 0008)."""
        if self.running:
            self.publish()

    # -- rest (decision 0008) -------------------------------------------------------------------------
    def rest_state(self) -> bytes | None:
        """The firmware's state and both windows, as bytes; None while the card has work: bytes
        in the command ring, replies or captures to post, queued or contouring motion, a home
        search, armed capture inputs. A card whose application is stopped does nothing."""
        if not self.running:
            return b"stopped"
        fw = self.fw
        m = fw.motion
        if (fw.replies or fw.contours or fw.running_contours or fw.waiting_contours
                or fw.live_contours or fw.capture.armed or fw.capture.pending
                or fw.reset_requested or m.searching.any()
                or any(q.items for q in fw.queues)
                or (not self.decode_on_arrival and rings.commands_waiting(self.mem))):
            return None
        core = m.core.rest_state()
        if core is None:
            return None
        return b"".join((core, state_bytes(fw, m, m.encoders, m.servo, fw.capture, self.mu,
                                           skip=("now_ns",)),
                         repr(fw.wk_flags).encode(), self.mem, self.mu_region.buf))

    def polled_state(self) -> bytes:
        """Decoding at the cycle, the card reads the command ring's indices at every cycle (the
        process index is passive: a local client may write it through the shared mapping)."""
        if self.decode_on_arrival:
            return b""
        return bytes(self.mem[_CMD_INSERT:_CMD_INSERT + 8])  # insert and process indices

    def skip(self, k: int) -> None:
        self.fw.motion.core.skip(k)
        super().skip(k)
        if self.running:
            self.fw.now_ns = self.now_ns  # what the last of the k cycles would have set

    def publish(self) -> None:
        """Positions, status words and DACs as the host reads them every cycle [S Table 3-1]."""
        fw, n, words = self.fw, self.n, self.words
        m = fw.motion
        encoder = fw.encoder_position()
        words[MOTOR_WORDS[:n]] = wrap_int32(fw.motor_position())
        words[ENCODER_WORDS[:n]] = wrap_int32(encoder)
        words[DAC_WORDS[:n]] = self._dac()
        mem = self.mem
        rings.put_u32(mem, Shm.LIMIT_SWITCH_STATUS, fw.limit_word())
        rings.put_u32(mem, Shm.HOME_SWITCH_STATUS, home_word(m.home_level))
        rings.put_u32(mem, Shm.FIRMWARE_STATE, self.firmware_state())
        rings.put_u32(mem, Shm.GPIO_STATUS, fw.gpio_levels())
        rings.put_u32(mem, Shm.W_STATUS_FLAGS, fw.wk_flags[0])
        rings.put_u32(mem, Shm.K_STATUS_FLAGS, fw.wk_flags[1])
        words[SSI_WORDS[:n]] = fw.ssi.words(encoder, gray=self.ssi_gray)

    def snapshot(self) -> None:
        """The position request: motor, encoder and DAC of every axis from the same cycle."""
        fw, n, words = self.fw, self.n, self.words
        words[COHERENT_MOTOR_WORDS[:n]] = wrap_int32(fw.motor_position())
        words[COHERENT_ENCODER_WORDS[:n]] = wrap_int32(fw.encoder_position())
        words[COHERENT_DAC_WORDS[:n]] = self._dac()

    def _dac(self) -> np.ndarray:
        """The DAC words: counts, +-32767 = +-10 V, 0..32767 on unipolar servo axes (servo.py)."""
        return self.fw.motion.servo.dac_words()

    def capture(self, a: int, home_bits: int = 0, rising: int = 0, falling: int = 0,
                position: int | None = None) -> None:
        """One real-time capture entry (the encoder position now unless given) and the OMR1
        notice [S §3.7]."""
        enc = int(self.fw.encoder_position()[a]) if position is None else position
        rings.push_capture(self.mem, enc, a, home_bits, rising, falling)
        self.mu.message(1, CAPTURE_MESSAGE)

    def _post_captures(self) -> None:
        """The entries the update cycle recorded (capture.py), in order."""
        pending = self.fw.capture.pending
        for e in pending:
            self.capture(e.axis, e.home, e.rising, e.falling, e.position)
        pending.clear()

    def describe(self) -> dict[str, Any]:
        info = super().describe()
        info["board"] = self.board
        info["axes"] = self.n
        return info

    # -- the axis world ------------------------------------------------------------------------------
    def _make_world(self) -> None:
        """The `[[card.axis]]` mechanics; an axis whose table gives no index keeps the card's
        encoder default (a pulse every 4096 counts from 0, encoder.py)."""
        world = self.make_world(self.n)
        given = [m.index is not None for m in self.opts.axis]
        for a in range(self.n):
            if a >= len(given) or not given[a]:
                world.index_period[a], world.index_phase[a] = DEFAULT_INDEX
        #: axes with probe positions to cross (position capture, capture.py)
        self._probe_axes = [a for a, p in enumerate(world.probes) if len(p)]
        self._probing = bool(self._probe_axes)

    def push_axis(self, a: int, counts: float) -> None:
        """Backdoor `push`: the axis moved by hand (MotionCore.push)."""
        self.fw.motion.core.push(a, counts)

    def physical_positions(self) -> np.ndarray:
        """The stage's positions (motor counts): the core's actual ones less every LP and
        home search (MotionCore.physical), and less what a restart zeroed (power_up)."""
        return self.fw.motion.core.physical()

    def _sense(self) -> None:
        """After each cycle's motion: the switches from the stage's positions, then the probe
        positions crossed (Firmware.sense)."""
        if self.world.mechanical:
            self.sense_world()
        if self._probing:
            here = self.physical_positions()
            world, fw = self.world, self.fw
            for a in self._probe_axes:
                at = world.probe_between(a, float(self._probe_from[a]), float(here[a]))
                if at is not None:
                    fw.capture.probe(fw, a, float(here[a]) - at)
            self._probe_from = here

    def apply_world(self) -> None:
        """The world's levels and faults on the card's signals (README.md "Axis world",
        "Backdoor"): the limit and home inputs through their polarity (OmsMotion.set_world),
        set_estop holding every limit input active; index pulses to the encoders; amplifier
        fault (servo axes), encoder loss (axes with an encoder) and jam to the motion core."""
        world, fw, done = self.world, self.fw, self._applied
        m = fw.motion
        core = m.core
        m.window_lo[:], m.window_hi[:] = world.home_lo, world.home_hi
        for a in np.flatnonzero((world.index_period != done.index_period)
                                | (world.index_phase != done.index_phase)).tolist():
            m.encoders.place_index(a, float(world.index_period[a]), float(world.index_phase[a]))
        done.index_period[:], done.index_phase[:] = world.index_period, world.index_phase
        m.set_world(world.limit_pos | world.estop, world.limit_neg | world.estop, world.home,
                    np.isfinite(world.neg_at) | np.isfinite(world.pos_at),
                    world.home_lo <= world.home_hi)
        m.check_homes()
        servo = np.array([t == "M" for t in fw.params.ptype])
        encoder = np.array([t in "EM" for t in fw.params.ptype])
        fault, loss = world.amp_fault & servo, world.encoder_loss & encoder
        if (fault != core.amp_fault).any() or (loss != core.encoder_loss).any():
            core.set_inputs(amp_fault=fault, encoder_loss=loss)
        core.follow_jams(world.jammed)
        fw.on_motion_events(int(AxisFlag.AMP_FAULT) if fault.any() else 0)
        # sensed every cycle only while positions matter (switches placed, probes to cross)
        fw.sense = self._sense if world.mechanical or self._probing else None
        self.publish()

    def drive_input(self, line: int, level: bool) -> None:
        """General-purpose I/O line IOn (0-15) as the outside drives it (inputs only)."""
        if not isinstance(line, int) or not 0 <= line <= 15:
            raise ValueError("line must be 0-15")
        fw = self.fw
        fw.gpio_in = fw.gpio_in | 1 << line if level else fw.gpio_in & ~(1 << line)
        self.publish()

    def drive_analog(self, channel: int, volts: float) -> None:
        """Analog input AI0-AI3 in volts (+-10 V, 16-bit) [S §4.5.1]."""
        fw = self.fw
        if not 0 <= channel < fw.analog_channels:
            raise ValueError(f"channel must be 0-{fw.analog_channels - 1}")
        counts = max(-32767, min(32767, round(float(volts) / 10 * 32767)))
        fw.analog_in[channel] = counts * 10 / 32767

    def drive_estop(self, active: bool) -> None:
        """The MAXk has no emergency-stop input: the E-stop chain is wired into every axis's
        limit inputs (README.md "Assumptions"), so while active all of them are."""
        self.world.estop = bool(active)
        self._world_changed()

    # -- backdoor ------------------------------------------------------------------------------------
    @control(deprecated="set_limit")
    def set_limits(self, axis: str, positive: bool | None = None,
                   negative: bool | None = None) -> None:
        """Limit switches of one axis, True = held active (set_limit with side and active)."""
        for side, level in (("positive", positive), ("negative", negative)):
            if level is not None:
                self.set_limit(axis, side, bool(level))

    @control()
    def set_home(self, axis: str | int, active: bool = True) -> None:
        """Hold the home switch active (or release it to the mechanics); a switch set_home_edge
        placed on the axis is removed."""
        a, m = self.axis_index(axis), self.fw.motion
        if math.isfinite(m.home_edge[a]):  # the edge's level gives way to the world's
            m.set_home_edge(a, None)
            high = bool(self.fw.params.home_high[a])
            m.home_level[a] = high if m.home_world[a] else not high
        super().set_home(axis, active)

    @control()
    def set_home_edge(self, axis: str, position: float | None = None,
                      width: float | None = None) -> None:
        """A home switch at `position` counts: active from there up, for `width` counts if given
        (None: back to set_home). The level follows HH/HL; it stays where it is on the axis when
        LP or a home search renumber the axis."""
        if width is not None and not width > 0:
            raise ValueError("width must be positive")
        self.fw.motion.set_home_edge(self.axis_index(axis), position, width)
        self.publish()

    def _encoder_axis(self, axis: str | int, types: str = "EM") -> int:
        a = self.axis_index(axis)
        if self.fw.params.ptype[a] not in types:
            raise ValueError(f"axis {AXES[a]} is PS{self.fw.params.ptype[a]}, "
                             f"this needs PS{' or PS'.join(types)}")
        return a

    @control()
    def set_encoder_slip(self, axis: str, counts: int) -> None:
        """The encoder of a PSE or PSM axis loses `counts` counts (gains them if negative): it
        reads that much less than the motor moved, until LP/LPE or a home search load it. A
        servo's loop makes up for it (the motor runs on), a stepper's encoder stays behind."""
        if not -2**31 < counts < 2**31:
            raise ValueError(f"counts {counts!r} outside the encoder's 32-bit range")
        self.fw.motion.core.slip_encoder(self._encoder_axis(axis), int(counts))

    @control()
    def set_encoder_loss(self, axis: str | int, active: bool = True) -> None:
        """A lost encoder (PSE, PSM): its reading freezes while active."""
        if active:
            self._encoder_axis(axis)
        super().set_encoder_loss(axis, active)

    @control()
    def set_amp_fault(self, axis: str | int, active: bool = True) -> None:
        """The amplifier fault input of a servo axis (PSM): the axis is aborted and its loop
        opened and it is reported as a slip, all at once (faults.py)."""
        if active:
            self._encoder_axis(axis, "M")
        super().set_amp_fault(axis, active)

    @control()
    def get_outputs(self) -> dict[str, Any]:
        """What the card drives on its output pins: the 16 I/O lines (`gpio`, bit n = IOn),
        the auxiliary outputs (`aux`, one bool per axis, AN/AF) and the DACs (`dac_volts`)."""
        fw, m = self.fw, self.fw.motion
        volts = self._dac() * 10 / 32767
        return {"gpio": fw.gpio_levels(), "aux": fw.aux.tolist(),
                "dac_volts": [round(float(v), 4) for v in volts],
                "direction": m.servo.direction_outputs(m.direction).tolist()}

    @control()
    def set_firmware_state(self, state: str) -> None:
        """running | no_firmware | flash_checksum | defaults_checksum; takes effect at once
        (the card restarts). Without firmware (no_firmware, flash_checksum) the card parses no
        command; defaults_checksum loads the factory set (Table 3-4 bits 12, 18)."""
        if state not in ("running", "no_firmware", "flash_checksum", "defaults_checksum"):
            raise ValueError(f"unknown firmware state {state!r}")
        self.fault = None if state == "running" else state
        self.power_up()
