"""vdevclient.mx4's pure parts: the RTC bytes against the manual's examples (Ch6 Examples 1-3 byte
for byte, the Ch5 listings' values), the split of long lists (spec Q-3), the unit helpers, the
status block's acknowledge. No daemon: each per-RTC function posts to a recorder."""

from __future__ import annotations

import random
import struct
from typing import Any

import pytest
from vdevclient import mx4
from vdevclient._mx4_codec import IntStatus, Post, cleared, encode, encode_list
from vdevmaps.octavia import ARG_BYTES, BY_NAME, DspStat1, DspStat2, pack, unpack


class Recorder:
    """Stands for an open card: keeps what a per-RTC function posts."""

    def __init__(self) -> None:
        self.posts: list[Post] = []
        self.checks: list[bool] = []

    def send(self, posts: list[Post], *, timeout_ms: int | None = None, check: bool = True) -> None:
        self.posts += posts
        self.checks.append(check)


def posted(fn: Any, *args: Any, **kwargs: Any) -> list[tuple[int, bytes]]:
    """(code, argument bytes) of each RTC `fn(h, *args)` posts."""
    h = Recorder()
    fn(h, *args, **kwargs)
    return [(p.code, p.args) for p in h.posts]


# -- Chapter 6, Real-Time Commands: Examples 1-3, byte for byte ---------------------------------------
def test_ch6_example_1_pos_preset_of_axis_3() -> None:
    assert posted(mx4.POS_PRESET, 0x04, [0, 0, 0x00112233]) == [
        (0x68, bytes([0x04, 0x33, 0x22, 0x11, 0x00]))]


def test_ch6_example_2_axmove_of_axes_2_and_4() -> None:
    assert posted(mx4.AXMOVE, 0x0A, acc=0x0150, pos=[0, 0x00234567, 0, 0x00112233],
                  vel=0x00200000) == [(0x60, bytes([
                      0x0A,
                      0x50, 0x01, 0x67, 0x45, 0x23, 0x00, 0x00, 0x00, 0x20, 0x00,    # 3C4h..3CDh axis 2
                      0x50, 0x01, 0x33, 0x22, 0x11, 0x00, 0x00, 0x00, 0x20, 0x00]))]  # 3CEh..3D7h axis 4


def test_ch6_example_3_en_err_of_axes_1_to_4() -> None:
    assert posted(mx4.EN_ERR, 0x0F, [0x64, 0x65, 0x66, 0x67]) == [
        (0x67, bytes([0x0F, 0x64, 0x00, 0x65, 0x00, 0x66, 0x00, 0x67, 0x00]))]


# -- Chapter 5 listings ------------------------------------------------------------------------------
def test_ctrl_example_with_the_corrected_kd_of_axis_6() -> None:
    """[Ch5 CTRL] n=28h; Kd = 7000 is 1B58h (the manual prints 1658h, spec Q-30.1)."""
    gains = {"ki": [0, 0, 0, 100, 0, 20], "kp": [0, 0, 0, 4000, 0, 8000],
             "kf": [0, 0, 0, 3000, 0, 5500], "kd": [0, 0, 0, 2500, 0, 7000]}
    assert posted(mx4.CTRL, 0x28, **gains) == [(0x62, bytes.fromhex(
        "28" "6400a00fb80bc409" "1400401f7c15581b"))]


def test_axmove_example_2_takes_the_negative_target_as_its_hex_pattern() -> None:
    """[Ch5 AXMOVE] Example 2: axis 6 to FFAA0000h; -5636096 is the same word."""
    as_hex = posted(mx4.AXMOVE, 0x20, 0x150, [0] * 5 + [0xFFAA0000], 0x00E00000)
    assert as_hex == posted(mx4.AXMOVE, 0x20, 0x150, [0] * 5 + [-0x560000], 0x00E00000)
    assert as_hex == [(0x60, bytes.fromhex("20" "5001" "0000aaff" "0000e000"))]


def test_io_examples() -> None:
    """[Ch5 OUTP_ON, OUTP_OFF, INP_STATE, POSBRK_OUT]."""
    assert posted(mx4.OUTP_ON, 0x1802, 0x0040) == [(0x56, bytes.fromhex("02184000"))]
    assert posted(mx4.OUTP_OFF, 0x1061, 0x0000) == [(0x55, bytes.fromhex("61100000"))]
    assert posted(mx4.INP_STATE, 0x000F, 0x0000) == [(0xB4, bytes.fromhex("0f000000"))]
    assert posted(mx4.POSBRK_OUT, 0x03, on1=[0x000F, 0], on2=0, off1=[0x0010, 0xFFFF],
                  off2=[0, 0xFFFF]) == [(0x7D, bytes.fromhex("03" "0f00000010000000" "00000000ffffffff"))]


