"""The Octavia's RTC window: the encoding of every opcode [Ch5 listing, Ch6 Real-Time Commands],
the manual's Chapter 6 examples byte for byte, and the card's handling of bad input."""

from __future__ import annotations

import random
import re
import struct

import pytest
from vdevmaps import octavia as o

from tests.devices.digest import digest_text
from tests.devices.octavia.host import Host
from vdevd.devices.octavia.commands import COMMANDS


def test_chapter6_example1_pos_preset_bytes_and_effect() -> None:
    """Ch6 Example 1: preset axis 3 to 00112233h: 3C2h = 68h, 3C3h = 04h, then 33 22 11 00."""
    args = o.pack(o.BY_NAME["POS_PRESET"], {"n": 0x04}, [{"pset": 0x00112233}])
    assert args == bytes.fromhex("04 33 22 11 00")
    assert o.BY_NAME["POS_PRESET"].code == 0x68
    host = Host(plant="ideal")
    host.raw_rtc(0x68, args)
    host.run(1)
    assert host.position(3) == 0x00112233
    assert host.error(3) == 0


def test_chapter6_example2_axmove_bytes_and_completion_times() -> None:
    """Ch6 Example 2: axes 2 and 4 to 234567h and 112233h at 200000h, acc 150h: the 21 bytes
    of the table; each axis ends on its own after D/V + V/A samples (spec §5.3, +-2)."""
    groups = [{"acc": 0x150, "pos": 0x234567, "vel": 0x200000},
              {"acc": 0x150, "pos": 0x112233, "vel": 0x200000}]
    args = o.pack(o.BY_NAME["AXMOVE"], {"n": 0x0A}, groups)
    assert args == bytes.fromhex("0A 5001 67452300 00002000 5001 33221100 00002000")
    host = Host(plant="ideal")
    host.rtc("EN_MOTCP", {"n": 0x0A})
    host.raw_rtc(0x60, args)
    v, a = 0x200000 / 65536, 0x150 / 32768
    done = {}
    t = 1
    while len(done) < 2 and t < 80_000:
        host.card.tick(1)
        t += 1
        src = host.u8(o.Dpr.INTAXIS_MOTCP)
        for axis in (2, 4):
            if src >> (axis - 1) & 1 and axis not in done:
                done[axis] = t
    assert done[4] == pytest.approx(0x112233 / v + v / a, abs=2)
    assert done[2] == pytest.approx(0x234567 / v + v / a, abs=2)
    host.run(30)
    assert (host.position(2), host.position(4)) == (0x234567, 0x112233)
    assert host.u8(o.Dpr.DSPSTAT1) & o.DspStat1.MOTCP


def test_chapter6_example3_en_err_bytes_and_setpoints() -> None:
    """Ch6 Example 3: following-error interrupts at 100..103 counts for axes 1-4; PARREAD 1Ah
    reads the setpoints back."""
    args = o.pack(o.BY_NAME["EN_ERR"], {"n": 0x0F}, [{"fer": f} for f in (100, 101, 102, 103)])
    assert args == bytes.fromhex("0F 6400 6500 6600 6700")
    host = Host()
    host.raw_rtc(0x67, args)
    host.write(o.Dpr.PARACC, b"\x00")
    host.rtc("PARREAD", {"m": 0x1A})
    assert struct.unpack("<4H", host.read(o.Dpr.PARRDBK, 8)) == (100, 101, 102, 103)


@pytest.mark.parametrize("rtc", [*o.RTCS, *o.RTC_8E.values()], ids=lambda r: r.name)
def test_every_rtc_packs_and_unpacks_its_layout(rtc: o.Rtc) -> None:
    """Every opcode's layout round-trips: the head, then one group per axis of its mask (or the
    counted groups), LSB first, no padding [Ch6 Real-Time Commands rules 1-4]."""
    rnd = random.Random(rtc.code)

    def value(code: str) -> object:
        if code == "6s":
            return bytes(rnd.randrange(256) for _ in range(6))
        if code == "f":
            return float(rnd.randrange(-1000, 1000)) / 4
        bits = struct.calcsize(code) * 8
        return rnd.randrange(-(1 << bits - 1), 1 << bits - 1) if code.islower() else \
            rnd.randrange(1 << bits)

    head = {n: value(c) for n, c in rtc.head}
    if rtc.mask:
        head[rtc.mask] = 0b10100101
    if rtc.count:
        head[rtc.count] = 3
    groups = [{n: value(c) for n, c in rtc.group} for _ in rtc.groups(head)]
    data = o.pack(rtc, head, groups)
    assert len(data) == rtc.size(head)
    got_head, got = o.unpack(rtc, data + bytes(9))
    assert got_head == head
    assert [g for _, g in got] == groups
    assert [a for a, _ in got] == ([1, 3, 6, 8] if rtc.mask else [1, 2, 3] if rtc.count else [])


