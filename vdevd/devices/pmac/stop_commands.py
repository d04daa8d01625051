"""The `/` and `\\` on-line commands of a coordinate system's running program [Turbo SRM `/`,
`\\`, `<`; Turbo UM "Writing and Executing Motion Programs": stopping commands].

`/` stops the program at the end of the move executing now, in every mode that can end there
without a step of velocity; the moves calculated past it go back to the calculation (R or S
calculates them again from their statements) and the program stops there, resumable as after Q:
- LINEAR: the blend into the next move is replaced by a deceleration onto the executing move's
  end point in the blend's own TA and TS (centred on the corner, so it ends on it), whether one
  move (Isx13 > 0) or two (Isx13 = 0) are calculated past it;
- CIRCLE: the sequence ends on the executing move as the planner before the next move would have
  ended it (its own kernel, along its path), spliced in where the next move's blend begins;
- PVT: the next segment is dropped and the executing one ends in `PvtPlanner.stop` (pvt.py);
- SPLINE: the executing segment already bends toward the point after it (SPLINE2: and the times
  two on): the sequence ends as soon as that allows (`_cut_next_spline`), one move before Q;
- RAPID: nothing is calculated past the executing move; a move in the special lookahead, a
  DWELL or any motion that cannot be cut this way: `/` acts as Q, the end of the moves
  calculated (ASSUMPTION: the Turbo SRM text for `/` was not in the sources retrieved; README
  "`/` and `\\`").
Q (program_runner.py) in PVT ends in the same deceleration (`pvt_quit`).

`\\` is the quick stop in the special lookahead buffer; "if the coordinate system is not currently
in the middle of a lookahead sequence", it is a feed hold (H) [SRM `<`, `\\`]. Here it is always
H, resumed with R: the quick stop inside a lookahead sequence is not built (README "Not
emulated").
"""

from __future__ import annotations

import copy
from typing import TYPE_CHECKING, Any

import numpy as np

from vdevd.devices.pmac.circle import CirclePlanner
from vdevd.devices.pmac.linear import LinearPlanner, blend
from vdevd.devices.pmac.pieces import NAXES, Piece
from vdevd.devices.pmac.pvt import PvtPlanner
from vdevd.devices.pmac.spline import SplinePlanner

if TYPE_CHECKING:
    from vdevd.devices.pmac.program_runner import CsProgram


def stop_at_end_of_move(r: CsProgram) -> None:
    """`/` for C.S. r (module docstring)."""
    if not r.running:
        return
    if not (_cut_next_move(r) or _cut_next_pvt(r) or _cut_next_circle(r)
            or _cut_next_spline(r)):
        r.quit()


def quick_stop(r: CsProgram) -> None:
    """`\\`: outside a lookahead sequence, a feed hold [SRM `<`]."""
    r.feed_hold()


def _cut_next_move(r: CsProgram) -> bool:
    """Replace the blend into move `started + 1` by a stop at the corner; False when that is
    not how the motion stands (the caller quits instead)."""
    if r.mode != "LINEAR" or r.wait \
            or not isinstance(r.planner, LinearPlanner):   # not in a CIRCLE sequence
        return False
    nxt = r.started + 1
    rec = r.move_recs.get(nxt)
    count = r.blend_at.get(nxt, 0)
    # Isx13 > 0: the next move alone is calculated; Isx13 = 0: the next two [module docstring]
    ahead = nxt if r.segmenter is not None else nxt + 1
    if rec is None or rec[0] != nxt or not nxt <= r.calc <= ahead or count <= 0:
        return False
    _, prog, pc, stack, ops, corner = rec
    if prog == 0 and r.rot.ops is not ops:
        return False   # the rotary line of that move is gone: it cannot be calculated again
    if r.segmenter is not None:   # Isx13 segments in the queue, not the planner's pieces
        cut = _segmented_stop(r, nxt, corner)
        if cut is None:
            return False
        at, stop = cut
    else:
        queue = list(r.queue)
        found = next((k for k, q in enumerate(queue) if q.starts == nxt), None)
        if found is None or found + count > len(queue):
            return False
        at = found
        pieces = [q.piece for q in queue[at:at + count]]
        ta = sum(p.dur for p in pieces)
        ts = pieces[0].dur if count > 1 else 0.0
        start = pieces[0].coef
        stop = blend(start[0], start[1], np.zeros(NAXES), ta, ts)
    if stop:
        last = stop[-1]
        coef = last.coef.copy()   # end exactly on the corner, free of rounding
        coef[0] += corner - last.end()[0]
        stop[-1] = Piece(last.dur, coef)
    while len(r.queue) > at:
        r.queue.pop()
    r.segmenter = None   # the stop runs as planned; R segments afresh from the corner
    r._enqueue(stop, starts=0)
    r.pos = corner.copy()
    r.calc = r.started
    r.move_from = None
    _quit_at(r, prog, pc, stack)
    return True


