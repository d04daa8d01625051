"""The interpreter's compiled report lines (`#1P`, `#2?PVF`, `I130`) against its general parse: two
firmwares fed the same commands and servo cycles, one through `execute` (compiled lines when it
can), the other through `execute_general` only, answer alike and end in the same port state
[spec pmac.md §2.5]. Also the I3 = 2 framing shortcut against the I3 table."""

from __future__ import annotations

import random

from vdevd.devices.pmac.firmware import Firmware
from vdevd.devices.pmac.online import PLAN_CACHE, PortState, compile_reports
from vdevd.devices.pmac.reply import Reply, frame

PERIOD_NS = 442_710
SETUP = ["I130=1500", "P5=1.25", "Q7=-2.5", "&2Q7=3&1", "M1->X:$0,0,24", "I8191=7",
         "#1J=1000", "#2J^-333.3", "#3J+"]
#: report tokens, their neighbours that must leave the compiled path, and plain errors
TOKENS = ["#1", "#2", "#3", "#8", "#9", "#0", "#33", "#", "##2", "#1->", "#2 ->",
          "P", "V", "F", "p", "v", "f", "?", "??", "???", "PV", "PVF", "FVP",
          "I130", "i9", "I8191", "I8192", "I0130", "I130 ", "P5", "Q7", "q7", "M1", "m1", "M1->",
          "P(5)", "I(130)", "I130..131", "I130,2", "I130.", "I130=1500", "I130 = 1500", "I130==1",
          "PASSWORD", "J/", "K", "H", "&2", "&1", "%", "1", "-", ";c", "\xe9", "\x01", ",",
          "LIST COMP", "MOVETIME", "CID", "VER"]


class Twin:
    """Two firmwares and ports kept in step: `fast` runs `execute`, `general` `execute_general`."""

    def __init__(self) -> None:
        self.fast, self.general = Firmware(8, PERIOD_NS, "servo"), Firmware(8, PERIOD_NS, "servo")
        for fw in (self.fast, self.general):
            fw.restore({})
        self.fast_port, self.general_port = PortState(), PortState()

    def run(self, line: str) -> tuple[list[str], int | None]:
        a = self.fast.interpreter.execute(self.fast_port, line)
        b = self.general.interpreter.execute_general(self.general_port, line)
        assert (a.lines, a.error) == (b.lines, b.error), line
        assert self.fast_port == self.general_port, line
        return a.lines, a.error

    def tick(self, n: int) -> None:
        for fw in (self.fast, self.general):
            for _ in range(n):
                fw.tick(fw.now_ns + PERIOD_NS)


def test_report_lines_compile_and_others_take_the_general_path() -> None:
    assert compile_reports("#1P") is not None and compile_reports("#1?PVF m190 p99") is not None
    assert compile_reports("I130") is not None and compile_reports("PVF") is not None
    for line in ("#1J+", "I130=5", "I130..131", "P(1)", "#33P", "#1->", "##2", "PASSWORD",
                 "#1P;x", "M1->", "i65???&1??%", "#1p\xe9"):
        assert compile_reports(line) is None, line


def test_compiled_lines_answer_as_the_general_parse_over_random_lines() -> None:
    twin = Twin()
    for line in SETUP:
        assert twin.run(line)[1] is None, line
    twin.tick(300)  # moving motors: P, V and F with fractions
    rng = random.Random(1940)
    for i in range(4000):
        if i % 500 == 0:  # long form and decimal/hex I-variables (I9 bits 0 and 1)
            twin.run(f"I9={i // 500 % 4}")
            twin.tick(7)
        tokens = rng.choices(TOKENS, k=rng.randint(1, 5))
        twin.run("".join(t + rng.choice(("", "", " ", "\t")) for t in tokens))


def test_the_same_line_follows_the_state_it_reports() -> None:
    twin = Twin()
    twin.run("#1J=2000")
    seen = set()
    for _ in range(40):
        seen.add(tuple(twin.run("#1PVF?")[0]))
        twin.tick(25)
    assert len(seen) > 30  # the compiled line reads the motor afresh every time
    assert twin.run("I130")[0] == ["2000"]
    twin.run("I130=1234")
    assert twin.run("I130")[0] == ["1234"]
    twin.run("I9=3")
    assert twin.run("I130")[0] == ["I130=1234"]
    assert twin.run("I8192") == ([], 3)
    assert twin.run("#2P I8192 #3P") == (["0"], 3)


def test_a_table_download_in_progress_takes_its_entries_first() -> None:
    twin = Twin()
    twin.run("#3 DEFINE COMP 1.1,#1,#2,100,100")
    for line in ("#1P", "5", "P", "6 7", "#1P", "LIST COMP"):
        twin.run(line)


def test_the_plan_cache_stays_bounded_and_starts_afresh() -> None:
    twin = Twin()
    plans = twin.fast.interpreter._plans
    for n in range(PLAN_CACHE + 50):
        twin.run(f"I{n}")
        assert len(plans) <= PLAN_CACHE
    twin.run("#1P")
    assert "#1P" in plans and len(plans) < PLAN_CACHE


def test_i3_2_framing_matches_the_i3_table() -> None:
    for lines in ([], ["0"], ["1.940", "", "$78000"]):
        for error in (None, 3, 18):
            reply = Reply(list(lines), error)
            expected = b"".join(line.encode() + b"\r" for line in lines)
            expected += b"\x06" if error is None else b"\x07ERR%03d\r" % error
            assert frame(reply, 2, 1) == expected
            assert frame(reply, 3, 1) == b"".join(b"\n" + line.encode() + b"\r" for line in lines) + (
                b"\x06" if error is None else b"\x07ERR%03d\r" % error)
