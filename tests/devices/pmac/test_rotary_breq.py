"""BREQ, the rotary buffer request, without sockets: low for each line sent, high again while
fewer than I17 lines wait, held low once I17 lines wait until fewer than I16 do; each rising
edge is one `on_request` (the card's IR1) [Turbo SRM I16, I17; SRM `??` word 2 bit 16]."""

from __future__ import annotations

import pytest

from tests.devices.pmac.test_online import Card


@pytest.fixture
def card() -> tuple[Card, list[int]]:
    c = Card()
    c.raw("I3=2")
    edges: list[int] = []
    c.fw.rotary.on_request = lambda: edges.append(c.fw.rotary.remaining(c.fw.rotary.request_cs))
    return c, edges


def test_each_line_below_i17_raises_breq_and_a_full_buffer_holds_it_low(
        card: tuple[Card, list[int]]) -> None:
    """SRM I17: a line sent takes BREQ low; "fewer than I17 ... lines": high again (an edge);
    "greater than or equal to I17 lines": left low."""
    c, edges = card
    c.ask("I16=2 I17=4")
    c.ask("&1 DEFINE ROT 100 OPEN ROT")
    for k in range(6):
        c.ask(f"X{k}")
    assert edges == [1, 2, 3]          # the 4th, 5th and 6th lines leave BREQ low
    assert c.fw.rotary.full(1)


def test_breq_rises_when_fewer_than_i16_lines_wait(card: tuple[Card, list[int]]) -> None:
    """SRM `??` bit 16: not cleared "until there are less than I16 program lines ahead"; BREQ
    goes high again then [SRM I17]."""
    c, edges = card
    c.ask("I16=2 I17=4")
    c.ask("&1 DEFINE ROT 100 OPEN ROT")
    for k in range(5):
        c.ask(f"X{k}")
    edges.clear()
    for expected in (4, 3, 2):
        c.fw.rotary.take(1)
        assert c.fw.rotary.remaining(1) == expected and edges == []
    c.fw.rotary.take(1)
    assert edges == [1]
    c.fw.rotary.take(1)
    assert edges == [1]                # no new edge: BREQ is already high


def test_breq_follows_the_coordinate_system_the_host_sends_to(card: tuple[Card, list[int]]) -> None:
    """Turbo PMAC2: "the BREQ line always reflects the status of the software-host-addressed
    coordinate system" [SRM I17 note]: C.S. 2 emptying while the host sends to C.S. 1 is no
    edge."""
    c, edges = card
    c.ask("I16=1 I17=2")
    c.ask("&2 DEFINE ROT 100 &1 DEFINE ROT 100 OPEN ROT")
    c.ask("&2 X1")
    c.ask("&2 X2")
    c.ask("&1 X1")
    edges.clear()
    c.fw.rotary.take(2)
    c.fw.rotary.take(2)
    assert edges == [] and not c.fw.rotary.full(2)


def test_breq_rises_as_a_running_program_takes_its_lines(card: tuple[Card, list[int]]) -> None:
    """The runner takes the lines while the program runs: the request comes once the C.S. has
    fewer than I16 lines ahead, and the moves end where the lines put them."""
    c, edges = card
    c.ask("I16=2 I17=4")
    c.ask("&1#1->1000X #1J/ &1 DEFINE ROT 200 &1 B0 OPEN ROT")
    for line in ("INC LINEAR TA20 TS0 F10", "X0.1", "X0.1", "X0.1", "X0.1"):
        c.ask(line)
    assert c.fw.rotary.full(1)
    edges.clear()
    c.ask("&1R")
    for _ in range(2000):
        c.tick()
        if edges:
            break
    assert edges == [1]
    c.tick(4000)                       # 0.4 units at 10 units/s: well done by now
    assert c.ask("#1P") == "400" and c.ask("&1PR") == "0"
