"""The OMS MAXk PCI card (type `oms-maxk`): README.md in this package.

Two windows: `shm` (BAR2, the 64 KiB shared memory, big-endian) and `mu` (BAR4, the message unit,
little-endian). A host write of the command ring's insert index hands the new bytes to the
firmware at once (`decode = "arrival"`, default) or at the next update cycle (`"cycle"`); replies
go out one at a time through the response ring and the message semaphore; every update cycle the
firmware advances its queues and the motion core and publishes positions and status words.
"""

from __future__ import annotations

import struct
from collections.abc import Mapping
from typing import Any, ClassVar

import numpy as np

from vdevd.devices.base import Card, CardContext, Option, control
from vdevd.devices.oms import rings
from vdevd.devices.oms.firmware import Firmware
from vdevd.devices.oms.layout import (
    AXIS_LETTERS,
    CAPTURE_MESSAGE,
    COHERENT_DAC_WORDS,
    COHERENT_ENCODER_WORDS,
    COHERENT_MOTOR_WORDS,
    DAC_WORDS,
    ENCODER_WORDS,
    MOTOR_WORDS,
    MU_SIZE,
    SHM_SIZE,
    SSI_WORDS,
    DirectCommand,
    Shm,
    home_word,
)
from vdevd.devices.oms.layout import (
    Firmware as FwFlags,
)
from vdevd.devices.oms.motion import clip32
from vdevd.devices.oms.mu import MessageUnit
from vdevd.devices.oms.params import AXIS_TYPES
from vdevd.region import Region

UPDATE_RATES = (1024, 2048, 4096, 8192)
VERSION = "1.50"


def _default_types(n: int) -> list[str]:
    """Servo on the first four axes, steppers after (the issue's default)."""
    return ["servo" if a < 4 else "stepper" for a in range(n)]


