"""The PMAC's saved image (what SAVE writes, `Firmware.image`) checked before power-up restores
it (issue 22 §4): I-variables as an `Ixx=` command takes them (the variable's range
[SRM]), P and Q variables finite numbers of their ranges, M-definitions that parse as `Mxx->`
does; the tables, axis definitions and PLCs restored on trial. An image that fails is set aside
(`NvramStore.quarantine`) and the card powers up with its factory state."""

from __future__ import annotations

from typing import Any

from vdevd import nvcheck
from vdevd.devices.pmac.errors import CommandError
from vdevd.devices.pmac.firmware import CS_COUNT, VARIABLES, Firmware
from vdevd.devices.pmac.mvars import parse_definition
from vdevd.nvram import NvramStore


def check_image(fw: Firmware, image: dict[str, Any]) -> None:
    """`ImageError` naming the first entry of `image` a command would refuse."""
    nvcheck.only(image, fw.image().keys())
    for key, value in nvcheck.mapping(image.get("ivars", {}), "ivars").items():
        n = nvcheck.index(key, "ivars", 0, VARIABLES - 1)
        v = nvcheck.number(value, f"I{n}")
        if fw.ivars.check(n, v) is None:
            raise nvcheck.ImageError(f"I{n}: {v!r} is out of its range")
    for key, value in nvcheck.mapping(image.get("p", {}), "p").items():
        nvcheck.number(value, f"P{nvcheck.index(key, 'p', 0, VARIABLES - 1)}")
    for key, value in nvcheck.mapping(image.get("q", {}), "q").items():
        cs, _, q = nvcheck.text(key, "q key").partition(",")
        where = f"q {key!r}"
        nvcheck.number(value, f"{where}: C.S. {nvcheck.index(cs, where, 0, CS_COUNT - 1)} "
                              f"Q{nvcheck.index(q, where, 0, VARIABLES - 1)}")
    for key, value in nvcheck.mapping(image.get("mdefs", {}), "mdefs").items():
        n = nvcheck.index(key, "mdefs", 0, VARIABLES - 1)
        try:
            parse_definition(nvcheck.text(value, f"M{n}->", 256))
        except (CommandError, ValueError, IndexError) as exc:
            raise nvcheck.ImageError(f"M{n}->{value}: {exc}") from None
    for key in ("comp", "comp1d", "axes"):
        nvcheck.sequence(image.get(key, []), key)
    nvcheck.mapping(image.get("plc", {}), "plc")
    nvcheck.mapping(image.get("kinematics", {}), "kinematics")


def restore(fw: Firmware, store: NvramStore | None, name: str) -> None:
    """Power-up from the saved image of card `name`, checked; an image that fails its check
    or its restore is set aside and the card powers up with its factory state."""
    image = store.load(name, lambda image: check_image(fw, image)) if store is not None else None
    try:
        fw.restore(image or {})
    except Exception as exc:  # the tables, axes and PLCs of an image no command would make
        assert store is not None and image  # the factory state restores
        store.quarantine(name, "invalid", f"{type(exc).__name__}: {exc}")
        fw.restore({})
