"""Saved card images of the wrong shape on a live daemon (issue 22 §4; vdevd/nvram.py,
vdevd/nvcheck.py and each card's check): the daemon starts, the image is kept aside as
`<card>.nvram.corrupt` with a warning naming the card and the entry, and the card starts from
its defaults, whole (no part of a bad image restored). Images the cards save themselves load
back untouched."""

from __future__ import annotations

import logging
import socket
from collections.abc import Callable, Iterator
from contextlib import contextmanager
from dataclasses import replace
from pathlib import Path
from typing import Any

import msgpack
import numpy as np
import pytest
import vdevclient

from tests.card_ports import connect, pmac_ask
from vdevd.config import Config, default_config
from vdevd.devices.pmac.ethernet_server import parse_endpoint
from vdevd.testing import DaemonThread

GALIL_FLASH = "vdevd-galil-dmc13x8-flash"


def rack(state_dir: Path) -> Config:
    """The default rack (one card of each type), lockstep, its TCP ports on free ports, the
    Galil's on too, saving to `state_dir`."""
    cfg = default_config()
    cfg.clock = "lockstep"
    cfg.endpoint = cfg.events = "tcp://127.0.0.1:*"
    cfg.state_dir = str(state_dir)
    cfg.cards = [replace(spec, options={**spec.options, "ethernet": "tcp://127.0.0.1:0"})
                 if "ethernet" in spec.options or spec.name == "galil0" else spec
                 for spec in cfg.cards]
    return cfg


@contextmanager
def daemon(state_dir: Path) -> Iterator[DaemonThread]:
    with DaemonThread(rack(state_dir)) as d:
        yield d


def card(d: DaemonThread, name: str) -> Any:
    assert d.server is not None
    return d.server.rack.cards[name]


def port(d: DaemonThread, name: str) -> tuple[str, int]:
    return parse_endpoint(card(d, name).ethernet_endpoint)


def galil_ask(s: socket.socket, data: bytes, answers: int) -> bytes:
    """Send `data`; read until `answers` replies (each ends ':' or '?') have come."""
    s.sendall(data)
    got = b""
    while got.count(b":") + got.count(b"?") < answers:
        chunk = s.recv(4096)
        assert chunk
        got += chunk
    return got


#: card, a bad image (some of it good), and what shows the card at its defaults
BAD: list[tuple[str, dict[str, Any], Callable[[Any], bool]]] = [
    ("servo0", {"vmax": [-1, -2, -3, -4]},
     lambda c: bool((c.axis_regs["vmax"] == 50_000).all())),
    ("servo0", {"vmax": [1000] * 4, "acc": ["fast"] * 4},
     lambda c: bool((c.axis_regs["vmax"] == 50_000).all())),
    ("pmac0", {"ivars": {"130": "x"}, "p": {"1": 5.0}},
     lambda c: c.fw.p[1] == 0 and c.fw.ivars.values[130] == c.fw.ivars.defaults[130]),
    ("pmac0", {"ivars": {"130": 1e300}}, lambda c: c.fw.ivars.values[130] == c.fw.ivars.defaults[130]),
    ("pmac0", {"mdefs": {"1": "nonsense"}}, lambda c: c.fw.saved == {}),
    ("maxk0", {"format": 2, "values": {"KP": ["x"] * 8}},
     lambda c: c.archive_error and c.fw.loaded == "factory"),
    ("maxk0", {"format": 2, "values": {"VL": [5e9] * 8}, "gpio_dir": 1},
     lambda c: c.archive_error and c.fw.gpio_dir != 1),
    ("galil0", {"flash": {"format": GALIL_FLASH, "version": 1, "variables": {"V1": 5.0},
                          "parameters": {"values": {"KP": ["x"]}}}},
     lambda c: "V1" not in c.firmware.variables and c._flash is None),
    ("galil0", {"flash": {"format": GALIL_FLASH, "version": 1, "programs": ["#A", "#A"]}},
     lambda c: c._flash is None),
    ("galil0", {"flash": 1}, lambda c: c._flash is None),
    ("octavia0", {"format": "octavia-battery-1", "ram": b"\x01" * 65536, "vars": b"x"},
     lambda c: not c.fw.ram.words.any()),
    ("adlink0", {"flash": {"board": {"0x8000": "x"}}}, lambda c: True),
]


@pytest.mark.parametrize(("name", "image", "at_defaults"), BAD,
                         ids=[f"{n}-{i}" for i, (n, _, _) in enumerate(BAD)])
def test_a_bad_image_is_set_aside_and_the_card_starts_from_its_defaults(
        tmp_path: Path, caplog: pytest.LogCaptureFixture, name: str, image: dict[str, Any],
        at_defaults: Callable[[Any], bool]) -> None:
    (tmp_path / f"{name}.nvram").write_bytes(msgpack.packb(image, use_bin_type=True))
    with caplog.at_level(logging.WARNING, logger="vdevd"), daemon(tmp_path) as d:
        with vdevclient.connect(d.endpoint, timeout=10) as client:
            client.sim.step(ns=1_000_000)  # the rack runs
        assert at_defaults(card(d, name))
    assert not (tmp_path / f"{name}.nvram").exists()
    assert (tmp_path / f"{name}.nvram.corrupt").read_bytes() == msgpack.packb(image,
                                                                             use_bin_type=True)
    warnings = [r.getMessage() for r in caplog.records if r.name == "vdevd.nvram"]
    assert len(warnings) == 1
    assert "invalid flash image" in warnings[0] and f"{name} starts from its defaults" in warnings[0]


def test_images_the_cards_save_load_back(tmp_path: Path) -> None:
    """servo0's save, the PMAC's SAVE and the Galil's BP BV BN: a restart restores each, no
    image set aside."""
    program = b"DL\r#A\rMG 1\rEN\r\\"
    with daemon(tmp_path) as d:
        servo = card(d, "servo0")
        servo.axis_regs["vmax"] = [1000, 2000, 3000, 4000]
        with vdevclient.connect(d.endpoint, timeout=10) as client:
            client.control("servo0", "save")
        with connect(port(d, "pmac0")) as s:
            assert pmac_ask(s, "i6=1 i3=2 I130=5000 P1=7 M1->Y:$78800,0 SAVE") == b"\x06"
        with connect(port(d, "galil0")) as s:
            commands = b"V1=123;DM POS[3];POS[2]=-7;KP 12,13;CO 2;SB 26;OP 9;PF-4;VF 2.1;MO X;BP;BV;BN\r"
            assert galil_ask(s, program + commands, 14) == b":" * 14
    with daemon(tmp_path) as d:
        assert card(d, "servo0").axis_regs["vmax"].tolist() == [1000, 2000, 3000, 4000]
        pmac = card(d, "pmac0").fw
        assert pmac.ivars.values[130] == 5000 and pmac.p[1] == 7
        galil = card(d, "galil0").firmware
        assert galil.variables["V1"] == 123 and galil.arrays.array("POS")[2] == -7
        assert np.allclose(galil.motion.values["KP"][:2], [12, 13])
        assert galil.threads.program.lines == ["#A", "MG 1", "EN"]
    assert not list(tmp_path.glob("*.corrupt"))
