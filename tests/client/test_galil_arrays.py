"""Arrays and record mode of the DMC-13X8 through both clients, on a lockstep daemon:
vdevclient.galil's DMCArrayDownload/DMCArrayUpload (the DMC library, spec §6.2) and
vdevclient.gclib's GArrayDownload/GArrayUpload/GArrayDownloadFile/GArrayUploadFile."""

from __future__ import annotations

import ctypes
from collections.abc import Callable, Iterator
from pathlib import Path

import pytest
from vdevclient import galil, gclib

from tests.client.galil import GALIL, card, rack_config
from vdevd.testing import DaemonThread

OK = galil.DMCNOERROR
BIG = 1000  # elements of the large round trips (two of the 512-byte FIFOs many times over)


@pytest.fixture
def daemon() -> Iterator[DaemonThread]:
    with DaemonThread(rack_config(card(GALIL, "galil0"))) as d:
        yield d


@pytest.fixture
def h(daemon: DaemonThread) -> Iterator[ctypes.c_long]:
    handle = ctypes.c_long()
    assert galil.DMCOpen(1, 0, ctypes.byref(handle), endpoint=daemon.endpoint) == OK
    yield handle
    galil.DMCClose(handle)


@pytest.fixture
def g(daemon: DaemonThread) -> Iterator[gclib.py]:
    conn = gclib.py()
    conn.GOpen(f"galil0 --endpoint {daemon.endpoint}")
    yield conn
    conn.GClose()


def command(h: ctypes.c_long, text: str) -> bytes:
    buf = ctypes.create_string_buffer(1024)
    assert galil.DMCCommand(h, text, buf, 1024) == OK, text
    return buf.value


def upload(h: ctypes.c_long, name: str, first: int, last: int, comma: int,
           size: int = 64_000) -> tuple[int, bytes, int]:
    buf = ctypes.create_string_buffer(size)
    read = ctypes.c_ulong()
    rc = galil.DMCArrayUpload(h, name, first, last, buf, size, ctypes.byref(read), comma)
    return rc, buf.value, read.value


def download(h: ctypes.c_long, name: str, first: int, last: int, data: bytes) -> tuple[int, int]:
    written = ctypes.c_ulong()
    rc = galil.DMCArrayDownload(h, name, first, last, ctypes.create_string_buffer(data), len(data),
                                ctypes.byref(written))
    return rc, written.value


def error_text(h: ctypes.c_long, code: int) -> bytes:
    buf = ctypes.create_string_buffer(256)
    galil.DMCError(h, code, buf, 256)
    return buf.value


# -- the DMC library --------------------------------------------------------------------------------
def test_dmc_array_download_and_upload_round_trip_1000_elements(h: ctypes.c_long) -> None:
    command(h, f"DM BIG[{BIG}]")
    sent = [i * 1.5 - 300 for i in range(BIG)]
    data = ",".join(f"{v:g}" for v in sent).encode()
    assert download(h, "BIG", 0, BIG - 1, data) == (OK, len(data))
    rc, text, read = upload(h, "BIG", 0, BIG - 1, 1)
    assert rc == OK and read == len(text)
    assert [float(v) for v in text.split(b",")] == sent
    rc, text, _ = upload(h, "BIG", 10, 12, 0)
    assert (rc, text) == (OK, b"-0000000285.0000\r-0000000283.5000\r-0000000282.0000")
    assert command(h, "MG BIG[999]") == b" 0000001198.5000\r\n:"


def test_dmc_array_calls_on_a_missing_array_or_range_answer_the_card_s_reason(h: ctypes.c_long) -> None:
    rc, text, read = upload(h, "NONE", 0, 3, 1)
    assert (rc, text, read) == (galil.DMCERROR_COMMAND, b"", 0)
    assert error_text(h, rc) == b"82 Undefined array."
    command(h, "DM A[4]")
    assert download(h, "A", 2, 5, b"1,2,3,4") == (galil.DMCERROR_COMMAND, 0)
    assert error_text(h, galil.DMCERROR_COMMAND) == b"56 Array index invalid or out of range."
    assert download(h, "A", 0, 1, b"1,2,3") == (galil.DMCERROR_COMMAND, 0)  # one too many
    assert upload(h, "A", 0, 3, 1)[1] == b"0000000001.0000,0000000002.0000,0000000000.0000,0000000000.0000"
    assert command(h, "TPX") == b"0000000000\r\n:"  # the card still serves


def test_dmc_array_upload_into_a_small_buffer_is_DMCERROR_BUFFERFULL(h: ctypes.c_long) -> None:
    command(h, "DM A[10]")
    rc, text, read = upload(h, "A", 0, 9, 1, size=20)
    assert rc == galil.DMCERROR_BUFFERFULL and text == b"0000000000.0000,000" and read == 19


