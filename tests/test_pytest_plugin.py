"""The `vdevd` pytest plugin (vdevd/pytest_plugin.py), run on test files of an application's
through pytester: the rack chosen per test or module (marker, ini option), one daemon per rack
for the session, reset between tests, the events endpoint and the `vdevd_step` helper."""

from __future__ import annotations

import re
from pathlib import Path

import pytest

pytest_plugins = ["pytester"]

STAGE = """
[clock]
mode = "realtime"           # the plugin runs lockstep all the same
[state]
dir = "/nonexistent/never-written"
[[card]]
type = "generic-servo"
name = "stage"
axes = 2
plant = "ideal"
"""

PMAC = """
[[card]]
type = "pmac-turbo"
name = "pmac0"
ethernet = "tcp://127.0.0.1:1025"
"""

APPLICATION = '''
import os
import socket
import pytest
import vdevclient
import zmq
import msgpack

pytestmark = pytest.mark.vdevd_rack("racks/stage.toml")
SEEN = {}
TARGET, COMMAND, POSITION, IRQ_ENABLE = 0x104, 0x100, 0x11C, 0x24


def move_to(rack, position):
    """The application: a move of the stage's axis 0."""
    bar = rack.card("stage").region("bar0")
    bar.write32(IRQ_ENABLE, 1)
    bar.write32(TARGET, position)
    bar.write32(COMMAND, 1)


def test_moves_and_steps(vdevd_daemon, vdevd_rack, vdevd_step, vdevd_events):
    SEEN["endpoint"] = vdevd_daemon.endpoint
    assert [c.name for c in vdevd_rack.cards()] == ["stage"]
    assert vdevd_rack.sim.mode == "lockstep"
    sub = zmq.Context.instance().socket(zmq.SUB)
    sub.linger = 0
    sub.subscribe(b"stage")
    sub.connect(vdevd_events)
    while not sub.poll(100):  # until the subscription is through: a sync event arrives
        vdevd_rack.request("sync", card="stage")
    move_to(vdevd_rack, 1000)
    assert vdevd_step(0.5) == 500_000_000
    assert vdevd_rack.card("stage").region("bar0").read32(POSITION) == 1000
    kinds = []
    while "irq" not in kinds and sub.poll(10_000):
        kinds.append(msgpack.unpackb(sub.recv_multipart()[1])["kind"])
    assert "irq" in kinds
    sub.close()
    vdevd_rack.card("stage").control("save")
    assert os.listdir(vdevd_daemon.cfg.state_dir) == ["stage.nvram"]


def test_the_next_test_finds_the_rack_reset(vdevd_daemon, vdevd_rack):
    assert vdevd_daemon.endpoint == SEEN["endpoint"]  # the same daemon
    assert vdevd_rack.sim.now_ns() == 0
    assert vdevd_rack.card("stage").region("bar0").read32(POSITION) == 0
    assert os.listdir(vdevd_daemon.cfg.state_dir) == []  # the last test's save is gone


def test_the_environment_names_the_daemon(vdevd_daemon):
    with vdevclient.connect() as rack:
        assert [c.name for c in rack.cards()] == ["stage"]


@pytest.mark.vdevd_rack("racks/pmac.toml")
def test_a_test_of_its_own_rack_and_card_port(vdevd_daemon, vdevd_rack):
    assert [c.name for c in vdevd_rack.cards()] == ["pmac0"]
    ethernet = vdevd_daemon.listeners()["cards"]["pmac0"]["ethernet"]
    assert not ethernet.endswith(":1025")  # moved to a free port
    host, port = ethernet.removeprefix("tcp://").rsplit(":", 1)
    socket.create_connection((host, int(port)), timeout=5).close()
'''

DEFAULT = '''
def test_without_marker_the_ini_rack(vdevd_rack):
    assert [c.name for c in vdevd_rack.cards()] == ["pmac0"]
'''


@pytest.fixture
def app(pytester: pytest.Pytester) -> pytest.Pytester:
    pytester.makefile(".toml", **{"racks/stage": STAGE, "racks/pmac": PMAC})
    pytester.makepyfile(test_app=APPLICATION, test_default=DEFAULT)
    return pytester


def test_racks_by_marker_and_ini_one_daemon_reset_between_tests(app: pytest.Pytester) -> None:
    app.makeini("[pytest]\nvdevd_rack = racks/pmac.toml\n")
    result = app.runpytest("-v")
    result.assert_outcomes(passed=5)


def test_the_default_rack_without_marker_or_ini(pytester: pytest.Pytester) -> None:
    pytester.makepyfile(test_default='''
def test_default(vdevd_rack, vdevd_step):
    assert {c.type for c in vdevd_rack.cards()} >= {"generic-servo", "pmac-turbo"}
    assert vdevd_step(ns=1000) == 1000
''')
    pytester.runpytest().assert_outcomes(passed=1)


