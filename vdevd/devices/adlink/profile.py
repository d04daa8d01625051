"""Scalar acceleration/deceleration profiles of the AMP-204C/208C [M §4.2.3] (spec §2.5, §2.7, §2.9).

Manual, 4.2.3.1 "Trapezoidal Speed Profile, T-curve": "In a V-T chart the area under the trapezoidal
curve equals motion distance. If the user does not set up sufficient motion distance the controller
shall increase (decrease) the maximum speed while maintain the acceleration [...] The acceleration and
deceleration rate remain intact to maintain the best (shortest) motion time."

Manual, 4.2.3.2 "S-curve": "To shorten acceleration and deceleration time the linear section (t2, t6)
is inserted in these area to maintain the maximum acceleration [...] S = t1/(t1+t2); and t1 = t2 [read
t1 = t3] [...] S = 0, the speed profile becomes a T-curve [...] When S = 1, the profile comes to a Pure
S-curve with its A-T chart become a triangle. [...] when motion distance is insufficient, the
controller adjust the maximum velocity automatically [...] Acceleration ACC and DEC and S-factor remain
consistent to maintain acceleration rate and the jerk rate will be changed".

Model (spec §2.5 ASSUMPTION, Q19): Acc/Dec are the peak accelerations; a velocity change dv at peak A
with factor S has t1 = t3 = S*dv/A, t2 = (1-S)*dv/A, jerk A/t1, so its time and distance are (1+S) times
the T-curve's, and the lowered peak of a short move has the closed form
    Vm'^2 = (2*D*Acc*Dec/(1+S) + Dec*Vs^2 + Acc*Ve^2) / (Acc + Dec)
(Vs = Ve = 0, Acc = Dec = A: Vm' = sqrt(A*D/(1+S)); S = 0: the T-curve formula). A pulse card starts
by jumping from 0 to Vs; a move too short for Vs/Ve keeps Vm' = max(Vs, Ve) and is cut where the
distance is covered, ending with a velocity step (`Plan.ve_reached` False: the caller's
ERR_DistantNotEnough -22 for buffered segments, Q7).

Sans-I/O and pure Python: planned at command time in closed form, evaluated in closed form
(`Plan.state`), handed to the motion core as phases (`to_core_phases`). The plan_* functions take
finite acc/dec > 0, speeds >= 0 (signed where said) and any S (clamped to [0, 1]); they raise nothing
for those: NaN, infinite or non-positive acc/dec are the caller's to refuse (with the vendor's code).
"""

from __future__ import annotations

import bisect
import math
from dataclasses import dataclass, field
from enum import IntEnum

from vdevd.rt.profiles import INF, Phase, Segment, to_phases

#: highest pulse rate [M §3.1]: "a command whose Vm exceeds 6.5 Mpps is clamped" (spec §2.5, Q7)
VM_MAX_PPS = 6.5e6

#: relative slack under which a distance counts as covered (float rounding of the closed forms)
_REL = 1e-12


class ProfilePhase(IntEnum):
    """What the profile does at a time: the motion status bits ACC, VM, DEC [M §4.8.1]; IDLE once
    done."""

    IDLE = 0
    ACC = 1
    VM = 2
    DEC = 3


_ACC, _DEC = ProfilePhase.ACC, ProfilePhase.DEC  # (a class attribute of an enum costs a lookup)


def clamp_vm(vm: float, unit_factor: float = 1.0) -> float:
    """`vm` (user units/s, signed) limited to VM_MAX_PPS pulses/s; `unit_factor` is pulses per user
    unit (axis parameter 86h [M §4.2.2]); a zero factor leaves `vm` as it is."""
    if unit_factor == 0:
        return vm
    limit = VM_MAX_PPS / abs(unit_factor)
    return math.copysign(min(abs(vm), limit), vm)


