"""The sample's quick paths (motion.py `GalilMotion.tick`, `check_error`) give what the general
computations give: TV as keep x TV + gain x (encoder - previous encoder) in four steps, the axes
that completed as previous moving > moving, and the ER crossings as |TE| > ER against the last
sample's, compared at every sample of random command sequences on a firmware with no card."""

from __future__ import annotations

import numpy as np
from hypothesis import given, settings
from hypothesis import strategies as st

from tests.devices.galil.test_firmware import PERIOD_NS
from vdevd.devices.galil.bus import A16Window
from vdevd.devices.galil.firmware import Firmware
from vdevd.devices.galil.motion import TV_FLUSH, GalilMotion

#: lines that start, change, stop and trip motion: jogs, moves, ST, AB, MO/SH, ER with OE
LINES = ["JG 20000,-25000,30000,-35000;BG ABCD", "JG -3000,4000,,;BG AB", "ST ABCD", "AB",
         "PR 1000,-2000,300,40;BG ABCD", "PA 0,0,0,0;BG ABCD", "ER 20,30,40,50", "ER -1,-1,5,5",
         "OE 1,0,1,0", "MO C", "SH ABCD", "AC 1000000;DC 1000000", "JG 500;BG A", "IP 100,,,",
         "KP 1;ER 1,2,3,4", "KP 1;ER 8,1,1,2", "KP 6"]


class Checked:
    """A firmware whose motion checks each sample's tick and error check against the general
    computations."""

    def __init__(self, plant: str) -> None:
        self.fw = Firmware(4, PERIOD_NS, plant, 1000, A16Window(), raise_irq=lambda s: None,
                           clear_irq=lambda: None, clock=lambda: self.fw.ticks * PERIOD_NS)
        self.samples = 0

    def send(self, line: str) -> None:
        for b in (line + "\r").encode():
            self.fw.bus.write(1, b)
        self.fw.serve()
        self.fw.bus.read_data(256)

    def sample(self) -> None:
        m = self.fw.motion
        tick, check = m.tick, m.check_error
        m.tick = lambda: self._tick(m, tick)  # type: ignore[method-assign]
        m.check_error = lambda: self._check(m, check)  # type: ignore[method-assign]
        try:
            self.fw.step()
        finally:
            del m.tick, m.check_error
        self.samples += 1

    @staticmethod
    def _tick(m: GalilMotion, tick: object) -> np.ndarray | None:
        tv, enc_prev, prev = m.tv.copy(), m._enc_prev.copy(), m._moving_prev.copy()
        done = tick()  # type: ignore[operator]
        core = m.core
        step = core.axes.fb - enc_prev
        np.multiply(step, m._tv_gain, step)
        np.multiply(tv, m._tv_keep, tv)
        np.add(tv, step, tv)
        if not core.profile.ticks & 63:
            np.copyto(tv, 0.0, where=np.abs(tv) < TV_FLUSH)
        assert m.tv.tobytes() == tv.tobytes()
        expected = prev > core.profile.moving
        if expected.any():
            assert done is not None and done.tolist() == expected.tolist()
        else:
            assert done is None
        return done

    @staticmethod
    def _check(m: GalilMotion, check: object) -> np.ndarray | None:
        before = m.error_over.copy()
        over = np.abs(m.core.axes.ferr) > m._er
        new = check()  # type: ignore[operator]
        expected = over > before
        if expected.any():
            assert new is not None and new.tolist() == expected.tolist()
        else:
            assert new is None
        assert m.error_over.tolist() == over.tolist()
        return new


@settings(max_examples=25, deadline=None)
@given(plant=st.sampled_from(["servo", "stepper", "ideal"]),
       script=st.lists(st.tuples(st.sampled_from(LINES), st.integers(1, 300)), max_size=8))
def test_a_sample_gives_what_the_general_computations_give(
        plant: str, script: list[tuple[str, int]]) -> None:
    rig = Checked(plant)
    for line, samples in script:
        rig.send(line)
        for _ in range(samples):
            rig.sample()
    assert rig.samples == sum(k for _, k in script)


def test_the_checks_see_completions_and_error_crossings() -> None:
    """The scenario the random one may miss: a move completes and an axis crosses ER both ways."""
    rig = Checked("servo")
    completed, crossed = [], []
    m = rig.fw.motion
    rig.send("KP 1;ER 1,1,2,2;PR 2000,-2000,0,0;BG AB")
    for _ in range(1500):
        moving, over = m.core.profile.moving.copy(), m.error_over.copy()
        rig.sample()
        completed.append(bool((moving > m.core.profile.moving).any()))
        crossed.append(bool((over != m.error_over).any()))
    assert any(completed) and sum(crossed) >= 2
