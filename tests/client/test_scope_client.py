"""The scope from vdevclient and vdevctl (issue 23 §1) through a real lockstep daemon:
`card.scope(...)` returns numpy arrays with the simulated time base, the CSV has `time_s` and one
column per axis and signal, the PNG has one panel per signal, and `vdevctl scope` arms, steps
the clock itself (or waits, with --no-step), reads and writes both."""

from __future__ import annotations

import contextlib
import csv
import io
import threading
from collections.abc import Iterator
from pathlib import Path

import numpy as np
import pytest
import vdevclient
from vdevclient import gclib
from vdevclient.cli import main as vdevctl
from vdevclient.scope import parse_trigger

from tests.client.galil import card, rack_config
from tests.test_scope import AxisReg, i32, move
from vdevd.testing import DaemonThread


def run(*argv: str) -> tuple[int, str, str]:
    out, err = io.StringIO(), io.StringIO()
    with contextlib.redirect_stdout(out), contextlib.redirect_stderr(err):
        try:
            code = vdevctl(list(argv))
        except SystemExit as exc:  # argparse's usage errors
            code = int(exc.code or 0)
    return code, out.getvalue(), err.getvalue()


def test_card_scope_returns_arrays_with_the_simulated_time_base(rack: vdevclient.Rack) -> None:
    t0 = rack.sim.now_ns()
    move(rack, 0, 400)
    trace = rack.card("servo0").scope(["0"], ["position", "velocity", "status"], seconds=0.1)
    assert rack.sim.now_ns() == t0 + 100_000_000  # stepped the recording's length
    assert len(trace) == 100 and trace.state == "done"
    assert trace.time_ns.dtype == np.int64 and trace.time_ns[0] == t0 + 1_000_000
    assert np.allclose(trace.time, trace.time_ns / 1e9)
    assert trace["0.position"].dtype == np.float64 and trace["0.status"].dtype == np.int64
    assert trace["0.position"][-1] == i32(rack, 0, AxisReg.POSITION)
    assert trace.signals() == ["position", "velocity", "status"] and trace.axes() == ["0"]


def test_csv_has_time_s_then_one_column_per_axis_and_signal(rack: vdevclient.Rack,
                                                            tmp_path: Path) -> None:
    move(rack, 1, -250)
    trace = rack.card("servo0").scope(["0", "1"], ["position", "error", "inputs"], seconds=0.05)
    path = tmp_path / "t.csv"
    trace.to_csv(path)
    rows = list(csv.reader(path.read_text().splitlines()))
    assert rows[0] == ["time_s", "0.position", "0.error", "0.inputs", "1.position", "1.error",
                       "1.inputs"]
    assert len(rows) == 51
    assert [float(r[0]) for r in rows[1:]] == pytest.approx(list(trace.time))
    assert [float(r[4]) for r in rows[1:]] == list(trace["1.position"])
    assert rows[-1][3].isdigit()  # a word as an integer


def test_png_has_one_panel_per_signal(rack: vdevclient.Rack, tmp_path: Path) -> None:
    import matplotlib.image

    move(rack, 2, 100)
    trace = rack.card("servo0").scope(["2"], ["position", "velocity", "error"], seconds=0.05)
    one = rack.card("servo0").scope(["2"], ["position"], seconds=0.05)
    trace.to_png(tmp_path / "three.png", title="three")
    one.to_png(tmp_path / "one.png")
    three_px = matplotlib.image.imread(tmp_path / "three.png")
    one_px = matplotlib.image.imread(tmp_path / "one.png")
    assert three_px.shape[0] == round(100 * (2.2 * 3 + 0.6))  # figure height follows panels
    assert one_px.shape[0] == round(100 * (2.2 + 0.6))
    assert three_px.std() > 0  # something drawn


@pytest.fixture
def galil_daemon() -> Iterator[DaemonThread]:
    with DaemonThread(rack_config(card("galil-dmc13x8", "galil0"))) as d:
        yield d


def test_vdevctl_scope_records_a_galil_profiled_move(galil_daemon: DaemonThread,
                                                     tmp_path: Path) -> None:
    """The README's command: the move begun just before, recorded for 1 s of simulated time."""
    g = gclib.py()
    g.GOpen(f"galil0 --endpoint {galil_daemon.endpoint}")
    try:
        g.GCommand("SH X;PR 10000;SP 20000;DC 100000;AC 100000;BG X")
        csv_path, png_path = tmp_path / "move.csv", tmp_path / "move.png"
        code, out, err = run("--endpoint", galil_daemon.endpoint, "scope", "galil0", "--axes",
                             "X", "--signals", "position,velocity,error", "--seconds", "1",
                             "--csv", str(csv_path), "--png", str(png_path))
        assert (code, err) == (0, "")
        assert out == (f"galil0: 1000 samples of 3 columns, 0.001000..1.000000 s (done) -> "
                       f"{csv_path}, {png_path}\n")
        rows = list(csv.reader(csv_path.read_text().splitlines()))
        assert rows[0] == ["time_s", "X.position", "X.velocity", "X.error"]
        assert float(rows[-1][1]) == int(g.GCommand("TP X")) == 10_000
        assert png_path.read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"
        with vdevclient.connect(galil_daemon.endpoint) as rack:
            assert rack.sim.now_ns() == 1_000_000_000
    finally:
        g.GClose()


