"""The BAR0 mailbox without a daemon (sans-I/O): a command posted through the region runs at
the doorbell and is acknowledged with its sequence number, its code and its reply; bad posts
(unknown codes, wrong argument bytes, lengths past the window, random bytes) are answered with
the documented codes and change nothing [spec adlink.md §3.8; card README "Host interface"]."""

from __future__ import annotations

import random
import struct

import numpy as np
from vdevmaps.adlink import BY_NAME, Bar, encode
from vdevmaps.aps_defs import ERR_FunctionNotAvailable, ERR_ParametersInvalid

from vdevd.devices.adlink.card import AdlinkCard
from vdevd.devices.base import CardContext


def make() -> AdlinkCard:
    return AdlinkCard("amp0", {}, CardContext(emit=lambda e: None))


def post(card: AdlinkCard, code: int, args: bytes, seq: int, length: int | None = None
         ) -> tuple[int, int, bytes]:
    bar = card.bar
    bar.write(Bar.CODE, struct.pack("<II", code, len(args) if length is None else length) + args)
    bar.write(Bar.DOORBELL, struct.pack("<I", seq))
    got_seq, rc, n, got_code = struct.unpack("<IiII", bar.read(Bar.ACK_SEQ, 16))
    assert got_seq == seq and got_code == code
    return rc, n, bar.read(Bar.REPLY, n) if n else b""


def test_a_command_runs_at_the_doorbell_and_replies() -> None:
    card = make()
    call = BY_NAME["get_axis_param_f"]
    rc, n, reply = post(card, call.code, encode(call.args, [3, 0x21]), 7)
    assert (rc, n) == (0, 8) and struct.unpack("<d", reply)[0] == 1e6


def test_bad_posts_change_nothing() -> None:
    card = make()
    rng = random.Random(19)
    before = card.kernel.axis_params.values.copy()
    bar0 = bytes(card.bar.buf[Bar.AXIS:Bar.AXIS_END])
    assert post(card, 0xEEEE, b"", 1)[0] == ERR_FunctionNotAvailable
    ptp = BY_NAME["ptp"]
    assert post(card, ptp.code, b"\x00" * 5, 2)[0] == ERR_ParametersInvalid  # truncated
    good = encode(ptp.args, [0, 0, 1.0] + [float("nan")] * 6)
    assert post(card, ptp.code, good + b"\x00", 3)[0] == ERR_ParametersInvalid  # one too many
    assert post(card, ptp.code, good, 4, length=1 << 20)[0] == ERR_ParametersInvalid
    set_f = BY_NAME["set_axis_param_f"]
    assert post(card, set_f.code, encode(set_f.args, [9, 0x21, 5.0]), 5)[0] == \
        ERR_ParametersInvalid  # axis 9 of 8
    for seq in range(6, 400):  # random codes and bytes: an APS code each time, nothing changed
        code = rng.choice([c.code for c in BY_NAME.values() if c.name.startswith("get")]
                          + [rng.randrange(1 << 16)])
        args = bytes(rng.randrange(256) for _ in range(rng.randrange(40)))
        rc = post(card, code, args, seq)[0]
        assert rc <= 0
    assert np.array_equal(before, card.kernel.axis_params.values)
    assert bytes(card.bar.buf[Bar.AXIS:Bar.AXIS_END]) == bar0
    card.tick(10)  # the card goes on


def test_reads_of_the_identity() -> None:
    card = make()
    assert card.bar.read(Bar.MAGIC, 4) == b"ADLK"
    assert struct.unpack("<IIII", card.bar.read(Bar.MODEL, 16)) == (0x208, 8, 15, 1000)
