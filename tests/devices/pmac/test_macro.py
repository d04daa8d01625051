"""Virtual MACRO stations (vdevd/devices/pmac/macro.py): MS{node},MI{n}[={v}], MSR, MSW, I20-I23 and
the ring status bits [Turbo SRM MS/MSR/MSW; A L3225-3229; spec §2.1, §3.3 item 5]."""

from __future__ import annotations

from collections.abc import Iterator

import pytest

from tests.devices.pmac.conftest import Pmac, pmac_card
from tests.devices.pmac.test_online import Card

NODES = [0, 1, 4, 5]


def card(nodes: list[int] = NODES) -> Card:
    c = Card()
    c.fw.macro.configure(nodes)
    c.fw.ivars.defaults[20:24] = c.fw.macro.ic_bases()   # what the card does with its config
    c.fw.restore({})
    c.raw("I3=2")
    return c


def test_mi_variables_read_zero_then_what_was_written_per_node() -> None:
    c = card()
    assert c.ask("MS0,MI910 MS1,MI910") == "0\r0"
    c.raw("MS1,MI910=7 MS4,MI926=2982")
    assert c.ask("MS0,MI910 MS1,MI910 MS4,MI926") == "0\r7\r2982"
    c.raw("P1=3")
    assert c.raw("MS5,MI912=P1+1 MS5,MI913=2") == b"\x06"   # an expression ends at the next command
    assert c.ask("MS5,MI912 MS5,MI913") == "4\r2"


def test_dls_pmaclib_spelling_ms_node_comma_i() -> None:
    """dls-pmaclib reads `ms{node},i{var}` and writes `ms{node},i{var}={value}` [spec §3.3 item 5]."""
    c = card()
    c.raw("ms4,i911=3")
    assert c.ask("ms4,i911 ms4,mi911") == "3\r3"


def test_unconfigured_node_answers_err008_and_nothing_changes() -> None:
    """No station at the node: the MACRO auxiliary communication error [spec §2.4 ERR008]."""
    c = card()
    assert c.raw("MS2,MI910") == b"\x07ERR008\r"
    assert c.raw("MS8,MI910=1") == b"\x07ERR008\r"
    assert c.raw("MSR9,$C000,P1") == b"\x07ERR008\r"
    assert c.ask("MS0,MI910") == "0"


def test_card_without_stations_answers_err008() -> None:
    c = Card()
    c.raw("I3=2")
    assert c.raw("MS0,MI910") == b"\x07ERR008\r"
    assert c.ask("I20 I21 I22 I23") == "$0\r$0\r$0\r$0"


@pytest.mark.parametrize("bad", ["MS0,MI1024", "MS0,MI910=16777216", "MS0,MI910=-8388609",
                                 "MS0", "MS,MI910", "MS0,P1", "MSR0,$10000,P1", "MSR0,$C000",
                                 "MSW0,$C000,Z1", "MS64,MI0"])
def test_out_of_range_or_malformed_is_err003(bad: str) -> None:
    c = card([0, 63])
    assert c.raw(bad) == b"\x07ERR003\r"
    assert c.ask("MS0,MI910") == "0"


def test_msw_writes_a_variable_to_a_node_register_and_msr_reads_it_back() -> None:
    c = card()
    c.raw("P10=$123456 MSW1,$C080,P10")
    c.raw("MSR1,$C080,P11 MSR0,Y:$C080,P12 MSR1,X:$C081,M0")
    assert c.ask("P11 P12") == f"{0x123456}\r0"
    c.raw("P10=-1 MSW1,$C080,P10 MSR1,$C080,Q5")
    assert c.ask("Q5") == str(0xFFFFFF)       # a 24-bit register


def test_i20_to_i23_hold_the_macro_ic_bases_of_the_configured_nodes() -> None:
    """I20-I23 = base addresses of MACRO ICs 0-3 [A L3228]; node n is on IC n // 16."""
    c = card([0, 1, 17, 52])
    assert c.ask("I20 I21 I22 I23") == "$78400\r$79400\r$0\r$7B400"
    c.raw("I20=$0 $$$***")
    c.raw("I3=2")
    assert c.ask("I20") == "$78400"             # the factory value of this card


def test_ring_error_bits_stay_clear_and_stations_survive_a_card_reset() -> None:
    c = card()
    c.raw("MS0,MI910=5")
    assert not int(c.ask("???")[:6], 16) & 0x30   # global status bits 4, 5 [spec §2.1]
    c.raw("$$$***")
    c.raw("I3=2")
    assert c.ask("MS0,MI910") == "5"              # the station is hardware of its own


# -- through the daemon and dls-pmaclib ------------------------------------------------------------------
@pytest.fixture
def macro() -> Iterator[Pmac]:
    with pmac_card(plant="ideal", macro_stations=NODES) as host:
        yield host


def test_config_stations_seen_by_dls_pmaclib(macro: Pmac) -> None:
    """A Geo Brick with MACRO IC 0 present: dls-pmaclib counts 8 on-board + 8 MACRO axes and reads
    and writes the station variables of MACRO axes [spec §3.3 items 4, 5]."""
    dls = macro.dls()
    assert dls.getNumberOfAxes() == 16
    assert dls.getAxisMacroStationNumber(10) == 1
    dls.setAxisMsIVar(10, 910, 7)
    assert dls.getAxisMsIVars(10, [910, 911]) == ["7", "0"]
    assert dls.sendCommand("ms2,i910") == ("\x07ERR008\r", True)


def test_bad_macro_stations_config_is_refused() -> None:
    with pytest.raises(Exception, match="macro_stations"), pmac_card(macro_stations=[64]):
        pass
