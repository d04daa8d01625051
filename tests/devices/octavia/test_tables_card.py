"""The table RTCs and the battery-backed RAM on the card [Ch5 TABLE_SEL, LOAD_POS_TABLE,
LOAD_VEL_TABLE, CLEAR_POS_TABLE, CLEAR_VEL_TABLE, LOAD_CUBIC_TABLE, CLEAR_CUBIC_TABLE; Ch7; Ch8
Table 8-1; spec octavia.md §6]: tables in the board RAM with its aliasing, kept by RESET and
(the battery option) across daemon restarts in the state directory. The host cannot read the
RAM back: the card's `read_ram` backdoor does."""

from __future__ import annotations

import asyncio
import struct
import threading
from pathlib import Path
from typing import Any

import numpy as np
import pytest
import vdevclient
from vdevmaps.octavia import CARD_TYPE, Dpr

from tests.devices.octavia.cam_host import (
    CARD,
    CLEAR_CUBIC_TABLE,
    CLEAR_POS_TABLE,
    CLEAR_VEL_TABLE,
    LOAD_CUBIC_TABLE,
    LOAD_POS_TABLE,
    LOAD_VEL_TABLE,
    RESET,
    TABLE_SEL,
    Host,
    linear_table,
    load_cam_table,
)
from vdevd.config import CardSpec, Config
from vdevd.devices.octavia.battery import Writer
from vdevd.nvram import NvramStore
from vdevd.testing import DaemonThread

POS, VEL = 0x2000, 0x2400  # table 1 of each; table t at + (t-1) * 800h [Ch8 Table 8-1]


def words(host: Host, address: int, count: int) -> list[int]:
    return list(host.control("read_ram", address=address, count=count))


def load_comp(host: Host, code: int, tables: int, index: int, values: list[int]) -> None:
    host.stage(struct.pack(f"<{len(values)}H", *values))
    host.rtc(code, struct.pack("<BHH", tables, index, len(values)))


def test_load_pos_table_then_clear_pos_table_example_07h_clears_tables_1_to_3() -> None:
    """[Ch5 CLEAR_POS_TABLE example] n=07h clears position tables 1, 2 and 3; table 4 and the
    velocity tables keep their data."""
    host = Host()
    load_comp(host, LOAD_POS_TABLE, 0x0F, 0, list(range(1, 337)))  # tables 1-4 at once
    load_comp(host, LOAD_VEL_TABLE, 0x01, 1000, [0xBEEF] * 24)
    for t in range(4):
        assert words(host, POS + 0x800 * t, 3) == [1, 2, 3]
    host.rtc(CLEAR_POS_TABLE, b"\x07")
    for t in range(3):
        assert words(host, POS + 0x800 * t, 1024) == [0] * 1024
    assert words(host, POS + 0x800 * 3, 337) == [*range(1, 337), 0]
    assert words(host, VEL + 1000, 24) == [0xBEEF] * 24


def test_clear_vel_table_example_08h_clears_table_4() -> None:
    host = Host()
    load_comp(host, LOAD_VEL_TABLE, 0x0C, 100, [7, 8, 9])  # tables 3 and 4
    host.rtc(CLEAR_VEL_TABLE, b"\x08")
    assert words(host, VEL + 0x800 * 2 + 100, 3) == [7, 8, 9]
    assert words(host, VEL + 0x800 * 3 + 100, 3) == [0, 0, 0]


def test_compensation_loads_past_1024_entries_or_over_336_are_ignored() -> None:
    host = Host()
    load_comp(host, LOAD_POS_TABLE, 0x01, 1000, [5] * 25)  # 1000 + 25 > 1024
    host.stage(struct.pack("<336H", *([6] * 336)))
    host.rtc(LOAD_POS_TABLE, struct.pack("<BHH", 0x01, 0, 337))  # one more than the area holds
    assert words(host, POS, 1024) == [0] * 1024
    load_comp(host, LOAD_POS_TABLE, 0x80, 1000, [5] * 24)  # table 8 (Ch8 has eight)
    assert words(host, POS + 0x800 * 7 + 1000, 24) == [5] * 24


