"""DEFINE COMP two-dimensional compensation tables (vdevd/devices/pmac/comp2d.py) [A L3118-3219]."""

from __future__ import annotations

import numpy as np
import pytest

from vdevd.devices.pmac.comp2d import CompError, CompTables, parse_define
from vdevd.devices.pmac.ivars import IVars


@pytest.mark.parametrize(
    ("motor", "text", "count", "sources", "target", "col_spacing", "row_spacing"),
    [  # the addendum's four examples [A L3191-3216]
        (4, "30.40,#1,#2,#3,400000,300000", 1270, (1, 2), 3, 10000, 10000),
        (3, "25.20,#2,#3,#1,200000,250000", 545, (2, 3), 1, 10000, 10000),
        (2, "10.10,#1,#4,10000,20000", 120, (1, 4), 2, 1000, 2000),
        (1, "12.10,#4,1280,1200", 142, (4, 1), 1, 128, 100),
    ],
)
def test_define_examples(motor: int, text: str, count: int, sources: tuple[int, int], target: int,
                         col_spacing: float, row_spacing: float) -> None:
    d = parse_define(text, motor)
    assert d.owner == motor
    assert d.entry_count == count
    assert (d.row_motor, d.column_motor, d.target) == (*sources, target)
    assert (d.column_spacing, d.row_spacing) == (col_spacing, row_spacing)


def test_define_accepts_the_command_words_and_desired_markers() -> None:
    d = parse_define("DEF COMP 2.3, #1D, #2D, #3, 300, 200", 5)
    assert (d.rows, d.columns, d.row_desired, d.column_desired) == (2, 3, True, True)
    assert d.text() == "DEFINE COMP 2.3,#1D,#2D,#3,300,200"


@pytest.mark.parametrize(
    "text", ["30,40,#1,100,100", "3.4,#1,#2,#3,#4,10,10", "0.4,#1,10,10", "3.4,#33,10,10"]
)
def test_malformed_define_is_err003(text: str) -> None:
    with pytest.raises(CompError) as e:
        parse_define(text, 1)
    assert e.value.code == 3


def _fill(tables: CompTables, values: list[int] | None = None) -> None:
    n = tables.pending
    for v in values if values is not None else [0] * n:
        tables.feed(v)
    assert tables.pending == 0


def test_err007_ordering_example() -> None:
    buffers = {"GATHER", "ROTARY1", "ROTARY2"}
    t = CompTables(IVars(8), 8, other_buffers=lambda: bool(buffers))
    buffers.clear()
    t.define(3, "2.2,#1,10,10")
    _fill(t)
    t.define(2, "2.2,#1,10,10")
    _fill(t)
    buffers.update({"GATHER", "ROTARY1", "ROTARY2"})
    with pytest.raises(CompError) as e:           # [A L3183-3185]
        t.define(1, "40.30,#1,#2,#3,300000,400000")
    assert e.value.code == 7
    buffers.clear()                               # DELETE GATHER, &1/&2 DELETE ROTARY
    with pytest.raises(CompError):                # #2 still holds a table below #4
        t.define(4, "30.40,#1,#2,#3,400000,300000")
    with pytest.raises(CompError):                # delete from low to high [A L3139]
        t.delete(3)
    t.delete(2)
    t.delete(3)
    for motor, text, count in ((4, "30.40,#1,#2,#3,400000,300000", 1270),
                               (3, "25.20,#2,#3,#1,200000,250000", 545),
                               (2, "10.10,#1,#4,10000,20000", 120),
                               (1, "12.10,#4,1280,1200", 142)):
        t.define(motor, text)
        assert t.pending == count
        _fill(t)
    assert sorted(t.tables) == [1, 2, 3, 4]


def test_entries_are_integers_in_order_with_implied_zero_first() -> None:
    t = CompTables(IVars(8), 8)
    t.define(1, "2.2,#2,#3,#4,200,100")
    with pytest.raises(CompError):
        t.feed(1.5)
    _fill(t, [1, 2, 3, 4, 5, 6, 7, 8])
    e = t.entries[1].reshape(3, 3)
    assert e.tolist() == [[0, 1, 2], [3, 4, 5], [6, 7, 8]]   # E_k, k = i*(c+1)+j [A L3161-3167]
    assert t.list_text(1) == "1 2\n3 4 5\n6 7 8\n"
    assert t.list_definition(1) == "DEFINE COMP 2.2,#2,#3,#4,200,100"
    with pytest.raises(CompError):
        t.feed(9)


def _table() -> tuple[CompTables, IVars]:
    iv = IVars(8)
    t = CompTables(iv, 8)
    t.define(1, "2.2,#2,#3,#4,200,100")   # columns every 100 counts of #2, rows every 50 of #3
    _fill(t, [16, 32, 48, 64, 80, 96, 112, 128])
    return t, iv


def test_correction_needs_i51() -> None:
    t, iv = _table()
    act = np.array([0, 100, 50, 0, 0, 0, 0, 0], dtype=float)
    assert not t.correction(act, act).any()
    iv.values[51] = 1
    assert t.correction(act, act)[3] == 64 / 16     # E_4 at (row 1, column 1), into motor #4


def test_correction_is_bilinear_and_rolls_sources_over_the_span() -> None:
    t, iv = _table()
    iv.values[51] = 1
    pos = np.zeros(8)
    pos[1], pos[2] = 150.0, 25.0          # halfway in both directions of cell (0..1, 1..2)
    expect = (16 + 32 + 64 + 80) / 4 / 16
    assert t.correction(pos, pos)[3] == pytest.approx(expect)
    pos[1], pos[2] = 150.0 + 3 * 200, 25.0 - 100
    assert t.correction(pos, pos)[3] == pytest.approx(expect)


def test_desired_sources_use_the_desired_positions() -> None:
    iv = IVars(8)
    iv.values[51] = 1
    t = CompTables(iv, 8)
    t.define(1, "1.1,#2D,#3,100,100")
    _fill(t, [16, 0, 32])
    act, des = np.zeros(8), np.zeros(8)
    des[1] = 50.0
    assert t.correction(act, des)[0] == pytest.approx(0.5)
    assert t.correction(des, act)[0] == 0
