"""The daemon's shared segment (vdevd/shm.py, decision 0010): an owner-only file named after the
endpoint, page-aligned parts for the regions, removed at exit, a stale one replaced at start, and
never a reason for the daemon not to start."""

from __future__ import annotations

import errno
import fcntl
import logging
import mmap
import os
import signal
import subprocess
import sys
import time
from collections.abc import Iterator
from pathlib import Path

import pytest
import vdevclient

from tests.conftest import free_endpoint, rack_config
from vdevd.shm import LIVE, STALE_AGE_S, Segment, segment_name
from vdevd.testing import DaemonThread


@pytest.fixture
def segment(tmp_path: Path) -> Iterator[Segment]:
    seg = Segment.create(tmp_path, "tcp://127.0.0.1:5555")
    assert seg is not None
    yield seg
    seg.close()


def test_a_segment_is_an_owner_only_file_named_after_the_endpoint(tmp_path: Path) -> None:
    seg = Segment.create(tmp_path, "ipc:///run/vdevd.sock")
    assert seg is not None
    assert seg.path == tmp_path / segment_name("ipc:///run/vdevd.sock")
    assert seg.path.name.startswith(f"vdevd-{os.getuid()}-")
    st = seg.path.stat()
    assert st.st_mode & 0o777 == 0o600 and st.st_uid == os.getuid()
    seg.close()
    assert not seg.path.exists()
    seg.close()  # again: nothing


def test_allocations_are_zeroed_page_aligned_parts_after_a_header_page(segment: Segment) -> None:
    page = mmap.PAGESIZE
    first, second = segment.allocate(100), segment.allocate(page + 1)
    assert first is not None and second is not None
    assert (first[1], second[1]) == (page, 2 * page)
    assert segment.size == 4 * page == segment.path.stat().st_size
    assert first[0][:] == bytes(100)
    second[0][:4] = b"vdev"
    with open(segment.path, "rb") as f:  # another mapping of the file sees the same pages
        assert f.read(1)[0] == LIVE
        f.seek(2 * page)
        assert f.read(4) == b"vdev"
    assert segment.describe() == {"path": str(segment.path), "size": 4 * page,
                                  "dev": segment.ident[0], "ino": segment.ident[1]}


def test_a_stale_segment_is_replaced(tmp_path: Path) -> None:
    stale = tmp_path / segment_name("tcp://127.0.0.1:5555")
    stale.write_bytes(b"left by a killed daemon")
    seg = Segment.create(tmp_path, "tcp://127.0.0.1:5555")
    assert seg is not None and seg.path == stale
    assert stale.read_bytes() == bytes([LIVE]) + bytes(mmap.PAGESIZE - 1)
    assert stale.stat().st_mode & 0o777 == 0o600
    seg.close()


def test_a_replaced_or_closed_segment_reads_gone_to_those_who_map_it(tmp_path: Path) -> None:
    """A client of a daemon that stopped, or that was killed and then replaced, sees byte 0
    drop to 0 and goes back to requests."""
    path = tmp_path / segment_name("tcp://127.0.0.1:5555")
    # a process that exits without cleaning up, as a killed daemon: its lock goes, nothing else
    subprocess.run([sys.executable, "-c", "import os, sys; from vdevd.shm import Segment; "
                    "s = Segment.create(sys.argv[1], 'tcp://127.0.0.1:5555'); os._exit(0)",
                    str(tmp_path)], check=True, timeout=60)
    with open(path, "rb") as f:
        view = mmap.mmap(f.fileno(), mmap.PAGESIZE, prot=mmap.PROT_READ)
    assert view[0] == LIVE
    successor = Segment.create(tmp_path, "tcp://127.0.0.1:5555")
    assert successor is not None and successor.path == path
    assert view[0] == 0
    with open(successor.path, "rb") as f:
        view = mmap.mmap(f.fileno(), mmap.PAGESIZE, prot=mmap.PROT_READ)
    assert view[0] == LIVE
    successor.close()
    assert view[0] == 0


def test_a_live_segment_is_left_alone_and_the_next_name_taken(segment: Segment) -> None:
    assert segment.allocate(10) is not None
    other = Segment.create(segment.path.parent, "tcp://127.0.0.1:5555")
    assert other is not None
    assert other.path.name == segment.path.name + "-1"
    assert segment.path.stat().st_size == 2 * mmap.PAGESIZE  # untouched
    other.close()
    assert segment.path.exists()


def test_close_leaves_a_successors_file_alone(segment: Segment) -> None:
    segment.path.unlink()
    segment.path.write_bytes(b"another daemon's")
    segment.close()
    assert segment.path.read_bytes() == b"another daemon's"


def test_stale_segments_of_other_endpoints_are_removed_when_old_enough(tmp_path: Path) -> None:
    old, young, held = (tmp_path / segment_name(f"tcp://127.0.0.1:{p}") for p in (1, 2, 3))
    for path in (old, young, held):
        path.write_bytes(b"x")
    past = time.time() - 2 * STALE_AGE_S
    os.utime(old, (past, past))
    os.utime(held, (past, past))
    with open(held, "rb+") as lock:
        fcntl.flock(lock, fcntl.LOCK_EX)  # a live daemon holds it
        seg = Segment.create(tmp_path, "tcp://127.0.0.1:4")
        assert seg is not None
        assert not old.exists() and young.exists() and held.exists()
        seg.close()