class MaxkCard(Card):
    type_name: ClassVar[str] = "oms-maxk"
    endian: ClassVar[str] = "big"
    options: ClassVar[Mapping[str, Option]] = {
        "board": Option(int, 1, min=1, max=8, help="board number (J5 jumpers, 1-8)"),
        "axes": Option(int, 8, min=1, max=10, help="1-10: MAXk-1000 ... MAXk-A000"),
        "axis_types": Option(list, None, choices=tuple(AXIS_TYPES),
                             help="per axis stepper | stepper_encoder | servo"),
        "update_hz": Option(int, 1024, choices=UPDATE_RATES, help="update rate, as #UR sets it"),
        "plant": Option(str, "model", choices=("model", "ideal"),
                        help="model: stepper and servo plants; ideal: axes follow exactly"),
        "decode": Option(str, "arrival", choices=("arrival", "cycle"),
                         help="parse commands when the insert index is written, or next cycle"),
        "serial": Option(int, 1, min=0, max=999999, help="serial number WY reports"),
    }

    def __init__(self, name: str, config: Mapping[str, Any], ctx: CardContext) -> None:
        super().__init__(name, config, ctx)
        cfg = self.config
        self.board = int(cfg.get("board") or 1)
        self.n = int(cfg.get("axes") or 8)
        types = list(cfg.get("axis_types") or _default_types(self.n))
        if len(types) != self.n:
            raise ValueError(f"axis_types: {len(types)} types for {self.n} axes")
        self.types = [AXIS_TYPES[t] for t in types]
        self.update_hz = int(cfg.get("update_hz") or 1024)
        if not cfg.get("period_ns"):
            self.period_ns = round(1e9 / self.update_hz)
        self.ideal = str(cfg.get("plant") or "model") == "ideal"
        self.decode_on_arrival = str(cfg.get("decode") or "arrival") == "arrival"
        self.serial = int(cfg.get("serial") or 1)

        self.shm = self.add_region(Region(
            "shm", SHM_SIZE, widths=(1, 2, 4), endian="big",
            description="BAR2 shared memory: positions, status, rings, capture (Table 3-1)"))
        self.mem = self.shm.buf
        self.words = np.frombuffer(self.mem, dtype=">i4")
        for offset, fn in ((Shm.DIRECT_COMMAND, self._direct_command),
                           (Shm.POSITION_REQUEST, self._position_request),
                           (Shm.SEMAPHORE, self._release),
                           (Shm.W_FLAGS, self._wk_clear), (Shm.K_FLAGS, self._wk_clear),
                           (Shm.CMD_INSERT, self._commands_written),
                           (Shm.RSP_PROCESS, self._release)):
            self.shm.hook(offset, 4, on_write=fn)
        self.mu_region = self.add_region(Region(
            "mu", MU_SIZE, widths=(4,), endian="little",
            description="BAR4 message unit: OMISR, OMIMR, OMR0/1, ODBR, IDBR (MPC8245)"))
        self.mu_region.hook(0, MU_SIZE, on_read=self._mu_read, on_write=self._mu_write,
                            peek=self._mu_peek)
        self.inta = self.add_irq("inta")
        self.mu = MessageUnit(on_line=self._line, on_inbound=self._inbound)
        self.saved = self.ctx.nvram.load(self.name) if self.ctx.nvram else None
        self.fault: str | None = None  # backdoor firmware state (no firmware, checksum error)
        self.power_up()

    # -- power-up -------------------------------------------------------------------------------------
    def power_up(self) -> None:
        """Firmware start: positions 0, working parameters from the stored defaults if valid."""
        self.mem[:] = bytes(SHM_SIZE)
        self.mu.reset()
        self.inta.clear()
        image = None if self.fault == "defaults_checksum" else self.saved
        self.fw = Firmware(self.n, self.types, self.period_ns, ideal=self.ideal,
                           ring=self.mu.ring, version=VERSION, serial=self.serial,
                           save=self._save_defaults, saved=image)
        self.fw.now_ns = self.now_ns
        self.publish()

    def reset(self) -> None:
        self.power_up()

    def _save_defaults(self, image: dict[str, Any]) -> None:
        self.saved = image
        if self.ctx.nvram is not None:
            self.ctx.nvram.save(self.name, image)

    def nvram(self) -> dict[str, Any]:
        return self.saved or {}

    def firmware_state(self) -> int:
        """Table 3-4: running, and which parameter set was loaded."""
        if self.fault == "no_firmware":
            return int(FwFlags.NOT_DOWNLOADED)
        if self.fault == "flash_checksum":
            return int(FwFlags.NOT_DOWNLOADED | FwFlags.FLASH_CHECKSUM)
        state = int(FwFlags.RUNNING)
        if self.fault == "defaults_checksum":
            state |= int(FwFlags.DEFAULTS_CHECKSUM)
        state |= int(FwFlags.POWER_UP_SET if self.fw.loaded == "power_up"
                     else FwFlags.FACTORY_SET)
        return state

    # -- the host's accesses to the shared memory ----------------------------------------------------
    def _store(self, offset: int, data: bytes, base: int) -> int | None:
        """Store a (possibly partial) write of the word at `base`; its value once the write
        reached the word's last byte, else None."""
        self.mem[offset: offset + len(data)] = data
        if offset + len(data) < base + 4:
            return None
        return rings.u32(self.mem, base)

    def _commands_written(self, offset: int, data: bytes) -> None:
        if self._store(offset, data, Shm.CMD_INSERT) is not None and self.decode_on_arrival:
            self._serve()

    def _release(self, offset: int, data: bytes) -> None:
        base = Shm.SEMAPHORE if offset < Shm.RSP_PROCESS else Shm.RSP_PROCESS
        if self._store(offset, data, base) is not None:
            self._post_reply()

    def _wk_clear(self, offset: int, data: bytes) -> None:
        """W/K status words: the host clears bits by writing ones."""
        base = Shm.W_FLAGS if offset < Shm.K_FLAGS else Shm.K_FLAGS
        i = 0 if base == Shm.W_FLAGS else 1
        old = self.fw.wk_flags[i]
        value = self._store(offset, data, base)
        if value is not None:
            self.fw.wk_flags[i] = old & ~value
            rings.put_u32(self.mem, base, self.fw.wk_flags[i])

    def _direct_command(self, offset: int, data: bytes) -> None:
        code = self._store(offset, data, Shm.DIRECT_COMMAND)
        if code is None or code == 0:
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
        return struct.pack("<I", self.mu.read(offset))

    def _mu_peek(self, offset: int, size: int) -> bytes:
        words = b"".join(struct.pack("<I", self.mu.read(o)) for o in range(offset & ~3,
                                                                           offset + size, 4))
        skip = offset & 3
        return words[skip: skip + size]

    def _mu_write(self, offset: int, data: bytes) -> None:
        self.mu.write(offset, struct.unpack("<I", data)[0])

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
        """Parse the new bytes of the command ring, then post a reply if the host is free."""
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
        fw = self.fw
        fw.now_ns = self.now_ns
        if not self.decode_on_arrival:
            self._serve()
        fw.cycle()
        if fw.replies:
            self._post_reply()
        self.publish()

    def publish(self) -> None:
        """Positions, status words and DACs as the host reads them every cycle [S Table 3-1]."""
        fw, n, words = self.fw, self.n, self.words
        m = fw.motion
        words[MOTOR_WORDS[:n]] = clip32(fw.motor_position())
        words[ENCODER_WORDS[:n]] = clip32(fw.encoder_position())
        words[DAC_WORDS[:n]] = np.rint(np.clip(m.core.axes.out, -32767, 32767))
        mem = self.mem
        rings.put_u32(mem, Shm.LIMITS, fw.limit_word())
        rings.put_u32(mem, Shm.HOMES, home_word(m.home_level))
        rings.put_u32(mem, Shm.FIRMWARE, self.firmware_state())
        rings.put_u32(mem, Shm.GPIO, fw.gpio_levels())
        rings.put_u32(mem, Shm.W_FLAGS, fw.wk_flags[0])
        rings.put_u32(mem, Shm.K_FLAGS, fw.wk_flags[1])
        words[SSI_WORDS[:n]] = clip32(fw.encoder_position())

    def snapshot(self) -> None:
        """The position request: motor, encoder and DAC of every axis from the same cycle."""
        fw, n, words = self.fw, self.n, self.words
        words[COHERENT_MOTOR_WORDS[:n]] = clip32(fw.motor_position())
        words[COHERENT_ENCODER_WORDS[:n]] = clip32(fw.encoder_position())
        words[COHERENT_DAC_WORDS[:n]] = np.rint(np.clip(fw.motion.core.axes.out, -32767, 32767))

    def capture(self, a: int, home_bits: int = 0, rising: int = 0, falling: int = 0) -> None:
        """One real-time capture entry and the OMR1 notice [S §3.7]."""
        enc = int(self.fw.encoder_position()[a])
        rings.push_capture(self.mem, enc, a, home_bits, rising, falling)
        self.mu.message(1, CAPTURE_MESSAGE)

    def describe(self) -> dict[str, Any]:
        info = super().describe()
        info["board"] = self.board
        return info

    # -- backdoor ------------------------------------------------------------------------------------
    def _axis(self, axis: str | int) -> int:
        a = AXIS_LETTERS.index(axis.upper()) if isinstance(axis, str) else int(axis)
        if not 0 <= a < self.n:
            raise ValueError(f"no axis {axis!r} on this {self.n}-axis card")
        return a

    @control()
    def set_limits(self, axis: str, positive: bool | None = None,
                   negative: bool | None = None) -> None:
        """Limit switches of one axis, True = switch active (the input level follows LTH/LTL)."""
        a, m = self._axis(axis), self.fw.motion
        high = bool(self.fw.params.limit_high[a])
        if positive is not None:
            m.limit_pos_level[a] = high if positive else not high
        if negative is not None:
            m.limit_neg_level[a] = high if negative else not high
        m.apply_limits()
        self.fw.on_motion_events(1)
        self.publish()

    @control()
    def set_home(self, axis: str, active: bool) -> None:
        """The home switch of one axis, True = active (the level follows HH/HL)."""
        a, m = self._axis(axis), self.fw.motion
        m.set_home_edge(a, None)
        high = bool(self.fw.params.home_high[a])
        m.home_level[a] = high if active else not high
        m.apply_limits()
        m.check_homes()
        self.publish()

    @control()
    def set_home_edge(self, axis: str, position: float | None = None) -> None:
        """A home switch at `position`: active at and above it (None: back to set_home)."""
        self.fw.motion.set_home_edge(self._axis(axis), position)

    @control()
    def set_input(self, bit: int, level: int) -> None:
        """General-purpose I/O line IOn as the outside drives it (inputs only)."""
        if not 0 <= bit <= 15:
            raise ValueError("bit must be 0-15")
        fw = self.fw
        fw.gpio_in = fw.gpio_in | 1 << bit if level else fw.gpio_in & ~(1 << bit)
        self.publish()

    @control()
    def set_analog(self, channel: int, volts: float) -> None:
        """Analog input AI0-AI3 in volts (+-10 V, 16-bit) [S §4.5.1]."""
        fw = self.fw
        if not 0 <= channel < fw.analog_channels:
            raise ValueError(f"channel must be 0-{fw.analog_channels - 1}")
        counts = max(-32767, min(32767, round(float(volts) / 10 * 32767)))
        fw.analog_in[channel] = counts * 10 / 32767

    @control()
    def set_firmware_state(self, state: str) -> None:
        """running | no_firmware | flash_checksum | defaults_checksum; takes effect at once
        (the card restarts)."""
        if state not in ("running", "no_firmware", "flash_checksum", "defaults_checksum"):
            raise ValueError(f"unknown firmware state {state!r}")
        self.fault = None if state == "running" else state
        self.power_up()
