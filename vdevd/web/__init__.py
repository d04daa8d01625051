"""The live web view of a rack (issue 23 §3): `[web] listen = "127.0.0.1:8080"` serves a page of
the cards, their axes, inputs, outputs and interrupts, a scope panel, and buttons for the
backdoor and the lockstep clock, on the daemon's event loop (aiohttp). Off by default.

config.py parses `[web]`; state.py reads a rack into the page's JSON (sans-I/O); ops.py runs the
page's requests through the rack's protocol operations and steps the clock at real-time pace;
app.py is the HTTP and websocket server; static/ the page (plain HTML, CSS and JavaScript).
"""

from vdevd.web.config import WebConfig, parse_web

__all__ = ["WebConfig", "parse_web"]
