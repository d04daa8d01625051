"""pytest fixtures for testing applications against vdevd (registered as the `vdevd` plugin).

The rack: `@pytest.mark.vdevd_rack("rack.toml")` on a test, class or module (`pytestmark`; a
path relative to the test file), else the `vdevd_rack` ini option (relative to the ini file),
else the embedded default rack. One daemon per rack file serves the whole session; before each
test but the first it is reset to a fresh rack (`DaemonThread.reset`: power-on cards, simulated
time 0), so tests do not see each other's moves, on the same endpoints and card ports.

The daemon always runs the lockstep clock on free loopback ports (the file's `[server]`
endpoints and `[clock] mode` are replaced); card ports the file gives (a PMAC `ethernet`) are
moved to free loopback ports too; a `[state] dir` is replaced by a directory of the session's,
emptied at each reset.

Fixtures:

- `vdevd_daemon`: the daemon (`vdevd.testing.DaemonThread`): `.endpoint`, `.events`,
  `.listeners()` (every bound port, the cards' own among them). `VDEVD_ENDPOINT` and
  `VDEVD_EVENTS` are set for the test, so vendor clients (`vdevclient.pcomm`, the gclib drop-in)
  and an application's own `vdevclient.connect()` find it.
- `vdevd_rack`: a `vdevclient.Rack` connected to it.
- `vdevd_events`: the events endpoint (ZeroMQ PUB, topic = card name).
- `vdevd_step`: `vdevd_step(seconds=..., ns=..., ticks=...)` advances the lockstep clock and
  returns the new time in ns.

A test can start from a snapshot instead of a power-on rack (issue 23 §2: homed axes, a loaded
program, without the set-up sequence): `@pytest.mark.vdevd_snapshot("homed.snap")` on a test,
class or module (a path relative to the test file), else the `vdevd_snapshot` ini option
(relative to the ini file). The file is one `vdevctl snapshot save` wrote from a daemon of the
same rack in lockstep; after the reset, the daemon serves it (`DaemonThread.restore`). A snapshot
that does not load (another rack layout, another vdevd version, a damaged file) fails the test
with the daemon's reason.
"""

from __future__ import annotations

import shutil
from collections.abc import Callable, Iterator
from dataclasses import replace
from pathlib import Path
from typing import Any

import pytest

from vdevd import config as configmod
from vdevd.testing import DaemonThread

LOOPBACK = "tcp://127.0.0.1:*"
#: the card options that name a TCP port of the card's own
PORT_OPTIONS = ("ethernet",)


def pytest_addoption(parser: pytest.Parser) -> None:
    parser.addini("vdevd_rack", "the rack TOML of the vdevd fixtures, relative to the ini file "
                  "(default: the embedded default rack)", default="")
    parser.addini("vdevd_snapshot", "a snapshot (vdevctl snapshot save) each test starts from, "
                  "relative to the ini file (default: none, a power-on rack)", default="")


def pytest_configure(config: pytest.Config) -> None:
    config.addinivalue_line("markers", "vdevd_rack(path): the rack TOML the vdevd fixtures serve "
                            "to this test, class or module (relative to the test file)")
    config.addinivalue_line("markers", "vdevd_snapshot(path): the snapshot the vdevd fixtures "
                            "start this test, class or module from (relative to the test file)")


