"""The web view in a real browser (issue 23 §3): headless Chromium, driven by Playwright, loads
the page of a lockstep daemon, jogs a Galil axis and steps the clock with the page's buttons,
trips the forward limit with a backdoor button, and checks what the page shows against the
card's own answers (TP, RP, TS, _BG) through the vendor library; arms the scope and sees it
plotted, sees an interrupt come, and a bad request's error; a screenshot is saved; then moves
an axis at rest, its motor off, by the push buttons (backdoor `push`) and checks the page and
TP.

Chromium is installed by `make test` where the machine allows (`make chromium`: root with
apt); without it the test is skipped, saying so. VDEVD_WEB_SCREENSHOT names where the screenshot goes
(default: the test's tmp dir); the README's docs/web-view.png is made that way.
"""

from __future__ import annotations

import ctypes
import os
import shutil
from collections.abc import Iterator
from pathlib import Path
from typing import Any

import pytest
from vdevclient import galil

from tests.client.galil import GALIL, card, rack_config
from vdevd.testing import DaemonThread
from vdevd.web.config import WebConfig

CHROMIUM = os.environ.get("VDEVD_CHROMIUM", "/usr/bin/chromium")
ARGS = ["--headless", "--no-sandbox", "--disable-gpu", "--disable-quic", "--no-first-run",
        "--disable-background-networking", "--disable-component-update", "--disable-sync"]
#: how long the page may take to show what the daemon holds (it is pushed 10 times a second)
SHOWN_MS = 10_000

sync_api = pytest.importorskip("playwright.sync_api",
                               reason="playwright is not installed (pip install -e '.[test]')")

pytestmark = pytest.mark.skipif(
    not (os.access(CHROMIUM, os.X_OK) or shutil.which(CHROMIUM)),
    reason=f"no Chromium at {CHROMIUM}: `make chromium` (part of `make test`'s install) "
           "installs it as root with apt; or set VDEVD_CHROMIUM to a Chromium binary")


@pytest.fixture
def daemon() -> Iterator[DaemonThread]:
    cfg = rack_config(card(GALIL, "galil0"), card("dspcg-octavia", "octavia0"))
    cfg.web = WebConfig("127.0.0.1:0")
    with DaemonThread(cfg) as d:
        yield d


@pytest.fixture
def page(tmp_path: Path) -> Iterator[Any]:
    with sync_api.sync_playwright() as p:
        browser = p.chromium.launch_persistent_context(
            str(tmp_path / "profile"), executable_path=CHROMIUM, args=ARGS, headless=True,
            viewport={"width": 1500, "height": 900})
        try:
            yield browser.pages[0] if browser.pages else browser.new_page()
        finally:
            browser.close()


#: the canvas pixels drawn on
INKED = """() => {
  const c = document.getElementById('scope-canvas');
  const d = c.getContext('2d').getImageData(0, 0, c.width, c.height).data;
  let n = 0;
  for (let i = 3; i < d.length; i += 4) if (d[i]) n++;
  return n;
}"""


def command(h: Any, text: str) -> bytes:
    buf = ctypes.create_string_buffer(1024)
    assert galil.DMCCommand(h, text, buf, 1024) == galil.DMCNOERROR, text
    return buf.value.strip(b": \r\n")


def shown(value: float) -> str:
    """A number as the page shows it (JavaScript's String(Number(v.toFixed(3))))."""
    text = f"{round(value, 3):.3f}".rstrip("0").rstrip(".")
    return "0" if text == "-0" else text


