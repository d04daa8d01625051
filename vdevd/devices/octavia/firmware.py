"""The Octavia's firmware, sans-I/O: it polls the DPR for RTCs once per 200 us sample, runs the
trajectory generators and the control law on the shared motion core, checks the interrupt
conditions and posts them through the mailbox [Ch4, Ch6, Ch7; spec octavia.md §5.1].

One `cycle()` is one sample, in the order of spec §5.1: hardware sampled (the card applies its
axis world before), a pending RTC executed, trajectories and the control law (the core's tick),
following-error, breakpoint and completion checks, and every 25 samples (5 ms) the housekeeping
(SERVOCHK, INT5MS, the PARREAD echo, the MONITOR_VAR refresh). The DPR windows are published by
the card after the last sample of a batch (`publish`).
"""

from __future__ import annotations

import logging
from collections.abc import Callable

import numpy as np
from vdevmaps.octavia import (
    ACTVEL_SCALE,
    DPR_SIZE,
    SAMPLE_NS,
    Dpr,
    DspStat1,
    DspStat2,
    HostInt,
    Rtc,
    Truncated,
    Window,
    table_for,
    unpack,
)

from vdevd.devices.octavia import (
    cmd_cam,
    cmd_contour,
    cmd_control,
    cmd_dspl,
    cmd_filters,
    cmd_gear,
    cmd_interrupts,
    cmd_io,
    cmd_motion,
    cmd_nurbs,
    cmd_tables,
    pubkernel,
)
from vdevd.devices.octavia.commands import COMMANDS
from vdevd.devices.octavia.contour import RingContour
from vdevd.devices.octavia.cubic_int import CubicInt
from vdevd.devices.octavia.dpr import Mailbox, Memory, Windows, clear_dpr
from vdevd.devices.octavia.dspl import Dspl
from vdevd.devices.octavia.filters import Biquads, Coeffs
from vdevd.devices.octavia.follow import Following
from vdevd.devices.octavia.law import DAC_PER_VOLT, PLANT_AMP_GAIN, pid_params
from vdevd.devices.octavia.nurbs import DprRings, NurbsRun, NurbsState, pending
from vdevd.devices.octavia.ram import BoardRam
from vdevd.devices.octavia.state import HALTING, Mode, Params, axes_bits
from vdevd.rt import AxisFlag, MotionCore, PlantKind

log = logging.getLogger(__name__)

TS = SAMPLE_NS / 1e9
HOUSEKEEPING = 25  # samples in 5 ms [Ch5 INT5MS, Ch7 Table 7-1 SERVOCHK]
_DONE = int(AxisFlag.DONE)
#: Firmware.watch: the per-sample checks in use
_WATCH_FE, _WATCH_ENCFLT, _WATCH_POSBRK, _WATCH_INDEX = 1, 2, 4, 8
#: the RTCs that change none of the enables the per-sample checks follow (the motion and gain
#: commands a host sends most): `poll_rtc` leaves `watch` as it is after them
_WATCH_KEPT = frozenset({
    "AXMOVE", "AXMOVE_S", "AXMOVE_T", "REL_AXMOVE", "REL_AXMOVE_S", "REL_AXMOVE_T", "VELMODE",
    "STOP", "DDAC", "MAXACC", "ESTOP_ACC", "CTRL", "CTRL_KA", "KILIMIT", "OUTGAIN",
    "TRQ_LIMIT", "PARREAD", "OUTP_ON", "OUTP_OFF", "EN_MOTCP"})
_RTC, _ARGS = int(Dpr.RTC), int(Dpr.ARGMNTS)
#: the registers `publish` touches at every batch, as ints (an IntEnum index costs more)
_HOSTACC_ACTPOS, _HOSTACC_ACTVEL, _HOSTACC_ERROR = (
    int(Dpr.HOSTACC_ACTPOS), int(Dpr.HOSTACC_ACTVEL), int(Dpr.HOSTACC_ERROR))
_M4ACC_ACTPOS, _M4ACC_ACTVEL, _M4ACC_ERROR = (
    int(Dpr.M4ACC_ACTPOS), int(Dpr.M4ACC_ACTVEL), int(Dpr.M4ACC_ERROR))