class DaemonPool:
    """One started daemon per rack file, for the session; reset between its tests."""

    def __init__(self, state_root: Path) -> None:
        self.state_root = state_root
        self._daemons: dict[str, DaemonThread] = {}
        self._used: set[str] = set()
        self._state: dict[str, Path] = {}

    def get(self, path: Path | None) -> DaemonThread:
        """The daemon of `path` (None: the default rack), started or reset for a new test."""
        key = str(path) if path else ""
        daemon = self._daemons.get(key)
        if daemon is None:
            daemon = self._daemons[key] = DaemonThread(self._config(path, key)).start()
        elif key in self._used:
            state = self._state.get(key)
            if state is not None:  # what the last test saved is gone too
                shutil.rmtree(state, ignore_errors=True)
                state.mkdir()
            daemon.reset()
        self._used.add(key)
        return daemon

    def _config(self, path: Path | None, key: str) -> configmod.Config:
        if path is None:
            cfg = configmod.default_config()
        else:
            try:
                cfg = configmod.load(path)
            except configmod.ConfigError as exc:
                raise pytest.UsageError(f"vdevd_rack {path}: {exc}") from None
        cfg.clock = "lockstep"
        cfg.endpoint = cfg.events = LOOPBACK
        cfg.metrics = None
        if cfg.state_dir is not None:
            state = self.state_root / f"rack{len(self._state)}"
            state.mkdir()
            cfg.state_dir = str(state)
            self._state[key] = state
        cfg.cards = [replace(spec, options={**spec.options, **{
            k: LOOPBACK for k in PORT_OPTIONS if spec.options.get(k)}}) for spec in cfg.cards]
        return cfg

    def close(self) -> None:
        for daemon in self._daemons.values():
            daemon.stop()
        self._daemons.clear()


@pytest.fixture(scope="session")
def _vdevd_pool(tmp_path_factory: pytest.TempPathFactory) -> Iterator[DaemonPool]:
    pool = DaemonPool(tmp_path_factory.mktemp("vdevd-state"))
    try:
        yield pool
    finally:
        pool.close()


def rack_path(request: pytest.FixtureRequest, name: str = "vdevd_rack",
              example: str = "rack.toml") -> Path | None:
    """The rack file (`name`: or the snapshot) chosen for the requesting test: the closest
    marker, else the ini option."""
    marker = request.node.get_closest_marker(name)
    if marker is not None:
        if len(marker.args) != 1 or not isinstance(marker.args[0], str | Path):
            raise pytest.UsageError(f"{name}: give one path, @pytest.mark.{name}(\"{example}\")")
        return (Path(request.node.path).parent / marker.args[0]).resolve()
    ini = str(request.config.getini(name) or "")
    if ini:
        base = request.config.inipath.parent if request.config.inipath else request.config.rootpath
        return (base / ini).resolve()
    return None


def start_from_snapshot(daemon: DaemonThread, path: Path) -> None:
    """Serve the snapshot at `path` in place of the daemon's fresh rack; the test fails with
    the reason when it does not load."""
    from vdevd.errors import VdevError

    try:
        daemon.restore(path.read_bytes())
        return
    except OSError as exc:
        reason = str(exc.strerror or exc)
    except VdevError as exc:
        reason = f"{exc.code}: {exc.message}"
    pytest.fail(f"vdevd_snapshot {path}: {reason}", pytrace=False)


@pytest.fixture
def vdevd_daemon(request: pytest.FixtureRequest, _vdevd_pool: DaemonPool,
                 monkeypatch: pytest.MonkeyPatch) -> DaemonThread:
    daemon = _vdevd_pool.get(rack_path(request))
    snapshot = rack_path(request, "vdevd_snapshot", "homed.snap")
    if snapshot is not None:
        start_from_snapshot(daemon, snapshot)
    monkeypatch.setenv("VDEVD_ENDPOINT", daemon.endpoint)
    monkeypatch.setenv("VDEVD_EVENTS", daemon.events)
    return daemon


@pytest.fixture
def vdevd_rack(vdevd_daemon: DaemonThread) -> Iterator[Any]:
    import vdevclient

    with vdevclient.connect(vdevd_daemon.endpoint, vdevd_daemon.events) as rack:
        yield rack


@pytest.fixture
def vdevd_events(vdevd_daemon: DaemonThread) -> str:
    return vdevd_daemon.events


@pytest.fixture
def vdevd_step(vdevd_rack: Any) -> Callable[..., int]:
    def step(seconds: float | None = None, *, ns: int | None = None,
             ticks: int | None = None) -> int:
        """Advance the lockstep clock by `seconds`, `ns` or `ticks`; the new time, ns."""
        return int(vdevd_rack.sim.step(ns=ns, ticks=ticks, seconds=seconds))

    return step
