"""pytest fixtures for testing applications against vdevd (registered as the `vdevd` plugin).

- `vdevd_daemon`: a lockstep daemon with the embedded default rack, on free loopback ports.
- `vdevd_rack`: a connected `vdevclient.Rack` to it.
"""

from __future__ import annotations

from collections.abc import Iterator

import pytest

from vdevd.testing import DaemonThread


@pytest.fixture
def vdevd_daemon() -> Iterator[DaemonThread]:
    with DaemonThread(clock="lockstep") as daemon:
        yield daemon


@pytest.fixture
def vdevd_rack(vdevd_daemon: DaemonThread) -> Iterator[object]:
    import vdevclient

    with vdevclient.connect(vdevd_daemon.endpoint, vdevd_daemon.events) as rack:
        yield rack
