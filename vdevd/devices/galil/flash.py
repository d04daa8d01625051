"""The DMC-13X8's flash EEPROM: what BP, BV and BN burn and what power-up and RS restore (spec
galil.md §1.4-1.5; [M Ch1 §Microcomputer Section] "2M Flash EEPROM provides non-volatile storage
of variables, programs, and arrays"; [M Ch2 Step 7b E] BN).

Sans-I/O: the card hands `save(image)` (an atomic write in the daemon's state directory,
vdevd/nvram.py) and the image it loaded at start. The image is a map of sections:
`programs` (the lines), `variables` ({name: value}), `arrays` ({name: elements}, burned with
the variables by BV), `parameters` ({command: per-axis values}, the motor-off state and EO/LZ).
A section that does not read back (another program's or version's image) is skipped with a
warning: the card keeps its defaults. `^R^S` (master reset) erases the flash [M Ch2 §Master
Reset].
"""

from __future__ import annotations

import logging
from collections.abc import Callable
from typing import TYPE_CHECKING, Any

from vdevd.devices.galil.errors import GalilError
from vdevd.devices.galil.formats import parse_format
from vdevd.devices.galil.params import PARAMS

if TYPE_CHECKING:
    from vdevd.devices.galil.firmware import Firmware

log = logging.getLogger("vdevd.galil.flash")

FORMAT = "vdevd-galil-dmc13x8-flash"
VERSION = 1
#: parameters BN does not burn: the move commands' targets
_NOT_BURNED = frozenset({"PR", "PA"})


class Flash:
    """The burned image of one card, with its burn and restore procedures."""

    def __init__(self, fw: Firmware, save: Callable[[dict[str, Any]], None] | None = None,
                 image: dict[str, Any] | None = None) -> None:
        self.fw = fw
        self.save = save
        self.image: dict[str, Any] = {}
        if image is not None:
            if isinstance(image, dict) and image.get("format") == FORMAT:
                self.image = dict(image)
            else:
                log.warning("flash image of another kind ignored: the card starts from its defaults")

    # -- burning ----------------------------------------------------------------------------------------
    def burn(self, what: str) -> None:
        """BP "programs", BV "variables" (and arrays), BN "parameters"."""
        fw = self.fw
        if what == "programs":
            self.image["programs"] = list(fw.threads.program.lines)
        elif what == "variables":
            self.image["variables"] = dict(fw.variables)
            self.image["arrays"] = {name: a.tolist() for name, a in fw.arrays.arrays.items()}
        elif what == "parameters":
            m = fw.motion
            self.image["parameters"] = {
                "values": {name: m.values[name].tolist() for name in PARAMS if name not in _NOT_BURNED},
                "motor_off": (~m.core.servo_on_mask).tolist(),
                "EO": fw.echo, "LZ": fw.lz,
                # PF, VF; CO and the outputs ("The configuration of the extended I/O and the
                # state of the outputs can be stored in the EEPROM with the BN command",
                # DMC-1700/1800 appendix)
                "PF": [fw.pf.digits, fw.pf.frac], "VF": [fw.vf.digits, fw.vf.frac],
                "CO": fw.ext.config, "OP": fw.outputs, "extended_outputs": fw.ext.latches,
            }
        else:
            raise ValueError(what)
        self.write()

    def write(self) -> None:
        if self.save is not None:
            self.save({**self.image, "format": FORMAT, "version": VERSION})

    def erase(self) -> None:
        """^R^S: the flash returns to the factory state."""
        self.image = {}
        self.write()

    # -- power-up / RS ------------------------------------------------------------------------------
    def restore(self) -> None:
        """Programs, variables and parameters from the image; a section that does not read
        back is skipped with a warning."""
        for name, apply in (("programs", self._programs), ("variables", self._variables),
                            ("arrays", self._arrays), ("parameters", self._parameters)):
            if name in self.image:
                try:
                    apply(self.image[name])
                except (GalilError, TypeError, ValueError, KeyError, AttributeError) as exc:
                    log.warning("flash section %s unreadable (%s): defaults kept", name, exc)

    def _programs(self, lines: Any) -> None:
        if not isinstance(lines, list) or not all(isinstance(s, str) for s in lines):
            raise TypeError("programs is not a list of lines")
        self.fw.threads.program.load(lines)

    def _variables(self, values: Any) -> None:
        good = {str(k): float(v) for k, v in dict(values).items()}
        self.fw.variables.update(good)

    def _arrays(self, section: Any) -> None:
        arrays = {str(name): [float(v) for v in values] for name, values in dict(section).items()}
        table = self.fw.arrays
        table.dimension([(name, len(values)) for name, values in arrays.items()])
        for name, values in arrays.items():
            table.array(name)[:] = values

    def _parameters(self, section: Any) -> None:
        fw = self.fw
        m = fw.motion
        n = fw.n
        for name, vals in dict(section["values"]).items():
            if name not in PARAMS or name in _NOT_BURNED:
                continue
            coerced = [PARAMS[name].coerce(float(v)) for v in list(vals)[:n]]
            axes = [a for a, v in enumerate(coerced) if v is not None]
            m.set_param(name, axes, [v for v in coerced if v is not None])
        off = [a for a, v in enumerate(list(section.get("motor_off", []))[:n]) if v]
        if off:
            m.motor_off(off)
        fw.echo = int(section.get("EO", fw.echo)) & 1
        fw.lz = int(section.get("LZ", fw.lz)) & 1
        for name in ("PF", "VF"):
            if name in section:
                m_, n_ = (int(v) for v in section[name])
                form = parse_format(f"{m_}.{n_}")
                if form is not None:
                    setattr(fw, name.lower(), form)
        if "CO" in section:
            fw.ext.configure(int(section["CO"]) & 0xFF)
            fw.ext.latches = int(section.get("extended_outputs", 0)) & fw.ext.output_mask()
        fw.outputs = int(section.get("OP", fw.outputs)) & 0xFF
