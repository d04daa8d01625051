"""The card's options, declared once and read from `self.opts` (docs/card-pattern.md "Options:
declared once"): a legal value the former `cfg.get(key) or default` turned into the default is
kept."""

from __future__ import annotations

from vdevclient import maxk

from tests.client.galil import card, rack_config
from vdevd.testing import DaemonThread


def test_serial_0_is_what_wy_reports() -> None:
    """`serial = 0` is legal (0..999999): WY shows S/N 000000, not the default 1 [S §2.6]."""
    spec = card("oms-maxk", "maxk0", board=1, axes=4, serial=0)
    with DaemonThread(rack_config(spec)) as d, maxk.open(1, endpoint=d.endpoint) as m:
        assert m.send_and_get_string("WY") == "MAXk-4000, Ver: 1.50, S/N: 000000, FPGA:20"


def test_the_default_serial_is_1() -> None:
    spec = card("oms-maxk", "maxk0", board=1, axes=4)
    with DaemonThread(rack_config(spec)) as d, maxk.open(1, endpoint=d.endpoint) as m:
        assert "S/N: 000001" in m.send_and_get_string("WY")
