"""`#UR` sets the update rate the card runs at [S §2.13]: the cycle count per second follows it
from the next cycle, speeds stay in counts per second, a restart without APP returns to the
configured rate. Periods are exact (1024 Hz: 976562.5 ns, DESIGN.md "Second step")."""

from __future__ import annotations

import pytest
import vdevclient
from vdevmaps.oms import Shm

from tests.devices.oms.conftest import Maxk, maxk_card
from vdevd import config as configmod
from vdevd.config import ConfigError

S = 1_000_000_000


def cycles(maxk: Maxk) -> int:
    return int(maxk.rack.stats()["cards"]["maxk0"]["ticks"])


def period_ns(maxk: Maxk) -> int:
    (card,) = [c for c in maxk.rack.request("hello")["cards"] if c["name"] == "maxk0"]
    return int(card["period_ns"])


def test_ur2048_doubles_the_cycle_rate(maxk: Maxk) -> None:
    maxk.rack.sim.step(seconds=1.0)
    assert cycles(maxk) == 1024  # exactly: the 1024th cycle falls at 1 s, not 0.9999995 s
    maxk.send("#UR2048;")
    assert maxk.query("#UR?;") == "2048"
    before = cycles(maxk)
    maxk.rack.sim.step(seconds=1.0)
    assert cycles(maxk) - before == 2048
    assert period_ns(maxk) == 488281  # hello's rounded figure of 488281.25 ns
    assert maxk.rack.stats()["cards"]["maxk0"]["lost_ticks"] == 0


def test_a_jog_keeps_its_speed_in_counts_per_second_across_the_change(maxk: Maxk) -> None:
    maxk.send("AX JG4000;")
    maxk.rack.sim.step(seconds=1.0)
    first = int(maxk.query("AX RP;"))
    maxk.send("#UR8192;")
    maxk.rack.sim.step(seconds=1.0)
    second = int(maxk.query("AX RP;"))
    assert abs((second - first) - 4000) <= 8  # a second at 4000 counts/s, to a few cycles


def test_a_restart_without_app_returns_to_the_configured_rate() -> None:
    with maxk_card(update_hz=2048) as maxk:
        maxk.send("#UR4096;")
        maxk.send("RS;")
        maxk.rack.sim.step(seconds=0.5)
        assert maxk.query("#UR?;") == "2048"
        before = cycles(maxk)
        maxk.rack.sim.step(seconds=1.0)
        assert cycles(maxk) - before == 2048


def test_a_rate_the_card_does_not_have_is_a_command_error(maxk: Maxk) -> None:
    maxk.send("#UR3000;")
    assert maxk.query("#UR?;") == "1024"
    before = cycles(maxk)
    maxk.rack.sim.step(seconds=1.0)
    assert cycles(maxk) - before == 1024


def test_rdf_restores_the_factory_rate_with_the_io_configuration(maxk: Maxk) -> None:
    maxk.send("#UR4096;")
    maxk.send("RDF;")
    assert maxk.query("#UR?;") == "1024"
    before = cycles(maxk)
    maxk.rack.sim.step(seconds=1.0)
    assert cycles(maxk) - before == 1024


def feed_forward_dac(*commands: str) -> int:
    """X's DAC word after the commands and a jog at 1000 counts/s with only KV acting."""
    with maxk_card(axis_types=["servo"] * 4, axes=4) as maxk:
        for text in commands:
            maxk.send(text)
        maxk.send("AX JG1000;")
        maxk.rack.sim.step(seconds=1.0)
        return maxk.word(Shm.DAC)


def test_kv_acts_per_cycle_of_the_rate_running_whatever_the_order_of_kv_and_ur() -> None:
    """KV's feed-forward is per update cycle [S §2.9]: at 2048 Hz it gives half the 1024 Hz DAC
    output, set before or after #UR."""
    gains = "AX KP0 KI0 KD0 KV100;"
    at_1024 = feed_forward_dac(gains)
    assert at_1024 > 0
    assert feed_forward_dac(gains, "#UR2048;") == feed_forward_dac("#UR2048;", gains)
    assert abs(feed_forward_dac(gains, "#UR2048;") - at_1024 / 2) <= 1


def test_a_jog_across_ur_sent_mid_cycle_keeps_its_speed_to_the_count(maxk: Maxk) -> None:
    """The cycle under way when #UR arrives ends on the old schedule, and motion integrates
    each cycle's own length: no counts are lost or gained at the change."""
    maxk.send("AX VL4000 AC1000000 JG4000;")
    maxk.rack.sim.step(seconds=1.0)
    start_ns, start = maxk.rack.sim.now_ns(), int(maxk.query("AX RP;"))
    maxk.rack.sim.step(ns=900_000)  # 0.9 ms into a 976.5625 us cycle
    maxk.send("#UR8192;")
    end_ns = 2_000_976_562  # the cycle under way ends at 1000976562 ns, then 8192 cycles
    maxk.rack.sim.step(ns=end_ns - maxk.rack.sim.now_ns())
    travel = int(maxk.query("AX RP;")) - start
    elapsed = end_ns - start_ns
    assert abs(travel - 4000 * elapsed / 1e9) <= 1


def test_sim_step_counts_base_ticks_of_the_exact_period(maxk: Maxk) -> None:
    """`sim step ticks=N` on a rack of one MAXk runs N update cycles (976562.5 ns each)."""
    assert maxk.rack.sim.step(ticks=1024) == 1_000_000_000
    assert cycles(maxk) == 1024


def test_sim_step_ticks_of_a_card_from_between_its_ticks_runs_that_many(maxk: Maxk) -> None:
    maxk.rack.sim.step(ns=500_000)  # half-way through the first cycle
    assert maxk.rack.sim.step(ticks=1, card="maxk0") == 976_562
    assert cycles(maxk) == 1


def test_sim_step_with_a_card_takes_ticks_only(maxk: Maxk) -> None:
    with pytest.raises(vdevclient.VdevClientError, match="card goes with ticks"):
        maxk.rack.request("sim", action="step", seconds=1.0, card="maxk0")
    assert maxk.rack.sim.now_ns() == 0  # still serving, nothing stepped


def test_a_period_of_its_own_is_a_configuration_error_naming_update_hz() -> None:
    """The MAXk's period is 1/update_hz, the rate #UR? reports: a `period_ns` would run it at a
    rate it does not report."""
    with pytest.raises(ConfigError, match=r"card\[0\].period_ns: an oms-maxk runs at "
                                          r"1/update_hz; set update_hz"):
        configmod.parse({"card": [{"type": "oms-maxk", "name": "m", "period_ns": 500_000}]})
