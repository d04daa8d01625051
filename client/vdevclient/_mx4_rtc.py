"""One function per real-time command of the Mx4 Octavia, named after its mnemonic [Ch5; spec
octavia.md §4.2, §8.2 layer 2]: `AXMOVE(h, mask, acc, pos, vel)`. Arguments are in DPR order and
raw DPR units (the unit helpers convert); per-axis arguments are sequences indexed by axis (index
0 = axis 1, only the axes of the mask are sent) or one value for every axis of the mask. Each call
is one batch: it returns once the card has taken the command (3C2h back to 00h), and raises the
card's report of a discarded command as Mx4Error (vdevclient._mx4_bus.Mx4.send). A list longer
than the 57-byte window goes as several RTCs, split by axes (spec Q-3).

`vdevclient.mx4` re-exports these; `h` is its `Mx4`.
"""

from __future__ import annotations

from collections.abc import Sequence
from typing import TYPE_CHECKING, Any

from vdevmaps.octavia import RESET_ARGS

from vdevclient._mx4_codec import PerAxis, Post, encode, encode_list

if TYPE_CHECKING:
    from vdevclient._mx4_bus import Mx4

__all__ = [
    "AXMOVE", "AXMOVE_S", "AXMOVE_T", "BTRATE", "CAM", "CAM_OFF", "CAM_OFF_ACC", "CAM_POINT",
    "CAM_POS", "CAM_PROBE", "CHANGE_VAR", "CLEAR_CUBIC_TABLE", "CLEAR_DSPL", "CLEAR_POS_TABLE",
    "CLEAR_VEL_TABLE", "CTRL", "CTRL_KA", "CUBIC_INT", "CUBIC_RATE", "CUBIC_SCALE", "DDAC",
    "DISABL2_INT", "DISABL_INT", "DSPL_AUTOSTART", "EN_BUFBRK", "EN_ENCFLT", "EN_ERR", "EN_ERRHLT",
    "EN_INDEX", "EN_MOTCP", "EN_POSBRK", "EN_PROBE", "ESTOP_ACC", "GEAR", "GEAR_OFF",
    "GEAR_OFF_ACC", "GEAR_POS", "GEAR_PROBE", "INP_STATE", "INT5MS", "KILIMIT", "LOAD_CAM_TABLE",
    "LOAD_CUBIC_TABLE", "LOAD_POS_TABLE", "LOAD_VEL_TABLE", "LOW_PASS", "MAXACC", "MONITOR_VAR",
    "NOTCH", "NURBS", "NURBS_BUFBRK", "NURBS_FEEDRATE", "OFFSET", "OUTGAIN", "OUTP_OFF", "OUTP_ON",
    "OVERRIDE", "POSBRK_OUT", "POS_PRESET", "POS_SHIFT", "REL_AXMOVE", "REL_AXMOVE_S",
    "REL_AXMOVE_SLAVE", "REL_AXMOVE_T", "RESET", "SIGNAL_DSPL", "START", "START_DSPL",
    "STEPPER_ON", "STOP", "STOP_DSPL", "SYNC", "TABLE_SEL", "TRQ_LIMIT", "VECCHG", "VELMODE",
]


def _send(h: Mx4, posts: list[Post]) -> None:
    h.send(posts)


def _one(h: Mx4, name: str, **head: float) -> None:
    h.send(encode(name, head))


def _axes(h: Mx4, name: str, mask: int, head: dict[str, int] | None = None,
          **per_axis: PerAxis) -> None:
    h.send(encode(name, {"n": mask, **(head or {})}, **per_axis))


def _slaves(h: Mx4, name: str, master: int, slaves: int, head: dict[str, int] | None = None,
            **per_axis: PerAxis) -> None:
    h.send(encode(name, {"n": master, "m": slaves, **(head or {})}, **per_axis))


# -- control law and initialization [Ch5 Control Law and Initialization] ---------------------------
def CTRL(h: Mx4, mask: int, ki: PerAxis, kp: PerAxis, kf: PerAxis, kd: PerAxis) -> None:
    """62h: integral, proportional, velocity feed-forward and differential gains [Ch5 CTRL]."""
    _axes(h, "CTRL", mask, ki=ki, kp=kp, kf=kf, kd=kd)


def CTRL_KA(h: Mx4, mask: int, ka: PerAxis) -> None:
    """59h: the acceleration feed-forward gain [Ch5 CTRL_KA]."""
    _axes(h, "CTRL_KA", mask, ka=ka)


