"""Non-volatile memory: saved atomically to the state directory, restored at start (DESIGN.md)."""

from __future__ import annotations

from pathlib import Path

import pytest
import vdevclient

from tests.conftest import rack_config
from tests.protocol.motion import axis_reg
from vdevd.devices.generic.regions import AxisReg
from vdevd.nvram import NvramStore
from vdevd.testing import DaemonThread


def test_store_round_trips_and_leaves_no_temporary_files(tmp_path: Path) -> None:
    store = NvramStore(tmp_path / "state")
    assert store.load("card") is None
    store.save("card", {"vmax": [1, 2], "name": "x"})
    store.save("card", {"vmax": [3, 4], "name": "y"})
    assert store.load("card") == {"vmax": [3, 4], "name": "y"}
    assert [p.name for p in (tmp_path / "state").iterdir()] == ["card.nvram"]


def test_saved_parameters_survive_a_daemon_restart(tmp_path: Path) -> None:
    cfg = rack_config()
    cfg.state_dir = str(tmp_path)
    vmax1 = axis_reg(1, AxisReg.VMAX)
    with DaemonThread(cfg) as d, vdevclient.connect(d.endpoint) as rack:
        bar = rack.card("servo0").region("bar0")
        bar.write32(vmax1, 12_345)
        rack.control("servo0", "save")
        bar.write32(vmax1, 999)  # not saved
    with DaemonThread(cfg) as d, vdevclient.connect(d.endpoint) as rack:
        assert rack.card("servo0").region("bar0").read32(vmax1) == 12_345


def test_save_without_a_state_directory_is_refused(rack: vdevclient.Rack) -> None:
    with pytest.raises(vdevclient.RemoteError) as info:
        rack.control("servo0", "save")
    assert info.value.code == "bad_param"


def test_pytest_plugin_fixture_gives_a_lockstep_default_rack(vdevd_rack: vdevclient.Rack) -> None:
    assert vdevd_rack.sim.mode == "lockstep"
    assert {c.type for c in vdevd_rack.cards()} >= {"generic-servo"}


@pytest.mark.parametrize("image", [b"\xc1", b"\x82\xa4vmax", b"\x93\x01\x02\x03"])
def test_an_unreadable_flash_image_starts_the_card_from_its_defaults(tmp_path: Path,
                                                                      image: bytes) -> None:
    (tmp_path / "servo0.nvram").write_bytes(image)  # not msgpack, truncated, not a map
    (tmp_path / ".servo0.k1ll3d").write_bytes(b"half a save")  # a save killed mid-write
    cfg = rack_config()
    cfg.state_dir = str(tmp_path)
    vmax0 = axis_reg(0, AxisReg.VMAX)
    with DaemonThread(cfg) as d, vdevclient.connect(d.endpoint) as rack:
        bar = rack.card("servo0").region("bar0")
        assert bar.read32(vmax0) == 50_000  # the power-on default
        bar.write32(vmax0, 777)
        rack.control("servo0", "save")
    assert sorted(p.name for p in tmp_path.iterdir()) == ["servo0.nvram", "servo0.nvram.corrupt"]
    assert (tmp_path / "servo0.nvram.corrupt").read_bytes() == image
    assert NvramStore(tmp_path).load("servo0")["vmax"][0] == 777  # type: ignore[index]
