"""One source for the Turbo PMAC's bus maps: vdevmaps.pmac holds only constants and imports
neither side; the client's PMAC modules never import the daemon [DESIGN "Second step"]."""

from __future__ import annotations

import ast
from pathlib import Path

import vdevclient
import vdevmaps.pmac

CLIENT = Path(vdevclient.__file__).resolve().parent
CLIENT_PMAC = ("_pmac_bus.py", "_pcomm_codes.py", "_pcomm_device.py", "_pcomm_download.py",
               "_pcomm_dpr.py", "pcomm.py")


def imported_packages(path: Path) -> set[str]:
    """The top-level packages a module imports anywhere in it."""
    found: set[str] = set()
    for node in ast.walk(ast.parse(path.read_text(encoding="utf-8"))):
        if isinstance(node, ast.Import):
            found.update(alias.name.split(".")[0] for alias in node.names)
        elif isinstance(node, ast.ImportFrom) and node.module and not node.level:
            found.add(node.module.split(".")[0])
    return found


def test_the_map_imports_neither_the_daemon_nor_the_client() -> None:
    assert imported_packages(Path(vdevmaps.pmac.__file__)) <= {"__future__", "enum"}


def test_the_client_never_imports_the_daemon() -> None:
    for name in CLIENT_PMAC:
        assert "vdevd" not in imported_packages(CLIENT / name), name


def test_daemon_and_client_share_one_interrupt_map() -> None:
    from vdevclient import pcomm

    from vdevd.devices.pmac import card

    assert pcomm.HostIrq is vdevmaps.pmac.HostIrq is card.HostIrq