def KILIMIT(h: Mx4, mask: int, val: PerAxis) -> None:
    """74h: the integral channel's limit, 10 V / 2^val, val 0..14 [Ch5 KILIMIT]."""
    _axes(h, "KILIMIT", mask, val=val)


def OUTGAIN(h: Mx4, mask: int, m: PerAxis) -> None:
    """81h: the output loop gain 2^m, m 0..4 [Ch5 OUTGAIN]."""
    _axes(h, "OUTGAIN", mask, m=m)


def TRQ_LIMIT(h: Mx4, mask: int, val: PerAxis) -> None:
    """5Bh: the output clamp, 0..7FFFh = 0..+-10 V [Ch5 TRQ_LIMIT]."""
    _axes(h, "TRQ_LIMIT", mask, val=val)


def MAXACC(h: Mx4, mask: int, acc: PerAxis) -> None:
    """71h: the acceleration of STOP, VELMODE, cam/gear slaves (1.15) [Ch5 MAXACC]."""
    _axes(h, "MAXACC", mask, acc=acc)


def ESTOP_ACC(h: Mx4, mask: int, acc: PerAxis) -> None:
    """86h: the deceleration of *ESTOP and EN_ERRHLT halts (1.15) [Ch5 ESTOP_ACC]."""
    _axes(h, "ESTOP_ACC", mask, acc=acc)


def OFFSET(h: Mx4, mask: int) -> None:
    """5Fh: DAC offset cancellation on one axis; its end is DSPSTAT2 b2 [Ch5 OFFSET]
    (`calibrate_offset` waits for it)."""
    _one(h, "OFFSET", n=mask)


def OVERRIDE(h: Mx4, val: int) -> None:
    """8Bh: the feed-rate override, 16.16, 00002000h..000A0000h [Ch5 OVERRIDE]."""
    _one(h, "OVERRIDE", val=val)


def POS_PRESET(h: Mx4, mask: int, pos: PerAxis) -> None:
    """68h: define the present position of the axes [Ch5 POS_PRESET]."""
    _axes(h, "POS_PRESET", mask, pset=pos)


def POS_SHIFT(h: Mx4, mask: int, psft: PerAxis) -> None:
    """5Dh: add psft to the position counters, without losing position integrity [Ch5
    POS_SHIFT]."""
    _axes(h, "POS_SHIFT", mask, psft=psft)


def RESET(h: Mx4) -> None:
    """72h AAh AAh: the card returns to its power-up state, clearing the DPR [Ch5 RESET]; `reset`
    also waits for "reset finished" and checks the signature."""
    h.send(encode("RESET", {"sig1": RESET_ARGS[0], "sig2": RESET_ARGS[1]}), check=False)


def SYNC(h: Mx4, m: int) -> None:
    """87h: master (0) or slave of the J5 sync chain [Ch5 SYNC]."""
    _one(h, "SYNC", m=m)


def STEPPER_ON(h: Mx4, mask: int) -> None:
    """8Dh: the axes driven by the Stp4 stepper add-on [Ch5 STEPPER_ON]."""
    _one(h, "STEPPER_ON", n=mask)


def NOTCH(h: Mx4, mask: int, freq: int, q: int) -> None:
    """8Eh (NOTCH firmware option): notch filter of one axis, freq Hz (0 off), q 0/1 [Ch5 NOTCH]."""
    _one(h, "NOTCH", n=mask, freq=freq, q=q)


def LOW_PASS(h: Mx4, mask: int, idx: int) -> None:
    """8Eh (LOW_PASS firmware option): low-pass filter of one axis, frequency index 0..46 [Ch5
    LOW_PASS]."""
    _one(h, "LOW_PASS", n=mask, idx=idx)


# -- simple motion [Ch5 Simple Motion] -------------------------------------------------------------
def AXMOVE(h: Mx4, mask: int, acc: PerAxis, pos: PerAxis, vel: PerAxis) -> None:
    """60h: trapezoidal move to pos at slew vel (16.16) and acc (1.15) [Ch5 AXMOVE]."""
    _axes(h, "AXMOVE", mask, acc=acc, pos=pos, vel=vel)