def test_table_sel_example_selects_tables_2_2_1_1() -> None:
    """[Ch5 TABLE_SEL example] n=0Fh, tb = 02h, 02h, 01h, 01h; a table number outside 1..8 is
    ignored; RESET selects table 1 again (a parameter)."""
    host = Host()
    host.rtc(TABLE_SEL, bytes.fromhex("0F 02 02 01 01"))
    assert host.control("get_dspl")["table_sel"] == [2, 2, 1, 1, 1, 1, 1, 1]
    host.rtc(TABLE_SEL, bytes.fromhex("30 09 08"))
    assert host.control("get_dspl")["table_sel"] == [2, 2, 1, 1, 1, 8, 1, 1]
    host.rtc(RESET, b"\xaa\xaa")
    assert host.control("get_dspl")["table_sel"] == [1] * 8


def test_load_cubic_table_overwrites_the_cam_points_it_aliases() -> None:
    """Ch8: the cubic table and the cam table share 2000h..3FFFh: a cubic point is 2 words, a
    cam point 5."""
    host = Host()
    load_cam_table(host, 0, linear_table(10, 100, 100))
    assert words(host, 0x2000 + 5, 5) == [100, 0, 100, 0, 128]
    host.stage(struct.pack("<168i", *range(-1, 167)))
    host.rtc(LOAD_CUBIC_TABLE, struct.pack("<HH", 0, 168))
    assert words(host, 0x2000, 6) == [0xFFFF, 0xFFFF, 0, 0, 1, 0]
    host.stage(struct.pack("<2i", 70000, -2))
    host.rtc(LOAD_CUBIC_TABLE, struct.pack("<HH", 4094, 2))  # the last two points
    assert words(host, 0x2000 + 2 * 4094, 4) == [70000 & 0xFFFF, 1, 0xFFFE, 0xFFFF]
    host.rtc(LOAD_CUBIC_TABLE, struct.pack("<HH", 4095, 2))  # past 4096: ignored
    assert words(host, 0x2000 + 2 * 4095, 2) == [0xFFFE, 0xFFFF]


def test_clear_cubic_table_clears_2000h_to_3fffh_and_no_further() -> None:
    """spec §6.1: with the cubic table go the cam table and compensation tables 1-4; table 5
    (4000h) stays."""
    host = Host()
    load_comp(host, LOAD_POS_TABLE, 0x11, 0, [9] * 10)  # tables 1 and 5
    load_cam_table(host, 1500, linear_table(5, 10, 10))
    host.rtc(CLEAR_CUBIC_TABLE)
    assert not any(words(host, 0x2000, 0x2000))
    assert words(host, 0x4000, 10) == [9] * 10


def test_tables_are_copied_out_of_120h_before_3c2h_clears() -> None:
    host = Host()
    load_comp(host, LOAD_VEL_TABLE, 0x02, 0, [1, 2, 3])
    host.stage(bytes(672))
    host.tick(10)
    assert words(host, VEL + 0x800, 3) == [1, 2, 3]


def test_reset_keeps_the_tables() -> None:
    """[Ch7 Power-Up/Reset State] reset does not clear the compensation, cam or cubic tables."""
    host = Host()
    load_comp(host, LOAD_POS_TABLE, 0x20, 3, [4, 5])
    host.rtc(RESET, b"\xaa\xaa")
    assert words(host, POS + 0x800 * 5 + 3, 2) == [4, 5]


def close(host: Host) -> None:
    """What the daemon does when it stops: the card's services close (the last image saved)."""
    asyncio.run(host.card.close_services())


def test_tables_survive_a_daemon_restart_in_the_state_directory(tmp_path: Path) -> None:
    store = NvramStore(tmp_path)
    host = Host(store)
    load_comp(host, LOAD_POS_TABLE, 0x01, 0, [1, 2, 3])
    load_cam_table(host, 7, linear_table(3, 10, 20))
    close(host)
    assert store.path(CARD).exists()
    again = Host(store)
    assert words(again, POS, 3) == [1, 2, 3]
    assert words(again, 0x2000 + 5 * 8, 5) == [10, 0, 20, 0, 0x100]


