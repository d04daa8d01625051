"""The 64 extended TTL I/O points 17-80, in banks 2-9 of 8, each an input or an output bank as
`CO` configures it [M Ch1 §General I/O, Ch3 §Uncommitted Digital Inputs; spec §1 "Extended
I/O"; the form of CO, OP and TI is the DMC-1700/1800's appendix "64 Extended I/O" and command
reference, which the seed's appendix would hold]. Plain state, no I/O.

`CO n`: bit k of n (0..255) makes bank k+2 (points 17+8k .. 24+8k) outputs; 0 (power-on) makes
every bank inputs. An input point reads its level (open: 1; the backdoor drives it); an output
point reads its output latch. SB/CB/OB on a point of an input bank are refused (TC 6, the card's
choice: the manual says nothing); OP's words a-d write the output banks only ("Arguments that are
given for I/O points configured as inputs will be ignored").
"""

from __future__ import annotations

from vdevd.devices.galil.errors import TC, GalilError

FIRST_POINT = 17
LAST_POINT = 80
FIRST_BANK = 2
LAST_BANK = 9
_ALL = (1 << 64) - 1


class ExtendedIO:
    """CO's configuration, the output latches and the input levels of points 17-80."""

    def __init__(self) -> None:
        self.config = 0  # CO n: bit k = bank k + 2 is an output bank
        self.latches = 0  # bit i = output point 17 + i
        self.levels = _ALL  # bit i = input point 17 + i (open inputs read 1)

    def reset(self) -> None:
        """RS: CO 0 (every bank inputs), the latches cleared; driven levels stay."""
        self.config = 0
        self.latches = 0

    def configure(self, n: int) -> None:
        """CO n (0..255); the output latches of banks made inputs clear."""
        if not 0 <= n <= 255:
            raise GalilError(TC.NUMBER_OUT_OF_RANGE, f"CO {n}")
        self.config = n
        self.latches &= self.output_mask()

    def output_mask(self) -> int:
        """The bits of the points of output banks."""
        mask = 0
        for k in range(8):
            if self.config >> k & 1:
                mask |= 0xFF << (8 * k)
        return mask

    def is_output(self, point: int) -> bool:
        return bool(self.config >> ((point - FIRST_POINT) // 8) & 1)

    def write(self, point: int, on: bool) -> None:
        """SB/CB/OB on an output point; TC 6 on a point of an input bank."""
        if not self.is_output(point):
            raise GalilError(TC.NUMBER_OUT_OF_RANGE, f"output {point}: an input bank (CO)")
        bit = 1 << (point - FIRST_POINT)
        self.latches = self.latches | bit if on else self.latches & ~bit

    def write_words(self, words: list[int | None]) -> None:
        """OP's a, b, c, d: 16 bits each for banks 2-3, 4-5, 6-7, 8-9; None leaves them."""
        mask = self.output_mask()
        for k, word in enumerate(words):
            if word is None:
                continue
            shift = 16 * k
            keep = ~(0xFFFF << shift) | ~mask
            self.latches = (self.latches & keep) | ((word << shift) & mask)

    def word(self, k: int) -> int:
        """OP's k-th word as the outputs read (0 for input banks)."""
        return self.latches >> (16 * k) & 0xFFFF

    def output(self, point: int) -> int:
        """@OUT[n]: the output latch (0 on an input bank)."""
        return self.latches >> (point - FIRST_POINT) & 1

    def read(self, point: int) -> int:
        """@IN[n]: an input point's level, an output point's latch."""
        if self.is_output(point):
            return self.output(point)
        return self.levels >> (point - FIRST_POINT) & 1

    def bank(self, n: int) -> int:
        """TI n (2..9): the bank's 8 points as a byte, as `read` gives them."""
        shift = 8 * (n - FIRST_BANK)
        source = self.latches if self.config >> (n - FIRST_BANK) & 1 else self.levels
        return source >> shift & 0xFF

    def record_bytes(self) -> tuple[bytes, bytes]:
        """The data record's banks 2-9: what TI reads, and the latches of output banks."""
        mask = self.output_mask()
        seen = (self.latches & mask) | (self.levels & ~mask & _ALL)
        return seen.to_bytes(8, "little"), (self.latches & mask).to_bytes(8, "little")

    def set_input(self, point: int, level: bool) -> None:
        """The level driven on an input point (an output bank ignores it until made inputs)."""
        bit = 1 << (point - FIRST_POINT)
        self.levels = self.levels | bit if level else self.levels & ~bit