def test_the_page_jogs_an_axis_steps_the_clock_and_trips_a_limit(
        daemon: DaemonThread, page: Any, tmp_path: Path) -> None:
    expect = sync_api.expect
    assert daemon.web is not None
    h = ctypes.c_long()
    assert galil.DMCOpen(1, 0, ctypes.byref(h), endpoint=daemon.endpoint) == galil.DMCNOERROR
    try:
        page.goto(daemon.web.url + "/")
        expect(page.locator("#link")).to_have_text("live", timeout=SHOWN_MS)
        expect(page.locator("#position-galil0-X")).to_have_text("0", timeout=SHOWN_MS)

        # the scope panel arms a 0.3 s recording of X's position, velocity and error
        page.fill("#scope-axes", "X")
        page.fill("#scope-seconds", "0.3")
        page.click("#btn-scope-arm")
        expect(page.locator("#scope-status")).to_contain_text("recording", timeout=SHOWN_MS)

        command(h, "AC 100000;JG 2000;BGX")  # the application starts a jog; the page steps
        page.select_option("#step-size", "0.1")
        page.click("#btn-step")
        expect(page.locator("#clock-now")).to_have_text("0.100000", timeout=SHOWN_MS)
        tp = int(command(h, "TPX"))
        assert 150 < tp < 200  # 100 ms of a 2000 counts/s jog that took 20 ms to reach it
        expect(page.locator("#position-galil0-X")).to_have_text(shown(tp), timeout=SHOWN_MS)
        expect(page.locator("#flags-galil0-X")).to_contain_text("MOVING", timeout=SHOWN_MS)

        page.click("#btn-limpos-galil0-X")  # +lim: the forward limit switch, held active
        expect(page.locator("#btn-limpos-galil0-X")).to_have_class("active", timeout=SHOWN_MS)
        page.click("#btn-step")
        expect(page.locator("#clock-now")).to_have_text("0.200000", timeout=SHOWN_MS)
        expect(page.locator("#flags-galil0-X")).to_contain_text("HARD_LIMIT_POS",
                                                                timeout=SHOWN_MS)
        expect(page.locator("#flags-galil0-X")).not_to_contain_text("MOVING",
                                                                    timeout=SHOWN_MS)
        ts = int(command(h, "TSX"))
        assert not ts & 0x08  # the forward limit bit reads 0: tripped [M Ch3 TS]
        assert float(command(h, "MG _BGX")) == 0  # the jog stopped at the limit
        tp = int(command(h, "TPX"))
        expect(page.locator("#position-galil0-X")).to_have_text(shown(tp), timeout=SHOWN_MS)
        rp = int(command(h, "RPX"))  # the commanded position, where the stop ended
        # the page shows the state of the position checked above; RP reads it in whole counts
        assert round(float(page.locator("#command-galil0-X").inner_text())) == rp

        # a bad request from the page: the daemon's error is shown, nothing else changes
        page.select_option("#action-galil0", "set_limit")
        page.fill("#params-galil0", '{"axis": "Q"}')
        page.click("#btn-control-galil0")
        expect(page.locator("#error")).to_contain_text("bad_param: set_limit: no axis 'Q'",
                                                       timeout=SHOWN_MS)
        assert int(command(h, "TPX")) == tp

        # an interrupt as it comes: a DSPL program's INT_HOST on the Octavia, from its form
        page.select_option("#action-octavia0", "dspl_host_interrupt")
        page.fill("#params-octavia0", '{"value": 1}')
        page.click("#btn-control-octavia0")
        row = page.locator("#irqs tbody tr").first
        expect(row).to_contain_text("octavia0", timeout=SHOWN_MS)
        expect(row.locator("td").nth(1)).to_have_text("inta")

        shot = Path(os.environ.get("VDEVD_WEB_SCREENSHOT", tmp_path / "web-view.png"))
        page.click("#btn-step")  # the error clears at the next request that succeeds
        expect(page.locator("#error")).to_be_hidden(timeout=SHOWN_MS)
        # 0.3 s recorded: the page reads the trace and plots it, one panel a signal
        expect(page.locator("#scope-status")).to_contain_text("done: 300 of 300 samples",
                                                              timeout=SHOWN_MS)
        page.wait_for_function("() => document.getElementById('scope-canvas')"
                               ".dataset.samples === '300'", timeout=SHOWN_MS)
        assert page.evaluate(INKED) > 2000
        page.screenshot(path=str(shot), full_page=True)
        assert shot.stat().st_size > 10_000

        # Run steps the clock at real-time pace until Pause
        page.click("#btn-run")
        expect(page.locator("#clock-running")).to_have_text("running", timeout=SHOWN_MS)
        expect(page.locator("#clock-now")).not_to_have_text("0.300000", timeout=SHOWN_MS)
        page.click("#btn-pause")
        expect(page.locator("#clock-running")).to_have_text("paused", timeout=SHOWN_MS)
        assert page.locator("#error").is_hidden()

        # the push buttons move Y (at rest: X coasts from its limit stop once its motor is off)
        # by hand (backdoor `push`): its motor off [M Ch2 MO], it stays there, TP reads it, and
        # at the next step its command follows
        command(h, "MO Y")
        tp, rp = int(command(h, "TPY")), int(command(h, "RPY"))
        page.click("#btn-pushpos-galil0-Y")
        expect(page.locator("#position-galil0-Y")).to_have_text(shown(tp + 100), timeout=SHOWN_MS)
        page.click("#btn-pushpos-galil0-Y")
        expect(page.locator("#position-galil0-Y")).to_have_text(shown(tp + 200), timeout=SHOWN_MS)
        page.click("#btn-pushneg-galil0-Y")
        expect(page.locator("#position-galil0-Y")).to_have_text(shown(tp + 100), timeout=SHOWN_MS)
        held = page.locator("#command-galil0-Y").inner_text()
        assert round(float(held)) == rp  # the command did not move (no tick yet)
        assert int(command(h, "TPY")) == tp + 100
        before = page.locator("#clock-now").inner_text()
        page.click("#btn-step")
        expect(page.locator("#clock-now")).not_to_have_text(before, timeout=SHOWN_MS)
        expect(page.locator("#command-galil0-Y")).to_have_text(shown(tp + 100), timeout=SHOWN_MS)
        expect(page.locator("#position-galil0-Y")).to_have_text(shown(tp + 100), timeout=SHOWN_MS)
        assert int(command(h, "TPY")) == tp + 100  # it stayed where it was pushed
        assert int(command(h, "RPY")) == tp + 100  # the command follows a motor off
        assert page.locator("#error").is_hidden()
    finally:
        galil.DMCClose(h)