def test_an_unusable_directory_gives_no_segment_and_a_warning(tmp_path: Path,
                                                               caplog: pytest.LogCaptureFixture
                                                               ) -> None:
    with caplog.at_level(logging.WARNING, "vdevd.shm"):
        assert Segment.create(tmp_path / "missing", "tcp://127.0.0.1:5555") is None
    assert [r.levelname for r in caplog.records] == ["WARNING"]
    assert "no shared memory" in caplog.text


def test_a_full_directory_leaves_further_regions_private(segment: Segment,
                                                         monkeypatch: pytest.MonkeyPatch,
                                                         caplog: pytest.LogCaptureFixture) -> None:
    assert segment.allocate(10) is not None

    def full(fd: int, offset: int, size: int) -> None:
        raise OSError(errno.ENOSPC, os.strerror(errno.ENOSPC))

    monkeypatch.setattr(os, "posix_fallocate", full)
    with caplog.at_level(logging.WARNING, "vdevd.shm"):
        assert segment.allocate(10) is None
        assert segment.allocate(10) is None
    assert len(caplog.records) == 1  # logged once
    assert segment.path.stat().st_size == segment.size == 2 * mmap.PAGESIZE


def test_a_daemon_whose_shm_dir_is_unusable_serves_by_requests(tmp_path: Path) -> None:
    cfg = rack_config()
    cfg.shm_dir = str(tmp_path / "missing")
    with DaemonThread(cfg) as d, vdevclient.connect(d.endpoint) as rack:
        assert "shm" not in rack.info and rack.shm is None
        bar = rack.card("servo0").region("bar0")
        assert not bar.mapped
        bar.write32(0x104, 1234)
        assert bar.read32(0x104) == 1234


def test_shm_dir_empty_turns_the_mappings_off() -> None:
    cfg = rack_config()
    cfg.shm_dir = ""
    with DaemonThread(cfg) as d, vdevclient.connect(d.endpoint) as rack:
        assert "shm" not in rack.info


# -- a daemon process: killed, restarted, stopped ----------------------------------------------------
UTILITY = 0x900  # the MAXk's utility buffer: passive memory nobody else writes
RACK = """
[server]
endpoint = "{endpoint}"
events = "{events}"

[clock]
mode = "lockstep"

[[card]]
type = "oms-maxk"
name = "maxk0"
"""


def start(tmp_path: Path, endpoint: str, events: str) -> subprocess.Popen[bytes]:
    config, ready = tmp_path / "rack.toml", tmp_path / "ready.json"
    config.write_text(RACK.format(endpoint=endpoint, events=events))
    ready.unlink(missing_ok=True)
    proc = subprocess.Popen([sys.executable, "-m", "vdevd", "serve", "--config", str(config),
                             "--ready-file", str(ready)], stderr=subprocess.DEVNULL)
    deadline = time.monotonic() + 60  # a guard against a hung daemon, not a measured wait
    while not ready.exists():
        try:
            code = proc.wait(timeout=0.01)
        except subprocess.TimeoutExpired:
            assert time.monotonic() < deadline, "no ready file"
            continue
        raise AssertionError(f"vdevd exited {code}")
    return proc


@pytest.mark.skipif(not os.path.isdir("/dev/shm"), reason="no /dev/shm")
def test_a_killed_daemons_segment_is_replaced_at_restart_and_removed_at_exit(tmp_path: Path
                                                                             ) -> None:
    endpoint, events = free_endpoint(), free_endpoint()
    path = Path("/dev/shm") / segment_name(endpoint)
    proc = start(tmp_path, endpoint, events)
    try:
        st = path.stat()
        assert st.st_mode & 0o777 == 0o600 and st.st_uid == os.getuid()
        early = vdevclient.connect(endpoint)  # stays connected across the kill and restart
        shm = early.card("maxk0").region("shm")
        assert early.info["shm"]["path"] == str(path) and shm.is_mapped(UTILITY, 4)
        shm.write32(UTILITY, 0x600D)
        proc.send_signal(signal.SIGKILL)
        proc.wait(timeout=30)
        assert path.stat().st_ino == st.st_ino  # what a killed daemon leaves
        proc = start(tmp_path, endpoint, events)
        with vdevclient.connect(endpoint) as rack:
            assert rack.info["shm"]["ino"] == path.stat().st_ino
            assert rack.card("maxk0").region("shm").read32(0x48) & 0x4  # RUNNING, from the new one
        # the old mapping is marked gone: the early client asks the new daemon instead
        assert not shm.is_mapped(UTILITY, 4) and shm.read32(UTILITY) == 0
        early.close()
    finally:
        proc.send_signal(signal.SIGTERM)
        assert proc.wait(timeout=30) in (0, -signal.SIGKILL)
    assert not path.exists()