def s_ramp(v_from: float, v_to: float, peak: float, sf: float) -> list[Segment]:
    """Segments changing the velocity from v_from to v_to at peak acceleration `peak` with S-factor
    `sf`: t1 = t3 = sf*dv/peak of jerk peak/t1 around t2 = (1-sf)*dv/peak of constant acceleration
    [M §4.2.3.2]; sf = 0 (or so small the jerk would overflow) is the T-curve's one segment."""
    dv = v_to - v_from
    if dv == 0:
        return []
    s, t = math.copysign(1.0, dv), abs(dv) / peak
    t1 = sf * t
    jerk = peak / t1 if t1 > 0 else INF
    if math.isinf(jerk):
        return [(t, 0.0, s * peak)]
    segs = [(t1, s * jerk, 0.0), ((1 - sf) * t, 0.0, s * peak), (t1, -s * jerk, s * peak)]
    return [seg for seg in segs if seg[0] > 0]


def _ramp_distance(v_from: float, v_to: float, peak: float, sf: float) -> float:
    """Signed distance of `s_ramp` (its acceleration is symmetric: the mean velocity times its time)."""
    return (v_from + v_to) / 2 * sum(d for d, _, _ in s_ramp(v_from, v_to, peak, sf))


def _advance(v: float, seg: Segment, tau: float) -> tuple[float, float, float]:
    """(distance, velocity, acceleration) `tau` into `seg` entered at velocity v."""
    _, j, a = seg
    return tau * (v + tau * (a / 2 + j * tau / 6)), v + tau * (a + j * tau / 2), a + j * tau


def _solve(v: float, seg: Segment, target: float) -> float:
    """The time into `seg` (entered at v, distance 0) where its distance reaches `target`: bisection,
    the velocity keeping one sign within a segment (every plan's segments are built so)."""
    lo, hi = 0.0, seg[0]
    up = _advance(v, seg, hi)[0] >= 0
    for _ in range(200):
        mid = (lo + hi) / 2
        if not lo < mid < hi:
            break
        if (_advance(v, seg, mid)[0] < target) == up:
            lo = mid
        else:
            hi = mid
    return hi


#: segments with what each does (ACC, VM or DEC): known where they are built, not guessed from the
#: sign of a velocity that rounding may leave at -1e-16 at the end of a stop
_Tagged = list[tuple[Segment, ProfilePhase]]


def _ramp(v_from: float, v_to: float, peak: float, sf: float) -> _Tagged:
    """`s_ramp`, each segment tagged ACC when the speed grows, DEC when it falls."""
    tag = ProfilePhase.ACC if abs(v_to) > abs(v_from) else ProfilePhase.DEC
    return [(seg, tag) for seg in s_ramp(v_from, v_to, peak, sf)]


def _ramp_with_distance(v_from: float, v_to: float, peak: float, sf: float) -> tuple[_Tagged, float]:
    """`_ramp` and `_ramp_distance` from one `s_ramp` (the same numbers as each on its own)."""
    segs = s_ramp(v_from, v_to, peak, sf)
    tag = _ACC if abs(v_to) > abs(v_from) else _DEC
    time: float = 0  # summed as `sum` does, from the int 0
    for seg in segs:
        time += seg[0]
    return [(seg, tag) for seg in segs], (v_from + v_to) / 2 * time


def _cut(segs: _Tagged, v: float, dist: float) -> tuple[_Tagged, float]:
    """`segs` (from velocity v, moving forward) cut where their distance reaches `dist`, and the
    velocity there."""
    s = 0.0
    for k, (seg, tag) in enumerate(segs):
        ds, v1, _ = _advance(v, seg, seg[0])
        if s + ds >= dist:
            tau = _solve(v, seg, dist - s)
            out = segs[:k] + ([((tau, seg[1], seg[2]), tag)] if tau > 0 else [])
            return out, _advance(v, seg, tau)[1]
        s, v = s + ds, v1
    return segs, v


@dataclass(frozen=True)
class _Leg:
    segs: _Tagged
    peak: float
    end_velocity: float
    ve_reached: bool
    travelled: float