def AXMOVE_S(h: Mx4, mask: int, acc: PerAxis, pos: PerAxis, vel: PerAxis) -> None:
    """82h: S-curve move, peak acceleration 2*acc [Ch5 AXMOVE_S]."""
    _axes(h, "AXMOVE_S", mask, acc=acc, pos=pos, vel=vel)


def AXMOVE_T(h: Mx4, mask: int, acc: PerAxis, pos: PerAxis, tm: PerAxis) -> None:
    """8Fh: move in tm samples of 200 us [Ch5 AXMOVE_T]."""
    _axes(h, "AXMOVE_T", mask, acc=acc, pos=pos, tm=tm)


def REL_AXMOVE(h: Mx4, mask: int, acc: PerAxis, pos: PerAxis, vel: PerAxis) -> None:
    """B7h: move by pos from the command position [Ch5 REL_AXMOVE]."""
    _axes(h, "REL_AXMOVE", mask, acc=acc, pos=pos, vel=vel)


def REL_AXMOVE_S(h: Mx4, mask: int, acc: PerAxis, pos: PerAxis, vel: PerAxis) -> None:
    """75h: relative S-curve move [Ch5 REL_AXMOVE_S]."""
    _axes(h, "REL_AXMOVE_S", mask, acc=acc, pos=pos, vel=vel)


def REL_AXMOVE_T(h: Mx4, mask: int, acc: PerAxis, pos: PerAxis, tm: PerAxis) -> None:
    """78h: relative move in tm samples [Ch5 REL_AXMOVE_T]."""
    _axes(h, "REL_AXMOVE_T", mask, acc=acc, pos=pos, tm=tm)


def DDAC(h: Mx4, mask: int, val: PerAxis) -> None:
    """63h: open loop, the DAC at val (7FFFh = +10 V; `volts_to_dac`) [Ch5 DDAC]."""
    _axes(h, "DDAC", mask, val=val)


def STOP(h: Mx4, mask: int) -> None:
    """6Eh: decelerate at MAXACC and abort the axes' command [Ch5 STOP]."""
    _one(h, "STOP", n=mask)


def VELMODE(h: Mx4, mask: int, vel: PerAxis) -> None:
    """70h: run at the signed velocity vel (16.16), ramping at MAXACC [Ch5 VELMODE]."""
    _axes(h, "VELMODE", mask, vel=vel)


# -- contouring set-up [Ch5 Contouring] ------------------------------------------------------------
def START(h: Mx4, mask: int) -> None:
    """6Dh: start ring-buffer contouring on the axes [Ch5 START]."""
    _one(h, "START", n=mask)


def VECCHG(h: Mx4, mask: int, m: int) -> None:
    """6Fh: at ring slot m the contouring axes become mask [Ch5 VECCHG]."""
    _one(h, "VECCHG", n=mask, m=m)


def BTRATE(h: Mx4, m: int) -> None:
    """73h: the 2nd-order block rate, 5/10/15/20 ms for m 0..3 [Ch5 BTRATE]."""
    _one(h, "BTRATE", m=m)


def CUBIC_RATE(h: Mx4, m: int) -> None:
    """A1h: the cubic spline point interval, m x 200 us, m 5..511 [Ch5 CUBIC_RATE]."""
    _one(h, "CUBIC_RATE", m=m)


def CUBIC_SCALE(h: Mx4, mask: int, pos_mult: PerAxis, pos_shift: PerAxis) -> None:
    """B0h: p' = p * pos_mult (s1.14) + pos_shift for the internal table [Ch5 CUBIC_SCALE]."""
    _axes(h, "CUBIC_SCALE", mask, pos_mult=pos_mult, pos_shift=pos_shift)


def CUBIC_INT(h: Mx4, m: int, si: int, n: int, ax: int) -> None:
    """B1h: run m internal table points from si, n times (0: for ever), on the axes ax [Ch5
    CUBIC_INT]."""
    _one(h, "CUBIC_INT", m=m, si=si, n=n, ax=ax)


def LOAD_CUBIC_TABLE(h: Mx4, index: int, num: int) -> None:
    """AFh: copy num int32 points staged at 120h to the table at index [Ch5 LOAD_CUBIC_TABLE]
    (`load_table` stages and chunks)."""
    _one(h, "LOAD_CUBIC_TABLE", index=index, num=num)


def CLEAR_CUBIC_TABLE(h: Mx4) -> None:
    """B6h: clear the internal cubic spline table [Ch5 CLEAR_CUBIC_TABLE]."""
    _one(h, "CLEAR_CUBIC_TABLE")


