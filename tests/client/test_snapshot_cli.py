"""`vdevctl snapshot save|load FILE` and the `snapshot` op (PROTOCOL.md "snapshot"): a snapshot
saved by one daemon loads into a fresh daemon of the same configuration and replays the same
replies; one of another rack layout or vdevd version, a truncated or changed file, one over the
size bound or a payload that names what a snapshot never holds is refused with one line naming
why, and the rack served is untouched; the NV image comes back with the rest; the card ports
(Galil DMC and PMAC Ethernet) serve after a load, on the same ports."""

from __future__ import annotations

import ctypes
import hashlib
import json
import os
import pickle
import socket
import struct
import zlib
from dataclasses import replace
from pathlib import Path

import pytest
import vdevclient
from vdevclient import galil
from vdevclient.cli import main as vdevctl
from vdevclient.errors import RemoteError

from tests.client.test_snapshot_cards import (
    default_rack,
    digest,
    galil_after,
    galil_before,
    galil_session,
)
from vdevd import snapshot as snapmod
from vdevd import snapshot_transfer
from vdevd.nvram import NvramStore
from vdevd.testing import DaemonThread


def cli(d: DaemonThread, *argv: str) -> int:
    return vdevctl(["--endpoint", d.endpoint, *argv])


def rewrite_header(data: bytes, payload: bytes | None = None, **changes: object) -> bytes:
    """The snapshot with its header's fields changed, and its payload (or `payload`)."""
    header, kept = snapmod.read_header(data)
    head = json.dumps({**header, **changes}, sort_keys=True).encode()
    return snapmod.MAGIC + struct.pack(">I", len(head)) + head + (
        kept if payload is None else payload)


def with_payload(data: bytes, raw: bytes) -> bytes:
    """The snapshot with another pickle as its payload, its header's sizes and checksum
    matching it (what a file written to attack the daemon would be)."""
    payload = zlib.compress(raw)
    return rewrite_header(data, payload, raw_size=len(raw), payload_size=len(payload),
                          payload_sha256=hashlib.sha256(payload).hexdigest())


class CallsVdevd:
    """Pickles as a call of one of vdevd's functions (a class may be found, a function of
    vdevd named, but only reconstructors are called)."""

    def __reduce__(self) -> tuple[object, tuple[()]]:
        return snapmod.vdevd_version, ()


def state(d: DaemonThread) -> tuple[int, str]:
    """The clock and the Galil's positions: what a refused load must leave as it was."""
    with vdevclient.connect(d.endpoint, shm=False) as rack, galil_session(d) as g:
        return rack.sim.now_ns(), g.GCommand("TP")


@pytest.fixture
def saved(tmp_path: Path) -> tuple[Path, str]:
    """A snapshot of the default rack mid-motion saved with vdevctl, and the digest of the
    replies the Galil sequence gets after it."""
    path = tmp_path / "mid.snap"
    with default_rack() as d, pytest.MonkeyPatch.context() as mp:
        galil_before(d)
        assert cli(d, "snapshot", "save", str(path)) == 0
        with digest(mp) as h:
            galil_after(d)
    return path, h.hexdigest()


def test_a_snapshot_saved_by_one_daemon_replays_in_a_fresh_one(
        saved: tuple[Path, str], monkeypatch: pytest.MonkeyPatch,
        capsys: pytest.CaptureFixture[str]) -> None:
    path, expected = saved
    capsys.readouterr()
    with default_rack() as d:
        assert cli(d, "snapshot", "load", str(path)) == 0
        assert capsys.readouterr().out.startswith(f"loaded {path}: 6 cards at ")
        with digest(monkeypatch) as h:
            galil_after(d)
    assert h.hexdigest() == expected


