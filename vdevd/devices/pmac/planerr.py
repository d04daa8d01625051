"""What a move planner answers when a move cannot be made: the coordinate system stops its program
at the start of that move and sets the status bit the Turbo SRM names [spec pmac.md §2.6 C.S.
status word 2: bit 21 circle radius error, bit 22 run-time error]."""

from __future__ import annotations

#: C.S. status word 2 bits a planner error sets [§2.6; EPICS-HW, M-vars M5181-M5190]
CIRCLE_RADIUS_ERROR = 21
RUN_TIME_ERROR = 22


class PlanError(Exception):
    """A move the card refuses while running: `bit` is the C.S. status word 2 bit to set."""

    def __init__(self, bit: int, message: str) -> None:
        super().__init__(message)
        self.bit = bit