# -- cam and gearing [Ch5 Cam, Gearing] ------------------------------------------------------------
def CAM(h: Mx4, master: int, slaves: int, tablestart: PerAxis, tablesize: PerAxis) -> None:
    """A4h: the slaves follow their cam tables of the master [Ch5 CAM]."""
    _slaves(h, "CAM", master, slaves, tablestart=tablestart, tablesize=tablesize)


def CAM_POS(h: Mx4, master: int, slaves: int, masterpos: PerAxis, tablestart: PerAxis,
            tablesize: PerAxis) -> None:
    """A5h: each slave engages when the master reaches masterpos [Ch5 CAM_POS]."""
    _slaves(h, "CAM_POS", master, slaves, masterpos=masterpos, tablestart=tablestart,
            tablesize=tablesize)


def CAM_PROBE(h: Mx4, master: int, slaves: int, q: int, tablestart: PerAxis,
              tablesize: PerAxis) -> None:
    """A6h: the slaves engage at the *EXTq edge (q 01h/02h/04h/08h) [Ch5 CAM_PROBE]."""
    _slaves(h, "CAM_PROBE", master, slaves, {"q": q}, tablestart=tablestart, tablesize=tablesize)


def CAM_OFF(h: Mx4, mask: int) -> None:
    """A7h: disengage the slaves at once [Ch5 CAM_OFF]."""
    _one(h, "CAM_OFF", n=mask)


def CAM_OFF_ACC(h: Mx4, mask: int) -> None:
    """A8h: disengage and stop the slaves at MAXACC [Ch5 CAM_OFF_ACC]."""
    _one(h, "CAM_OFF_ACC", n=mask)


def CAM_POINT(h: Mx4, tablestart: int, tablesize: int, index: int, masterpos: int,
              slavepos: int) -> None:
    """B3h: write one cam point; the card computes the ratio [Ch5 CAM_POINT]."""
    _one(h, "CAM_POINT", tablestart=tablestart, tablesize=tablesize, index=index,
         masterpos=masterpos, slavepos=slavepos)


def LOAD_CAM_TABLE(h: Mx4, index: int, numpts: int) -> None:
    """AAh: copy numpts 10-byte points staged at 120h to the cam memory at index [Ch5
    LOAD_CAM_TABLE] (`load_table` stages and chunks)."""
    _one(h, "LOAD_CAM_TABLE", index=index, numpts=numpts)


def GEAR(h: Mx4, leader: int, followers: int, r: PerAxis) -> None:
    """9Ch: the followers follow the leader at ratio r (1.8.7, `ratio_to_raw`) [Ch5 GEAR]."""
    _slaves(h, "GEAR", leader, followers, r=r)


def GEAR_POS(h: Mx4, leader: int, followers: int, r: PerAxis, tp: PerAxis) -> None:
    """9Dh: each follower engages when the leader reaches tp [Ch5 GEAR_POS]."""
    _slaves(h, "GEAR_POS", leader, followers, r=r, tp=tp)


def GEAR_PROBE(h: Mx4, leader: int, followers: int, q: int, r: PerAxis) -> None:
    """9Eh: the followers engage at the *EXTq edge [Ch5 GEAR_PROBE]."""
    _slaves(h, "GEAR_PROBE", leader, followers, {"q": q}, r=r)


def GEAR_OFF(h: Mx4, mask: int) -> None:
    """9Fh: disengage the followers at once [Ch5 GEAR_OFF]."""
    _one(h, "GEAR_OFF", n=mask)


def GEAR_OFF_ACC(h: Mx4, mask: int) -> None:
    """A0h: disengage and stop the followers at MAXACC [Ch5 GEAR_OFF_ACC]."""
    _one(h, "GEAR_OFF_ACC", n=mask)


def REL_AXMOVE_SLAVE(h: Mx4, mask: int, acc: PerAxis, rel_pos: PerAxis, rel_vel: PerAxis) -> None:
    """AEh: a relative move superimposed on a geared or cammed slave [Ch5 REL_AXMOVE_SLAVE]."""
    _axes(h, "REL_AXMOVE_SLAVE", mask, acc=acc, rel_pos=rel_pos, rel_vel=rel_vel)