@pytest.mark.parametrize(("damage", "why"), [
    (lambda data: data[:len(data) // 2], "truncated or extended: its payload is"),
    (lambda data: data[:20], "truncated: the file ends inside its header"),
    (lambda data: data[:-100] + bytes(b ^ 0xFF for b in data[-100:]),
     "corrupt: its payload does not match the checksum of its header"),
    (lambda data: rewrite_header(data, vdevd="0.0.1"),
     "saved by vdevd 0.0.1, this is vdevd "),
    (lambda data: rewrite_header(data, format=2),
     "snapshot format 2, this daemon reads format 1"),
    (lambda data: b"PK\x03\x04" + data, "not a vdevd snapshot"),
    (lambda data: with_payload(data, pickle.dumps(os.system)),
     "corrupt: it names posix.system, which a snapshot never holds"),
    (lambda data: with_payload(data, b"\x80\x05}q\x00."), "corrupt: its payload is not the rack"),
    (lambda data: with_payload(data, pickle.dumps(NvramStore("/etc"))),
     "corrupt: it names vdevd.nvram.NvramStore, which a snapshot never holds"),
    (lambda data: with_payload(data, pickle.dumps(CallsVdevd())), "corrupt: it calls <function"),
])
def test_a_damaged_snapshot_is_refused_in_one_line_and_the_rack_untouched(
        saved: tuple[Path, str], tmp_path: Path, capsys: pytest.CaptureFixture[str],
        damage: object, why: str) -> None:
    bad = tmp_path / "bad.snap"
    bad.write_bytes(damage(saved[0].read_bytes()))  # type: ignore[operator]
    with default_rack() as d:
        with galil_session(d) as g:
            g.GCommand("PR 1000;BG X")
        with vdevclient.connect(d.endpoint, shm=False) as rack:
            rack.sim.step(seconds=0.02)
        before = state(d)
        capsys.readouterr()
        assert cli(d, "snapshot", "load", str(bad)) == 1
        err = capsys.readouterr().err
        assert err.startswith(f"vdevctl: bad_snapshot: {why}") and err.count("\n") == 1, err
        assert state(d) == before


def test_a_snapshot_of_another_rack_layout_is_refused_naming_the_difference(
        saved: tuple[Path, str], capsys: pytest.CaptureFixture[str]) -> None:
    other = default_rack()
    other.cfg.cards = [replace(s, options={**s.options, "axes": 2}) if s.name == "galil0" else s
                       for s in other.cfg.cards]
    with other as d:
        before = state(d)
        assert cli(d, "snapshot", "load", str(saved[0])) == 1
        err = capsys.readouterr().err
        assert err.startswith("vdevctl: bad_snapshot: another rack layout: card galil0: its "
                              "axis count 4 differs from this rack's 2"), err
        assert state(d) == before
    fewer = default_rack()
    fewer.cfg.cards = fewer.cfg.cards[1:]
    with fewer as d:
        assert cli(d, "snapshot", "load", str(saved[0])) == 1
        assert "its cards are servo0, galil0" in capsys.readouterr().err


def test_a_snapshot_over_the_size_bound_and_a_chunk_too_large_are_refused(
        tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    with default_rack() as d, vdevclient.connect(d.endpoint, shm=False) as rack:
        with pytest.raises(RemoteError, match=r"bad_snapshot: a snapshot of 67108865 bytes "
                                              r"\(at most 67108864\)"):
            rack.request("snapshot", action="load", offset=0, size=snapmod.MAX_SNAPSHOT + 1,
                         data=b"VDEVSNAP")
        with pytest.raises(RemoteError, match="too_large: snapshot load: a chunk of 524289"):
            rack.request("snapshot", action="load", offset=0, size=1 << 20,
                         data=bytes(snapshot_transfer.CHUNK + 1))
        huge = tmp_path / "huge.snap"
        with huge.open("wb") as f:
            f.truncate(snapmod.MAX_SNAPSHOT + 1)
        assert cli(d, "snapshot", "load", str(huge)) == 1
        assert "a snapshot is at most 67108864" in capsys.readouterr().err


def test_transfers_go_in_chunks_one_per_client_and_bounded(
        monkeypatch: pytest.MonkeyPatch) -> None:
    """With 4 KiB chunks, a snapshot goes in many requests each way; a chunk out of order
    drops the load; a client's new transfer replaces its last; MAX_TRANSFERS at once."""
    from vdevclient import snapshot as client_snapshot

    monkeypatch.setattr(snapshot_transfer, "CHUNK", 4096)
    monkeypatch.setattr(client_snapshot, "CHUNK", 4096)
    with default_rack() as d, vdevclient.connect(d.endpoint, shm=False) as rack:
        rack.sim.step(seconds=0.01)
        data = rack.snapshot()
        assert len(data) > 10 * 4096
        first = rack.request("snapshot", action="save", offset=0)
        assert len(first["data"]) == 4096 and first["size"] == len(first["data"]) + len(
            data) - 4096
        with pytest.raises(RemoteError, match="bad_param: snapshot load: a chunk at offset "
                                              "4096, expected 0"):
            rack.request("snapshot", action="load", offset=4096, size=len(data),
                         data=data[4096:8192])
        rack.sim.step(seconds=0.01)
        assert rack.restore(data)["now_ns"] == 10_000_000
        assert rack.sim.now_ns() == 10_000_000
        others = [vdevclient.connect(d.endpoint, shm=False) for _ in range(snapshot_transfer.MAX_TRANSFERS)]
        try:
            for other in others[:-1]:
                other.request("snapshot", action="save", offset=0)
            rack.request("snapshot", action="save", offset=0)  # its own again: replaced
            with pytest.raises(RemoteError, match="busy: snapshot: 4 transfers under way"):
                others[-1].request("snapshot", action="save", offset=0)
        finally:
            for other in others:
                other.close()


def test_the_nv_image_comes_back_with_the_snapshot(tmp_path: Path) -> None:
    """BP burns a program; a snapshot; another program burned; the load brings back the first
    in the card's flash (what RS restores) and in the state directory."""
    d = default_rack()
    d.cfg.state_dir = str(tmp_path / "state")
    with d:
        with galil_session(d) as g:
            g.GProgramDownload("#FIRST\nMG 1\nEN")
            g.GCommand("BP")
            with vdevclient.connect(d.endpoint, shm=False) as rack:
                rack.sim.step(seconds=0.1)
                snap = rack.snapshot()
            g.GProgramDownload("#SECOND\nMG 2\nEN")
            g.GCommand("BP")
        with vdevclient.connect(d.endpoint, shm=False) as rack:
            rack.sim.step(seconds=0.1)
            rack.restore(snap)
        with galil_session(d) as g:
            g.GProgramDownload("#THIRD\nEN")  # not burned: RS brings back the flash's
            g.GCommand("RS")
            assert g.GProgramUpload().startswith("#FIRST")
    from vdevd.nvram import NvramStore

    image = NvramStore(tmp_path / "state").load("galil0")
    assert image is not None and image["flash"]["programs"][0] == "#FIRST"


def test_card_ports_serve_after_a_load_on_the_same_ports(
        saved: tuple[Path, str]) -> None:
    pmacremote = pytest.importorskip("dls_pmaclib.dls_pmacremote")
    d = default_rack()
    with d:
        ports = d.listeners()["cards"]
        with vdevclient.connect(d.endpoint, shm=False) as rack:
            rack.restore(saved[0].read_bytes())
        assert d.listeners()["cards"] == ports
        host, port = ports["galil0"]["ethernet"].removeprefix("tcp://").rsplit(":", 1)
        with socket.create_connection((host, int(port)), timeout=10) as s:
            s.sendall(b"MG _BGX\r")
            got = b""
            while not got.endswith(b":"):
                chunk = s.recv(4096)
                assert chunk
                got += chunk
        h = ctypes.c_long()
        assert galil.DMCOpen(1, 0, ctypes.byref(h), endpoint=d.endpoint) == galil.DMCNOERROR
        buf = ctypes.create_string_buffer(256)
        galil.DMCCommand(h, "MG _BGX", buf, 256)
        galil.DMCClose(h)
        assert got == buf.value  # the restored card answers on its port as on its FIFO
        host, port = ports["pmac0"]["ethernet"].removeprefix("tcp://").rsplit(":", 1)
        pmac = pmacremote.PmacEthernetInterface()
        pmac.setConnectionParams(host, int(port))
        assert pmac.connect() is None
        try:
            assert pmac.sendCommand("I10")[0].split("\r")[0].isdigit()
        finally:
            pmac.disconnect()


def test_vdevd_serve_saves_and_loads_snapshots(tmp_path: Path,
                                               capsys: pytest.CaptureFixture[str]) -> None:
    """The daemon's own serve path (not the test thread's): a load swaps the rack in, on a new
    shared segment that a client connecting after it maps; a refused load leaves the rack."""
    import subprocess
    import sys

    from tests.conftest import free_endpoint

    endpoint, events = free_endpoint(), free_endpoint()
    path = tmp_path / "rack.snap"
    with subprocess.Popen([sys.executable, "-m", "vdevd", "serve", "--clock", "lockstep",
                           "--endpoint", endpoint, "--events", events, "--no-card-ports"],
                          stderr=subprocess.PIPE, text=True) as proc:
        try:
            assert proc.stderr is not None
            assert "listening on" in proc.stderr.readline()
            argv = ["--endpoint", endpoint]
            with vdevclient.connect(endpoint) as rack:
                bar = rack.card("servo0").region("bar0")
                assert bar.mapped
                bar.write32(0x104, 5000)  # TARGET, then MOVE_ABS
                bar.write32(0x100, 1)
                rack.sim.step(seconds=0.05)
                moving = bar.read32(0x11C)
                assert 0 < moving < 5000
            assert vdevctl([*argv, "snapshot", "save", str(path)]) == 0
            assert vdevctl([*argv, "step", "2"]) == 0
            assert vdevctl([*argv, "snapshot", "load", str(path)]) == 0
            with vdevclient.connect(endpoint) as rack:
                bar = rack.card("servo0").region("bar0")
                assert bar.mapped and bar.read32(0x11C) == moving  # through the new segment
                assert rack.sim.now_ns() == 50_000_000
                rack.sim.step(seconds=2)
                assert bar.read32(0x11C) == 5000
            path.write_bytes(path.read_bytes()[:-1])
            capsys.readouterr()
            assert vdevctl([*argv, "snapshot", "load", str(path)]) == 1
            assert "bad_snapshot: truncated" in capsys.readouterr().err
            with vdevclient.connect(endpoint) as rack:
                assert rack.sim.now_ns() == 2_050_000_000
        finally:
            proc.terminate()
            proc.communicate(timeout=20)


def test_a_snapshot_taken_with_card_port_connections_open_loads_without_them() -> None:
    """A buffer a PMAC Ethernet connection had open when the snapshot was taken is released
    at the load (that connection is gone, as if it had dropped); a Galil TCP connection open
    at the save is no part of the snapshot either."""
    pmacremote = pytest.importorskip("dls_pmaclib.dls_pmacremote")
    from tests.client.test_snapshot_cards import pmac_ask, pmac_session

    with default_rack() as d:
        ports = d.listeners()["cards"]
        host, port = ports["pmac0"]["ethernet"].removeprefix("tcp://").rsplit(":", 1)
        other = pmacremote.PmacEthernetInterface()
        other.setConnectionParams(host, int(port))
        assert other.connect() is None
        ghost = socket.create_connection(
            tuple(ports["galil0"]["ethernet"].removeprefix("tcp://").rsplit(":", 1)), timeout=10)
        try:
            with pmac_session(d):
                pmac_ask("OPEN PROG 3 CLEAR")
                pmac_ask("X1")
                pmac_ask("CLOSE")
                pmac_ask("#1$")
            other.sendCommand("OPEN PROG 4")  # left open by the Ethernet port
            with pmac_session(d):
                assert "ERR015" in pmac_ask("&1B3R")  # a buffer left open
            with vdevclient.connect(d.endpoint, shm=False) as rack:
                snap = rack.snapshot()
                rack.restore(snap)
        finally:
            other.disconnect()
            ghost.close()
        with pmac_session(d):
            assert "ERR015" not in pmac_ask("&1B3R")  # the buffer is no longer open


@pytest.mark.parametrize(("argv", "status", "says"), [
    (["snapshot", "restore", "x.snap"], 2, "argument action: invalid choice: 'restore'"),
    (["snapshot", "save"], 2, "the following arguments are required: file"),
    (["snapshot", "load", "/nonexistent/x.snap"], 1, "No such file or directory"),
    (["snapshot", "save", "/nonexistent/dir/x.snap"], 1, "No such file or directory"),
])
def test_snapshot_usage_and_file_errors_are_one_line(argv: list[str], status: int, says: str,
                                                     capsys: pytest.CaptureFixture[str]) -> None:
    with default_rack() as d:
        if status == 2:
            with pytest.raises(SystemExit) as exited:
                cli(d, *argv)
            assert exited.value.code == 2
        else:
            assert cli(d, *argv) == 1
    err = capsys.readouterr().err
    assert err.startswith("vdevctl") and says in err and err.count("\n") == 1, err