def test_interrupt_control_examples() -> None:
    """[Ch5 EN_POSBRK, EN_ENCFLT, DISABL_INT, DISABL2_INT, EN_INDEX, EN_PROBE]."""
    assert posted(mx4.EN_POSBRK, 0x11, [0x0000EA60, 0, 0, 0, 0x0007A120]) == [
        (0x6B, bytes.fromhex("11" "60ea0000" "20a10700"))]
    assert posted(mx4.EN_ENCFLT, 0x0C, 0x0C, 0x01F4) == [(0x58, bytes.fromhex("0c0c" "f401f401"))]
    assert posted(mx4.DISABL_INT, 0x05, [0x04, 0, 0x20]) == [(0x64, bytes.fromhex("05" "04" "20"))]
    assert posted(mx4.DISABL2_INT, 0x49, 0x01) == [(0x5A, bytes.fromhex("49010101"))]
    assert posted(mx4.EN_INDEX, 0x80) == [(0x69, b"\x80")]
    assert posted(mx4.EN_PROBE, 0x08) == [(0x6C, b"\x08")]


def test_cam_and_gear_examples_put_groups_on_the_slave_mask() -> None:
    """[Ch5 CAM, CAM_POS (start and size as the text means them, spec Q-30.6), CAM_PROBE, GEAR,
    GEAR_PROBE (q 08h for EXT4, spec Q-30.4), CAM_POINT]."""
    assert posted(mx4.CAM, 0x01, 0x06, [0, 0, 100], [0, 10, 25]) == [
        (0xA4, bytes.fromhex("0106" "00000a00" "64001900"))]
    assert posted(mx4.CAM_POS, 0x08, 0x06, [0, 1000, 4096], [0, 0, 100], [0, 10, 25]) == [
        (0xA5, bytes.fromhex("0806" "e8030000" "0000" "0a00" "00100000" "6400" "1900"))]
    assert posted(mx4.CAM_PROBE, 0x02, 0x41, 0x02, [0] + [0] * 5 + [220], [100] + [0] * 5 + [250]) == [
        (0xA6, bytes.fromhex("024102" "00006400" "dc00fa00"))]
    assert posted(mx4.GEAR, 0x01, 0x10, mx4.ratio_to_raw(2.0)) == [(0x9C, bytes.fromhex("0110" "0001"))]
    assert posted(mx4.GEAR_PROBE, 0x08, 0x10, 0x08, mx4.ratio_to_raw(2.5)) == [
        (0x9E, bytes.fromhex("081008" "4001"))]
    assert posted(mx4.CAM_POINT, 500, 10, 2, 1000, 3000) == [
        (0xB3, bytes.fromhex("f401" "0a00" "0200" "e8030000" "b80b0000"))]


def test_contouring_and_filter_examples() -> None:
    """[Ch5 CUBIC_INT, CUBIC_SCALE, BTRATE, VECCHG, LOW_PASS (3C3h = 04h, 3C4h = 0Ah), NOTCH]."""
    assert posted(mx4.CUBIC_INT, 300, 100, 8, 0x09) == [(0xB1, bytes.fromhex("2c01" "6400" "0800" "09"))]
    assert posted(mx4.CUBIC_SCALE, 0x02, [0, 0x2000], 0) == [(0xB0, bytes.fromhex("02" "0020" "00000000"))]
    assert posted(mx4.BTRATE, 1) == [(0x73, b"\x01")]
    assert posted(mx4.VECCHG, 0x07, 0x17) == [(0x6F, b"\x07\x17")]
    assert posted(mx4.LOW_PASS, 0x04, 10) == [(0x8E, b"\x04\x0a")]
    assert posted(mx4.NOTCH, 0x02, 300, 1) == [(0x8E, bytes.fromhex("02" "2c01" "01"))]


def test_dspl_examples() -> None:
    """[Ch5 MONITOR_VAR] m=0Fh with VAR3, VAR12, VAR15, VAR55; CHANGE_VAR pairs of 7 bytes."""
    assert posted(mx4.MONITOR_VAR, 0x0F, [3, 12, 15, 55]) == [(0xB2, bytes.fromhex("0f030c0f37"))]
    assert posted(mx4.CHANGE_VAR, [(1, b"\x01\x02\x03\x04\x05\x06")]) == [
        (0xAD, bytes.fromhex("01" "01" "010203040506"))]
    with pytest.raises(ValueError, match="6"):
        posted(mx4.CHANGE_VAR, [(1, b"\x01")])


