"""vdevclient.gclib, gclib's Python class `py`, against a lockstep daemon with one DMC-13X8 card."""

from __future__ import annotations

from collections.abc import Iterator

import pytest
import vdevclient
from vdevclient import gclib
from vdevmaps.galil import InterruptStatus

from tests.client.galil import GALIL, card, rack_config, round_trips
from vdevd.testing import DaemonThread


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


def test_gcommand_trims_the_colon_and_whitespace(g: gclib.py) -> None:
    assert g.GCommand("TPX") == "0000000000"
    assert g.GCommand("DP 1000") == ""
    assert g.GCommand("MG _TPX") == "0000001000.0000"
    assert g.GCommand("TPX;TPY") == "0000001000\r\n:0000000000"


def test_a_question_mark_raises_gclib_s_error_and_tc1_tells_why(g: gclib.py) -> None:
    with pytest.raises(gclib.GclibError) as err:
        g.GCommand("XYZ")
    assert str(err.value) == "question mark returned by controller"
    assert g.GCommand("TC1") == "1 Unrecognized command"


def test_gmotioncomplete_returns_when_the_axes_have_stopped(g: gclib.py, rack: vdevclient.Rack) -> None:
    start = rack.sim.now_ns()
    g.GCommand("PR 5000,-2000;BG XY")
    g.GMotionComplete("XY")
    assert g.GCommand("MG _BGX,_BGY") == "0000000000.0000 0000000000.0000"
    assert g.GCommand("RP") == "0000005000,-0000002000,0000000000,0000000000"
    assert rack.sim.now_ns() - start > 100_000_000  # the move took card time, polled on its clock


def test_ginfo_and_gversion(g: gclib.py, daemon: DaemonThread) -> None:
    assert g.GInfo() == f"galil0 on {daemon.endpoint}, DMC1348 Rev 1.1a"
    assert g.GVersion().startswith("py.")


def test_grecord_decodes_the_data_record(g: gclib.py) -> None:
    g.GCommand("PR 1000;BGX;AMX")
    g.GSleep(20)  # DR-4: a record loaded after the move ended
    record = g.GRecord(gclib.G_DR)
    assert record["axis_a_reference_position"] == 1000
    assert record["axis_a_stop_code"] == 1
    assert record["input_bank_0"] == 0xFF
    assert "axis_d_torque" in record and "axis_e_torque" not in record


def test_ginterrupt_gives_the_y_motion_complete_code(g: gclib.py) -> None:
    g.GCommand("EI 2,,255;PR,5000;BGY")
    assert g.GInterrupt() == InterruptStatus.AXIS_COMPLETE + 1  # D1
    g.GCommand("UI 1")
    assert g.GInterrupt() == InterruptStatus.USER + 1  # F1


def test_ginterrupt_times_out_without_an_interrupt(g: gclib.py, rack: vdevclient.Rack) -> None:
    g.GTimeout(50)
    start = rack.sim.now_ns()
    with pytest.raises(gclib.GclibError, match="^device timed out$"):
        g.GInterrupt()
    assert rack.sim.now_ns() - start == 50_000_000
    g.GTimeout(0)
    with pytest.raises(gclib.GclibError, match="^data was not waiting for a zero-timeout read$"):
        g.GInterrupt()


def test_gtimeout_bounds_a_command_and_minus_one_restores_the_open_timeout(
        g: gclib.py, rack: vdevclient.Rack) -> None:
    assert g.timeout == gclib.DEFAULT_TIMEOUT_MS
    g.GTimeout(100)
    start = rack.sim.now_ns()
    with pytest.raises(gclib.GclibError, match="^device timed out$"):
        g.GCommand("WT 2000")
    assert rack.sim.now_ns() - start == 100_000_000
    g.timeout = -1
    assert g.GCommand("TPX") == "0000000000"  # WT's late ':' went to GMessage
    assert g.GMessage() == ":"