# -- interrupt control [Ch5 Interrupt Control] -----------------------------------------------------
def EN_BUFBRK(h: Mx4, buffbrk: int) -> None:
    """61h: interrupt (1FFEh b0) when fewer than buffbrk ring slots are filled [Ch5 EN_BUFBRK]."""
    _one(h, "EN_BUFBRK", buffbrk=buffbrk)


def EN_ENCFLT(h: Mx4, m: int, mask: int, fer: PerAxis) -> None:
    """58h: encoder-fault interrupt, mode m, following-error setpoints fer [Ch5 EN_ENCFLT]."""
    h.send(encode("EN_ENCFLT", {"m": m, "n": mask}, fer=fer))


def EN_ERR(h: Mx4, mask: int, fer: PerAxis) -> None:
    """67h: following-error interrupt over fer counts [Ch5 EN_ERR]."""
    _axes(h, "EN_ERR", mask, fer=fer)


def EN_ERRHLT(h: Mx4, mask: int, fer: PerAxis) -> None:
    """66h: following-error interrupt and halt at ESTOP_ACC [Ch5 EN_ERRHLT]."""
    _axes(h, "EN_ERRHLT", mask, fer=fer)


def EN_INDEX(h: Mx4, mask: int) -> None:
    """69h: interrupt at the first index pulse of one axis, latching INDPOS [Ch5 EN_INDEX]."""
    _one(h, "EN_INDEX", n=mask)


def EN_MOTCP(h: Mx4, mask: int) -> None:
    """65h: motion-complete interrupt on the axes [Ch5 EN_MOTCP]."""
    _one(h, "EN_MOTCP", n=mask)


def EN_POSBRK(h: Mx4, mask: int, pos: PerAxis) -> None:
    """6Bh: position-breakpoint interrupt (one-shot) [Ch5 EN_POSBRK]."""
    _axes(h, "EN_POSBRK", mask, pos=pos)


def EN_PROBE(h: Mx4, m: int) -> None:
    """6Ch: interrupt at the first edge of *EXTm (01h/02h/04h/08h), latching PRB [Ch5
    EN_PROBE]."""
    _one(h, "EN_PROBE", m=m)


def DISABL_INT(h: Mx4, mask: int, bits: PerAxis) -> None:
    """64h: per axis, a set bit disables that interrupt (DisableBit) [Ch5 DISABL_INT]."""
    h.send(encode("DISABL_INT", {"n": mask}, mask=bits))


def DISABL2_INT(h: Mx4, mask: int, bits: PerAxis) -> None:
    """5Ah: per axis, b0 disables the encoder-fault interrupt [Ch5 DISABL2_INT]."""
    h.send(encode("DISABL2_INT", {"n": mask}, mask=bits))


def INT5MS(h: Mx4, m: int) -> None:
    """8Eh (INT5MS firmware option): the 5 ms interrupt on (m != 0) or off [Ch5 INT5MS]."""
    _one(h, "INT5MS", m=m)


# -- input / output [Ch5 Input/Output] -------------------------------------------------------------
def OUTP_ON(h: Mx4, outp1: int, outp2: int) -> None:
    """56h: turn ON (drive low) the outputs of the set bits: outp1 OUT0..15, outp2 OUT16..31
    [Ch5 OUTP_ON; spec Q-11]."""
    _one(h, "OUTP_ON", outp1=outp1, outp2=outp2)


def OUTP_OFF(h: Mx4, outp1: int, outp2: int) -> None:
    """55h: turn OFF (high) the outputs of the set bits [Ch5 OUTP_OFF]."""
    _one(h, "OUTP_OFF", outp1=outp1, outp2=outp2)


def INP_STATE(h: Mx4, inp1: int, inp2: int) -> None:
    """B4h: input polarity, bit set = active high: inp1 IN0..15, inp2 IN16..31 [Ch5 INP_STATE]."""
    _one(h, "INP_STATE", inp1=inp1, inp2=inp2)


def POSBRK_OUT(h: Mx4, mask: int, on1: PerAxis, on2: PerAxis, off1: PerAxis,
               off2: PerAxis) -> None:
    """7Dh: the outputs each axis's breakpoint turns ON and OFF [Ch5 POSBRK_OUT]."""
    _axes(h, "POSBRK_OUT", mask, on1=on1, on2=on2, off1=off1, off2=off2)


