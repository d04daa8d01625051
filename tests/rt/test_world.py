"""The axis world (vdevd/rt/world.py): `[[card.axis]]` tables checked, switch levels sensed from
physical positions, index and probe crossings, backdoor forces."""

from __future__ import annotations

import numpy as np
import pytest

from vdevd.rt.world import AxisMechanics, AxisWorld


def test_a_full_axis_table_parses_into_counts() -> None:
    m = AxisMechanics.parse({"limits": [-5000, 5000], "home": [1000, 1200],
                             "index": {"period": 4000, "phase": 250}, "probe": [300, -20],
                             "amp_fault": True, "encoder_loss": False}, "card[0].axis[0]")
    assert m == AxisMechanics((-5000.0, 5000.0), (1000.0, 1200.0), (4000.0, 250.0),
                              (300.0, -20.0), True, False)


@pytest.mark.parametrize(("table", "named"), [
    ({"limit": [0, 1]}, "card.axis[1].limit: unknown key"),
    ({"limits": [5, -5]}, "card.axis[1].limits: 5 must be below -5"),
    ({"limits": [5]}, "card.axis[1].limits: expected [low, high]"),
    ({"home": ["a", 3]}, "card.axis[1].home: expected a finite number"),
    ({"index": {"period": 0}}, "card.axis[1].index.period: 0.0 is not a positive count"),
    ({"index": {"phase": 3}}, "card.axis[1].index: expected {period"),
    ({"probe": 7}, "card.axis[1].probe: expected a list"),
    ({"amp_fault": 1}, "card.axis[1].amp_fault: expected true or false"),
    ([1, 2], "card.axis[1]: must be a table"),
])
def test_a_bad_axis_table_is_refused_naming_the_key(table: object, named: str) -> None:
    with pytest.raises(ValueError, match=named.replace("[", r"\[").replace("]", r"\]")
                       .replace("{", r"\{")):
        AxisMechanics.parse(table, "card.axis[1]")


def test_more_tables_than_axes_is_refused() -> None:
    with pytest.raises(ValueError, match="3 \\[\\[card.axis\\]\\] tables for 2 axes"):
        AxisWorld(2, [AxisMechanics()] * 3)


def test_limits_are_active_at_and_beyond_their_positions_home_inside_its_window() -> None:
    w = AxisWorld(3, [AxisMechanics(limits=(-100, 100), home=(10, 20))])
    assert w.mechanical
    assert w.sense(np.array([100.0, 0.0, 1e9]))
    assert w.limit_pos.tolist() == [True, False, False]  # axis 2 has no mechanics
    assert w.sense(np.array([-100.0, 0.0, 0.0]))
    assert (w.limit_pos.tolist(), w.limit_neg.tolist()) == ([False] * 3, [True, False, False])
    assert w.sense(np.array([10.0, 0.0, 0.0]))
    assert w.home.tolist() == [True, False, False]
    assert not w.sense(np.array([20.0, 0.0, 0.0]))  # still inside: nothing changed
    assert w.sense(np.array([20.5, 0.0, 0.0]))
    assert not w.home.any()


def test_a_forced_input_is_active_wherever_the_stage_is_and_released_to_the_mechanics() -> None:
    w = AxisWorld(1, [AxisMechanics(limits=(-100, 100))])
    w.force_limit(0, positive=True, active=True)
    w.sense(np.array([0.0]))
    assert w.limit_pos[0]
    w.force_limit(0, positive=True, active=False)
    w.sense(np.array([0.0]))
    assert not w.limit_pos[0]
    w.sense(np.array([150.0]))
    assert w.limit_pos[0]


def test_a_world_without_mechanics_takes_its_levels_from_the_forces() -> None:
    w = AxisWorld(2)
    assert not w.mechanical
    w.force_home_switch(1, True)
    w.forced()
    assert w.home.tolist() == [False, True]


def test_the_probe_fires_at_the_first_target_crossed_in_the_direction_of_travel() -> None:
    w = AxisWorld(1, [AxisMechanics(probe=(300, -20, 900))])
    assert w.probe_between(0, 0, 1000) == 300
    assert w.probe_between(0, 300, 1000) == 900  # the start itself is not a crossing
    assert w.probe_between(0, 1000, -100) == 900
    assert w.probe_between(0, 100, -100) == -20
    assert w.probe_between(0, 400, 800) is None


def test_a_home_window_moved_by_the_backdoor_is_sensed() -> None:
    w = AxisWorld(1)
    w.set_home_window(0, 50, 60)
    assert w.mechanical
    w.sense(np.array([55.0]))
    assert w.home[0]
    with pytest.raises(ValueError, match="low <= high"):
        w.set_home_window(0, 60, 50)