def _leg(u: float, dist: float, vm: float, ve: float, acc: float, dec: float, sf: float) -> _Leg:
    """Forward profile from speed u >= 0 over dist >= 0, peak at most vm (slowing first when u > vm),
    ending at ve (clamped to vm) [M §4.2.3]: the fastest one, with Vm lowered in closed form when the
    distance is short (module docstring), cut with a velocity step when even that is too long."""
    ve_eff = min(ve, vm)
    reached = ve_eff == ve
    if dist <= 0 or (u == 0 and vm <= 0):
        return _Leg([], 0.0, u if dist <= 0 else 0.0, reached and u == ve, 0.0)
    lo = max(u, ve_eff) if u <= vm else vm  # the lowest peak: no cruise, a single ramp or two
    planned: dict[float, tuple[_Tagged, _Tagged, float]] = {}  # by peak: a plan asks twice

    def ramps(vp: float) -> tuple[_Tagged, _Tagged, float]:
        if vp not in planned:
            up, travel_up = _ramp_with_distance(u, vp, acc if vp > u else dec, sf)
            down, travel_down = _ramp_with_distance(vp, ve_eff, dec, sf)
            planned[vp] = up, down, travel_up + travel_down
        return planned[vp]

    up, down, least = ramps(lo)
    if dist < least * (1 - _REL):  # too short even for Vs/Ve: cut, ending at a velocity step
        segs, v_end = _cut(up + down, u, dist)
        return _Leg(segs, max(u, lo), v_end, False, dist)
    vp = vm
    if u <= vm and ramps(vm)[2] > dist:
        k = 1 + sf
        vp2 = (2 * dist * acc * dec / k + dec * u * u + acc * ve_eff * ve_eff) / (acc + dec)
        vp = min(vm, max(lo, math.sqrt(vp2)))
    up, down, travel = ramps(vp)
    if vp <= 0:  # Vm 0 on the fly: it can only stop
        return _Leg(up, 0.0, 0.0, reached and ve == 0, travel)
    cruise = (dist - travel) / vp  # none for a rounding's worth of distance
    body = up + ([((cruise, 0.0, 0.0), ProfilePhase.VM)] if dist - travel > dist * _REL else []) + down
    return _Leg(body, vp, ve_eff, reached, dist)


@dataclass(frozen=True)
class Plan:
    """A scalar profile along one axis or a path: constant-jerk segments from t = 0 entered at v0,
    covering `distance` (>= 0 in the direction of travel; negative only when the plan reverses or
    runs backwards, see plan_from and plan_velocity).

    `endless`: a velocity move, whose velocity stays `end_velocity` after the last segment; its
    `distance` is the travel at the end of the segments. `ve_reached` is False when the end
    velocity asked for could not be reached (too short, or above Vm): the caller's -22. `vm` is the
    peak speed planned (Vm, or Vm' when lowered). `tags`: what each segment does (ACC, VM, DEC),
    as the planners know it; a plan built by hand without them gets them from the sign of velocity
    times acceleration. Immutable; evaluation is closed form.
    """

    segs: tuple[Segment, ...]
    v0: float
    distance: float
    endless: bool = False
    end_velocity: float = 0.0
    ve_reached: bool = True
    vm: float = 0.0
    tags: tuple[ProfilePhase, ...] = ()
    _t: tuple[float, ...] = field(init=False, repr=False, compare=False)
    _s: tuple[float, ...] = field(init=False, repr=False, compare=False)
    _v: tuple[float, ...] = field(init=False, repr=False, compare=False)

    def __post_init__(self) -> None:
        t, s, v = [0.0], [0.0], [self.v0]
        for seg in self.segs:
            ds, v1, _ = _advance(v[-1], seg, seg[0])
            t.append(t[-1] + seg[0])
            s.append(s[-1] + ds)
            v.append(v1)
        object.__setattr__(self, "_t", tuple(t))
        object.__setattr__(self, "_s", tuple(s))
        object.__setattr__(self, "_v", tuple(v))
        if len(self.tags) != len(self.segs):
            object.__setattr__(self, "tags", tuple(self._guess_tag(k) for k in range(len(self.segs))))

    def _guess_tag(self, k: int) -> ProfilePhase:
        """VM without acceleration, else ACC when velocity and acceleration agree mid-segment."""
        seg = self.segs[k]
        _, v, a = _advance(self._v[k], seg, seg[0] / 2)
        if a == 0:
            return ProfilePhase.VM
        return ProfilePhase.ACC if v * a > 0 else ProfilePhase.DEC

    def duration(self) -> float:
        """The time of the segments; inf for an endless plan."""
        return INF if self.endless else self._t[-1]

    def state(self, t: float) -> tuple[float, float, float]:
        """(s, v, a) at time t in closed form; at and after the end (distance, end velocity, 0), an
        endless plan running on at its end velocity."""
        t, end = max(t, 0.0), self._t[-1]
        if t >= end:
            if self.endless:
                return self.distance + self.end_velocity * (t - end), self.end_velocity, 0.0
            return self.distance, self.end_velocity, 0.0
        k = bisect.bisect_right(self._t, t) - 1
        ds, v, a = _advance(self._v[k], self.segs[k], t - self._t[k])
        return self._s[k] + ds, v, a

    def decel_start(self) -> float:
        """When the final deceleration begins (the DEC status bit; the blend method "deceleration
        event"): the start of the trailing run of decelerating segments, else the end of the
        segments (inf for an endless plan that does not end decelerating)."""
        k = len(self.segs)
        while k > 0 and self.tags[k - 1] == ProfilePhase.DEC:
            k -= 1
        if k == len(self.segs) and self.endless:
            return INF
        return self._t[k]

    def phase_at(self, t: float) -> ProfilePhase:
        """ACC, VM or DEC at time t; after the segments VM for an endless plan still moving, else
        IDLE."""
        if t >= self._t[-1]:
            moving = self.endless and self.end_velocity != 0
            return ProfilePhase.VM if moving else ProfilePhase.IDLE
        return self.tags[max(0, bisect.bisect_right(self._t, t) - 1)]

    def time_at(self, s: float) -> float:
        """The first time the travelled (signed) distance reaches s (pre-distance event; a blend at
        residual distance r is time_at(distance - r)). Not reached: 0 if s is behind the start
        (opposite the plan's direction: its end velocity for an endless plan), else the end of the
        segments (inf for an endless plan)."""
        if s == 0:
            return 0.0
        n = len(self.segs)
        ends = list(self._s)
        if not self.endless:
            ends[n] = self.distance  # so the last segment brackets the exact end
        for k in range(n):
            if min(ends[k], ends[k + 1]) <= s <= max(ends[k], ends[k + 1]):
                return self._t[k] + _solve(self._v[k], self.segs[k], s - self._s[k])
        if self.endless:
            beyond = (s - self.distance) / self.end_velocity if self.end_velocity else -1.0
            if beyond >= 0:
                return self._t[n] + beyond
        direction = self.end_velocity if self.endless else self.distance or self.v0
        if s * direction < 0:
            return 0.0
        return INF if self.endless else self._t[n]