def _segmented_stop(r: CsProgram, nxt: int,
                    corner: np.ndarray) -> tuple[int, list[Piece]] | None:
    """With Isx13 segmentation (lookahead.py) the queue holds segments: every segment the
    segmenter still holds is released (ending in a stop, as at the end of a program), and the
    segments from the one where move `nxt` (its TA blend) begins are replaced by a deceleration
    from the state there onto the corner: in the time that covers the distance left at half the
    speed there (the blend's TA when the segment begins where the blend does), S-curve TS. None
    when that segment cannot be found or the axes stand there (the caller quits instead)."""
    r._release_segments(final=True)
    start = _move_start(r, nxt)
    if start is None:
        return None
    at, before = start
    p, v = before.end()
    speed, left = float(np.linalg.norm(v)), float(np.linalg.norm(corner - p))
    if speed <= 0 or left <= 0:
        return None
    ta = 2 * left / speed
    ts = min(float(r._params()["TS"]), ta / 2)
    return at, blend(p, v, np.zeros(NAXES), ta, ts)



# -- PVT: no velocity step at the stop (pvt.py) -----------------------------------------------------
def ixx15_time(r: CsProgram, v: np.ndarray) -> float:
    """The shortest time in which every motor of C.S. r comes from axis velocity `v` (units/s)
    to rest at its Ixx15 (counts/ms^2) [SRM Ixx15]; 0 where Ixx15 is 0."""
    if not len(r.members):
        return 0.0
    counts = np.abs(r.scale @ v)                                       # counts/s
    dec = r.fw.ivars.values[100 * (r.members + 1) + 15] * 1e6          # counts/s^2
    need = np.divide(counts, dec, out=np.zeros_like(counts), where=dec > 0)
    return float(need.max())


def pvt_quit(r: CsProgram) -> None:
    """Q (or `/` with nothing calculated past the executing move) in PVT mode: the segments
    calculated run out, then the deceleration of `PvtPlanner.stop` brings the axes to rest from
    the last point's velocity; the program stands (and R goes on) where they stop."""
    planner = r.planner
    if not isinstance(planner, PvtPlanner):
        return
    r._enqueue(planner.stop(ixx15_time(r, planner.velocity)), starts=0)
    r.pos = planner.position.copy()


def _cut_next_pvt(r: CsProgram) -> bool:
    """`/` in PVT mode with the next segment calculated: that segment is dropped and given back to
    the calculation, and the executing segment ends in the deceleration of `PvtPlanner.stop`
    from its end point and velocity; False when that is not how the motion stands."""
    planner = r.planner
    if r.mode != "PVT" or r.wait or not isinstance(planner, PvtPlanner):
        return False
    nxt = r.started + 1
    rec = r.move_from
    if rec is None or rec[0] != nxt or r.calc != nxt:
        return False
    _, prog, pc, stack, ops, _start = rec
    if prog == 0 and r.rot.ops is not ops:
        return False   # the rotary line of that move is gone: it cannot be calculated again
    start = _move_start(r, nxt)
    if start is None:
        return False
    at, before = start
    p, v = before.end()
    while len(r.queue) > at:
        r.queue.pop()
    planner.position, planner.velocity = p.copy(), v.copy()
    pvt_quit(r)
    r.calc = r.started
    r.move_from = None
    _quit_at(r, prog, pc, stack)
    return True


