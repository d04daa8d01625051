"""Application programs through the client libraries: DMCDownloadFile / DMCUploadToBuffer ... of
vdevclient.galil and GProgramDownload / GProgramUpload ... of vdevclient.gclib, against a lockstep
daemon with one DMC-13X8 card; the flash across a daemon restart (spec galil.md §1.5, §6.2)."""

from __future__ import annotations

import ctypes
from collections.abc import Iterator
from pathlib import Path

import pytest
from vdevclient import galil, gclib

from tests.client.galil import GALIL, card, rack_config, round_trips
from vdevd.testing import DaemonThread

OK = galil.DMCNOERROR
#: [M Ch2 Ex12] with a message at the end
EX12 = "#A\nDP 0\nV1=1000\n#Loop\nPA V1\nBG X\nAM X\nWT 500\nV1=V1+1000\nJP #Loop,V1<10001\nMG \"DONE\"\nEN"


def hundred_lines() -> str:
    """A 100-line program of ordinary lines (labels, moves, jumps, messages)."""
    lines = []
    for k in range(25):
        lines += [f"#L{k}", f"PR {k * 100},{k * 50}", "BG XY;AM XY", f"JP #L{k + 1},V1<{k}"]
    return "\n".join(lines)


@pytest.fixture
def daemon() -> Iterator[DaemonThread]:
    with DaemonThread(rack_config(card(GALIL, "galil0"))) as d:
        yield d


@pytest.fixture
def g(daemon: DaemonThread) -> Iterator[gclib.py]:
    conn = gclib.py()
    conn.GOpen(f"galil0 --endpoint {daemon.endpoint}")
    yield conn
    conn.GClose()


@pytest.fixture
def h(daemon: DaemonThread) -> Iterator[ctypes.c_long]:
    handle = ctypes.c_long()
    assert galil.DMCOpen(1, 0, ctypes.byref(handle), endpoint=daemon.endpoint) == OK
    yield handle
    galil.DMCClose(handle)


def upload(h: ctypes.c_long, size: int = 10_000) -> tuple[int, bytes]:
    buf = ctypes.create_string_buffer(size)
    rc = galil.DMCUploadToBuffer(h, buf, size)
    return rc, buf.value


# -- gclib -------------------------------------------------------------------------------------------
def test_gprogramdownload_then_upload_round_trips(g: gclib.py) -> None:
    g.GProgramDownload(EX12)
    assert g.GProgramUpload() == EX12.replace("\n", "\r\n") + "\r\n"


def test_a_100_line_program_downloads_in_few_round_trips(
        g: gclib.py, monkeypatch: pytest.MonkeyPatch) -> None:
    program = hundred_lines()
    with round_trips(monkeypatch) as spy:
        g.GProgramDownload(program)
    assert spy.count <= 20
    assert g.GProgramUpload() == program.replace("\n", "\r\n") + "\r\n"
    assert g.GCommand("LS 99,99") == "099 JP #L25,V1<24"


def test_a_program_runs_while_gcommand_is_served_and_gmessage_gets_its_output(g: gclib.py) -> None:
    g.GProgramDownload(EX12)
    g.GCommand("XQ #A")
    assert g.GCommand("MG _XQ0") != "-0000000001.0000"
    g.GSleep(2000)
    assert 0 < float(g.GCommand("MG _TPX")) < 10000
    g.GSleep(5000)
    assert g.GCommand("MG _XQ0") == "-0000000001.0000"
    assert g.GCommand("MG _TPX") == "0000010000.0000"
    assert g.GMessage() == "DONE\r\n"


def test_program_messages_with_colons_do_not_disturb_replies(g: gclib.py) -> None:
    """A program's messages reach the host marked (CW1), so a ':' in them ends no reply."""
    g.GProgramDownload("#A\nN=0\n#L\nMG \"N:\",N\nN=N+1\nWT 1\nJP #L,N<20\nEN")
    g.GCommand("XQ #A")
    replies = []
    for _ in range(10):
        g.GSleep(2)
        replies.append(g.GCommand("MG 7"))
    assert replies == ["0000000007.0000"] * 10
    g.GSleep(50)
    messages = g.GMessage().split("\r\n")
    assert messages[:3] == ["N: 0000000000.0000", "N: 0000000001.0000", "N: 0000000002.0000"]
    assert len([m for m in messages if m]) == 20


def test_a_refused_download_raises_and_tc1_tells_why(g: gclib.py) -> None:
    g.GProgramDownload(EX12)
    with pytest.raises(gclib.GclibError, match="^question mark returned by controller$"):
        g.GProgramDownload("#A\nEN\n#A\nEN")
    assert g.GCommand("TC1") == "61 Duplicate or bad label"
    assert g.GProgramUpload().startswith("#A\r\nDP 0\r\n")  # the old program stays
    with pytest.raises(gclib.GclibError, match="^question mark returned by controller$"):
        g.GProgramDownload("#A\nMG \"" + "x" * 100 + "\"")
    assert g.GCommand("TC1") == "60 Download error - line too long or too many lines"
    assert g.GCommand("MG 1") == "0000000001.0000"


def test_the_preprocessor_max_option_checks_line_lengths(g: gclib.py) -> None:
    with pytest.raises(gclib.GclibError, match="out of range"):
        g.GProgramDownload("#A\nMG \"hello\"", "--max 4")
    g.GProgramDownload("#A\nEN", "--max 4")
    with pytest.raises(gclib.GclibError, match="out of range"):
        g.GProgramDownload("#A", "--bogus")