def _mirror(segs: _Tagged, sign: float) -> _Tagged:
    """`segs` with jerk and acceleration times `sign` (-1: the other direction; + 0.0: no -0.0)."""
    return segs if sign == 1 else [((d, sign * j + 0.0, sign * a + 0.0), tag) for (d, j, a), tag in segs]


def _plan(segs: _Tagged, v0: float, distance: float, *, endless: bool = False,
          end_velocity: float = 0.0, ve_reached: bool = True, vm: float = 0.0) -> Plan:
    return Plan(tuple(seg for seg, _ in segs), v0, distance, endless, end_velocity, ve_reached, vm,
                tuple(tag for _, tag in segs))


def _clamp_sf(sf: float) -> float:
    return min(max(sf, 0.0), 1.0)


def plan_ptp(distance: float, vs: float, vm: float, ve: float, acc: float, dec: float,
             sf: float) -> Plan:
    """A point-to-point move from rest [M §4.6.1] with the T/S-curve of [M §4.2.3]: jump to Vs,
    accelerate with Acc to Vm (lowered for a short move), cruise, decelerate with Dec to Ve.

    distance >= 0 (0 or less: an empty plan). Vs and Ve above Vm are clamped to Vm (Ve then
    `ve_reached` False); Vm 0 moves nothing (`ve_reached` False).
    """
    sf = _clamp_sf(sf)
    vm = max(vm, 0.0)
    vs, ve = min(max(vs, 0.0), vm), max(ve, 0.0)
    if distance <= 0:
        return Plan((), 0.0, 0.0, ve_reached=ve == 0)
    leg = _leg(vs, distance, vm, ve, acc, dec, sf)
    v0 = vs if leg.travelled > 0 else 0.0
    return _plan(leg.segs, v0, leg.travelled, end_velocity=leg.end_velocity,
                 ve_reached=leg.ve_reached and leg.travelled > 0, vm=leg.peak)