def test_without_the_battery_option_nothing_is_kept(tmp_path: Path) -> None:
    store = NvramStore(tmp_path)
    host = Host(store, battery_backup=False)
    load_comp(host, LOAD_POS_TABLE, 0x01, 0, [1, 2, 3])
    close(host)
    assert not store.path(CARD).exists()
    store.save(CARD, host.card.nvram())  # an image there is not read either
    assert words(Host(store, battery_backup=False), POS, 3) == [0, 0, 0]


def test_an_image_of_another_format_starts_the_ram_cleared(tmp_path: Path) -> None:
    store = NvramStore(tmp_path)
    store.save(CARD, {"format": "octavia-battery-0", "ram": b"\x01" * 65536})
    assert words(Host(store), POS, 2) == [0, 0]


class SlowStore(NvramStore):
    """A state directory on a slow disk: each save waits for `release`."""

    def __init__(self, path: Path) -> None:
        super().__init__(path)
        self.release = threading.Event()
        self.started = threading.Event()

    def save(self, card: str, image: dict[str, Any]) -> None:
        self.started.set()
        assert self.release.wait(10)
        super().save(card, image)


def test_a_slow_disk_does_not_stall_the_card(tmp_path: Path) -> None:
    """The images are saved on the writer's thread; while one is written the later ones replace
    each other, the last one is saved."""
    store = SlowStore(tmp_path)
    host = Host(store)
    writer = host.card._battery
    assert isinstance(writer, Writer)
    load_comp(host, LOAD_POS_TABLE, 0x01, 0, [1])
    assert store.started.wait(10)  # the first image is being written, the card runs on
    for value in range(2, 12):
        load_comp(host, LOAD_POS_TABLE, 0x01, 0, [value])
    assert words(host, POS, 1) == [11]
    store.release.set()
    assert writer.flush(10)
    assert writer.saved == 2
    saved = store.load(CARD)
    assert saved is not None
    assert np.frombuffer(saved["ram"], "<u2")[POS] == 11


def test_a_real_daemon_restart_restores_the_tables(tmp_path: Path) -> None:
    """Through vdevd and vdevclient, as a host driver on a machine sees it."""
    cfg = Config(endpoint="tcp://127.0.0.1:*", events="tcp://127.0.0.1:*", clock="lockstep",
                 cards=[CardSpec(CARD_TYPE, CARD, {})], state_dir=str(tmp_path))

    def post(dpr: vdevclient.Region, rack: vdevclient.Rack, code: int, args: bytes) -> None:
        dpr.write(Dpr.ARGMNTS, args)
        dpr.write(Dpr.RTC, bytes((code,)))
        for _ in range(50):
            rack.sim.step(ticks=1, card=CARD)
            if dpr.read8(Dpr.RTC) == 0:
                return
        raise AssertionError("the RTC was not executed")

    with DaemonThread(cfg) as d, vdevclient.connect(d.endpoint, d.events, timeout=10) as rack:
        dpr = rack.card(CARD).region("dpr")
        dpr.write(Dpr.RINGBUF, struct.pack("<4H", 10, 20, 30, 40))
        post(dpr, rack, LOAD_VEL_TABLE, struct.pack("<BHH", 0x40, 512, 4))
    with DaemonThread(cfg) as d, vdevclient.connect(d.endpoint, d.events, timeout=10) as rack:
        card = rack.card(CARD)
        assert card.control("read_ram", address=VEL + 0x800 * 6 + 512, count=4) == [10, 20, 30,
                                                                                     40]


def test_load_commands_outside_their_range_still_clear_3c2h() -> None:
    host = Host()
    host.rtc(LOAD_CUBIC_TABLE, struct.pack("<HH", 0, 169))
    host.rtc(LOAD_POS_TABLE, struct.pack("<BHH", 0x01, 0, 0))
    assert host.u8(Dpr.RTC) == 0


@pytest.mark.parametrize("code", [LOAD_POS_TABLE, LOAD_VEL_TABLE])
def test_a_table_mask_of_zero_loads_nothing(code: int) -> None:
    host = Host()
    load_comp(host, code, 0x00, 0, [1, 2])
    assert not any(words(host, 0x2000, 0x4000))
