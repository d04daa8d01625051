"""The drop-in `gclib` module (client/vdevclient/dropin/gclib.py): an unchanged gclib script, run
with `PYTHONPATH=$(vdevctl dropin-path)`, opens a galil-dmc13x8 card by the IP address the card
declares (`address`), against a real lockstep daemon."""

from __future__ import annotations

import importlib.util
import json
import os
import subprocess
import sys
import textwrap
import tomllib
from collections.abc import Iterator
from pathlib import Path

import pytest
import vdevclient
import vdevmaps
from vdevclient import _gclib_dropin, gclib
from vdevclient.cli import dropin_path
from vdevclient.cli import main as vdevctl

from tests.client.galil import GALIL, card, rack_config
from tests.conftest import free_endpoint
from vdevd.testing import DaemonThread

IP = "192.168.0.42"


@pytest.fixture
def daemon() -> Iterator[DaemonThread]:
    cfg = rack_config(card(GALIL, "galil0", address=IP, serial=15953),
                      card(GALIL, "galil1", axes=2, address="10.0.0.7"),
                      card(GALIL, "galil2"))
    with DaemonThread(cfg) as d:
        yield d


def run_script(daemon: DaemonThread, script: str) -> dict[str, object]:
    """Run a gclib script that imports only `gclib`, in its own interpreter, with the drop-in
    directory first on PYTHONPATH and $VDEVD_ENDPOINT at the daemon; its JSON output."""
    paths = [str(dropin_path()), str(Path(vdevclient.__file__).parents[1]),
             str(Path(vdevmaps.__file__).parents[1]), os.environ.get("PYTHONPATH", "")]
    env = {**os.environ, "PYTHONPATH": os.pathsep.join(p for p in paths if p),
           "VDEVD_ENDPOINT": daemon.endpoint}
    env.pop("VDEVD_EVENTS", None)
    done = subprocess.run([sys.executable, "-c", textwrap.dedent(script)], env=env,
                          capture_output=True, text=True, timeout=120, cwd=dropin_path().parent.parent)
    assert done.returncode == 0, done.stderr
    return json.loads(done.stdout)


def test_dropin_path_is_the_directory_holding_only_gclib(capsys: pytest.CaptureFixture[str]) -> None:
    assert vdevctl(["--endpoint", "tcp://127.0.0.1:1", "dropin-path"]) == 0  # no daemon needed
    path = Path(capsys.readouterr().out.strip())
    assert path == dropin_path()
    assert sorted(p.name for p in path.iterdir() if p.suffix == ".py" or p.is_dir()
                  and p.name != "__pycache__") == ["gclib.py"]


def test_the_dropin_is_package_data_of_vdevclient_not_a_package() -> None:
    """Installed with vdevclient (the wheel holds vdevclient/dropin/gclib.py), importable only as
    the top-level `gclib` of a path that names the directory."""
    pyproject = tomllib.loads((Path(__file__).resolve().parents[2] / "pyproject.toml").read_text())
    assert "dropin/*.py" in pyproject["tool"]["setuptools"]["package-data"]["vdevclient"]
    assert not (dropin_path() / "__init__.py").exists()
    assert dropin_path().parent == Path(vdevclient.__file__).resolve().parent


def test_names_added_to_vdevclient_gclib_later_are_the_dropin_s_too(monkeypatch: pytest.MonkeyPatch) -> None:
    """The module delegates (PEP 562) and `py` subclasses vdevclient.gclib.py: a method or code
    added there (GProgramDownload, GArrayUpload, ...) needs no change here."""
    spec = importlib.util.spec_from_file_location("gclib_under_test", dropin_path() / "gclib.py")
    assert spec is not None and spec.loader is not None
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    monkeypatch.setattr(gclib, "G_SOMETHING_NEW", -9999, raising=False)
    monkeypatch.setattr(gclib.py, "GSomethingNew", lambda self: "delegated", raising=False)
    assert module.G_SOMETHING_NEW == -9999
    assert module.py().GSomethingNew() == "delegated"
    assert module.GclibError is gclib.GclibError
    assert {"GclibError", "py", "G_NO_ERROR", "G_OPEN_ERROR", "G_TIMEOUT"} <= set(module.__all__)
    with pytest.raises(AttributeError, match="module 'gclib' has no attribute 'nothing'"):
        module.nothing  # noqa: B018


