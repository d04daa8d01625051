"""The AMP-204C/208C motion kernel, sans-I/O [M ch. 4; spec adlink.md §2].

One `cycle()` is one motion cycle in the order of the spec's emulation rule (§2.2): inputs
(the card applies its axis world before), protections, trajectories (the units' paths, then the
motion core's tick), the single-axis segment queue and completions, the units' after-motion work
(compare, PWM, sampling), the status words, the interrupt factors. `execute()` runs a mailbox
command at once (the host communication of §4.1.2.3) and republishes the status, so a status
call right after a start never shows a stale "done" (spec §2.2, Q10).

Units (interpolation groups, gearing, compare trigger, ... each in its own module) plug in as
objects with `before_motion(t)`, `after_motion(t)`, `busy()` and `reset()`; an axis a unit
drives is marked in `owned` and the unit keeps its status through `unit_moving` and `phase`.
"""

from __future__ import annotations

import logging
import math
import struct
from collections.abc import Callable
from typing import Any

import numpy as np
from vdevmaps.adlink import (
    BY_CODE,
    BY_NAME,
    INT_ITEMS,
    LAYOUT_VERSION,
    MAGIC,
    REPLY_MAX,
    Bar,
    CodecError,
    decode,
    encode,
)
from vdevmaps.aps_defs import (
    MIO_ALM,
    MIO_EMG,
    MIO_EZ,
    MIO_INP,
    MIO_MEL,
    MIO_ORG,
    MIO_PEL,
    MIO_SMEL,
    MIO_SPEL,
    MIO_SVON,
    MTS_ACC,
    MTS_ASTP,
    MTS_BLD,
    MTS_CSTP,
    MTS_DEC,
    MTS_DIR,
    MTS_GER,
    MTS_HMV,
    MTS_JOG,
    MTS_MDN,
    MTS_POSTD,
    MTS_PRED,
    MTS_PTB,
    MTS_VM,
    MTS_WAIT,
    STOP_ALM,
    STOP_EMG,
    STOP_ERROR_LEVEL,
    STOP_MEL,
    STOP_NORMAL,
    STOP_PEL,
    STOP_SMEL,
    STOP_SPEL,
    STOP_SVNO,
    ERR_FirmwareError,
    ERR_FunctionNotAvailable,
    ERR_ParametersInvalid,
)

from vdevd.devices.adlink import (
    cmd_interp,
    cmd_io,
    cmd_ptable,
    cmd_system,
    gear,
    home,
    interrupts,
    jog,
    motion,
    profile,
    pwm,
    safety,
    sampling,
    trigger,
)
from vdevd.devices.adlink import status as st
from vdevd.devices.adlink.commands import COMMANDS
from vdevd.devices.adlink.errors import ApsError
from vdevd.devices.adlink.interp import Interpolation
from vdevd.devices.adlink.modes import HOME, IDLE, JOG, STOPPING, UNIT, VEL, Unit
from vdevd.devices.adlink.params import AxisParams, BoardParams
from vdevd.devices.adlink.ptable import PointTables
from vdevd.devices.adlink.runs import Runs
from vdevd.region import Memory
from vdevd.rt import MotionCore, PlantKind
from vdevd.rt.axes import Axes

log = logging.getLogger(__name__)

# interrupt items [M §4.11]
ITEM_SYSTEM, ITEM_DI_RISE, ITEM_DI_FALL = 8, 9, 10
SYS_IEMG, SYS_IMOV, SYS_IHOV = 1 << 0, 1 << 5, 1 << 6
# the axis factors that follow status conditions (bit numbers of M §4.11)
_I = {"IALM": 0, "IPEL": 1, "IMEL": 2, "IORG": 3, "IEZ": 4, "IINP": 5, "IEMG": 6, "ICSTP": 8,
      "IVM": 9, "IACC": 10, "IDEC": 11, "IMDN": 12, "IASTP": 13, "ISPEL": 15, "ISMEL": 16,
      "IPRED": 18, "IPOSTD": 19}

#: the axis factors and the status bits they follow: (word 0 MSTS / 1 MIO, bit, factor bit)
_AXIS_FACTORS = (
    (1, MIO_ALM, _I["IALM"]), (1, MIO_PEL, _I["IPEL"]), (1, MIO_MEL, _I["IMEL"]),
    (1, MIO_ORG, _I["IORG"]), (1, MIO_EZ, _I["IEZ"]), (1, MIO_INP, _I["IINP"]),
    (1, MIO_EMG, _I["IEMG"]), (0, MTS_CSTP, _I["ICSTP"]), (0, MTS_VM, _I["IVM"]),
    (0, MTS_ACC, _I["IACC"]), (0, MTS_DEC, _I["IDEC"]), (0, MTS_MDN, _I["IMDN"]),
    (0, MTS_ASTP, _I["IASTP"]), (1, MIO_SPEL, _I["ISPEL"]), (1, MIO_SMEL, _I["ISMEL"]),
    (0, MTS_PRED, _I["IPRED"]), (0, MTS_POSTD, _I["IPOSTD"]))