# -- CIRCLE: the sequence ended on the executing move, along its path (circle.py) ---------------
def _cut_next_circle(r: CsProgram) -> bool:
    """`/` in a CIRCLE sequence: the planner as it stood before the next move was added ends the
    sequence on the executing move (its flush: the deceleration of its own blend kernel along
    its path), spliced in at the piece boundary where the next move's blend begins (the two
    agree up to there); the moves calculated after it go back to the calculation. False when
    no boundary of the flush meets the queued motion (the caller quits)."""
    if r.wait or not isinstance(r.planner, CirclePlanner):
        return False
    nxt = r.started + 1
    rec, saved = r.move_recs.get(nxt), r.circle_before.get(nxt)
    if rec is None or saved is None or r.calc < nxt:
        return False
    _, prog, pc, stack, ops, start = rec
    if prog == 0 and r.rot.ops is not ops:
        return False
    cut = _move_start(r, nxt)
    if cut is None:
        return False
    found, before = cut
    p0, v0 = before.end()
    flushed = copy.deepcopy(saved[0]).flush()
    at = next((k for k, piece in enumerate(flushed)
               if np.allclose(piece.at(0.0)[0], p0, atol=1e-6)
               and np.allclose(piece.at(0.0)[1], v0, atol=1e-4)), None)
    if at is None:
        return False   # the stop's kernel leaves the path before the next move's blend begins
    kept = flushed[at:]
    while len(r.queue) > found:
        r.queue.pop()
    r.segmenter = None   # what it still holds lies past the cut; R segments afresh
    r._enqueue(kept, starts=0)
    r.pos = start.copy()
    r.calc = r.started
    _quit_at(r, prog, pc, stack)
    return True


# -- SPLINE: the sequence ended as soon as its executing segment allows (spline.py) ----------------
def _cut_next_spline(r: CsProgram) -> bool:
    """`/` in a SPLINE sequence: the executing segment is shaped by the point after it (SPLINE2:
    and the times two on), so the sequence ends as the planner stood just before the move that
    began the next segment was added: its flush (the added end segment) from the end of the
    executing segment, stopping on that planner's last point, one move sooner than Q; the moves
    after it go back to the calculation. False when that cannot be done (the caller quits)."""
    if r.wait or not isinstance(r.planner, SplinePlanner):
        return False
    nxt = r.started + 1
    saved = r.spline_before.get(nxt)
    if saved is None:
        return False
    planner, last = copy.deepcopy(saved[0]), saved[1]
    rec = r.move_recs.get(last + 1)
    if rec is None or r.calc < last + 1:
        return False
    _, prog, pc, stack, ops, start = rec
    if prog == 0 and r.rot.ops is not ops:
        return False
    cut = _move_start(r, nxt)
    if cut is None:
        return False
    found, before = cut
    flushed = planner.flush()
    if not flushed:
        return False
    (p0, v0), (p1, v1) = before.end(), flushed[0].at(0.0)
    if not (np.allclose(p0, p1, atol=1e-6) and np.allclose(v0, v1, atol=1e-4)):
        return False
    while len(r.queue) > found:
        r.queue.pop()
    r.calc = last
    r._enqueue_labelled(flushed, planner.labels)
    r.pos = start.copy()
    _quit_at(r, prog, pc, stack)
    return True


# -- what every cut shares ---------------------------------------------------------------------------
def _move_start(r: CsProgram, nxt: int) -> tuple[int, Piece] | None:
    """Where move `nxt` begins in r's queue and the piece that ends there (the executing one when
    it is the first queued); None when the queue does not hold its start."""
    queue = list(r.queue)
    at = next((k for k, q in enumerate(queue) if q.starts == nxt), None)
    if at is None:
        return None
    before = queue[at - 1].piece if at else (r.cur.piece if r.cur is not None else None)
    return None if before is None else (at, before)


def _quit_at(r: CsProgram, prog: int, pc: int, stack: list[Any]) -> None:
    """The calculation given back to the move recorded at (prog, pc, stack): the program quits
    once what is queued has run, and R calculates again from there."""
    r.planner = None
    r.prog, r.pc, r.stack = prog, pc, stack
    r._blocked = r._glide = None
    r.state, r.stopping = "quit", True
