"""The DMC-13X8's flash image (what BP, BV and BN burn, flash.py) checked before power-up restores
it (issue 22 §4): programs as a download takes them (TC 60/61/62/98), variables and arrays as
their assignments and DM take them (names, finite values, the array space), parameters as their
commands take them (params.py's ranges), EO, LZ, PF, VF, CO and OP as those commands do. An
image that fails is set aside (`NvramStore.quarantine`): the card powers up from its defaults,
whole, not with some sections of a bad image."""

from __future__ import annotations

from typing import Any

from vdevd import nvcheck
from vdevd.devices.galil.arrays import ArrayTable
from vdevd.devices.galil.errors import GalilError
from vdevd.devices.galil.expr import MAX_NAME_LENGTH
from vdevd.devices.galil.flash import _NOT_BURNED, FORMAT
from vdevd.devices.galil.formats import parse_format
from vdevd.devices.galil.params import PARAMS
from vdevd.devices.galil.program import Program

_SECTIONS = ("format", "version", "programs", "variables", "arrays", "parameters")
_PARAMETERS = ("values", "motor_off", "EO", "LZ", "PF", "VF", "CO", "OP", "extended_outputs")


def check_image(n: int, image: dict[str, Any]) -> None:
    """`ImageError` naming the first entry of an `n`-axis card's saved image (`{"flash": ...}`)
    a command would refuse."""
    nvcheck.only(image, ("flash",))
    if "flash" not in image:
        return
    flash = nvcheck.mapping(image["flash"], "flash")
    nvcheck.only(flash, _SECTIONS, "flash")
    if flash.get("format") != FORMAT:
        raise nvcheck.ImageError(f"flash: format {flash.get('format')!r}, not {FORMAT!r}")
    try:
        if "programs" in flash:
            lines = nvcheck.sequence(flash["programs"], "programs")
            Program().load([nvcheck.text(line, f"programs[{k}]") for k, line in enumerate(lines)])
        for name, value in nvcheck.mapping(flash.get("variables", {}), "variables").items():
            nvcheck.number(value, f"variable {_name(name, 'variables')}")
        arrays = nvcheck.mapping(flash.get("arrays", {}), "arrays")
        sizes = []
        for name, values in arrays.items():
            for k, v in enumerate(nvcheck.sequence(values, f"array {_name(name, 'arrays')}")):
                nvcheck.number(v, f"{name}[{k}]")
            sizes.append((name, len(values)))
        ArrayTable().check_dimension(sizes)
    except GalilError as exc:
        raise nvcheck.ImageError(f"{exc} (TC {exc.code})") from None
    if "parameters" in flash:
        _parameters(n, nvcheck.mapping(flash["parameters"], "parameters"))


def _name(name: Any, where: str) -> str:
    text = nvcheck.text(name, where, MAX_NAME_LENGTH)
    if not text[:1].isalpha() or not text.isalnum() or not text.isascii():
        raise nvcheck.ImageError(f"{where}: {text!r} is not a name")
    return text


def _parameters(n: int, section: dict[str, Any]) -> None:
    nvcheck.only(section, _PARAMETERS, "parameters")
    for name, values in nvcheck.mapping(section.get("values", {}), "values").items():
        param = PARAMS.get(name) if isinstance(name, str) and name not in _NOT_BURNED else None
        if param is None:
            raise nvcheck.ImageError(f"values: {name!r} is no parameter BN burns")
        for a, v in enumerate(nvcheck.sequence(values, name, most=n)):
            if param.coerce(nvcheck.number(v, f"{name}[{a}]")) is None:
                raise nvcheck.ImageError(f"{name}[{a}]: {v!r} is out of range (TC 6)")
    for a, v in enumerate(nvcheck.sequence(section.get("motor_off", []), "motor_off", most=n)):
        nvcheck.flag(v, f"motor_off[{a}]")
    for name in ("EO", "LZ"):
        if name in section:
            nvcheck.flag(section[name], name)
    for name in ("PF", "VF"):
        if name in section:
            m, f = nvcheck.sequence(section[name], name, 2)
            form = f"{nvcheck.number(m, name, integer=True)}.{nvcheck.number(f, name, integer=True)}"
            if parse_format(form) is None:
                raise nvcheck.ImageError(f"{name}: {form} is out of range (TC 6)")
    if "CO" in section:
        nvcheck.number(section["CO"], "CO", 0, 255, integer=True)
    if "OP" in section:
        nvcheck.number(section["OP"], "OP", 0, 255, integer=True)
    if "extended_outputs" in section:
        nvcheck.number(section["extended_outputs"], "extended_outputs", 0, 2**64 - 1,
                       integer=True)
