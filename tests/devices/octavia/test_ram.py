"""The on-board RAM: table layouts, real aliasing, clearing, bounds and the state-file image
[Ch8 Table 8-1; spec octavia.md §6]."""

from __future__ import annotations

from collections.abc import Callable

import numpy as np
import pytest

from vdevd.devices.octavia.ram import RAM_WORDS, BoardRam, table_numbers, wrap_i32

# the LOAD_CAM_TABLE example table [Ch5 LOAD_CAM_TABLE]: FFE6h is −26
EXAMPLE = ([0, 100, 500, 1000], [0, 200, 300, 200], [0x0100, 0x0020, -26, 0])


def test_cam_points_round_trip_signed_values() -> None:
    ram = BoardRam()
    ram.store_cam_points(7, [0, -5000, 2**31 - 1], [-2**31, 1024, -1], [-0x8000, 0x7FFF, -1])
    master, slave, ratio = ram.cam_points(7, 3)
    assert master.tolist() == [0, -5000, 2**31 - 1]
    assert slave.tolist() == [-2**31, 1024, -1]
    assert ratio.tolist() == [-0x8000, 0x7FFF, -1]


def test_cam_point_i_is_five_words_at_2000h_plus_5i_lsw_first() -> None:
    ram = BoardRam()
    ram.store_cam_points(3, [0x12345678], [-2], [-26])
    assert ram.words[0x2000 + 15:0x2000 + 20].tolist() == [0x5678, 0x1234, 0xFFFE, 0xFFFF, 0xFFE6]
    assert not ram.words[:0x2000 + 15].any() and not ram.words[0x2000 + 20:].any()


def test_load_cam_table_example_reads_back_with_its_encoded_ratios() -> None:
    ram = BoardRam()
    ram.store_cam_points(100, *EXAMPLE)
    master, slave, ratio = ram.cam_points(100, 4)
    assert (master.tolist(), slave.tolist(), ratio.tolist()) == EXAMPLE
    assert ram.words[0x2000 + 5 * 102 + 4] == 0xFFE6


def test_cubic_point_i_is_two_words_at_2000h_plus_2i() -> None:
    ram = BoardRam()
    ram.store_cubic_points(4094, [2500, -957])
    assert ram.words[0x2000 + 2 * 4094:0x4000].tolist() == [2500, 0, 0xFC43, 0xFFFF]
    assert ram.cubic_points(4094, 2).tolist() == [2500, -957]


def test_load_cubic_table_overwrites_cam_points() -> None:
    ram = BoardRam()
    ram.store_cam_points(0, *EXAMPLE)
    ram.store_cubic_points(0, [111, -222, 0x0005_0003])
    master, slave, ratio = ram.cam_points(0, 2)
    # cubic 0 = cam 0's master, cubic 1 = its slave, cubic 2 = its ratio and cam 1's master LSW
    assert (master[0], slave[0], ratio[0]) == (111, -222, 3)
    assert master[1] == 5                       # LSW from cubic 2, MSW unchanged (0)
    assert (slave[1], ratio[1]) == (200, 0x20)  # beyond the cubic write: untouched


def test_compensation_tables_alias_the_cubic_area_and_table_5_is_at_4000h() -> None:
    ram = BoardRam()
    ram.store_pos_table(0x01, 0, [0x1111, 0x2222])
    ram.store_vel_table(0x01, 0, [0x3333])
    ram.store_pos_table(0x10, 1023, [0x5555])
    assert ram.cubic_points(0, 1).tolist() == [0x2222_1111]
    assert ram.cubic_points(0x200, 1).tolist() == [0x3333]         # 2400h = cubic point 512
    assert ram.words[0x4000 + 1023] == 0x5555                      # not 400h (Q-30 item 17)
    assert ram.words[0x2400] == 0x3333 and ram.words[0x5C00 - 1] == 0


def test_several_table_bits_write_each_table() -> None:
    ram = BoardRam()
    ram.store_vel_table(0x82, 10, [7, 8, 9])
    for table in range(1, 9):
        want = [7, 8, 9] if table in (2, 8) else [0, 0, 0]
        assert ram.vel_table(table)[10:13].tolist() == want
        assert not ram.pos_table(table).any()


def test_clear_cubic_erases_cam_and_tables_1_to_4_only() -> None:
    ram = BoardRam()
    ram.words[:] = 0xA5A5
    ram.clear_cubic()
    assert not ram.words[0x2000:0x4000].any()
    assert (ram.words[:0x2000] == 0xA5A5).all() and (ram.words[0x4000:] == 0xA5A5).all()
    assert not ram.pos_table(4).any() and (ram.pos_table(5) == 0xA5A5).all()
    assert not any(ram.cam_points(0, 1600)[0])


def test_clear_pos_table_mask_clears_the_selected_position_tables() -> None:
    ram = BoardRam()
    ram.words[:] = 0xFFFF
    ram.clear_pos_table(0x07)                 # the manual's example: tables 1, 2 and 3
    assert [not ram.pos_table(t).any() for t in range(1, 9)] == [True] * 3 + [False] * 5
    assert all(ram.vel_table(t).all() for t in range(1, 9))
    ram.clear_vel_table(0x08)                 # table 4
    assert [not ram.vel_table(t).any() for t in range(1, 9)] == [False] * 3 + [True] + [False] * 4


@pytest.mark.parametrize("call", [
    lambda r: r.store_cam_points(1599, [0, 0], [0, 0], [0, 0]),
    lambda r: r.cam_points(1598, 3),
    lambda r: r.cam_points(-1, 2),
    lambda r: r.store_cubic_points(4095, [1, 2]),
    lambda r: r.cubic_points(4000, 97),
    lambda r: r.store_pos_table(0x01, 1020, [1, 2, 3, 4, 5]),
    lambda r: r.store_vel_table(0x01, -1, [1]),
    lambda r: r.pos_table(0),
    lambda r: r.vel_table(9),
    lambda r: r.clear_pos_table(0x100),
    lambda r: r.store_cam_points(0, [0, 0], [0], [0, 0]),
])
def test_out_of_capacity_access_raises_and_writes_nothing(call: Callable[[BoardRam], object]) -> None:
    ram = BoardRam()
    with pytest.raises(ValueError):
        call(ram)
    assert not ram.words.any()


def test_a_table_may_end_exactly_at_its_capacity() -> None:
    ram = BoardRam()
    ram.store_cam_points(1599, [1], [2], [3])
    ram.store_cubic_points(4095, [-1])
    ram.store_pos_table(0x80, 1023, [9])
    assert len(ram.cam_points(0, 1600)[0]) == 1600 and ram.cubic_points(4095, 1)[0] == -1
    assert ram.pos_table(8)[1023] == 9


def test_state_image_is_little_endian_words_and_round_trips() -> None:
    ram = BoardRam()
    rng = np.random.default_rng(18)
    ram.words[:] = rng.integers(0, 0x10000, RAM_WORDS)
    ram.words[0] = 0x1234
    image = ram.to_bytes()
    assert len(image) == 65536 and image[:2] == b"\x34\x12"
    again = BoardRam.from_bytes(image)
    assert np.array_equal(again.words, ram.words) and again.words.dtype == np.uint16
    with pytest.raises(ValueError):
        BoardRam.from_bytes(image[:-2])


def test_table_numbers_and_wrap_i32() -> None:
    assert table_numbers(0x30) == [5, 6] and table_numbers(0) == []
    assert wrap_i32([2**31, -2**31 - 1, 5]).tolist() == [-2**31, 2**31 - 1, 5]