_U32 = struct.Struct("<I")
_ACK = struct.Struct("<IiII")

#: the rows `status_words` stacks: (their MSTS bit, their MIO bit), None where they have none
_ROWS = ((MTS_CSTP, None), (MTS_VM, None), (MTS_ACC, None), (MTS_DEC, None), (MTS_DIR, None),
         (MTS_MDN, None), (MTS_HMV, None), (MTS_WAIT, None), (MTS_PTB, None), (MTS_JOG, None),
         (MTS_ASTP, None), (MTS_BLD, None), (MTS_PRED, None), (MTS_POSTD, None), (MTS_GER, None),
         (None, MIO_ALM), (None, MIO_PEL), (None, MIO_MEL), (None, MIO_ORG), (None, MIO_EMG),
         (None, MIO_EZ), (None, MIO_INP), (None, MIO_SVON), (None, MIO_SPEL), (None, MIO_SMEL))
#: the interrupt condition bits [M §4.11] of the MSTS and MIO bits that raise them (the MIO
#: word orders EMG 4, EZ 5, INP 6 where the factors are IEZ 4, IINP 5, IEMG 6: by name)
_COND_OF_MSTS = {src: factor for word, src, factor in _AXIS_FACTORS if not word}
_COND_OF_MIO = {src: factor for word, src, factor in _AXIS_FACTORS if word}


def _weights() -> np.ndarray:
    """(3, rows) int64: each row's bit in MSTS, in MIO and in the interrupt conditions."""
    w = np.zeros((3, len(_ROWS)), dtype=np.int64)
    for i, (msts, mio) in enumerate(_ROWS):
        if msts is not None:
            w[0, i] = 1 << msts
            if msts in _COND_OF_MSTS:
                w[2, i] = 1 << _COND_OF_MSTS[msts]
        if mio is not None:
            w[1, i] = 1 << mio
            if mio in _COND_OF_MIO:
                w[2, i] = 1 << _COND_OF_MIO[mio]
    return w


_WEIGHTS = _weights()