def test_an_unchanged_gclib_script_runs_on_the_card_its_address_names(daemon: DaemonThread) -> None:
    out = run_script(daemon, f"""
        import json
        import gclib

        g = gclib.py()
        out = {{"module": gclib.__file__, "version": g.GVersion()}}
        g.GOpen("{IP} --direct -s ALL")
        out["info"] = g.GInfo()
        g.GCommand("DP 1500")
        out["tp"] = g.GCommand("MG _TPX")
        g.GCommand("PR 4000;BGX")
        g.GMotionComplete("X")
        out["rp"] = g.GCommand("RPX")
        try:
            g.GCommand("XYZ")
        except gclib.GclibError as e:
            out["bad"] = str(e)
        out["tc"] = g.GCommand("TC1")
        out["addresses"] = g.GAddresses()
        g.GTimeout(50)
        try:
            g.GMessage()
        except gclib.GclibError as e:
            out["message"] = str(e)
        g.GTimeout(0)
        try:
            g.GMessage()
        except gclib.GclibError as e:
            out["message0"] = str(e)
        g.GClose()
        try:
            gclib.py().GOpen("192.168.0.99 --direct")
        except gclib.GclibError as e:
            out["unknown"] = str(e)
        out["codes"] = [gclib.G_NO_ERROR, gclib.G_OPEN_ERROR]
        print(json.dumps(out))
    """)
    assert out["module"] == str(dropin_path() / "gclib.py")
    assert str(out["version"]).startswith("py.")
    assert out["info"] == f"{IP}, DMC1348 Rev 1.1a, 15953"
    assert out["tp"] == "0000001500.0000"
    assert out["rp"] == "0000005500"  # DP 1500 then PR 4000: the move ended before RPX
    assert out["bad"] == "question mark returned by controller"
    assert out["tc"] == "1 Unrecognized command"
    assert out["addresses"] == {IP: "DMC1348 Rev 1.1a", "10.0.0.7": "DMC1328 Rev 1.1a"}
    assert out["message"] == "device timed out"  # nothing pending: gclib's time-out
    assert out["message0"] == "data was not waiting for a zero-timeout read"
    assert out["unknown"] == "device failed to open"
    assert out["codes"] == [0, -1101]


@pytest.fixture
def g(daemon: DaemonThread) -> Iterator[_gclib_dropin.py]:
    conn = _gclib_dropin.py()
    conn.GOpen(f"{IP} --direct -s ALL --endpoint {daemon.endpoint}")
    yield conn
    conn.GClose()


def test_a_qcodes_style_driver_reads_its_idn_from_ginfo(g: _gclib_dropin.py) -> None:
    """What QCoDeS's Galil driver does: GOpen(address + " --direct -s ALL"), get_idn from
    GInfo().split(" ") (model data[1], serial data[4], firmware data[3][:-1]), commands with
    a CR appended, GTimeout in ms."""
    data = g.GInfo().split(" ")
    assert (data[1], data[4], data[3][:-1]) == ("DMC1348", "15953", "1.1a")
    g.GTimeout(2000)
    assert g.timeout == 2000
    g.GCommand("SP 10000\r")
    assert g.GCommand("MG _SPX\r") == "0000010000.0000"
    assert g.GCommand("MG _TPX\r") == "0000000000.0000"


def test_gmessage_waits_the_timeout_in_card_time(g: _gclib_dropin.py, rack: vdevclient.Rack) -> None:
    g.GTimeout(80)
    start = rack.sim.now_ns()
    with pytest.raises(gclib.GclibError, match="^device timed out$"):
        g.GMessage()
    assert rack.sim.now_ns() - start == 80_000_000


