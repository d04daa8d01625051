"""The PID family: parallel PID with integrator limit, velocity and acceleration feed-forward,
offset and output limit, vectorised over axes. Cards map their vendor gains onto it."""

from __future__ import annotations

from typing import Any

import numpy as np

Index = slice | np.ndarray | int | list[int]


def _readonly(arr: np.ndarray) -> np.ndarray:
    view = arr.view()
    view.flags.writeable = False
    return view


class Pid:
    """out = clamp(offset + kp*e + ki*I + kd*(e - e_prev) + vff*cmd_vel + aff*cmd_acc, +-out_limit)
    with I += e each tick on axes with ki != 0, clamped to +-il (anti-windup). Gains are per
    sample, as on the cards: kd multiplies the difference of two successive errors, ki the
    running sum of errors.

    Integrator hold (`set_hold`, PMAC's [spec pmac.md §2.7, PMAC1-UM p.108]): the error is not
    integrated on axes that hold it while their commanded velocity is not zero (`hold_moving`),
    nor on any axis while its previous output is saturated at out_limit (`hold_saturated`).

    The terms are the rows of `terms` (cmd_vel, cmd_acc, ones, I, e_prev, e; `Axes.pid_terms` in a
    motion core) and the gains are compiled into one matching block, so the output is a single
    per-axis dot product. Parameter arrays are read-only views: change them with `set`. Axes that
    are not `enabled` (servo off, not a servo axis) output exactly 0.
    """

    PARAMS = ("kp", "ki", "kd", "il", "vff", "aff", "offset", "out_limit")

    def __init__(self, n: int, terms: np.ndarray | None = None,
                 rows: np.ndarray | None = None) -> None:
        """`terms`: the (6, n) rows the output is the dot product of (its own if None);
        `rows`: where the compiled gains, the integrating switch, the two limits and the two
        hold switches live, (11, n) (a motion core's coefficient block; its own otherwise)."""
        rows = np.zeros((11, n)) if rows is None else rows
        if terms is None:
            terms = np.zeros((6, n))
            terms[2] = 1.0
        self.terms = terms
        self.cmd_vel: np.ndarray = terms[0]
        self.cmd_acc: np.ndarray = terms[1]
        self.integ: np.ndarray = terms[3]
        self.e_prev: np.ndarray = terms[4]
        self.e: np.ndarray = terms[5]
        self._params = {key: np.zeros(n) for key in self.PARAMS}
        self._params["il"], self._params["out_limit"] = rows[7], rows[8]
        self._params["il"][:] = np.inf
        self._params["out_limit"][:] = np.inf
        for key, arr in self._params.items():
            view = arr.view()
            view.flags.writeable = False
            setattr(self, key, view)
        self.enabled = np.ones(n, dtype=bool)
        self._gains = rows[:6]  # rows match `terms`
        self._integrating = rows[6]
        self._hold_moving, self._hold_sat = rows[9], rows[10]  # 1.0 where the hold applies
        self.hold_moving = _readonly(self._hold_moving != 0)
        self.hold_saturated = False
        self._hold = np.zeros(n, dtype=bool)
        self._sat = np.zeros(n, dtype=bool)
        self._abs = np.zeros(n)
        self._il, self._out_lim = self._params["il"], self._params["out_limit"]
        self._il_neg = np.zeros(n)
        self._out_neg = np.zeros(n)
        self._ie = np.zeros(n)
        self._configure()

    # the parameter views, for type checkers (set in __init__)
    kp: np.ndarray
    ki: np.ndarray
    kd: np.ndarray
    il: np.ndarray
    vff: np.ndarray
    aff: np.ndarray
    offset: np.ndarray
    out_limit: np.ndarray

    def set(self, axes: Index, **params: Any) -> None:
        """Set parameters of some axes (scalars or one value per selected axis)."""
        for key, value in params.items():
            if key not in self._params:
                raise ValueError(f"no PID parameter {key!r} (parameters: {', '.join(self.PARAMS)})")
            arr = np.asarray(value, dtype=float)
            if key in ("il", "out_limit") and not (arr >= 0).all():
                raise ValueError(f"{key} must be >= 0")
            if key not in ("il", "out_limit") and not np.isfinite(arr).all():
                raise ValueError(f"{key} must be finite")
            self._params[key][axes] = arr
        self._configure()

    def set_hold(self, moving: Any = None, saturated: bool | None = None) -> None:
        """Integrator hold: `moving`, one bool per axis (or one for all), holds while the
        commanded velocity is not zero; `saturated` holds every axis while its output is at
        out_limit. None leaves a setting as it is."""
        if moving is not None:
            self._hold_moving[...] = np.asarray(moving, dtype=bool)
            self.hold_moving = _readonly(self._hold_moving != 0)
        if saturated is not None:
            self.hold_saturated = bool(saturated)
            self._hold_sat[...] = self.hold_saturated
        self._configure()

    def enable(self, mask: np.ndarray) -> None:
        """Which axes drive their output (the others output 0 and are not integrated into out)."""
        self.enabled[:] = mask
        self._configure()

    def _configure(self) -> None:
        """Compile the gains into the dot-product block; note which limits are in use."""
        p, on = self._params, self.enabled
        rows = (p["vff"], p["aff"], p["offset"], p["ki"], -p["kd"], p["kp"] + p["kd"])
        for row, value in zip(self._gains, rows, strict=True):
            np.multiply(value, on, out=row)
        #: the axes that integrate (ki != 0 and enabled: an axis that is off is reset when it
        #: comes on), as bools and as 0/1 factors
        self.ki_on = (p["ki"] != 0) & on
        self._integrating[...] = self.ki_on
        self._integrate_all = bool(self._integrating.all())
        self._integrate_some = bool(self._integrating.any())
        self._holding = self._integrate_some and (self.hold_saturated or bool(self.hold_moving.any()))
        self._limit_integ = bool(np.isfinite(p["il"]).any())
        self._limit_out = bool(np.isfinite(p["out_limit"]).any())
        np.negative(p["il"], out=self._il_neg)
        np.negative(p["out_limit"], out=self._out_neg)

    def reset(self, axes: Index) -> None:
        """Clear the integrator and derivative memory (servo on, define position)."""
        self.integ[axes] = 0.0
        self.e_prev[axes] = 0.0

    def _dot(self, out: np.ndarray) -> None:
        """out = sum of gains x terms, row by row left to right as the compiled kernel adds
        them (not np.vecdot: BLAS orders and fuses its sums by CPU), so both agree to the bit."""
        g, t, tmp = self._gains, self.terms, self._ie
        np.multiply(g[0], t[0], out)
        for k in range(1, 6):
            np.multiply(g[k], t[k], tmp)
            out += tmp

    def update(self, out: np.ndarray) -> None:
        """One sample from the error in `e` (and the feed-forward rows): write the controller
        output into `out`, then remember `e` as the previous error. Only enabled axes with an
        integral gain integrate (the cards sum ki x error: without ki the sum stays where it
        is)."""
        e, integ = self.e, self.integ
        if self._holding:  # `out` still holds the previous output here
            hold, sat = self._hold, self._sat
            np.not_equal(self.cmd_vel, 0.0, out=hold)
            hold &= self.hold_moving
            if self.hold_saturated:
                np.abs(out, out=self._abs)
                np.greater_equal(self._abs, self.out_limit, out=sat)
                hold |= sat
            hold &= self.ki_on  # the others do not integrate at all
            integ -= e * hold  # added back below: no net integration
        if self._integrate_all:
            np.add(integ, e, integ)
        elif self._integrate_some:
            np.multiply(e, self._integrating, self._ie)
            np.add(integ, self._ie, integ)
        if self._limit_integ:
            np.minimum(integ, self._il, out=integ)
            np.maximum(integ, self._il_neg, out=integ)
        self._dot(out)
        if self._limit_out:
            np.minimum(out, self._out_lim, out=out)
            np.maximum(out, self._out_neg, out=out)
        self.e_prev[...] = e  # (an Ellipsis copy: a third of np.copyto's cost here)