def test_a_bad_rack_file_is_a_usage_error_naming_it(pytester: pytest.Pytester) -> None:
    pytester.makefile(".toml", bad="[[card]]\ntype = \"generic-servo\"\nname = \"s\"\naxes = 99\n")
    pytester.makepyfile(test_bad='''
import pytest
@pytest.mark.vdevd_rack("bad.toml")
def test_bad(vdevd_rack):
    pass
''')
    result = pytester.runpytest()
    result.stdout.fnmatch_lines(["*vdevd_rack*bad.toml: card[[]0[]].axes: 99 is above the maximum 16*"])
    assert result.ret != 0


MYAPP = '''
class Stage:
    """An application's driver of the generic servo card (its README's registers)."""

    def __init__(self, rack):
        self.bar = rack.card("stage").region("bar0")

    def move_to(self, axis, position):
        base = 0x100 + 0x40 * axis
        self.bar.write32(0x24, self.bar.read32(0x24) | 1 << axis)
        self.bar.write32(base + 0x04, position)
        self.bar.write32(base + 0x00, 1)
'''


def test_the_readme_example_runs_as_written(pytester: pytest.Pytester) -> None:
    readme = (Path(__file__).resolve().parents[1] / "README.md").read_text()
    start = readme.index("## Testing applications with pytest")
    section = readme[start:readme.index("\n## ", start + 1)]
    toml = re.findall(r"^```toml\n(.*?)^```", section, re.M | re.S)[0]
    python = re.findall(r"^```python\n(.*?)^```", section, re.M | re.S)[0]
    pytester.makefile(".toml", **{"racks/stage": toml})
    pytester.makepyfile(myapp=MYAPP, test_readme_example=python)
    pytester.syspathinsert()
    pytester.runpytest().assert_outcomes(passed=2)


HOMED = '''
import pytest

POSITION = 0x11C
pytestmark = pytest.mark.vdevd_rack("racks/stage.toml")


@pytest.mark.vdevd_snapshot("homed.snap")
def test_starts_from_the_snapshot(vdevd_rack):
    assert vdevd_rack.card("stage").region("bar0").read32(POSITION) == 5000
    assert vdevd_rack.sim.now_ns() == TAKEN_NS


def test_without_the_marker_a_power_on_rack(vdevd_rack):
    assert vdevd_rack.card("stage").region("bar0").read32(POSITION) == 0
    assert vdevd_rack.sim.now_ns() == 0


@pytest.mark.vdevd_snapshot("cut.snap")
def test_a_damaged_snapshot_fails_the_test(vdevd_rack):
    pass
'''


def test_a_test_starts_from_a_snapshot_by_marker(pytester: pytest.Pytester) -> None:
    """A snapshot of the stage moved to 5000 (what an application's set-up would leave),
    saved by a daemon of the same rack file; a test marked with it starts there."""
    import vdevclient

    from vdevd import config as configmod
    from vdevd.testing import DaemonThread

    pytester.makefile(".toml", **{"racks/stage": STAGE})
    cfg = configmod.load(pytester.path / "racks" / "stage.toml")
    cfg.clock, cfg.state_dir = "lockstep", None
    cfg.endpoint = cfg.events = "tcp://127.0.0.1:*"
    with DaemonThread(cfg) as d, vdevclient.connect(d.endpoint) as rack:
        bar = rack.card("stage").region("bar0")
        bar.write32(0x104, 5000)
        bar.write32(0x100, 1)
        rack.sim.step(seconds=2.0)
        assert bar.read32(0x11C) == 5000
        snap = rack.snapshot()
        taken = rack.sim.now_ns()
    (pytester.path / "homed.snap").write_bytes(snap)
    (pytester.path / "cut.snap").write_bytes(snap[:-10])
    pytester.makepyfile(test_homed=HOMED.replace("TAKEN_NS", str(taken)))
    result = pytester.runpytest("-v")
    result.assert_outcomes(passed=2, errors=1)  # at its set-up
    result.stdout.fnmatch_lines(["*vdevd_snapshot *cut.snap: bad_snapshot: truncated or extended*"])
    # the ini option: every test of the session from the snapshot
    pytester.makeini("[pytest]\nvdevd_snapshot = homed.snap\n")
    pytester.makepyfile(test_homed=HOMED.replace("TAKEN_NS", str(taken)).replace(
        "def test_without_the_marker_a_power_on_rack(vdevd_rack):",
        "def test_without_the_marker_the_ini_snapshot(vdevd_rack):\n"
        "    assert vdevd_rack.card(\"stage\").region(\"bar0\").read32(POSITION) == 5000\n\n\n"
        "def _unused(vdevd_rack):"))
    pytester.runpytest("-v").assert_outcomes(passed=2, errors=1)
