"""Fixtures of the client tests: a daemon serving the test's own cards (tests/client/pulser.py)."""

from __future__ import annotations

from collections.abc import Iterator

import pytest

from tests.client.pulser import serve_pulsers
from vdevd.testing import DaemonThread


@pytest.fixture
def pulsers() -> Iterator[DaemonThread]:
    """A lockstep daemon with two Pulser cards, `p0` and `p1`."""
    with serve_pulsers("p0", "p1") as d:
        yield d