def test_the_address_takes_a_timeout_flag_and_ignores_other_gclib_flags(daemon: DaemonThread) -> None:
    conn = gclib.py()
    conn.GOpen(f"galil0 --direct -s ALL --timeout 250 --endpoint {daemon.endpoint}")
    conn.GTimeout(1000)
    conn.GTimeout(-1)
    with pytest.raises(gclib.GclibError, match="^device timed out$"):
        conn.GCommand("WT 300")
    conn.GClose()


@pytest.mark.parametrize(("address", "text"), [
    ("", "a bad address was specified in open"),
    ("galil0 --endpoint", "a bad address was specified in open"),
    ("galil0 galil1", "a bad address was specified in open"),
    ("galil9 --endpoint {endpoint}", "device failed to open"),
])
def test_bad_addresses(daemon: DaemonThread, address: str, text: str) -> None:
    with pytest.raises(gclib.GclibError) as err:
        gclib.py().GOpen(address.format(endpoint=daemon.endpoint))
    assert str(err.value) == text


def test_calls_without_a_connection_raise(g: gclib.py) -> None:
    g.GClose()
    g.GClose()  # closing twice does nothing
    with pytest.raises(gclib.GclibError, match="^connection to hardware not established$"):
        g.GCommand("TPX")


def test_gcommand_costs_at_most_two_round_trips(g: gclib.py, monkeypatch: pytest.MonkeyPatch) -> None:
    with round_trips(monkeypatch) as trips:
        for text in ("TPY", "TP", "PR 100;BGX;AMX", "TPY"):
            trips.reset()
            g.GCommand(text)
            assert trips.count <= 2, text
        assert trips.count == 1


def test_a_gclib_script_runs_with_only_its_import_changed(daemon: DaemonThread,
                                                          capsys: pytest.CaptureFixture[str]) -> None:
    """The shape of Galil's example scripts: `import gclib` becomes an import of this module."""
    script = f"""
from vdevclient import gclib

def main():
    g = gclib.py()
    try:
        g.GOpen('galil0 --endpoint {daemon.endpoint}')
        print(g.GInfo())
        c = g.GCommand
        c('AB')
        c('MO')
        c('SH')
        c('SPA=10000')
        c('PRA=2000')
        c('BGA')
        g.GMotionComplete('A')
        print('position', c('RPA'))
        c('XYZ')
    except gclib.GclibError as e:
        print('Unexpected GclibError:', e)
    finally:
        g.GClose()

main()
"""
    exec(compile(script, "example.py", "exec"), {"__name__": "example"})
    out = capsys.readouterr().out.splitlines()
    assert out == [f"galil0 on {daemon.endpoint}, DMC1348 Rev 1.1a", "position 0000002000",
                   "Unexpected GclibError: question mark returned by controller"]


def test_m_ch3_home_switch_input_hm_and_a_jog_into_the_limit_on_a_configured_stage() -> None:
    """An application homes X with gclib [M Ch3 §Home Switch Input] on a stage whose switches are
    only in the card's `[[card.axis]]` table: HM;BG ends on the index (3500) as position 0 with
    SC 10; a jog then stops at the forward limit (physical 20000: 16500 counts) with SC 2 and
    TS bit 3 clear [M Ch3 §Limit Switch Input; spec §4.4]."""
    stage = {"limits": [-20_000, 20_000], "home": [3000, 30_000],
             "index": {"period": 4096, "phase": 3500}}
    with DaemonThread(rack_config(card(GALIL, "galil0", axis=[stage]))) as d:
        g = gclib.py()
        g.GOpen(f"galil0 --endpoint {d.endpoint}")
        try:
            g.GCommand("SP 5000;AC 256000;DC 256000;HM X;BG X")
            g.GMotionComplete("X")
            assert int(float(g.GCommand("SC X"))) == 10
            assert g.GCommand("RP X") == "0000000000"
            g.GCommand("JG 5000;BG X")
            g.GMotionComplete("X")
            assert int(float(g.GCommand("SC X"))) == 2
            assert not int(float(g.GCommand("TS X"))) & 0x08
            assert 16_500 < float(g.GCommand("RP X")) < 16_500 + 60
        finally:
            g.GClose()
