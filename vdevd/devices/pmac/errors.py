"""The error numbers an invalid on-line command answers (`<BELL>ERRnnn<CR>` with I6 = 1 or 3)
[spec pmac.md §2.4 "Error codes"; DLS-lib PMAC_errors, Turbo SRM I6]."""

from __future__ import annotations

ERR_DATA = 3         # data error or unrecognized command
ERR_ILLEGAL = 4      # illegal character (>127 outside a comment)
ERR_NOT_OPEN = 5     # command not allowed unless a buffer is open
ERR_IN_USE = 7       # buffer already in use (another one is open, or the buffer order)
ERR_MACRO = 8        # MACRO auxiliary communication error
ERR_NO_PROGRAM = 15  # not pointing to a valid program buffer
ERR_PHASE = 18       # enabling with the phase-clock error set


class CommandError(Exception):
    """An invalid command: `code` is the ERRnnn number."""

    def __init__(self, code: int = ERR_DATA, message: str = "") -> None:
        super().__init__(message or f"ERR{code:03d}")
        self.code = code
