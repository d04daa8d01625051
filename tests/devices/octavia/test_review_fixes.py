"""Defects a review found in the Octavia's cam, gear and CUBIC_INT paths, each fixed with a test
that failed before the fix."""

from __future__ import annotations

import struct

from vdevmaps.octavia import Dpr

from tests.devices.octavia.host import Host


def cam_table(host: Host) -> None:
    """Ten points, master 0..900, slave 0..450 (ratio 0.5), at cam index 0 [Ch5 LOAD_CAM_TABLE]."""
    pts = b"".join(struct.pack("<iih", 100 * i, 50 * i, 64) for i in range(10))
    host.write(Dpr.RINGBUF, pts)
    host.rtc("LOAD_CAM_TABLE", {"index": 0, "numpts": 10})


def test_a_gear_engaged_after_a_position_preset_does_not_jump() -> None:
    """POS_PRESET made while nothing follows is no travel: a GEAR engaged afterwards with its
    leader at rest keeps the follower where the preset put it (README "Cam and gearing")."""
    host = Host(plant="ideal")
    host.rtc("POS_PRESET", {"n": 0x02}, [{"pset": 5000}])
    host.run(5)
    host.rtc("GEAR", {"n": 0x01, "m": 0x02}, [{"r": 128}])
    host.run(50)
    assert host.position(2) == 5000


def test_a_cam_or_gear_naming_its_slave_as_master_leaves_the_running_one_alone() -> None:
    """"A slave that is its own master ... is ignored" (README): the engagement it had runs on
    unchanged (table, ratio)."""
    host = Host(plant="ideal")
    cam_table(host)
    host.rtc("CAM", {"n": 0x01, "m": 0x02}, [{"tablestart": 0, "tablesize": 10}])
    host.rtc("GEAR", {"n": 0x01, "m": 0x04}, [{"r": 128}])
    host.run(2)
    follow = host.card.fw.follow
    before = (int(follow.cam.start[1]), int(follow.cam.size[1]), int(follow.gears.ratio[2]))
    host.rtc("CAM", {"n": 0x02, "m": 0x02}, [{"tablestart": 500, "tablesize": 3}])
    host.rtc("GEAR", {"n": 0x04, "m": 0x04}, [{"r": 1000}])
    host.run(2)
    assert (int(follow.cam.start[1]), int(follow.cam.size[1]), int(follow.gears.ratio[2])) == before


def test_an_open_loop_axis_made_a_slave_leaves_no_open_axis_behind() -> None:
    """DDAC then GEAR on that axis: the loop closes, and the card no longer overrides any DAC
    every sample (`any_open` follows the modes)."""
    host = Host(plant="ideal")
    host.rtc("DDAC", {"n": 0x02}, [{"val": 1000}])
    host.run(2)
    assert host.card.fw.any_open
    host.rtc("GEAR", {"n": 0x01, "m": 0x02}, [{"r": 128}])
    host.run(2)
    assert not host.card.fw.any_open


def test_cubic_int_past_the_table_end_is_ignored() -> None:
    """CUBIC_INT with si + m past 4096 points is ignored (README "Internal table"), even when
    the entries a whole number of points per axis takes would fit."""
    host = Host(plant="ideal")
    host.rtc("CUBIC_RATE", {"m": 25})
    host.rtc("CUBIC_INT", {"m": 3, "si": 4094, "n": 1, "ax": 0x03})
    assert not host.card.fw.cubic.running
    host.rtc("CUBIC_INT", {"m": 8, "si": 0, "n": 0, "ax": 0x01})
    assert host.card.fw.cubic.running


def test_pos_shift_while_contouring_moves_the_path_with_the_counter() -> None:
    """POS_SHIFT "without losing position integrity" [Ch5 POS_SHIFT]: a CUBIC_INT axis (and a
    ring contour's) goes on where it was going physically; only its counter reads psft more."""
    host = Host(plant="ideal")
    host.write(Dpr.RINGBUF, b"".join(struct.pack("<i", v) for v in (0, 1000, 2000, 1000)))
    host.rtc("LOAD_CUBIC_TABLE", {"index": 0, "num": 4})
    host.rtc("CUBIC_INT", {"m": 4, "si": 0, "n": 0, "ax": 0x01})
    twin = Host(plant="ideal")
    twin.write(Dpr.RINGBUF, b"".join(struct.pack("<i", v) for v in (0, 1000, 2000, 1000)))
    twin.rtc("LOAD_CUBIC_TABLE", {"index": 0, "num": 4})
    twin.rtc("CUBIC_INT", {"m": 4, "si": 0, "n": 0, "ax": 0x01})
    host.run(199)
    twin.run(199)
    host.rtc("POS_SHIFT", {"n": 0x01}, [{"psft": 100_000}])
    twin.run(1)
    for _ in range(60):
        host.run(1)
        twin.run(1)
        assert host.card.fw.core.physical()[0] == twin.card.fw.core.physical()[0]
        assert host.position(1) == twin.position(1) + 100_000


def test_dspl_variables_survive_reset_unless_the_option_clears_them() -> None:
    """Spec Q-23 leaves it open whether RESET clears VAR1..128: they survive by default (the
    battery RAM), `reset_clears_vars = true` clears them."""
    for clears in (False, True):
        host = Host(reset_clears_vars=clears)
        host.rtc("CHANGE_VAR", {"m": 1}, [{"var": 3, "value": b"\x01\x02\x03\x04\x05\x06"}])
        host.rtc("RESET", {"sig1": 0xAA, "sig2": 0xAA})
        host.run(2)
        expected = 0 if clears else 0x060504030201
        assert host.card.control("dspl_var", {"var": 3}) == expected