_ENCSTAT, _ADC, _INPUT = int(Dpr.ENCSTAT), int(Dpr.ADC), int(Dpr.INPUT)
_ACTVEL_SCALE = float(ACTVEL_SCALE)
#: DSPSTAT1 type bit -> its INTAXIS source byte (000h + bit number + 1) [Table 6-2]
_SOURCE = {int(b): int(Dpr.DSPSTAT1) + 1 + int(b).bit_length() - 1 for b in DspStat1}


def acc_per_s2(raw: np.ndarray | float) -> np.ndarray:
    """Raw 1.15 accelerations (counts/sample^2) in counts/s^2."""
    return np.asarray(raw, dtype=float) / 32768.0 / (TS * TS)


def vel_per_s(counts_per_sample: np.ndarray | float) -> np.ndarray:
    return np.asarray(counts_per_sample, dtype=float) / TS


class Firmware:
    """The card's firmware over its DPR memory `buf` (8 KiB) and `n` axes (5..8)."""

    def __init__(self, buf: Memory, n: int, plant: str = "servo",
                 option: str = "standard", raise_line: Callable[[int], None] | None = None,
                 gear_ratio_bits: int = 7, follow_master: str = "actual",
                 reset_clears_vars: bool = False) -> None:
        self.buf, self.n, self.option = buf, n, option
        #: RESET clears the DSPL variables too (the card option; spec Q-23 leaves it open)
        self.reset_clears_vars = reset_clears_vars
        kind = PlantKind.SERVO if plant == "servo" else PlantKind.IDEAL
        self.core = MotionCore(n, SAMPLE_NS, kind)
        self.core.plant.set(slice(None), amp_gain=PLANT_AMP_GAIN)
        self.params = Params()
        self.mode = np.zeros(n, dtype=np.int64)
        self.windows = Windows(buf)
        self.mailbox = Mailbox(buf, raise_line or (lambda status: None))
        self.rtcs: dict[int, Rtc] = table_for(option)
        self.handlers = COMMANDS.bind(cmd_control, cmd_motion, cmd_interrupts, cmd_io,
                                      cmd_filters, cmd_nurbs, cmd_contour, cmd_cam, cmd_gear,
                                      cmd_tables, cmd_dspl)
        self.open_dac = np.zeros(n)  # DDAC output of open-loop axes (DAC codes)
        self.fault_open = np.zeros(n, dtype=bool)  # opened by an encoder fault (0 V)
        self.filters = Biquads(n)  # NOTCH or LOW_PASS at the controller output
        #: the amplifiers' input offsets (backdoor set_amp_offset), in DAC codes: the motor is
        #: driven by the DAC output plus it
        self.amp_offset = np.zeros(n)
        self.any_amp_offset = False
        #: OFFSET under way: the axis and the samples it has been settled for, and since when
        self.offset_axis = -1
        self.offset_settled = 0
        self.offset_samples = 0
        self._integ_last = 0.0
        #: NURBS [Ch9]: the run, the rings it reads, its axes, the breakpoint threshold and the
        #: knots pending at the last sample (the breakpoint fires on a downward crossing)
        self.nurbs = NurbsRun()
        self.nurbs_rings = DprRings(buf)
        self.nurbs_axes: list[int] = []
        self.nurbs_threshold = 0
        self.nurbs_pending = 0
        self.any_open = False
        self.estop = False  # the *ESTOP input is active
        self.levels = 0xFFFFFFFF  # IN0..31 electrical levels: pulled up, high = inactive
        self.inputs = 0  # input levels after polarity: bit set = active (INPUT 094h)
        self.ext = 0  # *EXT1..4 active (bit 0 = EXT1)
        self.encstat = 0  # ENCSTAT (113h): encoder hardware failure bits
        self.adc = np.zeros(4, dtype="<i2")  # ADC1..4 (the ACC4000 option), codes, as in the DPR
        #: index pulses (physical counts: phase + k * period; None: no encoder has any) and the
        #: physical positions at the last sample
        self.index_period: np.ndarray | None = None
        self.index_phase: np.ndarray | None = None
        self._index_from = np.zeros(n)
        #: captures waiting for the host to release their window
        self._deferred: list[tuple[tuple[np.ndarray, np.ndarray], Window, np.ndarray]] = []
        self.index_seen = 0  # index pulses seen in the current 5 ms window (SERVOCHK)
        self.parread: int | None = None  # a PARREAD to echo at the next 5 ms boundary
        self.sample = 0
        self.unknown: set[int] = set()  # opcodes met that the card does not know (logged once)
        self.rtc_count = 0
        self.refused = 0  # RTCs ignored for an argument out of range
        self.watch = 0  # the per-sample checks in use (refresh_watch)
        self.filtering = False
        self._prev_flags = np.zeros(n, dtype=np.int64)
        self._published = np.zeros((3, n), dtype=np.int64)
        self._pub_tmp = np.zeros((2, n))
        # publish's views, made once: ACTVEL's and ERROR's float rows, the int rows they go to,
        # and each bank's columns with the rows of its axes
        pub, k = self._published, min(n, 4)
        self._pub_rows = (self._pub_tmp[0], self._pub_tmp[1], pub[1:])
        bank1, bank2 = self.windows.state
        self._pub_banks = ((bank1[:, :k], pub[:, :k]),) + (
            ((bank2[:, :n - 4], pub[:, 4:n]),) if n > 4 else ())
        #: the rows and their store in one compiled call (pubkernel; None: the numpy path) over
        #: the DPR as bytes
        self._pub_kernel = pubkernel.compiled()
        self._mem8 = np.ndarray((DPR_SIZE,), np.uint8, buffer=buf)
        #: the RTC arguments from 3C3h on, for `unpack` (the DPR never changes size)
        self._args_view = memoryview(buf)[_ARGS:DPR_SIZE]
        # the battery-backed board RAM and DSPL surface (RESET keeps them) and the cam and gear
        # slaves (follow.py); nv_dirty: the battery image changed since it was last taken
        self.ram = BoardRam()  # the on-board RAM: tables a reset keeps [Ch8]
        self.dspl = Dspl()
        self.follow = Following(self, gear_ratio_bits, follow_master)
        self.nv_dirty = False
        # contouring: the ring buffer (contour.py) and the internal table (cubic_int.py)
        self.contour = RingContour(self)
        self.cubic = CubicInt(self)
        self.reset()

    # -- power-up / RESET [Ch7 Power-Up/Reset State; spec §1.5] --------------------------------
    def reset(self) -> None:
        """Clear every parameter and the whole DPR, zero the position counters and hold every
        axis there, write the signatures, then report "reset finished" (1FFEh b4)."""
        clear_dpr(self.buf)
        self.mailbox.clear()
        self.params.reset()
        core = self.core
        core.abort(slice(None))
        core.servo_on(slice(None))
        core.set_position(slice(None), 0)  # the position counters start at 0 (spec §1.5)
        self.mode[:] = Mode.HOLD
        self.contour.reset()
        self.cubic.reset()
        self.open_dac[:] = 0
        self.fault_open[:] = False
        self.nurbs.stop()
        self.nurbs_axes, self.nurbs_threshold = [], 0
        for a in range(self.n):
            self.filters.bypass(a)
        self.offset_axis = -1
        self.any_open = False
        self.parread = None
        self.index_seen = 0
        self._deferred.clear()
        self.follow.reset()
        if self.reset_clears_vars and self.dspl.vars.any():
            self.dspl.vars[:] = 0
            self.nv_dirty = True
        self.dspl.power_up()
        self.apply_gains()
        self.refresh_inputs()
        self.refresh_watch()
        self.write_signatures()
        self.publish()
        self.mailbox.post(int(HostInt.RESET_DONE))

    def write_signatures(self) -> None:
        """The hardware signature (086h: 'P', 'I', 'A') and the signature window (115h: "MX4",
        DSP1 version, '+', DSP2 version) [Tables 6-4, 6-6; spec Q-13]."""
        self.buf[Dpr.HW_SIGNATURE:Dpr.HW_SIGNATURE + 3] = b"PIA"
        self.buf[Dpr.SIGNATURE:Dpr.SIGNATURE + 11] = b"MX4\x04\x00+\x04\x00\x00\x00\x00"

    def apply_gains(self) -> None:
        """The core's PID from the card's gains and limits (law.py)."""
        p = self.params
        n = self.n
        self.core.pid.set(slice(None), **{k: v[:n] for k, v in pid_params(
            p.ki, p.kp, p.kf, p.kd, p.ka, p.outgain, p.kilimit, p.trq_limit, p.offset_v).items()})

    # -- the sample ------------------------------------------------------------------------------
    def cycle(self) -> None:
        """One 200 us sample (spec §5.1)."""
        self.sample += 1
        buf = self.buf
        if self.mailbox.queue:
            self.mailbox.flush()
        if buf[_RTC]:
            self.poll_rtc()
        if self.nurbs_axes:
            self.nurbs_sample()
        if self.contour.running:  # contouring: the next sample's commanded positions
            self.contour.step()
        if self.cubic.running:
            self.cubic.step()
        if self.follow.active:
            self.follow.step()
        events = self.core.tick()
        out = self.core.axes.out
        if self.filtering:  # the law's output: DDAC's value bypasses it (spec §5.2)
            self.filters.apply(out, out)
        if self.any_open:
            np.copyto(out, self.open_dac, where=self.mode == Mode.OPEN)
        if self.any_amp_offset:  # the amplifier adds its offset to what the DAC outputs
            out += self.amp_offset
        if self.offset_axis >= 0:
            self.calibrate_offset()
        if events:
            self.on_events()
        if self.watch:
            w = self.watch
            if w & _WATCH_FE:
                self.check_following_error()
            if w & _WATCH_ENCFLT:
                self.check_encoder_fault()
            if w & _WATCH_POSBRK:
                self.check_breakpoints()
            if w & _WATCH_INDEX:
                self.check_index()
        if self.sample % HOUSEKEEPING == 0:
            self.housekeeping()

    def poll_rtc(self) -> None:
        """Execute the RTC at 3C2h and clear it [Ch6 Real-Time Commands]: an unknown code is
        cleared and ignored; arguments are read linearly from 3C3h (past 3FBh when a layout is
        longer than the 57-byte window, spec Q-3)."""
        buf = self.buf
        code = buf[_RTC]
        rtc = self.rtcs.get(code)
        self.rtc_count += 1
        if rtc is None:
            if code not in self.unknown:
                self.unknown.add(code)
                log.warning("octavia: RTC code %02Xh is not defined: cleared and ignored", code)
        else:
            try:  # read in place (a view made once): no copy of the 7 KiB from 3C3h
                head, groups = unpack(rtc, self._args_view)
            except Truncated as exc:  # cannot happen within 8 KiB: a guard
                log.warning("octavia: %s", exc)
            else:
                handler = self.handlers.get(rtc.name)
                if handler is None:
                    if code not in self.unknown:
                        self.unknown.add(code)
                        log.warning("octavia: RTC %s is not emulated yet: cleared", rtc.name)
                else:
                    handler(self, head, groups)
        if rtc is None or rtc.name != "RESET":  # RESET cleared the whole DPR
            buf[_RTC] = 0
        if rtc is not None and rtc.name not in _WATCH_KEPT:
            self.refresh_watch()

    def refresh_watch(self) -> None:
        """Which per-sample checks have anything to check (after every RTC and change of the
        enables): a sample looks at one int instead of four arrays."""
        p, n = self.params, self.n
        self.watch = ((_WATCH_FE if (p.err_on[:n].any() or p.errhlt_on[:n].any()) else 0)
                      | (_WATCH_ENCFLT if p.encflt_on[:n].any() else 0)
                      | (_WATCH_POSBRK if p.posbrk_on[:n].any() else 0)
                      | (_WATCH_INDEX if self.index_period is not None else 0))
        self.filtering = self.filters.active

    def on_events(self) -> None:
        """Profiles that ended: halting axes hold, motion complete where enabled [Ch5
        EN_MOTCP]."""
        flags = self.core.axes.flags
        new = (flags & _DONE) & ~self._prev_flags
        np.copyto(self._prev_flags, flags & _DONE)
        done = new != 0
        if not done.any():
            return
        mode = self.mode
        finished = done & np.isin(mode, (Mode.MOVE, Mode.STOP, Mode.ESTOP, Mode.VELMODE))
        mode[finished] = Mode.HOLD
        hit = finished & self.params.motcp_on[:self.n]
        if hit.any():
            self.post_stat1(DspStat1.MOTCP, axes_bits(hit))

    def check_following_error(self) -> None:
        """EN_ERR and EN_ERRHLT: |FE| over the setpoint, on the rising edge (spec Q-7); an
        ERRHLT axis halts at its ESTOP_ACC [Ch5 EN_ERRHLT]."""
        p, n = self.params, self.n
        fe = np.abs(self.core.axes.ferr)
        over = p.err_on[:n] & (fe > p.err_thr[:n])
        rising = over & ~p.err_over[:n]
        p.err_over[:n] = over
        if rising.any():
            self.post_stat1(DspStat1.ERR, axes_bits(rising))
        over = p.errhlt_on[:n] & (fe > p.errhlt_thr[:n])
        rising = over & ~p.errhlt_over[:n]
        p.errhlt_over[:n] = over
        if rising.any():
            self.post_stat1(DspStat1.ERR_HALT, axes_bits(rising))
            cmd_motion.halt(self, np.flatnonzero(rising), estop=True)

    def check_encoder_fault(self) -> None:
        """EN_ENCFLT: |FE| over the setpoint (and, with mode bit 0 clear, the encoder's hardware
        failure bit) opens the axis's loop at 0 V and reports (DSPSTAT2 b0, 00Ah) [Ch5
        EN_ENCFLT; spec Q-9, Q-10]; nothing for an axis already open."""
        p, n = self.params, self.n
        over = p.encflt_on[:n] & (np.abs(self.core.axes.ferr) > p.encflt_thr[:n])
        if not p.encflt_mode & 2:  # bit 1 clear: the hardware status bit is required too
            over &= (self.encstat >> np.arange(n)) & 1 == 1
        over &= self.mode != Mode.OPEN
        if not over.any():
            return
        for a in np.flatnonzero(over).tolist():
            self.core.servo_off(a)
            self.mode[a], self.open_dac[a], self.fault_open[a] = Mode.OPEN, 0.0, True
        self.any_open = True
        self.post_stat2(DspStat2.ENCFLT, int(Dpr.INTAXIS_ENCFLT), axes_bits(over))

    def check_breakpoints(self) -> None:
        """EN_POSBRK: an axis that travelled |bp - start| either way fires once (then disabled),
        with its POSBRK_OUT masks applied [Ch5 EN_POSBRK, POSBRK_OUT]."""
        p, n = self.params, self.n
        pos = self.core.axes.encoder.astype(float)
        hit = p.posbrk_on[:n] & (np.abs(pos - p.posbrk_from[:n])
                                 >= np.abs(p.posbrk_at[:n] - p.posbrk_from[:n]))
        if not hit.any():
            return
        p.posbrk_on[:n] &= ~hit
        self.refresh_watch()
        for a in np.flatnonzero(hit).tolist():
            p.outputs_on |= int(p.posbrk_on_mask[a])
            p.outputs_on &= ~int(p.posbrk_off_mask[a])  # OFF after ON: OFF wins (spec §4.3)
        self.post_stat1(DspStat1.POSBRK, axes_bits(hit))

    # -- captures [Ch5 EN_INDEX, EN_PROBE; spec §5.8] ---------------------------------------------
    def set_index_pulses(self, period: np.ndarray, phase: np.ndarray) -> None:
        """The encoders' index pulses: at phase + k * period physical counts (period 0: none)."""
        if (period > 0).any():
            self.index_period, self.index_phase = period.copy(), phase.copy()
            self._index_from = self.core.physical()
        else:
            self.index_period = self.index_phase = None
        self.refresh_watch()

    def arm_index(self) -> None:
        self._index_from = self.core.physical()

    def check_index(self) -> None:
        """Index edges crossed during the last sample: SERVOCHK bits, and the armed axis's first
        one latches every axis's position at the edge (interpolated within the sample: the
        card's 100 ns capture) to INDPOS and reports (one-shot)."""
        if self.index_period is None:
            return
        now = self.core.physical()
        before = self._index_from
        self._index_from = now
        period, phase = self.index_period, self.index_phase
        assert phase is not None
        with np.errstate(divide="ignore", invalid="ignore"):
            k0 = np.floor((before - phase) / period)
            k1 = np.floor((now - phase) / period)
        crossed = (period > 0) & (k0 != k1)
        if not crossed.any():
            return
        self.index_seen |= axes_bits(crossed)
        a = self.params.index_axis
        if a < 0 or not crossed[a]:
            return
        edge = phase[a] + period[a] * max(k0[a], k1[a])
        f = (edge - before[a]) / (now[a] - before[a]) if now[a] != before[a] else 1.0
        self.latch(self.windows.indpos, Window.INDPOS, f)
        self.params.index_axis = -1
        self.post_stat1(DspStat1.INDEX, 1 << a)

    def latch(self, views: tuple[np.ndarray, np.ndarray], window: Window, f: float) -> None:
        """Every axis's actual position at fraction `f` of the last sample into a capture
        window (the card holds it until the host releases the window)."""
        ax = self.core.axes
        pos = ax.pos - ax.vel * TS * (1.0 - f)
        latched = np.floor(pos * self.core.encoder_scale).astype(np.int64)
        if not self.windows.put(window, views, _int32(latched), self.n):
            self._deferred.append((views, window, _int32(latched)))

    def probe_edge(self, inputs: int) -> None:
        """*EXT1..4 went active (bits of `inputs`): EN_PROBE's input latches every axis's
        position to PRB and reports with its code (006h) [Ch5 EN_PROBE]; one-shot."""
        inputs = self.follow.probe(inputs)  # CAM_PROBE / GEAR_PROBE take their edge first
        k = self.params.probe_input
        if k and inputs >> (k - 1) & 1:
            self.params.probe_input = 0
            self.latch(self.windows.prb, Window.PRB, 1.0)
            self.post_stat1(DspStat1.PROBE, 1 << (k - 1))

    # -- inputs ------------------------------------------------------------------------------------
    def refresh_inputs(self) -> None:
        """INPUT (094h): set bit = active: low level on an active-low input (polarity bit 0),
        high on an active-high one [Ch5 INP_STATE; Table 6-5]."""
        pol = self.params.inp_polarity
        self.inputs = (~self.levels & ~pol | self.levels & pol) & 0xFFFFFFFF
        self.buf[Dpr.INPUT:Dpr.INPUT + 4] = self.inputs.to_bytes(4, "little")

    def set_estop(self, active: bool) -> None:
        """*ESTOP: on going active, 1FFEh b2 and every axis halts at its ESTOP_ACC; while active,
        motion RTCs are ignored ("RTC ignored") [Ch7 Table 7-1; spec §5.3, Q-31]."""
        was, self.estop = self.estop, active
        if active and not was:
            self.mailbox.post(int(HostInt.ESTOP))
            # engaged cam and gear slaves follow their halting masters [Ch5 CAM Note]
            cmd_motion.halt(self, self.follow.unfollowed(np.arange(self.n)), estop=True)

    def housekeeping(self) -> None:
        """Every 5 ms: the PARREAD echo, INT5MS, SERVOCHK, the DSPL window [spec §5.1 step 8]."""
        if self.parread is not None:
            m, self.parread = self.parread, None
            self.buf[Dpr.PARACC] = m  # the data went first (cmd_io.parread)
        if self.params.int5ms and self.option == "int5ms":
            self.post_stat2(DspStat2.INT5MS, -1, 0)
        self.windows.put_bytes(Window.ENC, Dpr.SERVOCHK, bytes((self.index_seen & 0xFF,)))
        self.index_seen = 0
        self.dspl.refresh(self.windows)

    def publish_adc(self) -> None:
        """ADC1..4 at 502h.. unless the host holds 500h/501h [Table 6-10]."""
        self.windows.put_bytes(Window.ADC, Dpr.ADC, self.adc.tobytes())

    # -- NURBS [Ch9] -------------------------------------------------------------------------------
    def nurbs_count(self) -> int:
        return pending(self.nurbs_rings)

    def nurbs_sample(self) -> None:
        """The curve's next sample on its axes; the breakpoint on a downward crossing of the
        threshold, data run-out (1FFEh b5) when the run starves, hold at its end."""
        run, axes = self.nurbs, self.nurbs_axes
        was = run.state
        xyz = run.step(self.nurbs_rings)
        if run.state is NurbsState.DONE:
            self.end_nurbs(xyz[:len(axes)] if xyz is not None else None)
            return
        if xyz is not None:
            self.core.track(axes, xyz[:len(axes)])
        now = self.nurbs_count()
        if self.nurbs_threshold and now < self.nurbs_threshold <= self.nurbs_pending:
            self.mailbox.post(int(HostInt.NURBS_BUFBRK))
        self.nurbs_pending = now
        if run.state is NurbsState.STARVED and was is not NurbsState.STARVED:
            self.mailbox.post(int(HostInt.RUN_OUT))
        if run.state not in (NurbsState.RUNNING, NurbsState.STARVED):
            self.end_nurbs()

    def end_nurbs(self, last: np.ndarray | None = None) -> None:
        """The curve ended (its axes hold at its `last` point) or faulted (where they are)."""
        axes, self.nurbs_axes = self.nurbs_axes, []
        self.nurbs.stop()
        self.core.hold(axes, last)
        for a in axes:
            if self.mode[a] == Mode.CONTOUR:  # no motion complete: contouring [Ch5 EN_MOTCP]
                self.mode[a] = Mode.HOLD

    # -- the output stage ------------------------------------------------------------------------
    def dac(self) -> np.ndarray:
        """What the DACs output now, in codes (the motor's drive less the amplifiers' offsets)."""
        return np.clip(np.rint(self.core.axes.out - self.amp_offset), -32768, 32767)

    def set_filter(self, axis: int, coeffs: Coeffs | None) -> None:
        """NOTCH or LOW_PASS on `axis`'s output (None: no filter)."""
        if coeffs is None:
            self.filters.bypass(axis)
        else:
            self.filters.set(axis, coeffs)

    def refuse(self, name: str, exc: Exception) -> None:
        """An RTC whose argument is out of range: ignored (the manual has no report for it)."""
        self.refused += 1
        log.info("octavia: %s ignored: %s", name, exc)

    # -- OFFSET [Ch5 OFFSET; spec §5.2 "OFFSET algorithm"] -------------------------------------------
    OFFSET_SETTLE = 250  # samples (50 ms) settled: |e| <= 1 and the integral action steady
    OFFSET_TIMEOUT = 50_000  # samples (10 s)

    def start_offset(self, axis: int) -> None:
        self.offset_axis, self.offset_settled, self.offset_samples = axis, 0, 0
        self._integ_last = float(self.core.pid.integ[axis])

    def calibrate_offset(self) -> None:
        """One sample of an OFFSET run: once the axis has held within a count with its integral
        action changing by less than a DAC code for 50 ms, that action becomes the offset
        compensation (the integrator restarts from 0: the output is continuous) and completion
        is reported; an axis that cannot settle (Ki 0, moving, open loop) reports after 10 s,
        its compensation unchanged."""
        a, pid = self.offset_axis, self.core.pid
        self.offset_samples += 1
        integ = float(pid.integ[a])
        steady = (abs(float(self.core.axes.ferr[a])) <= 1.0 and self.mode[a] == Mode.HOLD
                  and pid.ki[a] != 0 and abs((integ - self._integ_last) * pid.ki[a]) < 1.0)
        self._integ_last = integ
        self.offset_settled = self.offset_settled + 1 if steady else 0
        if self.offset_settled >= self.OFFSET_SETTLE:
            self.params.offset_v[a] += float(pid.ki[a]) * integ / DAC_PER_VOLT
            pid.integ[a] = 0.0
            self.apply_gains()
        elif self.offset_samples < self.OFFSET_TIMEOUT:
            return
        self.offset_axis = -1
        self.post_stat2(DspStat2.OFFSET, int(Dpr.INTAXIS_OFFSET), 1 << a)

    # -- interrupts ------------------------------------------------------------------------------
    def post_stat1(self, bit: DspStat1, sources: int) -> None:
        """A DSPSTAT1 interrupt with its source byte (an axis mask or the EXT code)."""
        b = int(bit)
        self.mailbox.post(int(HostInt.STAT1), int(Dpr.DSPSTAT1), b, _SOURCE[b], sources & 0xFF)

    def post_stat2(self, bit: DspStat2, src_addr: int, sources: int) -> None:
        self.mailbox.post(int(HostInt.STAT2), int(Dpr.DSPSTAT2), int(bit), src_addr,
                          sources & 0xFF)

    # -- commands' helpers -----------------------------------------------------------------------
    def axes_of(self, groups: list[tuple[int, dict[str, int]]]) -> list[tuple[int, dict[str, int]]]:
        """The groups of axes the card has (0-based axis, fields); the others were parsed to keep
        the stream aligned and are ignored (spec §1.1)."""
        return [(a - 1, g) for a, g in groups if a <= self.n]

    def mask(self, mask: int) -> list[int]:
        """The 0-based axes of an axis mask that the card has."""
        return [a for a in range(self.n) if mask >> a & 1]

    def close_loop(self, axes: list[int] | np.ndarray) -> None:
        """Open-loop (DDAC) axes of `axes` close their loop and hold, as a motion command makes
        them [Ch5 DDAC]."""
        if not self.any_open:  # (the usual case: no axis is open)
            return
        idx = np.atleast_1d(np.asarray(axes, dtype=np.intp))
        opened = idx[self.mode[idx] == Mode.OPEN]
        if len(opened):
            self.core.servo_on(opened)
            self.mode[opened] = Mode.HOLD
            self.any_open = bool((self.mode == Mode.OPEN).any())

    def discarded(self, axes: list[int], conflicts: tuple[int, ...], halting: bool = True
                  ) -> bool:
        """Whether a motion command for `axes` (0-based) is discarded, reported as the card
        reports it (Ch7 Table 7-1): "RTC ignored" (000h b7, 008h) for axes halting under STOP or
        *ESTOP (with `halting`), else "conflicting commands" (b6, 007h) for axes in one of the
        modes `conflicts`. No axis: discarded, unreported."""
        modes = self.mode.tolist()
        stopping = busy = 0  # the axes' bits (loops, not comprehensions: every motion RTC)
        for a in axes:
            if modes[a] in HALTING:
                stopping |= 1 << a
            if modes[a] in conflicts:
                busy |= 1 << a
        if halting and axes and (self.estop or stopping):  # `halting`, modes read once
            self.post_stat1(DspStat1.IGNORED, sum(1 << a for a in axes) if self.estop else stopping)
            return True
        if busy:
            self.post_stat1(DspStat1.CONFLICT, busy)
            return True
        return not axes

    def halting(self, axes: list[int]) -> list[int]:
        """Of `axes`, those halting under STOP or ESTOP (or held by an active *ESTOP)."""
        if self.estop:
            return list(axes)
        modes = self.mode.tolist()
        return [a for a in axes if modes[a] in HALTING]

    # -- the DPR ---------------------------------------------------------------------------------
    def publish(self) -> None:
        """ACTPOS, ACTVEL, ERROR, ENCSTAT and INPUT, each unless the host holds its window
        [Table 6-5; spec §2.5.1]."""
        ax, n, w, buf = self.core.axes, self.n, self.windows, self.buf
        pub = self._published
        free = (buf[_HOSTACC_ACTPOS] != 1 and buf[_HOSTACC_ACTVEL] != 1
                and buf[_HOSTACC_ERROR] != 1)  # the usual case: one store a bank
        if free:
            buf[_M4ACC_ACTPOS] = buf[_M4ACC_ACTVEL] = buf[_M4ACC_ERROR] = 1
        if self._pub_kernel is not None:  # the rows and (free) their store, compiled
            self._pub_kernel(ax.encoder, ax.vel, ax.ferr, pub, self._mem8, n, TS, _ACTVEL_SCALE,
                             free)
        else:
            vel, fe, rows = self._pub_rows
            pub[0] = ax.encoder  # ACTPOS, ACTVEL, ERROR: one (3, n) block in the DPR's row order
            np.multiply(ax.vel, TS, out=vel)
            vel *= ACTVEL_SCALE
            np.rint(vel, out=vel)
            np.rint(ax.ferr, out=fe)
            rows[...] = self._pub_tmp  # counts as the card's int32 words: wrapping beyond 2^31 when stored
            if free:
                for bank, part in self._pub_banks:
                    bank[...] = part
        if free:
            buf[_M4ACC_ACTPOS] = buf[_M4ACC_ACTVEL] = buf[_M4ACC_ERROR] = 0
        else:
            w.put(Window.ACTPOS, w.actpos, pub[0].astype(np.int32), n)
            w.put(Window.ACTVEL, w.actvel, pub[1].astype(np.int32), n)
            w.put(Window.ERROR, w.error, pub[2].astype(np.int32), n)
        if buf[_ENCSTAT] != self.encstat & 0xFF:
            w.put_bytes(Window.ENC, Dpr.ENCSTAT, bytes((self.encstat & 0xFF,)))
        if buf[_ADC:_ADC + 8] != self.adc.tobytes():  # (little-endian int16 already)
            self.publish_adc()
        if self._deferred:
            self._deferred = [d for d in self._deferred if not w.put(d[1], d[0], d[2], n)]
        self.follow.publish()
        buf[_INPUT:_INPUT + 4] = (self.inputs & 0xFFFFFFFF).to_bytes(4, "little")


def _int32(values: np.ndarray) -> np.ndarray:
    """Counters as the card's int32 words: wrapping beyond 2^31."""
    return ((values + 2**31) % 2**32 - 2**31).astype(np.int32)