def test_the_other_addressed_card_and_a_card_name_open_too(daemon: DaemonThread) -> None:
    conn = _gclib_dropin.py()
    conn.GOpen(f"--address 10.0.0.7 -t 3000 --endpoint {daemon.endpoint}")
    assert conn.GInfo() == "10.0.0.7, DMC1328 Rev 1.1a, 0"
    assert conn.timeout == 3000
    conn.GOpen(f"galil2 --endpoint {daemon.endpoint}")  # vdevclient.gclib's form still opens
    assert conn.GInfo() == "galil2, DMC1348 Rev 1.1a, 0"
    conn.GClose()


@pytest.mark.parametrize("address", ["", "--direct", "1.2.3.4 5.6.7.8", "1.2.3.4 -t", "1.2.3.4 -t x",
                                     "1.2.3.4 -a 5.6.7.8", "'unclosed"])
def test_a_bad_address_string_is_gclibs_bad_address(address: str) -> None:
    with pytest.raises(gclib.GclibError, match="^a bad address was specified in open$"):
        _gclib_dropin.parse_address(address)


def test_the_address_string_flags() -> None:
    assert _gclib_dropin.parse_address("COM1 --baud 19200 --subscribe ALL -d") == {
        "address": "COM1", "baud": "19200", "subscribe": "ALL"}
    assert _gclib_dropin.parse_address("-s MG -a 10.1.1.1 --timeout 100") == {
        "subscribe": "MG", "address": "10.1.1.1", "timeout": "100"}


def test_an_address_no_card_declares_fails_to_open(daemon: DaemonThread) -> None:
    conn = _gclib_dropin.py()
    with pytest.raises(gclib.GclibError, match="^device failed to open$"):
        conn.GOpen(f"10.9.9.9 --direct --endpoint {daemon.endpoint}")
    with pytest.raises(gclib.GclibError, match="^connection to hardware not established$"):
        conn.GCommand("TPX")


def test_no_daemon_at_the_endpoint_fails_to_open() -> None:
    """Nothing answers: gclib's failure to open (after the look-up's time-out, LOOKUP_MIN_MS)."""
    conn = _gclib_dropin.py()
    with pytest.raises(gclib.GclibError, match="^device failed to open$"):
        conn.GOpen(f"{IP} -t 1 --endpoint {free_endpoint()}")


def test_an_unchanged_gclib_application_downloads_and_runs_a_program(daemon: DaemonThread) -> None:
    """A gclib application's usual flow through the drop-in: download a program, run it, wait,
    read its message, its array and its end position, upload the program back."""
    program = "\r".join(["#A", "DM SQ[5]", "i=0", "#L", "SQ[i]=i*i", "i=i+1", "JP #L,i<5",
                         "PR 1000", "BGX", "AMX", "MG \"DONE\"", "EN"])
    out = run_script(daemon, f"""
        import json
        import gclib

        g = gclib.py()
        g.GOpen("{IP} --direct -s ALL")
        g.GProgramDownload({program!r}, "")
        g.GCommand("XQ #A")
        g.GSleep(1000)
        out = {{"message": g.GMessage(), "squares": g.GArrayUpload("SQ", 0, 4, 1),
               "tp": g.GCommand("TPX"), "running": g.GCommand("MG _XQ0"),
               "program": g.GProgramUpload()}}
        g.GClose()
        print(json.dumps(out))
    """)
    assert out["message"] == "DONE\r\n"
    assert out["squares"] == [0.0, 1.0, 4.0, 9.0, 16.0]
    assert out["tp"] == "0000001000"
    assert float(str(out["running"])) == -1.0  # the thread ended [M Ch6 _XQ]
    assert str(out["program"]).replace("\r\n", "\r").strip("\r") == program