def test_reset_sends_its_signature_and_is_not_checked() -> None:
    h = Recorder()
    mx4.RESET(h)  # type: ignore[arg-type]
    assert [(p.code, p.args) for p in h.posts] == [(0x72, b"\xaa\xaa")] and h.checks == [False]


def test_encode_agrees_with_the_shared_layouts_for_every_rtc() -> None:
    """vdevmaps.octavia's `pack` is the one source of the layouts (the card decodes with it):
    for every RTC, seeded random values of every field, as many axes as one post holds."""
    rng = random.Random(18)
    bits = {"B": 8, "H": 16, "I": 32, "b": 8, "h": 16, "i": 32}

    def value(code: str) -> Any:
        if code == "6s":
            return rng.randbytes(6)
        if code == "f":
            return struct.unpack("<f", struct.pack("<f", rng.uniform(-1e4, 1e4)))[0]
        n = bits[code]
        return rng.randrange(-(1 << (n - 1)), 1 << (n - 1)) if code.islower() else rng.randrange(1 << n)

    for name, rtc in BY_NAME.items():
        head = {f: value(c) for f, c in rtc.head}
        if rtc.count is not None:
            items = [{f: value(c) for f, c in rtc.group} for _ in range(rng.randint(1, 8))]
            head[rtc.count] = len(items)
            assert encode_list(name, items) == [Post(name, rtc.code, pack(rtc, head, items))], name
            continue
        groups: list[dict[str, Any]] = []
        per_axis: dict[str, Any] = {}
        if rtc.mask is not None:
            room = (ARG_BYTES - rtc.head_size) // rtc.group_size
            axes = sorted(rng.sample(range(8), rng.randint(1, min(room, 8))))
            head[rtc.mask] = sum(1 << a for a in axes)
            rows = {a: {f: value(c) for f, c in rtc.group} for a in axes}
            groups = [rows[a] for a in axes]
            per_axis = {f: [rows[a][f] if a in rows else 0 for a in range(8)] for f, _ in rtc.group}
        assert encode(name, head, **per_axis) == [Post(name, rtc.code, pack(rtc, head, groups))], name


def test_every_mnemonic_of_the_table_has_its_function() -> None:
    for name in BY_NAME:
        assert callable(getattr(mx4, name)), name


# -- the split of long lists (spec Q-3) -------------------------------------------------------------
def test_an_8_axis_axmove_of_81_bytes_goes_as_5_axes_then_3() -> None:
    posts = posted(mx4.AXMOVE, 0xFF, acc=0x150, pos=list(range(1000, 9000, 1000)), vel=0x10000)
    assert [(code, len(args), args[0]) for code, args in posts] == [(0x60, 51, 0x1F), (0x60, 31, 0xE0)]
    rtc = BY_NAME["AXMOVE"]
    groups = [g for _, args in posts for g in unpack(rtc, args)[1]]
    assert [(axis, g["pos"]) for axis, g in groups] == [(a, 1000 * a) for a in range(1, 9)]


def test_splits_fill_the_57_byte_window() -> None:
    assert [len(a) for _, a in posted(mx4.CTRL, 0xFF, 1, 2, 3, 4)] == [57, 9]
    assert [len(a) for _, a in posted(mx4.CAM_POS, 0x01, 0xFE, 0, 0, 3)] == [50, 10]
    assert [len(a) for _, a in posted(mx4.POS_PRESET, 0xFF, 0)] == [33]
    pairs = [(v, bytes(6)) for v in range(1, 10)]
    assert [len(a) for _, a in posted(mx4.CHANGE_VAR, pairs)] == [ARG_BYTES, 8]
    full = encode_list("CHANGE_VAR", [{"var": 1, "value": bytes(6)}] * 8)
    assert [len(p.args) for p in full] == [ARG_BYTES]


def test_encode_refuses_what_does_not_fit() -> None:
    with pytest.raises(ValueError, match="acc = 65536"):
        encode("MAXACC", {"n": 1}, acc=0x10000)
    with pytest.raises(ValueError, match="vel = -1 does not fit an unsigned"):
        encode("AXMOVE", {"n": 1}, acc=1, pos=0, vel=-1)  # AXMOVE's slew is unsigned [Ch5 AXMOVE]
    with pytest.raises(ValueError, match="no value for axis 3"):
        encode("MAXACC", {"n": 0x04}, acc=[1, 2])
    with pytest.raises(TypeError, match="CTRL takes"):
        encode("CTRL", {"n": 1}, ki=1, kp=1)
    with pytest.raises(ValueError, match="n = 256 does not fit"):
        encode("STOP", {"n": 0x100})
    with pytest.raises(ValueError, match="mask 0x100"):
        encode("MAXACC", {"n": 0x100}, acc=1)
    assert encode("VELMODE", {"n": 1}, vel=-0x3B5C3)[0].args == bytes.fromhex("01" "3d4afcff")


