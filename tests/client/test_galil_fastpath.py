"""The quick paths of the DMC library give what the general path gives: a line's prebuilt first
batch in the common state (`DmcBus._quick_command`), the remembered line of a command text
(`galil._line`) and gclib's GCommand over `galil.command_text` send the same requests and get
the same replies, return codes and bus state, through replies whose length changes, '?', unread
replies, a full response FIFO, a time-out, a FIFO clear and echo."""

from __future__ import annotations

import copy
import ctypes
from collections.abc import Callable, Iterator
from typing import Any

import pytest
import vdevclient
from vdevclient import galil, gclib
from vdevclient._galil_bus import MEMO_SIZE, DmcBus
from vdevclient.core import Prepared, Rack

from tests.client.galil import GALIL, card, rack_config
from vdevd.testing import DaemonThread

LONG_MG = 'MG "' + "A" * 60 + '"'  # a 63-byte reply: eight fill the 512-byte response FIFO

#: (action, argument) steps on one controller; "cmd" is DMCCommand
SEQUENCE: list[tuple[str, Any]] = [
    *[("cmd", "TPX")] * 3,
    ("cmd", "DP -1000"), ("cmd", "TPX"), ("cmd", "TPX"), ("cmd", "TPX"),  # a longer reply
    ("cmd", "LZ 1"), ("cmd", "TPX"), ("cmd", "TPX"), ("cmd", "LZ 0"),  # a shorter one
    ("cmd", b"TPX\r"), ("cmd", "TP"), ("cmd", "TP"),
    ("cmd", "XYZ"), ("cmd", "XYZ"), ("cmd", "TC1"), ("cmd", "TPX"),  # '?'
    ("fast", "MG 7"), ("cmd", "TPX"), ("cmd", "TPX"),  # a reply owed
    *[("fast", LONG_MG)] * 10, ("cmd", "TPX"), ("cmd", "TPX"),  # the response FIFO full
    ("unsolicited", None),
    ("fast", "MG 8"), ("clear", None), ("cmd", "TPX"), ("cmd", "TPX"),
    ("cmd", "EO1"), ("cmd", "TPX"), ("cmd", "TPX"), ("cmd", "EO0"), ("cmd", "TPX"),
    ("cmd", "PR 1000;BGX;AMX"), ("cmd", "PR 1000;BGX;AMX"), ("cmd", "TPX"),
    ("cmd", "KP ?,?,?,?;KD ?,?,?,?"), ("cmd", "KP ?,?,?,?;KD ?,?,?,?"),  # two bursts
    ("binary", "D9 00 00 01"), ("binary", "D9 00 00 01"),  # TP X as a binary command
    ("cmd", "RS"), ("cmd", "TPX"), ("cmd", "TPX"),
    ("fast", "DP -5"), ("cmd", "TPX"), ("cmd", "TPX"),  # the new length learnt while owed
    # a time-out: the late reply is owed; the card held by WT had nothing to read for TPX, so
    # the library waits before reading from then on (not eager)
    ("timeout", 10), ("cmd", "WT 100"), ("cmd", "TPX"), ("step", 0.2), ("cmd", "TPX"),
    ("timeout", 1000), ("cmd", "TPX"), ("cmd", "TPX"),
    ("unsolicited", None),
]


@pytest.fixture
def daemon() -> Iterator[DaemonThread]:
    with DaemonThread(rack_config(card(GALIL, "galil0"))) as d:
        yield d


class Recorder:
    """Every request (without its id) and its result (but hello's), copied when it is made."""

    def __init__(self) -> None:
        self.calls: list[tuple[dict[str, Any], Any]] = []

    def install(self, monkeypatch: pytest.MonkeyPatch) -> None:
        call = Rack.call

        def recorded(rack: Rack, message: dict[str, Any] | Prepared, wait_s: float = 0.0) -> Any:
            sent = message.message if isinstance(message, Prepared) else message
            request = copy.deepcopy({k: v for k, v in sent.items() if k != "id"})
            result = call(rack, message, wait_s)
            # hello names the daemon's ports, which differ from run to run
            self.calls.append((request, None if request["op"] == "hello" else copy.deepcopy(result)))
            return result

        monkeypatch.setattr(Rack, "call", recorded)


def bus_state(bus: DmcBus) -> tuple[Any, ...]:
    return bus._room, bus.stale, bus.owed, bus.eager, bytes(bus.unsolicited)


def run_sequence(daemon: DaemonThread) -> list[Any]:
    """Each step's outcome and the bus state after it."""
    h = ctypes.c_long()
    assert galil.DMCOpen(1, 0, ctypes.byref(h), endpoint=daemon.endpoint) == galil.DMCNOERROR
    bus = galil.bus_of(h)
    assert bus is not None
    buf = ctypes.create_string_buffer(1024)
    out: list[Any] = []
    with vdevclient.connect(daemon.endpoint, daemon.events) as rack:
        for action, arg in SEQUENCE:
            if action == "cmd":
                outcome: Any = (galil.DMCCommand(h, arg, buf, 1024), buf.value)
            elif action == "fast":
                outcome = galil.DMCFastCommand(h, arg)
            elif action == "binary":
                data = bytes.fromhex(arg)
                outcome = (galil.DMCBinaryCommand(h, data, len(data), buf, 1024), buf.value)
            elif action == "unsolicited":
                outcome = (galil.DMCGetUnsolicitedResponse(h, buf, 1024), buf.value)
            elif action == "timeout":
                outcome = galil.DMCSetTimeout(h, arg)
            elif action == "step":
                outcome = rack.sim.step(seconds=arg)
            else:
                outcome = galil.DMCClear(h)
            out.append((action, arg, outcome, bus_state(bus)))
    galil.DMCClose(h)
    return out


