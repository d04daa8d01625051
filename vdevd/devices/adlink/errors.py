"""The exception a kernel command handler raises to answer an APS return code [spec adlink.md
§3.8]; the codes are `vdevmaps.aps_defs`' ERR_*."""

from __future__ import annotations

from vdevmaps.aps_defs import ERR_CommandInProcess, ERR_ParametersInvalid


class ApsError(Exception):
    """A command refused with an APS return code (nothing changed)."""

    def __init__(self, code: int, why: str = "") -> None:
        super().__init__(why or str(code))
        self.code = code


def invalid(why: str) -> ApsError:
    return ApsError(ERR_ParametersInvalid, why)


def busy(why: str) -> ApsError:
    return ApsError(ERR_CommandInProcess, why)