def plan_from(v0: float, distance: float, vm: float, ve: float, acc: float, dec: float,
              sf: float) -> Plan:
    """On-the-fly change [M §4.6.3] (spec §2.9): a new profile from the current velocity v0 (signed,
    along +distance) to `distance` from here, with no stop when the target can be reached ahead.

    If the target is behind, or closer than the stop distance, the axis decelerates to zero with
    Dec, reverses and approaches (the plan's distance may then be negative). The acceleration starts
    at the new plan's (the card re-plans from position and velocity); Ve applies along the final
    approach; from rest there is no Vs jump (use plan_ptp).
    """
    sf = _clamp_sf(sf)
    vm, ve = max(vm, 0.0), max(ve, 0.0)
    sign = 1.0 if distance > 0 else -1.0 if distance < 0 else (-1.0 if v0 < 0 else 1.0)
    u, dist = sign * v0, sign * distance
    stop = _ramp_distance(u, 0.0, dec, sf)
    if u >= 0 and dist >= stop:
        leg = _leg(u, dist, vm, ve, acc, dec, sf)
        segs, travelled, v_end = leg.segs, leg.travelled, leg.end_velocity
    else:
        rest = dist - stop
        turn = 1.0 if rest >= 0 else -1.0
        leg = _leg(0.0, abs(rest), vm, ve, acc, dec, sf)
        segs = _ramp(u, 0.0, dec, sf) + _mirror(leg.segs, turn)
        complete = leg.travelled == abs(rest)  # then exactly `distance`, not stop + rest rounded
        travelled = dist if complete else stop + turn * leg.travelled
        v_end = turn * leg.end_velocity
    return _plan(_mirror(segs, sign), v0, sign * travelled + 0.0, end_velocity=sign * v_end + 0.0,
                 ve_reached=leg.ve_reached, vm=max(abs(v0), leg.peak))


def plan_velocity(v0: float, v1: float, acc: float, dec: float, sf: float, vs: float = 0.0) -> Plan:
    """A velocity move [M §4.4]: from v0 to v1 (signed: direction = sign, spec §2.7) and on at v1;
    through zero with Dec then Acc when the sign changes. From rest the pulse card jumps to `vs`
    (at most |v1|) first."""
    sf = _clamp_sf(sf)
    if v0 == 0 and v1 != 0 and vs > 0:
        v0 = math.copysign(min(vs, abs(v1)), v1)
    if v0 != 0 and v1 != 0 and (v0 > 0) != (v1 > 0):
        segs = _ramp(v0, 0.0, dec, sf) + _ramp(0.0, v1, acc, sf)
        travel = _ramp_distance(v0, 0.0, dec, sf) + _ramp_distance(0.0, v1, acc, sf)
    else:
        peak = acc if abs(v1) > abs(v0) else dec
        segs, travel = _ramp(v0, v1, peak, sf), _ramp_distance(v0, v1, peak, sf)
    return _plan(segs, v0, travel, endless=v1 != 0, end_velocity=v1, vm=max(abs(v0), abs(v1)))


def plan_stop(v0: float, dec: float, sf: float) -> Plan:
    """A deceleration stop from v0 (signed) with Dec and the S-factor (`APS_stop_move`, spec §2.7)."""
    sf = _clamp_sf(sf)
    return _plan(_ramp(v0, 0.0, dec, sf), v0, _ramp_distance(v0, 0.0, dec, sf), vm=abs(v0))


def to_core_phases(plan: Plan, t0: float, p0: float, sign: float, hold: float | None) -> list[Phase]:
    """The plan as `vdevd.rt.profiles` phases for `ProfileGenerator.load`: positions p0 + sign*s,
    absolute times from t0. The last phase holds `hold` if given (a plan ending at Ve > 0 then stops
    with a velocity step, as a pulse card does), else runs on at the end velocity from the exact end
    position (a velocity move, or a buffered segment until the next plan is loaded)."""
    segs = [(d, sign * j, sign * a) for d, j, a in plan.segs]
    phases = to_phases(t0, p0, sign * plan.v0, segs[0][2] if segs else 0.0, segs, hold)
    if hold is None:
        end = phases[-1]
        phases[-1] = Phase(end.t0, INF, p0 + sign * plan.distance, sign * plan.end_velocity, 0.0, 0.0)
    return phases