def counting_quick(monkeypatch: pytest.MonkeyPatch) -> list[int]:
    """Count the exchanges the quick path makes."""
    used = [0]
    quick = DmcBus._quick_command

    def counted(bus: DmcBus, data: bytes, entry: Any) -> Any:
        used[0] += 1
        return quick(bus, data, entry)

    monkeypatch.setattr(DmcBus, "_quick_command", counted)
    return used


def test_the_quick_path_makes_the_general_paths_exchanges(monkeypatch: pytest.MonkeyPatch) -> None:
    runs = []
    for quick in (False, True):
        with monkeypatch.context() as m:
            if not quick:
                m.setattr(DmcBus, "_learn_quick", lambda bus, data, replies: None)
            quick_calls = counting_quick(m)
            recorder = Recorder()
            recorder.install(m)
            with DaemonThread(rack_config(card(GALIL, "galil0"))) as d:
                outcomes = run_sequence(d)
            runs.append((outcomes, recorder.calls, quick_calls[0]))
    (general, general_calls, none), (fast, fast_calls, used) = runs
    assert none == 0 and used >= 10
    for step, (want, got) in enumerate(zip(general, fast, strict=True)):
        assert got == want, f"step {step}: {SEQUENCE[step]}"
    assert fast_calls == general_calls


def test_gcommand_answers_as_dmccommand_into_gclibs_buffer(monkeypatch: pytest.MonkeyPatch) -> None:
    """GCommand before command_text: DMCCommand into its 500 000-byte buffer, then `.value`."""

    def through_the_buffer(g: gclib.py, command: str) -> str:
        g._cc()
        gclib._rc(galil.DMCCommand(g._gcon, command, g._buf, gclib._BUF_SIZE))
        response = g._buf.value.decode("latin-1")
        return response[:-1].strip() if response.endswith(":") else response.strip()

    texts = ["TPX", "TPX", "DP -1000", "TPX", "TPX", "XYZ", "TPX", "MG \"a\",\"b\"", "TP",
             "EO1", "TPX", "EO0", "TC1", "WT 2000", "TPX", "TPX"]
    runs = []
    for command in (gclib.py.GCommand, through_the_buffer):
        recorder = Recorder()
        with monkeypatch.context() as m:
            recorder.install(m)
            with DaemonThread(rack_config(card(GALIL, "galil0"))) as d:
                g = gclib.py()
                g.GOpen(f"galil0 --endpoint {d.endpoint} --timeout 100")
                outcomes: list[str] = []
                for text in texts:
                    try:
                        outcomes.append(command(g, text))
                    except gclib.GclibError as exc:
                        outcomes.append(f"error: {exc}")
                outcomes.append(g.GMessage())
                g.GClose()
                try:
                    command(g, "TPX")
                except gclib.GclibError as exc:
                    outcomes.append(f"error: {exc}")
        runs.append((outcomes, recorder.calls))
    assert runs[0] == runs[1]
    assert "error: question mark returned by controller" in runs[0][0]
    assert "error: device timed out" in runs[0][0]


@pytest.mark.parametrize("size", [1, 5, 13, 14, 15])
def test_command_text_is_dmccommand_into_a_buffer_of_that_size(daemon: DaemonThread,
                                                               size: int) -> None:
    h = ctypes.c_long()
    assert galil.DMCOpen(1, 0, ctypes.byref(h), endpoint=daemon.endpoint) == galil.DMCNOERROR
    extra, again = ctypes.create_string_buffer(64), ctypes.create_string_buffer(64)
    for text in ("TPX", "TPX", "XYZ"):  # a 13-byte reply, then '?'
        buf = ctypes.create_string_buffer(size)
        rc = galil.DMCCommand(h, text, buf, size)
        assert galil.DMCGetAdditionalResponse(h, extra, 64) == galil.DMCNOERROR
        assert galil.command_text(h, text, size) == (rc, buf.value)
        assert galil.DMCGetAdditionalResponse(h, again, 64) == galil.DMCNOERROR
        assert again.value == extra.value
    galil.DMCClose(h)
    assert galil.command_text(h, "TPX", size) == (galil.DMCERROR_HANDLE, b"")


def test_the_remembered_lines_and_batches_are_bounded(daemon: DaemonThread) -> None:
    h = ctypes.c_long()
    assert galil.DMCOpen(1, 0, ctypes.byref(h), endpoint=daemon.endpoint) == galil.DMCNOERROR
    bus = galil.bus_of(h)
    assert bus is not None
    buf = ctypes.create_string_buffer(64)
    texts: list[Callable[[int], str | bytes]] = [lambda i: f"MG {i}", lambda i: b"MG %d;" % i]
    for i in range(MEMO_SIZE + 40):
        for text in texts:
            assert galil.DMCCommand(h, text(i), buf, 64) == galil.DMCNOERROR
            assert galil.DMCCommand(h, text(i), buf, 64) == galil.DMCNOERROR
    assert len(bus._reply_len) <= MEMO_SIZE
    assert len(bus._quick) <= MEMO_SIZE
    assert set(bus._quick) <= set(bus._reply_len)
    controller = galil._handle(h)
    assert controller is not None and len(controller.lines) <= galil.LINES_MEMO_SIZE
    galil.DMCClose(h)