class Kernel:
    """The kernel of one card: parameters, the axes on a motion core, the status block."""

    def __init__(self, buf: Memory, n: int, model: int, card_id: int,
                 cycle_us: int, drive: str, raise_line: Callable[[], None],
                 inp_window: float = 1.0,
                 clear_line: Callable[[], None] = lambda: None) -> None:
        self.buf = buf
        self.n = n
        self.model = model
        self.card_id = card_id
        self.drive = drive
        self.raise_line = raise_line
        self.clear_line = clear_line
        self.inp_window = inp_window
        #: what a motion command refused for EMG/ALM/EL returns: 0 (the manual's "ignored"),
        #: or the card option `refused_rc` (-13) (spec Q15); `refusal` marks the command now
        self.refused_rc = 0
        self.refusal = False
        self.dt = cycle_us / 1e6
        self.cycle_us = cycle_us
        self.core = MotionCore(n, cycle_us * 1000,
                               PlantKind.SERVO if drive == "servo" else PlantKind.IDEAL)
        self.core.servo_on(slice(None))  # the drive follows the pulses; SVON is `svon` (jams)
        self.axis_params = AxisParams(n)
        self._logic_rows = np.array([self.axis_params.index(no)
                                     for no in (0x00, 0x00, 0x01, 0x04, 0x06, 0x05)])
        #: the rows the compiled `logic` reads: EL, ORG, ALM, EZ, INP logic, soft limits on
        #: (+, -) and at, the unit factor
        self._signal_rows = np.array([self.axis_params.index(no) for no in (
            0x00, 0x01, 0x04, 0x06, 0x05, 0x08, 0x09, 0x0A, 0x0B, 0x86)], dtype=np.intp)
        self.board_params = BoardParams()
        self._rec_ints, self._rec_floats = st.axis_blocks(buf, n)
        self._pub_ints = np.zeros((8, n), dtype=np.int64)  # the blocks' rows, then one copy each
        self._pub_floats = np.zeros((6, n))
        self._jit = st.compiled()  # the status words and records compiled, or None: numpy
        self.int_enable = st.u32_words(buf, Bar.INT_ENABLE, INT_ITEMS)
        self.int_signal = st.u32_words(buf, Bar.INT_SIGNAL, INT_ITEMS)
        #: the kernel's units, in the order of their cycle work (spec §2.2: trajectories,
        #: gearing, compare/PWM/VAO, sampling); each appends itself on its own line
        self.units: list[Unit] = []
        self.units.append(home.Homing(self))
        self.units.append(jog.Jogging(self))
        self.units.append(Interpolation(self))
        self.units.append(PointTables(self))
        self.units.append(gear.GearUnit(self))
        self.units.append(trigger.TriggerUnit(self))
        self.units.append(pwm.PwmUnit(self))
        self.units.append(safety.WatchdogUnit(self))
        self.sampling = sampling.Sampling(self)
        self.units.append(self.sampling)
        #: the mailbox handlers by command code
        bound = COMMANDS.bind(
            cmd_system,
            motion,
            home,
            jog,
            cmd_interp,
            gear,
            trigger,
            pwm,
            cmd_io,
            interrupts,
            sampling,
            cmd_ptable,
            safety,
        )
        self.handlers: dict[int, Callable[..., Any]] = {
            BY_NAME[name].code: fn for name, fn in bound.items()}
        self.flash: dict[str, Any] | None = None  # the parameter image saved to flash
        self.flash_dirty = False  # a new image for the card to write
        self.params_changed = False
        self.new_cycle_us: int | None = None  # PRB 8000h set: the card changes its period
        #: LPSTS (0.01 % of the cycle) and the over-cycle count [M §4.1.2]
        self.timing = [0, 0, 0, 0, 0]
        self.runs = Runs(self)
        self.power_up()

    def parameter_image(self) -> dict[str, Any]:
        """What APS_save_parameter_to_flash keeps: board and axis parameters, and the units'."""
        units = {type(u).__name__: u.image() for u in self.units if hasattr(u, "image")}
        return {"axis": self.axis_params.image(), "board": self.board_params.image(),
                "units": units}

    def restore_parameters(self, image: dict[str, Any]) -> int:
        """Take a parameter image; the count of its entries left out, not legal on this card
        (an image another program or version left: those keep their values)."""
        dropped = self.axis_params.restore(image.get("axis", {}))
        dropped += self.board_params.restore(image.get("board", {}))
        saved = image.get("units", {})
        if not isinstance(saved, dict):
            saved, dropped = {}, dropped + 1
        for u in self.units:
            if hasattr(u, "restore") and type(u).__name__ in saved:
                dropped += u.restore(saved[type(u).__name__])
        return dropped

    # -- state -----------------------------------------------------------------------------------
    def power_up(self) -> None:
        n = self.n
        self.cycles = 0
        self.mode = np.zeros(n, dtype=np.int8)
        self.svon = np.zeros(n, dtype=bool)
        self.cmd_off = np.zeros(n)  # user offsets of APS_set_command_f / set_position_f
        self.fb_off = np.zeros(n)
        self.target = np.zeros(n)  # user units
        self.stop_code = np.zeros(n, dtype=np.int32)
        self.astp = np.zeros(n, dtype=bool)
        self.mdn = np.ones(n, dtype=bool)
        self.wait = np.zeros(n, dtype=bool)
        self.direction = np.zeros(n, dtype=bool)  # DIR: 1 positive, held after a stop
        self.pred = np.zeros(n, dtype=bool)
        self.postd = np.zeros(n, dtype=bool)
        self.pred_at = np.full(n, math.inf)  # times the pre/post-distance events fall due
        self.postd_at = np.full(n, math.inf)
        self.seg_end = np.full(n, math.inf)  # end of the running single-axis segment
        self.owned = np.zeros(n, dtype=bool)  # a unit drives the axis
        self.unit_moving = np.zeros(n, dtype=bool)
        self.phase = np.zeros(n, dtype=np.int8)  # a unit's ACC 1 / VM 2 / DEC 3 of its axes
        self.hmv = np.zeros(n, dtype=bool)
        self.jog = np.zeros(n, dtype=bool)
        self.ptb = np.zeros(n, dtype=bool)
        self.bld = np.zeros(n, dtype=bool)
        self.ger = np.zeros(n, dtype=bool)
        self.gear_status = np.zeros(n, dtype=np.int32)
        #: the gear's share of a slave's command velocity (counts/s, gear.py): the status
        #: words, the limit checks and the readback add it to the profile's
        self.gear_vel = np.zeros(n)
        self.mq_usage = np.zeros(n, dtype=np.int32)
        # inputs: raw levels (True = the signal is on at the connector), logic applied later
        self.raw_alm = np.zeros(n, dtype=bool)
        self.raw_pel = np.zeros(n, dtype=bool)
        self.raw_mel = np.zeros(n, dtype=bool)
        self.raw_org = np.zeros(n, dtype=bool)
        self.raw_ez = np.zeros(n, dtype=bool)
        self.ez_mark = np.zeros(n)  # where the index mark last crossed is (counts, physical)
        self.inp_force = np.full(n, -1, dtype=np.int8)  # backdoor set_inp: -1 from the drive
        self.raw_emg = False
        self.di_raw = 0
        self.do_word = 0
        self.emg = False
        self.alm = np.zeros(n, dtype=bool)
        self.pel = np.zeros(n, dtype=bool)
        self.mel = np.zeros(n, dtype=bool)
        self.org = np.zeros(n, dtype=bool)
        self.ez = np.zeros(n, dtype=bool)
        self.inp = np.zeros(n, dtype=bool)
        self.spel = np.zeros(n, dtype=bool)
        self.smel = np.zeros(n, dtype=bool)
        self.queue: list[list[Any]] = [[] for _ in range(n)]  # queued PTP segments per axis
        self.seg_plan: list[Any] = [None] * n  # the running PTP segment
        self.seg_vm = np.zeros(n)  # its Vm and Ve, and where it started (user units)
        self.seg_ve = np.zeros(n)
        self.seg_from = np.zeros(n)
        self.pending_start = np.zeros(n, dtype=np.int8)  # what OPT_WAIT holds: PTP, VEL, UNIT
        self.vel_pending: list[Any] = [None] * n
        #: a unit's command waiting for APS_move_trigger, by axis (idempotent: every axis of a
        #: group holds the same one)
        self.unit_starts: dict[int, Callable[[], None]] = {}
        #: the next step of a home or jog sequence when the axis's profile ends (True: it
        #: planned another profile)
        self.sequences: dict[int, Callable[[], bool]] = {}
        self.mdn_due: dict[int, int] = {}  # the cycle MDN rises at (PRA_MDN_DELAY)
        self.int_main = False
        self.int_enable[:] = 0
        self.int_signal[:] = 0
        self.clear_line()
        self.prev_axis_cond = np.zeros(n, dtype=np.int64)
        self.prev_sys = 0
        self.prev_di = 0
        self.sys_events = 0  # system factors a unit raised this cycle (compare ends)
        self.ack_seq = 0
        self.msts = np.zeros(n, dtype=np.int64)
        self.mio = np.zeros(n, dtype=np.int64)
        self.axis_cond = np.zeros(n, dtype=np.int64)  # the interrupt conditions (events)
        self._cond_stale = False  # the cycles left prev_axis_cond unset (interrupts off)
        self._true, self._false = np.ones(n, dtype=bool), np.zeros(n, dtype=bool)
        for u in self.units:
            u.reset()
        # the conditions as they stand are no edges (MDN is 1 at power-up) [spec §2.23]
        self.logic()
        self.status_words()
        self.prev_axis_cond = self.axis_conditions()
        self.prev_sys = SYS_IEMG if self.emg else 0
        self.prev_di = self.di_word()
        self.write_identity()

    def write_identity(self) -> None:
        buf = self.buf
        for off, v in ((Bar.MAGIC, MAGIC), (Bar.LAYOUT, LAYOUT_VERSION), (Bar.MODEL, self.model),
                       (Bar.AXES, self.n), (Bar.CARD_ID, self.card_id),
                       (Bar.CYCLE_US, self.cycle_us)):
            _U32.pack_into(buf, off, v)

    # -- units and parameters ----------------------------------------------------------------------
    @property
    def t(self) -> float:
        """The kernel's clock, seconds (the motion core's profile clock)."""
        return self.core.profile.t

    def p(self, no: int) -> np.ndarray:
        """An axis parameter's row (F64 per axis)."""
        return self.axis_params.row(no)

    def factor(self, a: int) -> float:
        return float(self.axis_params.row(0x86)[a])

    def user_cmd(self) -> np.ndarray:
        return self.core.axes.cmd_pos / self.axis_params.row(0x86) + self.cmd_off

    def user_cmd_of(self, a: int) -> float:
        """`user_cmd()[a]` with scalars (the same IEEE operations: the same number)."""
        return (float(self.core.axes.cmd_pos[a]) / float(self.axis_params.row(0x86)[a])
                + float(self.cmd_off[a]))

    def user_fbk(self) -> np.ndarray:
        return self.core.axes.fb / self.axis_params.row(0x86) + self.fb_off

    def to_counts(self, a: int, user: float) -> float:
        return (user - float(self.cmd_off[a])) * self.factor(a)

    def check_axis(self, a: int) -> None:
        if isinstance(a, bool) or not 0 <= a < self.n:
            raise ApsError(ERR_ParametersInvalid, f"axis {a} outside 0..{self.n - 1}")

    # -- CPU load [M §4.1.2] --------------------------------------------------------------------------
    def measure_motion(self, ns: int) -> None:
        """A motion cycle's work took `ns` (wall): its load in 0.01 % of the cycle, the maximum,
        and an over-cycle (system factor IMOV) when it took longer than the cycle."""
        load = ns * 10_000 // (self.cycle_us * 1000)
        t = self.timing
        t[0], t[2] = load, max(t[2], load)
        if load > 10_000:
            t[4] += 1
            self.sys_events |= SYS_IMOV

    def measure_host(self, ns: int) -> None:
        """A host command took `ns`: the host loop's load (of its 2 ms cycle [M §4.1.2.3])."""
        load = ns * 10_000 // 2_000_000
        t = self.timing
        t[1], t[3] = load, max(t[3], load)
        if load > 10_000:
            t[4] += 1
            self.sys_events |= SYS_IHOV

    # -- the mailbox -------------------------------------------------------------------------------
    def execute(self, seq: int, code: int, args: bytes) -> None:
        """Run one posted command and leave its acknowledgement (seq, rc, reply)."""
        self.settle_conditions()
        call = BY_CODE.get(code)
        handler = self.handlers.get(code)
        reply = b""
        if call is None or handler is None:
            rc = ERR_FunctionNotAvailable
        else:
            try:
                values = decode(call.args, args)
                self.refusal = False
                out = handler(self, *values)
                rc = self.refused_rc if self.refusal else 0
                if call.reply:
                    reply = encode(call.reply, out if isinstance(out, list | tuple) else [out])
                    if len(reply) > REPLY_MAX:
                        raise ApsError(ERR_ParametersInvalid, "reply too long")
            except CodecError:
                rc, reply = ERR_ParametersInvalid, b""
            except ApsError as exc:
                rc, reply = exc.code, b""
            except (ValueError, OverflowError, struct.error) as exc:
                log.debug("adlink: %s refused: %s", call.name, exc)
                rc, reply = ERR_ParametersInvalid, b""
            except Exception:  # a kernel bug: the command fails, the card and daemon go on
                log.exception("adlink: %s failed", call.name)
                rc, reply = ERR_FirmwareError, b""
        self.ack_seq = seq
        _ACK.pack_into(self.buf, Bar.ACK_SEQ, seq & 0xFFFFFFFF, rc, len(reply), code & 0xFFFFFFFF)
        self.buf[Bar.REPLY:Bar.REPLY + len(reply)] = reply
        self.logic()  # a command may change what the signals show (SVON and INP, logic, limits)
        self.publish()
        self.command_edges()

    # -- the cycle ---------------------------------------------------------------------------------
    def cycle(self) -> None:
        """One motion cycle (spec §2.2's order)."""
        self.cycles += 1
        core = self.core
        t_next = core.profile.t + self.dt
        self.logic()
        self.protect()
        if np.count_nonzero(self.seg_end <= t_next + 1e-12):
            self.segment_ends(t_next)
        for u in self.units:
            u.before_motion(t_next)
        core.tick()
        self.completions()
        for u in self.units:
            u.after_motion(core.profile.t)
        self.events()

    def logic(self, state: np.ndarray | None = None, moving: np.ndarray | None = None) -> None:
        """The logical (post-inversion) signals from the raw levels [M §4.1.1.4]; INP and the
        soft limits from the motion core's `state` rows and the `moving` axes (default: now;
        the last cycle of a run takes those before its tick, runs.py)."""
        p = self.p
        self.emg = bool(self.raw_emg) != bool(self.board_params.values[0x00])
        if self._jit is not None:
            if state is None:
                state = self.core.axes.state
            prof_moving, unit_moving = (self.core.profile.moving, self.unit_moving) \
                if moving is None else (moving, moving)
            out = np.empty((8, self.n), dtype=bool)
            self._jit[2]((self.raw_pel, self.raw_mel, self.raw_org, self.raw_alm, self.raw_ez),
                         self.axis_params.values, self._signal_rows, state[Axes.CMD_POS],
                         state[Axes.FB], prof_moving, unit_moving, self.svon, self.inp_force,
                         self.inp_window, self.cmd_off, out)
            self.pel, self.mel, self.org, self.alm, self.ez, self.inp, self.spel, self.smel = out
            return
        # the logic parameters EL, EL, ORG, ALM, EZ, INP in one read
        el, _, org, alm, ez, inp_logic = self.axis_params.values[self._logic_rows] != 0
        self.pel = self.raw_pel != el
        self.mel = self.raw_mel != el
        self.org = self.raw_org != org
        self.alm = self.raw_alm != alm
        self.ez = self.raw_ez != ez
        if state is None:
            state = self.core.axes.state
        cmd_pos = state[Axes.CMD_POS]
        if moving is None:
            moving = self.moving()
        settled = (np.abs(cmd_pos - state[Axes.FB]) <= self.inp_window) & ~moving & self.svon
        force = self.inp_force
        inp = np.where(force >= 0, force == 1, settled) if np.count_nonzero(force + 1) else settled
        self.inp = inp != inp_logic
        soft_pos, soft_neg = p(0x08), p(0x09)
        if np.count_nonzero(soft_pos) or np.count_nonzero(soft_neg):
            cmd = cmd_pos / self.axis_params.row(0x86) + self.cmd_off
            self.spel = (soft_pos != 0) & (cmd >= p(0x0A))
            self.smel = (soft_neg != 0) & (cmd <= p(0x0B))
        else:  # no soft limit enabled [M §4.10]
            self.spel, self.smel = np.zeros(self.n, dtype=bool), np.zeros(self.n, dtype=bool)

    def moving(self) -> np.ndarray:
        return self.core.profile.moving | self.unit_moving

    def protect(self) -> None:
        """EMG, ALM, hard and soft limits, position-error protection [M §4.10].

        A limit stops only motion toward it (motion away is allowed [M §4.10.1.3]), at once or,
        with PRA_EL_MODE 1, at PRA_SD_DEC (spec Q4); an axis already decelerating to a stop
        meets an immediate-mode limit too (it is not left to run on through it)."""
        moving = self.moving()
        if not np.count_nonzero(moving) and not np.count_nonzero(self.svon):
            return
        vel = self.core.axes.cmd_vel + self.gear_vel
        if self.emg and np.count_nonzero(moving):
            self.abnormal(np.flatnonzero(moving), STOP_EMG, immediate=True)
            moving = self.moving()
        hit = moving & self.alm
        if np.count_nonzero(hit):
            self.abnormal(np.flatnonzero(hit), STOP_ALM, immediate=True)
        if np.count_nonzero(self.pel | self.mel | self.spel | self.smel):  # else no limit on
            decel = self.p(0x02) != 0
            for cond, sign, code in ((self.pel, 1, STOP_PEL), (self.mel, -1, STOP_MEL),
                                     (self.spel, 1, STOP_SPEL), (self.smel, -1, STOP_SMEL)):
                hit = (self.moving() & cond & (vel * sign > 0)
                       & ((self.mode != STOPPING) | ~decel))
                if np.count_nonzero(hit):
                    for a in np.flatnonzero(hit).tolist():
                        self.abnormal(np.array([a]), code, immediate=not decel[a])
        level = self.p(0x124)
        if not np.count_nonzero(level):  # no axis checks its position error
            return
        ax = self.core.axes
        over = (level > 0) & (np.abs(ax.cmd_pos - ax.fb) > level * self.axis_params.row(0x86))
        over &= self.svon
        if np.count_nonzero(over):
            idx = np.flatnonzero(over)
            self.abnormal(idx, STOP_ERROR_LEVEL, immediate=True)
            self.servo(idx, False)

    # -- stops -------------------------------------------------------------------------------------
    def abnormal(self, idx: np.ndarray, code: int, immediate: bool) -> None:
        """An abnormal stop of axes `idx` (and of the groups they are in): ASTP and the code
        [M §4.10]; immediate, or at PRA_SD_DEC."""
        self.stop_axes(idx, code, immediate=immediate, astp=True)

    def stop_axes(self, idx: np.ndarray, code: int, immediate: bool, astp: bool) -> None:
        """Stop axes `idx`: the queue cleared, WAIT cancelled; the code and ASTP recorded."""
        for a in idx.tolist():
            for u in self.units:
                stop = getattr(u, "stop_axis", None)
                if stop is not None:
                    stop(a, code, immediate)
        core = self.core
        for a in idx.tolist():
            self.queue[a].clear()
            self.seg_end[a] = math.inf
            self.stop_code[a] = code
            self.astp[a] = astp
            self.wait[a] = False
            if self.mode[a] in (HOME, JOG):
                self.hmv[a] = self.jog[a] = False
            if not core.profile.moving[a]:
                if self.mode[a] != UNIT:
                    self.mode[a] = IDLE
                    self.mdn[a] = True
                continue
            if immediate:
                core.profile.hold(a, float(core.axes.cmd_pos[a]))
                self.mode[a] = IDLE
                self.mdn[a] = True
            else:
                self.stop_profile(a, float(self.p(0x07)[a]), float(self.p(0x20)[a]))
                self.mode[a] = STOPPING
        core.profile.commit()

    def stop_profile(self, a: int, dec_user: float, sf: float) -> None:
        """Decelerate axis a to rest at `dec_user` (user units/s^2) with S-factor sf."""
        core = self.core
        p, v, _ = core.profile.state(a)
        f = self.factor(a)
        sign = 1.0 if v >= 0 else -1.0
        plan = profile.plan_stop(abs(v), dec_user * f, sf)
        self.load(a, plan, p, sign, None)

    def load(self, a: int, plan: profile.Plan, p0: float, sign: float, hold: float | None,
             endless: bool = False) -> None:
        """Give axis a the profile `plan` from now, from p0 in direction `sign` (counts): its
        end, when within 1 ns of a cycle boundary, lands on it (so a move that lasts a whole
        number of cycles ends in that cycle, not one later by a rounding)."""
        core = self.core
        t0 = core.profile.t
        phases = profile.to_core_phases(plan, t0, p0, sign, hold)
        if len(phases) >= 2:
            end = phases[-1].t0
            grid = round(end / self.dt) * self.dt
            if end != grid and abs(end - grid) < 1e-9 and grid > phases[-2].t0:
                phases[-2] = phases[-2]._replace(dur=grid - phases[-2].t0)
                phases[-1] = phases[-1]._replace(t0=grid)
        core.profile.load(a, phases, endless=endless)

    def servo(self, idx: np.ndarray, on: bool) -> None:
        """SVON of axes `idx` [M §4.1.1.4]: off, the drive no longer follows the pulses (the
        stage holds: a jam of the motion core); a moving axis stops at once (code 3). Units
        hear of a servo-off (`servo_off(idx)`: a gear slave is released [M §4.9.1])."""
        if not on:
            for u in self.units:
                hook = getattr(u, "servo_off", None)
                if hook is not None:
                    hook(idx)
            moving = idx[self.moving()[idx]]
            if len(moving):
                self.stop_axes(moving, STOP_SVNO, immediate=True, astp=True)
        self.svon[idx] = on
        self.follow_drive()

    def follow_drive(self, world_jams: np.ndarray | None = None) -> None:
        if world_jams is not None:
            self._world_jams = world_jams
        jams = getattr(self, "_world_jams", None)
        blocked = ~self.svon if jams is None else (~self.svon | jams)
        self.core.follow_jams(blocked)

    # -- segment queue and completions ---------------------------------------------------------------
    def segment_ends(self, t_next: float) -> None:
        """Single-axis segments ending by the next tick: the next queued one starts at the end
        of the last, from its end velocity [M §4.6.4]."""
        for a in np.flatnonzero(self.seg_end <= t_next + 1e-12).tolist():
            motion.next_segment(self, a)

    def completions(self) -> None:
        """Single-axis motions whose profile ended: MDN, the stop code, the home and jog
        sequences' next steps."""
        done = (self.mode != IDLE) & (self.mode != UNIT) & ~self.core.profile.moving
        if not np.count_nonzero(done):
            return
        for a in np.flatnonzero(done).tolist():
            motion.profile_ended(self, a)

    def finish(self, a: int, code: int = STOP_NORMAL) -> None:
        """Axis a's motion is complete."""
        if self.mode[a] != STOPPING:
            self.stop_code[a] = code
        self.mode[a] = IDLE
        self.mdn[a] = True
        self.seg_end[a] = math.inf
        self.hmv[a] = self.jog[a] = False

    # -- status and interrupts ---------------------------------------------------------------------
    def status_words(self) -> None:
        """The motion status and motion I/O words of every axis [M §4.8.1, §4.1.1.4], and the
        interrupt conditions `events` compares: the bool rows stacked, one product with their bit
        weights (`_WEIGHTS`: msts, mio, the conditions). Compiled: the same per axis in one
        call (status.py)."""
        ax = self.core.axes
        if self._jit is not None:
            out = np.empty((3, self.n), dtype=np.int64)  # new rows: prev_axis_cond keeps the old
            self._jit[0](ax.cmd_vel, self.gear_vel, ax.cmd_acc, self.core.profile.moving,
                         self.unit_moving, self.phase, self.direction,
                         (self.mdn, self.hmv, self.wait, self.ptb, self.jog, self.astp, self.bld,
                          self.pred, self.postd, self.ger, self.alm, self.pel, self.mel,
                          self.org, self.ez, self.inp, self.svon, self.spel, self.smel),
                         self.emg, _WEIGHTS, out)
            self.msts, self.mio, self.axis_cond = out
            return
        v, acc = ax.cmd_vel + self.gear_vel, ax.cmd_acc
        moving = self.moving()
        av = acc * v
        speeding = moving & ((av > 0) | ((v == 0) & (acc != 0)))
        slowing = moving & (av < 0)
        ph_vm = moving & ~speeding & ~slowing
        own = self.phase
        if np.count_nonzero(own):
            ph_acc = np.where(own > 0, own == 1, speeding) & moving
            ph_dec = np.where(own > 0, own == 3, slowing) & moving
            ph_vm = np.where(own > 0, own == 2, ph_vm) & moving
        else:
            ph_acc, ph_dec = speeding, slowing
        self.follow_direction(moving)
        flags = np.array((~moving, ph_vm, ph_acc, ph_dec, self.direction, self.mdn, self.hmv,
                          self.wait, self.ptb, self.jog, self.astp, self.bld, self.pred,
                          self.postd, self.ger, self.alm, self.pel, self.mel, self.org,
                          self._true if self.emg else self._false, self.ez, self.inp, self.svon,
                          self.spel, self.smel), dtype=bool)
        self.msts, self.mio, self.axis_cond = _WEIGHTS @ flags

    def follow_direction(self, moving: np.ndarray, state: np.ndarray | None = None) -> None:
        """DIR: the sign of the command velocity (of the acceleration from rest) of a moving
        axis; held after a stop [M §4.8.1 bit 4]. `state`: the motion core's rows to take
        (default: now)."""
        if np.count_nonzero(moving):
            if state is None:
                state = self.core.axes.state
            vel, acc = state[Axes.CMD_VEL] + self.gear_vel, state[Axes.CMD_ACC]
            v = np.where(vel != 0, vel, acc)
            self.direction = np.where(moving & (v != 0), v > 0, self.direction)

    def settle_conditions(self) -> None:
        """The interrupt conditions as of now become the ones edges are taken against, when the
        cycles left them unset (no interrupt on): the host's first command after them, or a
        change of the axis world, sees the last cycle's state (`events`)."""
        if self._cond_stale:
            self._cond_stale = False
            self.status_words()
            self.prev_axis_cond = self.axis_cond

    def events(self) -> None:
        """Pre/post-distance events, the status words, then the interrupt factors: a factor
        fires on the rising edge of its condition [M §4.11; spec §2.23].

        With the interrupts off (INT_MAIN 0) nothing can fire: the cycle keeps DIR and leaves the
        status words to `publish` and the axis conditions unset; `settle_conditions` sets them
        before anything but a cycle changes the state (a command, the axis world), so an
        interrupt enabled later takes its edges against the last cycle's conditions."""
        t = self.core.profile.t
        self.pred |= self.pred_at <= t + 1e-12
        self.postd |= self.postd_at <= t + 1e-12
        sys_cond = SYS_IEMG if self.emg else 0
        sys_rise = (sys_cond & ~self.prev_sys) | self.sys_events
        self.prev_sys, self.sys_events = sys_cond, 0
        di = self.di_word()
        di_rise, di_fall = di & ~self.prev_di, ~di & self.prev_di & 0xFFFFFF
        self.prev_di = di
        if not self.int_main:
            self.follow_direction(self.moving())
            self._cond_stale = True
            return
        self.settle_conditions()  # the interrupts came on other than by a command: no edge yet
        self.status_words()
        cond = self.axis_cond
        rising = cond & ~self.prev_axis_cond
        self.prev_axis_cond = cond
        if not (np.count_nonzero(rising) or sys_rise or di_rise or di_fall):
            return
        en = self.int_enable
        hits = [(item, bits & int(en[item])) for item, bits in enumerate(rising.tolist())]
        hits += [(item, bits & int(en[item])) for item, bits in (
            (ITEM_SYSTEM, sys_rise), (ITEM_DI_RISE, di_rise), (ITEM_DI_FALL, di_fall))]
        fired = [(item, hit) for item, hit in hits if hit]
        if fired:
            for item, hit in fired:
                self.int_signal[item] |= hit
            self.raise_line()

    def axis_conditions(self) -> np.ndarray:
        """The conditions of the axis factors (items 0-7) by factor bit [M §4.11, L3355], as
        `status_words` left them."""
        return self.axis_cond

    def command_edges(self) -> None:
        """After a mailbox command (its status words published): a condition it cleared counts
        as low, so a rise in the next cycle (a move of one cycle: MDN 1 -> 0 -> 1) is still an
        edge [spec §2.23]."""
        self.prev_axis_cond &= self.axis_conditions()

    def signal(self, item: int, bits: int) -> None:
        """Set signaled flags of `item` and assert `inta` (APS_set_int, a factor's event)."""
        self.int_signal[item] |= bits
        self.raise_line()

    def reset_signal(self, item: int, bits: int) -> None:
        """APS_reset_int: back to non-signaled; the line drops when nothing is signaled."""
        self.int_signal[item] &= ~bits & 0xFFFFFFFF
        if not self.int_signal.any():
            self.clear_line()

    def di_word(self) -> int:
        """The DI word after PRB_DI_LOGIC: bits 0-7 EDI, 8-23 TDI (spec §2.18)."""
        mask = (1 << 24) - 1 if self.n == 8 else 0xFFFF0F
        word = self.di_raw & mask
        return word ^ mask if self.board_params.values[0x15] else word

    def publish_cycles(self) -> None:
        _U32.pack_into(self.buf, Bar.CYCLE_COUNT, self.cycles & 0xFFFFFFFF)

    def publish(self) -> None:
        """The status block: every axis record and the card words."""
        self.status_words()
        ax = self.core.axes
        f = self.axis_params.row(0x86)
        if self._jit is not None:
            self._jit[1](ax.cmd_pos, ax.fb, ax.encoder, f, self.cmd_off, self.fb_off,
                         self.target, self.mode == VEL, ax.cmd_vel, self.gear_vel, ax.vel,
                         self.drive == "servo", (self.msts, self.mio, self.stop_code,
                                                 self.mq_usage, self.gear_status, self.svon),
                         self._rec_ints, self._rec_floats)
        else:
            self._records(f)
        for u in self.units:
            publish = getattr(u, "publish", None)
            if publish is not None:
                publish()
        buf = self.buf
        _U32.pack_into(buf, Bar.CYCLE_COUNT, self.cycles & 0xFFFFFFFF)
        _U32.pack_into(buf, Bar.EMG, int(self.emg))
        _U32.pack_into(buf, Bar.DI, self.di_word())
        _U32.pack_into(buf, Bar.DO, self.do_word & 0xFFFFFF)
        _U32.pack_into(buf, Bar.INT_MAIN, int(self.int_main))

    def _records(self, f: np.ndarray) -> None:
        """`publish`'s axis records with numpy (`f`: the unit factors): two blocks of rows in
        record order, one copy each."""
        ax = self.core.axes
        # the I32 fields; the counters wrap at 2^32 (spec Q20: the int64 -> I32 copy keeps the
        # low 32 bits, two's complement)
        ints = self._pub_ints
        ints[0] = self.msts
        ints[1] = self.mio
        ints[2] = self.stop_code
        ints[3] = np.rint(ax.cmd_pos)
        ints[4] = ax.encoder
        ints[5] = self.mq_usage
        ints[6] = self.gear_status
        ints[7] = self.svon
        self._rec_ints[...] = ints.T
        # the F64 fields, user units
        cmd, fbk, target, err, cmd_vel, fbk_vel = floats = self._pub_floats
        np.divide(ax.cmd_pos, f, out=cmd)
        cmd += self.cmd_off
        np.divide(ax.fb, f, out=fbk)
        fbk += self.fb_off
        np.copyto(target, self.target)
        np.copyto(target, cmd, where=self.mode == VEL)
        np.subtract(cmd, fbk, out=err)
        np.add(ax.cmd_vel, self.gear_vel, out=cmd_vel)
        if self.drive == "servo":
            np.divide(ax.vel, f, out=fbk_vel)
        else:
            np.multiply(cmd_vel, self.svon, out=fbk_vel)
            fbk_vel /= f
        cmd_vel /= f
        self._rec_floats[...] = floats.T
