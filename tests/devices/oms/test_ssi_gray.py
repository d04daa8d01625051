"""SSI words of Gray-code encoders (card option `ssi_code = "gray"`; spec oms.md §5.8: the card
latches "the simulated encoder's SSI word (binary or Gray, as the encoder model dictates)", and a
host decodes Gray itself, as EPICS drvMAXv's `greyCode` does)."""

from __future__ import annotations

from vdevmaps.oms import Shm

from tests.devices.oms.conftest import maxk_card

TYPES = ["stepper_encoder", "stepper_encoder", "stepper", "stepper"]


def gray(n: int) -> int:
    return n ^ (n >> 1)


def gray_decode(g: int) -> int:
    """What a host does with the word (the inverse of gray)."""
    n = 0
    while g:
        n ^= g
        g >>= 1
    return n


def test_a_gray_encoder_sends_the_gray_code_of_its_position() -> None:
    with maxk_card(axis_types=TYPES, ssi_code="gray") as maxk:
        maxk.send("AX ECA12,125000; AY ECA32,4000000;")
        for position in (0, 1, 2, 3, 1000, 4095, 4096 + 7, -1):
            maxk.send(f"AX LP{position}; AY LP{position};")
            maxk.step(1)
            x, y = maxk.shm.read32(Shm.SSI_POSITION), maxk.shm.read32(Shm.SSI_POSITION + 4)
            assert x == gray(position & 0xFFF), position  # within 12 bits, wrapped
            assert gray_decode(x) == position & 0xFFF
            assert y == gray(position & 0xFFFFFFFF), position
        # consecutive positions differ in one bit: the point of the code
        maxk.send("AX LP2047;")
        maxk.step(1)
        before = maxk.shm.read32(Shm.SSI_POSITION)
        maxk.send("AX LP2048;")
        maxk.step(1)
        assert bin(before ^ maxk.shm.read32(Shm.SSI_POSITION)).count("1") == 1


def test_binary_is_the_default_code() -> None:
    with maxk_card(axis_types=TYPES) as maxk:
        maxk.send("AX ECA12,125000; AX LP2048;")
        maxk.step(1)
        assert maxk.shm.read32(Shm.SSI_POSITION) == 2048