def test_record_mode_through_the_card_s_samples(h: ctypes.c_long, g: gclib.py) -> None:
    """RC 3: TIME recorded every 8 samples while the card's clock runs in lockstep (the card
    rests between commands and records in its samples); TP while X jogs."""
    command(h, "DM T[20],P[20];RA T[],P[];RD TIME,_TPX;JG 10000;BGX")
    command(h, "RC 3")
    g.GSleep(100)
    assert command(h, "MG _RC,_RD") == b" 0000000001.0000 0000000013.0000\r\n:"
    g.GSleep(100)
    assert command(h, "RC ?") == b"0\r\n:"
    times = g.GArrayUpload("T", 0, 19)
    positions = g.GArrayUpload("P")
    assert [b - a for a, b in zip(times, times[1:], strict=False)] == [8] * 19
    speeds = [(b - a) / 0.008 for a, b in zip(positions[10:], positions[11:], strict=False)]
    assert speeds == pytest.approx([10000] * len(speeds), abs=200)  # 10000 counts/s, 8 ms apart


# -- gclib --------------------------------------------------------------------------------------------
def test_garray_download_and_upload_round_trip_1000_elements(g: gclib.py) -> None:
    g.GCommand(f"DM big[{BIG}]")
    sent = [(i * 37) % 1001 - 500.25 for i in range(BIG)]
    g.GArrayDownload("big", -1, -1, sent)
    assert g.GArrayUpload("big", -1, -1) == sent
    assert g.GArrayUpload("big", 998, 999) == sent[998:]
    assert g.GArrayUpload("big", 3, 5, gclib.G_CR) == sent[3:6]


def test_garray_download_into_a_sub_range(g: gclib.py) -> None:
    g.GCommand("DM A[6]")
    g.GArrayDownload("A", 2, 4, [7, 8.5, -9])
    assert g.GArrayUpload("A", -1, -1) == [0, 0, 7, 8.5, -9, 0]


@pytest.mark.parametrize(("call", "code"), [
    (lambda g: g.GArrayUpload("NONE", -1, -1), "82"),
    (lambda g: g.GArrayDownload("NONE", -1, -1, [1]), "82"),
    (lambda g: g.GArrayUpload("A", 2, 4), "56"),
    (lambda g: g.GArrayDownload("A", 0, 1, [1, 2, 3]), "56"),
    (lambda g: g.GArrayDownload("A", -1, -1, [1e-12]), "83"),  # str() gives 1e-12: no DMC number
])
def test_garray_calls_refused_by_the_card_raise_gclib_s_error(g: gclib.py,
                                                             call: Callable[[gclib.py], object],
                                                             code: str) -> None:
    g.GCommand("DM A[3]")
    with pytest.raises(gclib.GclibError, match="^question mark returned by controller$"):
        call(g)
    assert g.GCommand("TC1").split(" ")[0] == code
    assert g.GCommand("TPX") == "0000000000"  # the card still serves


def test_garray_upload_file_and_download_file_round_trip(g: gclib.py, tmp_path: Path) -> None:
    g.GCommand("DM one[3],ten[4]")
    g.GArrayDownload("one", -1, -1, [0, 1, 2])
    g.GArrayDownload("ten", -1, -1, [0, 10, 20, -30.5])
    path = tmp_path / "arrays.csv"
    g.GArrayUploadFile(str(path))
    assert path.read_bytes() == (b"one,ten\r0000000000.0000,0000000000.0000\r"
                                 b"0000000001.0000,0000000010.0000\r0000000002.0000,0000000020.0000\r"
                                 b",-0000000030.5000\r")
    g.GCommand("DA *[]")
    g.GCommand("DM ten[2]")  # the wrong size: GArrayDownloadFile deallocates it first
    g.GArrayDownloadFile(str(path))
    assert g.GCommand("LA") == "one[3]\r\nten[4]"
    assert g.GArrayUpload("ten") == [0, 10, 20, -30.5]
    assert g.GArrayUpload("one") == [0, 1, 2]


def test_garray_upload_file_of_named_arrays_and_a_file_gclib_would_write(g: gclib.py,
                                                                         tmp_path: Path) -> None:
    path = tmp_path / "in.csv"
    path.write_bytes(b"pos,vel\r\n1,2\r\n3,4\r\n5,\r\n")
    g.GArrayDownloadFile(str(path))
    assert g.GArrayUpload("pos") == [1, 3, 5] and g.GArrayUpload("vel") == [2, 4]
    out = tmp_path / "out.csv"
    g.GArrayUploadFile(str(out), ["vel"])
    assert out.read_bytes() == b"vel\r0000000002.0000\r0000000004.0000\r"
    with pytest.raises(gclib.GclibError, match="^file was not found"):
        g.GArrayDownloadFile(str(tmp_path / "missing.csv"))


def test_arrays_on_a_card_that_decodes_at_its_samples() -> None:
    """decode = "sample": QD's data is taken at the samples too, the FIFO filling faster than
    the card empties it."""
    with DaemonThread(rack_config(card(GALIL, "galil0", decode="sample"))) as d:
        conn = gclib.py()
        conn.GOpen(f"galil0 --endpoint {d.endpoint}")
        try:
            conn.GCommand("DM A[300]")
            sent = [float(i) for i in range(300)]
            conn.GArrayDownload("A", -1, -1, sent)
            assert conn.GArrayUpload("A") == sent
            with pytest.raises(gclib.GclibError):
                conn.GArrayDownload("B", -1, -1, sent)
            assert conn.GCommand("TC") == "082"
        finally:
            conn.GClose()
