"""`#UR` sets the update rate the card runs at [S §2.13]: the cycle count per second follows it
from the next cycle, speeds stay in counts per second, a restart without APP returns to the
configured rate. Periods are exact (1024 Hz: 976562.5 ns, DESIGN.md "Second step")."""

from __future__ import annotations

from tests.devices.oms.conftest import Maxk, maxk_card

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