def test_the_table_has_the_manuals_72_opcodes_and_its_lengths() -> None:
    """74 listings on 72 opcodes, 8Eh three times by firmware option [spec §4.2]; the lengths
    of the table's formulas (k axes)."""
    assert len(o.RTCS) + len(o.RTC_8E) == 74
    assert len({r.code for r in o.RTCS} | {0x8E}) == 72
    k3 = {"n": 0b111, "m": 0b111}
    lengths = {"AXMOVE": 1 + 30, "CTRL": 1 + 24, "EN_ENCFLT": 2 + 6, "CAM_POS": 2 + 24,
               "GEAR_PROBE": 3 + 6, "POSBRK_OUT": 1 + 24, "CUBIC_INT": 7, "CAM_POINT": 14,
               "RESET": 2, "START_DSPL": 0, "CHANGE_VAR": 1 + 21, "MONITOR_VAR": 1 + 3}
    for name, n in lengths.items():
        rtc = o.BY_NAME[name]
        head = {f: 3 if f == rtc.count else k3.get(f, 3) for f, _ in rtc.head}
        assert rtc.size(head) == n, name
    assert o.table_for("notch")[0x8E].name == "NOTCH"
    assert 0x8E not in o.table_for("standard")


def test_every_mnemonic_of_the_digest_is_run_or_listed_as_not_emulated() -> None:
    """spec §4.2: every RTC mnemonic of the opcode table is in COMMANDS or its not_emulated."""
    text = digest_text("octavia")
    table = text[text.index("### 4.2 Opcode table"):text.index("### 4.3")]
    names = set(re.findall(r"^\| [0-9A-F]{2}h\*? \| ([A-Z0-9_]+) ", table, re.M))
    assert len(names) == 74
    assert COMMANDS.covers(names) == []
    assert names <= set(o.BY_NAME)


def test_an_unknown_opcode_is_cleared_and_ignored_and_the_card_goes_on() -> None:
    """spec §2.5.2: an undefined code is cleared to 00h and ignored; the next RTC runs."""
    host = Host(plant="ideal")
    for code in (0x01, 0x50, 0x57, 0xFF):
        host.raw_rtc(code, bytes(range(57)))
        assert host.u8(o.Dpr.RTC) == 0
    host.rtc("POS_PRESET", {"n": 1}, [{"pset": 77}])
    host.run(1)
    assert host.position(1) == 77


def test_a_mask_naming_missing_axes_is_parsed_and_those_axes_ignored() -> None:
    """A five-axis card: AXMOVE for axes 1 and 8 moves axis 1; axis 8's group was parsed (the
    stream stays aligned, spec §1.1) and nothing else moved."""
    host = Host(axes=5, plant="ideal")
    host.rtc("AXMOVE", {"n": 0x81}, [{"acc": 0x4000, "pos": 500, "vel": 0x100000},
                                      {"acc": 0x4000, "pos": 999, "vel": 0x100000}])
    host.run(200)
    assert host.position(1) == 500
    assert host.card.fw.core.axes.encoder.tolist() == [500, 0, 0, 0, 0]
    assert host.position(8) == 0


def test_an_eight_axis_axmove_is_read_past_the_57_byte_window() -> None:
    """An 8-axis AXMOVE needs 81 argument bytes, the window has 57 (spec Q-3): the card reads
    on past 3FBh, as naive firmware would."""
    host = Host(plant="ideal")
    groups = [{"acc": 0x4000, "pos": 100 * (a + 1), "vel": 0x80000} for a in range(8)]
    args = o.pack(o.BY_NAME["AXMOVE"], {"n": 0xFF}, groups)
    assert len(args) == 81
    host.raw_rtc(0x60, args)
    host.write(o.Dpr.HOSTACC_INT, b"\x00")  # the arguments ran over 3FDh: release the lock
    host.run(400)
    assert [host.position(a) for a in range(1, 9)] == [100 * a for a in range(1, 9)]


def test_reset_needs_its_two_signature_bytes() -> None:
    """RESET (72h AAh AAh) clears the DPR and the parameters and reports "reset finished"; with
    other bytes it is ignored (spec §2.5.2)."""
    host = Host(plant="ideal")
    host.rtc("MAXACC", {"n": 1}, [{"acc": 0x100}])
    host.write(0x200, b"\x55")
    host.write(o.Dpr.HOSTINT1, b"\x00")
    host.raw_rtc(0x72, b"\xaa\x55")
    assert host.u8(0x200) == 0x55 and host.card.fw.params.maxacc[0] == 0x100
    host.raw_rtc(0x72, b"\xaa\xaa")
    assert host.u8(0x200) == 0
    assert host.card.fw.params.maxacc[0] == 0
    assert host.read(o.Dpr.SIGNATURE, 3) == b"MX4"
    assert host.u8(o.Dpr.HOSTINT1) & o.HostInt.RESET_DONE