# -- units [Ch5 State Variables; spec §1.3] -----------------------------------------------------------
def test_units_match_the_manual_worked_values() -> None:
    assert mx4.raw_to_acc(0x077B) == pytest.approx(0.0584, abs=1e-4)
    assert mx4.raw_to_vel(0x000A8000) == 10.5
    assert mx4.acc_to_raw(0.25) == 0x2000  # MAXACC example
    assert mx4.acc_to_raw(0.5) == 0x4000  # ESTOP_ACC example
    assert mx4.vel_to_raw(3.71) == 0x0003B5C3  # VELMODE example
    assert mx4.vel_to_raw(32) == 0x00200000  # AXMOVE example 1
    assert mx4.volts_to_dac(3.7) == 0x2F5C  # DDAC example
    assert mx4.volts_to_dac(7.5) == 0x5FFF  # TRQ_LIMIT example
    assert mx4.ratio_to_raw(0.25) == 0x0020 and mx4.ratio_to_raw(2.0) == 0x0100  # LOAD_CAM_TABLE
    assert mx4.ratio_to_raw(-0.2) & 0xFFFF == 0xFFE6


def test_units_round_trip_and_refuse_out_of_range() -> None:
    for v in (-255.5, -3.71, 0.0, 1.25, 255.99):
        assert mx4.raw_to_vel(mx4.vel_to_raw(v)) == pytest.approx(v, abs=1 / 65536)
    assert mx4.raw_to_vel(mx4.vel_to_raw(-3.5) & 0xFFFFFFFF) == -3.5  # the DPR word
    assert mx4.raw_to_ratio(mx4.ratio_to_raw(-2.5)) == -2.5
    assert mx4.dac_to_volts(mx4.volts_to_dac(-10.0)) == pytest.approx(-10.0)
    assert mx4.raw_to_acc(mx4.acc_to_raw(1.5)) == 1.5
    for fn, value in ((mx4.acc_to_raw, 2.0), (mx4.acc_to_raw, -0.1), (mx4.vel_to_raw, 256.0),
                      (mx4.ratio_to_raw, 256.0), (mx4.volts_to_dac, 10.01)):
        with pytest.raises(ValueError):
            fn(value)


# -- the status block [Ch6 Handling Interrupts] ------------------------------------------------------
def test_cleared_takes_sources_by_axis_and_the_type_once_empty() -> None:
    raw = bytes([0x14, 0, 0, 0x80, 0, 0x03, 0, 0, 0, 0x04, 0, 0, 0x02, 0, 0, 0])
    assert cleared(raw, DspStat1.MOTCP, 0, 0x01)[:6] == bytes([0x14, 0, 0, 0x80, 0, 0x02])
    assert cleared(raw, DspStat1.MOTCP, 0, 0x03)[:6] == bytes([0x04, 0, 0, 0x80, 0, 0x00])
    assert cleared(raw, DspStat1.MOTCP | DspStat1.INDEX, 0, True)[:6] == bytes(6)
    assert cleared(raw, DspStat1.MOTCP, 0, False)[:6] == bytes([0x04, 0, 0, 0x80, 0, 0x03])
    after = cleared(raw, 0, DspStat2.OFFSET, True)
    assert after[9] == 0 and after[12] == 0
    status = IntStatus(raw)
    assert status.sources(DspStat1.MOTCP) == 0x03 and status.sources(DspStat2.OFFSET) == 0x02


def test_ratio_helpers_take_the_cards_gear_ratio_bits() -> None:
    """1.8.7 by default (0.25 -> 0020h, the LOAD_CAM_TABLE example); 12 fraction bits as the
    GEAR examples encode 2.0 (2000h) and 2.5 (2800h) [Ch5 GEAR; spec Q-5]."""
    assert mx4.ratio_to_raw(0.25) == 0x20
    assert mx4.ratio_to_raw(2.0, bits=12) == 0x2000 and mx4.ratio_to_raw(2.5, bits=12) == 0x2800
    assert mx4.raw_to_ratio(0x2800, bits=12) == 2.5
    with pytest.raises(ValueError):
        mx4.ratio_to_raw(9.0, bits=12)