def test_gprogram_files(g: gclib.py, tmp_path: Path) -> None:
    src, dst = tmp_path / "in.dmc", tmp_path / "out.dmc"
    src.write_text(EX12)
    g.GProgramDownloadFile(str(src))
    g.GProgramUploadFile(str(dst))
    assert dst.read_bytes() == EX12.replace("\n", "\r\n").encode() + b"\r\n"
    with pytest.raises(gclib.GclibError, match="^file was not found, contents are invalid, or write failed$"):
        g.GProgramDownloadFile(str(tmp_path / "missing.dmc"))


# -- DMC library ---------------------------------------------------------------------------------------
def test_dmc_download_from_buffer_and_upload_to_buffer(h: ctypes.c_long) -> None:
    assert galil.DMCDownloadFromBuffer(h, "#A\nREM skipped\n\nV1=1\nEN", None) == OK
    assert upload(h) == (OK, b"#A\r\nV1=1\r\nEN\r\n")
    assert galil.DMCDownloadFromBuffer(h, "#B\nV1=2\nEN", "#") == OK  # DL#: appended
    assert upload(h) == (OK, b"#A\r\nV1=1\r\nEN\r\n#B\r\nV1=2\r\nEN\r\n")


def test_a_refused_download_is_dmcerror_download(h: ctypes.c_long) -> None:
    assert galil.DMCDownloadFromBuffer(h, "#A\n#A", None) == galil.DMCERROR_DOWNLOAD
    buf = ctypes.create_string_buffer(64)
    assert galil.DMCCommand(h, "TC", buf, 64) == OK
    assert buf.value == b"061\r\n:"
    assert galil.DMCDownloadFromBuffer(h, "#A\nEN\nMG \"" + "x" * 90 + "\"", None) == galil.DMCERROR_DOWNLOAD
    text = ctypes.create_string_buffer(256)
    assert galil.DMCError(h, galil.DMCERROR_DOWNLOAD, text, 256) == OK
    assert text.value.endswith(b"60 Download error - line too long or too many lines at line 2.")


def test_upload_into_a_small_buffer_is_bufferfull(h: ctypes.c_long) -> None:
    galil.DMCDownloadFromBuffer(h, EX12, None)
    rc, text = upload(h, 8)
    assert rc == galil.DMCERROR_BUFFERFULL
    assert text == b"#A\r\nDP "


def test_dmc_download_file_and_upload_file(h: ctypes.c_long, tmp_path: Path) -> None:
    src, dst = tmp_path / "in.dmc", tmp_path / "out.dmc"
    src.write_bytes(b"#A\r\nV1=5\r\nEN\r\n")
    assert galil.DMCDownloadFile(h, str(src), None) == OK
    assert galil.DMCUploadFile(h, str(dst)) == OK
    assert dst.read_bytes() == b"#A\r\nV1=5\r\nEN\r\n"
    assert galil.DMCDownloadFile(h, str(tmp_path / "missing"), None) == galil.DMCERROR_FILE


# -- flash across a restart [spec §1.4-1.5] ------------------------------------------------------------
def test_burned_program_variables_and_parameters_survive_a_restart_and_auto_runs(
        tmp_path: Path) -> None:
    cfg = rack_config(card(GALIL, "galil0"))
    cfg.state_dir = str(tmp_path)
    with DaemonThread(cfg) as d:
        g = gclib.py()
        g.GOpen(f"galil0 --endpoint {d.endpoint}")
        g.GProgramDownload("#AUTO\nV2=V1*2\nPR 1000\nBGX\nEN")
        g.GCommand("V1=21;KP 9")
        g.GCommand("BP;BV;BN")
        g.GClose()
    assert (tmp_path / "galil0.nvram").exists()
    with DaemonThread(cfg) as d:
        g = gclib.py()
        g.GOpen(f"galil0 --endpoint {d.endpoint}")
        g.GSleep(10)  # #AUTO started at power-up: its BGX
        g.GMotionComplete("X")
        assert g.GCommand("MG V2") == "0000000042.0000"
        assert g.GCommand("KP ?") == "0009.00"
        assert g.GCommand("RPX") == "0000001000"
        assert g.GProgramUpload().startswith("#AUTO\r\n")
        g.GClose()


def test_a_corrupt_flash_file_does_not_stop_the_card(tmp_path: Path) -> None:
    (tmp_path / "galil0.nvram").write_bytes(b"\xc1not msgpack")
    cfg = rack_config(card(GALIL, "galil0"))
    cfg.state_dir = str(tmp_path)
    with DaemonThread(cfg) as d:
        g = gclib.py()
        g.GOpen(f"galil0 --endpoint {d.endpoint}")
        assert g.GCommand("KP ?") == "0006.00"
        assert g.GProgramUpload() == ""
        g.GClose()


def test_download_and_upload_on_a_card_that_decodes_at_its_samples() -> None:
    """decode = "sample": the card empties the command FIFO at its samples; the download's
    bursts wait for room in the same batch."""
    with DaemonThread(rack_config(card(GALIL, "galil0", decode="sample"))) as d:
        g = gclib.py()
        g.GOpen(f"galil0 --endpoint {d.endpoint}")
        program = hundred_lines()
        g.GProgramDownload(program)
        assert g.GProgramUpload() == program.replace("\n", "\r\n") + "\r\n"
        g.GProgramDownload("#A\nMG \"HI\"\nEN")
        g.GCommand("XQ #A")
        g.GSleep(5)
        assert g.GMessage() == "HI\r\n"
        g.GClose()