# -- tables and DSPL [Ch5 DSPL, tables] ------------------------------------------------------------
def TABLE_SEL(h: Mx4, mask: int, tb: PerAxis) -> None:
    """A2h: the compensation table of each axis [Ch5 TABLE_SEL]."""
    _axes(h, "TABLE_SEL", mask, tb=tb)


def CLEAR_POS_TABLE(h: Mx4, tables: int) -> None:
    """98h: zero the position compensation tables of the mask [Ch5 CLEAR_POS_TABLE]."""
    _one(h, "CLEAR_POS_TABLE", n=tables)


def CLEAR_VEL_TABLE(h: Mx4, tables: int) -> None:
    """99h: zero the velocity compensation tables of the mask [Ch5 CLEAR_VEL_TABLE]."""
    _one(h, "CLEAR_VEL_TABLE", n=tables)


def LOAD_POS_TABLE(h: Mx4, table: int, index: int, num: int) -> None:
    """9Ah: copy num u16 entries staged at 120h to the position tables of the mask [Ch5
    LOAD_POS_TABLE] (`load_table` stages and chunks)."""
    _one(h, "LOAD_POS_TABLE", table=table, index=index, num=num)


def LOAD_VEL_TABLE(h: Mx4, table: int, index: int, num: int) -> None:
    """9Bh: the same for the velocity tables [Ch5 LOAD_VEL_TABLE]."""
    _one(h, "LOAD_VEL_TABLE", table=table, index=index, num=num)


def START_DSPL(h: Mx4) -> None:
    """91h [Ch5 START_DSPL]."""
    _one(h, "START_DSPL")


def STOP_DSPL(h: Mx4) -> None:
    """97h: stop the DSPL programs; every axis halts at MAXACC [Ch5 STOP_DSPL]."""
    _one(h, "STOP_DSPL")


def SIGNAL_DSPL(h: Mx4) -> None:
    """94h: release a DSPL WAIT_UNTIL_RTC [Ch5 SIGNAL_DSPL]."""
    _one(h, "SIGNAL_DSPL")


def CLEAR_DSPL(h: Mx4) -> None:
    """95h [Ch5 CLEAR_DSPL]."""
    _one(h, "CLEAR_DSPL")


def DSPL_AUTOSTART(h: Mx4, x: int) -> None:
    """A3h: x = 55h enables the DSPL autostart (non-volatile) [Ch5 DSPL_AUTOSTART]."""
    _one(h, "DSPL_AUTOSTART", x=x)


def CHANGE_VAR(h: Mx4, pairs: Sequence[tuple[int, bytes]]) -> None:
    """ADh: set DSPL variables: (var 1..128, its 6-byte value LSB first) pairs [Ch5 CHANGE_VAR]."""
    items: list[dict[str, Any]] = [{"var": var, "value": bytes(value)} for var, value in pairs]
    for item in items:
        if len(item["value"]) != 6:
            raise ValueError(f"CHANGE_VAR: VAR{item['var']}'s value is {len(item['value'])} bytes, not 6")
    _send(h, encode_list("CHANGE_VAR", items))


def MONITOR_VAR(h: Mx4, slots: int, var: PerAxis) -> None:
    """B2h: map DSPL variables to the monitor slots of the mask (b0..b3 = 066h/06Ch/072h/078h),
    var indexed by slot [Ch5 MONITOR_VAR]."""
    h.send(encode("MONITOR_VAR", {"m": slots}, var=var))


# -- NURBS [Ch9; codes and layouts vdevd's, spec Q-27: vdevmaps.octavia NURBS_RTCS] -----------------
def NURBS(h: Mx4, feed: float, rate: float, first: float, last: float, npts: float) -> None:
    """B8h: run the NURBS curve of the DPR rings: FeedRate (counts/sample), NURBSRate (ms),
    first and last knot, the number of control points, all float32 [Ch9]."""
    _one(h, "NURBS", feed=feed, rate=rate, first=first, last=last, npts=npts)


def NURBS_BUFBRK(h: Mx4, threshold: int) -> None:
    """B9h: interrupt (1FFEh b7) when fewer than threshold knots are pending [Ch9]."""
    _one(h, "NURBS_BUFBRK", threshold=threshold)


def NURBS_FEEDRATE(h: Mx4, feed: float) -> None:
    """BAh: a new FeedRate (float32, counts/sample) from the next curve point [Ch9]."""
    _one(h, "NURBS_FEEDRATE", feed=feed)