def test_vdevctl_scope_no_step_waits_for_someone_to_step(daemon: DaemonThread,
                                                         rack: vdevclient.Rack,
                                                         tmp_path: Path) -> None:
    result: list[tuple[int, str, str]] = []
    path = tmp_path / "t.csv"
    worker = threading.Thread(target=lambda: result.append(run(
        "--endpoint", daemon.endpoint, "scope", "servo0", "--seconds", "0.02", "--no-step",
        "--every", "2", "--csv", str(path))))
    worker.start()
    recorder = rack.card("servo0").scope_recorder()
    for _ in range(500):  # until the command armed
        if recorder.status()["state"] != "idle":
            break
        threading.Event().wait(0.01)
    assert rack.sim.now_ns() == 0
    rack.sim.step(seconds=0.02)
    worker.join(30)
    assert result and result[0][0] == 0, result
    rows = list(csv.reader(path.read_text().splitlines()))
    assert len(rows) == 11 and rows[0][:4] == ["time_s", "0.position", "0.command", "0.error"]
    assert float(rows[-1][0]) == pytest.approx(0.02)


def test_vdevctl_scope_trigger_and_pre(daemon: DaemonThread, rack: vdevclient.Rack,
                                       tmp_path: Path) -> None:
    move(rack, 3, 1000)
    path = tmp_path / "t.csv"
    code, out, err = run("--endpoint", daemon.endpoint, "scope", "servo0", "--axes", "3",
                         "--signals", "position", "--seconds", "0.05", "--pre", "5",
                         "--trigger", "position:3:500:rising", "--csv", str(path))
    assert code == 0 and "(done)" in out, err
    pos = [float(r[1]) for r in list(csv.reader(path.read_text().splitlines()))[1:]]
    assert len(pos) == 50 and pos[4] < 500 <= pos[5]
    assert rack.sim.now_ns() == 150_000_000  # 0.05 s, then on 0.05 s at a time until done


def test_vdevctl_scope_not_triggered_writes_nothing(daemon: DaemonThread,
                                                   tmp_path: Path) -> None:
    path = tmp_path / "t.csv"
    code, out, err = run("--endpoint", daemon.endpoint, "scope", "servo0", "--seconds", "0.01",
                         "--trigger", "irq:inta", "--trigger-wait", "0.5", "--csv", str(path))
    assert code == 1 and out == ""
    assert err == "vdevctl: scope on servo0: the recording is armed after 0.51 s (0 samples)\n"
    with vdevclient.connect(daemon.endpoint) as rack:
        assert rack.sim.now_ns() == 510_000_000
    assert not path.exists()


@pytest.mark.parametrize(("argv", "words"), [
    (["--signals", "torque"], "no signal 'torque'"),
    (["--trigger", "edge:1"], "trigger 'edge:1' is not"),
    (["--trigger", "position:X:nan"], "not finite"),
    (["--every", "0"], "'0' is not a positive integer"),
    (["--seconds", "-1"], "'-1' is not a number of seconds"),
])
def test_vdevctl_scope_usage_errors(daemon: DaemonThread, argv: list[str], words: str) -> None:
    args = ["--endpoint", daemon.endpoint, "scope", "servo0", *argv]
    if "--seconds" not in argv:
        args += ["--seconds", "1"]
    code, out, err = run(*args)
    assert code == 2 and words in err


def test_vdevctl_scope_daemon_errors_exit_1(daemon: DaemonThread) -> None:
    code, _, err = run("--endpoint", daemon.endpoint, "scope", "servo0", "--axes", "7",
                       "--seconds", "1")
    assert code == 1 and "no axis '7'" in err
    code, _, err = run("--endpoint", daemon.endpoint, "scope", "servo0", "--seconds", "3000")
    assert code == 1 and "limit of 2,000,000 values" in err


def test_parse_trigger() -> None:
    assert parse_trigger("now") == {"kind": "now"}
    assert parse_trigger("irq") == {"kind": "irq"}
    assert parse_trigger("irq:cmp") == {"kind": "irq", "line": "cmp"}
    assert parse_trigger("position:X:-1.5:either") == {"kind": "position", "axis": "X",
                                                       "level": -1.5, "direction": "either"}
    assert parse_trigger("register:a16:0x4:1:0x80:0x80") == {
        "kind": "register", "region": "a16", "offset": 4, "width": 1, "mask": 0x80,
        "value": 0x80}
    with pytest.raises(ValueError):
        parse_trigger("register:a16")
