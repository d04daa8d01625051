"""Turbo PMAC command round trips against a lockstep daemon with one pmac-turbo card, each as a
ratio of a raw baseline measured in the same run with the same placement:

- pmac-dpram: `PmacGetResponseA(0, buf, 256, "#1P")` (vdevclient.pcomm, the DPRAM ASCII
  handshake) vs a raw pyzmq REQ/REP round trip (bench/rtt.py's baseline server).
- pmac-ethernet: dls-pmaclib `PmacEthernetInterface.sendCommand("#1P")` on the card's Ethernet
  port vs a raw TCP round trip of the same 8-byte-header VR_PMAC_GETRESPONSE packet to a trivial
  threaded server that answers "0\\r\\x06" (`python bench/pmac.py --tcp-echo PORT`).

Goal: both p50 <= 2.5x their raw round trip.

Method as bench/maxk.py (block timing, a fresh random order of the series in every block). One
PmacGetResponseA of a one-line reply is one batch of five ops: [the command bytes at 0x0E9E, in
a write that reaches 0x0F41 and so also acknowledges the last call's ACK (0x0F40 := 0),
0x0E9C := 1 (the card answers in that write), the response slot, 0x0F40 := 0, the slot's head
(the ACK: control word and count)]. Diagnostic: a one-op DPRAM read (the round trip floor
through vdevd). The round trips per call are counted.

    python bench/pmac.py [--quick] [--json]
"""

from __future__ import annotations

import argparse
import contextlib
import ctypes
import socket
import socketserver
import struct
import sys
import tempfile
import warnings
from collections.abc import Callable
from pathlib import Path
from typing import Any

if __package__ in (None, ""):  # run as a script: python bench/pmac.py
    sys.path.insert(0, str(Path(__file__).resolve().parents[1]))

import zmq  # noqa: E402
from vdevmaps.pmac import RESP_CONTROL  # noqa: E402

from bench.common import (  # noqa: E402
    child,
    connect,
    daemon,
    free_port,
    install_signal_handlers,
    pin_self,
    placement,
    write_json,
)
from bench.galil import checked_raw_client, command_figure, measure_commands, start_raw_server  # noqa: E402
from bench.rtt import (  # noqa: E402
    RAW,
    ratios_to_raw,
    report_against_raw,
    report_ratio_goals,
)

GOAL_P50 = 2.5
COMMAND = "#1P"
CARD = "pmac0"
DEVICE = 0
#: VR_PMAC_GETRESPONSE as dls-pmaclib sends it: 0x40 0xBF, wValue, wIndex, wLength (one byte used)
HEADER = struct.Struct("8B")
REPLY = b"0\r\x06"

DPRAM = f'PmacGetResponseA(0, buf, 256, "{COMMAND}")'
ETHERNET = f'dls-pmaclib sendCommand("{COMMAND}")'
TCP_RAW = "raw TCP 8-byte header round trip (baseline)"
READ = "diag: Region.read of 0x0F40 (one op)"


def pmac_card(ethernet: str, name: str = CARD, device: int = DEVICE) -> str:
    """A [[card]] table of one pmac-turbo card, its Ethernet protocol on `ethernet`."""
    return f'[[card]]\ntype = "pmac-turbo"\nname = "{name}"\ndevice = {device}\nethernet = "{ethernet}"\n'


class _Echo(socketserver.BaseRequestHandler):
    """Per packet: the 8-byte header, wLength bytes of command, then one send of REPLY."""

    def handle(self) -> None:
        sock: socket.socket = self.request
        sock.setsockopt(socket.IPPROTO_TCP, socket.TCP_NODELAY, 1)
        buf = b""
        while True:
            data = sock.recv(2048)
            if not data:
                return
            buf += data
            while len(buf) >= HEADER.size and len(buf) >= HEADER.size + buf[7]:
                buf = buf[HEADER.size + buf[7]:]
                sock.sendall(REPLY)


def tcp_echo(port: int) -> None:
    """The raw TCP baseline server (blocking, one thread per connection)."""
    socketserver.ThreadingTCPServer.allow_reuse_address = True
    with socketserver.ThreadingTCPServer(("127.0.0.1", port), _Echo) as server:
        server.serve_forever()


def tcp_client(stack: contextlib.ExitStack, port: int) -> Callable[[], bytes]:
    """The least a client of the PMAC Ethernet protocol does: one send, one recv."""
    sock = socket.create_connection(("127.0.0.1", port), timeout=10)
    stack.callback(sock.close)
    sock.setsockopt(socket.IPPROTO_TCP, socket.TCP_NODELAY, 1)
    packet = HEADER.pack(0x40, 0xBF, 0, 0, 0, 0, 0, len(COMMAND)) + COMMAND.encode()

    def roundtrip() -> bytes:
        sock.sendall(packet)
        return sock.recv(2048)

    return roundtrip


def run(n: int = 3000, repeats: int = 3, warmup: int = 1000, block: int = 5, pin: str = "split",
        diag: bool = True, seed: int = 1) -> dict[str, Any]:
    from vdevclient import pcomm
    from vdevclient.core import Rack

    with warnings.catch_warnings():
        warnings.simplefilter("ignore", DeprecationWarning)  # dls_pmacremote imports telnetlib
        from dls_pmaclib.dls_pmacremote import PmacEthernetInterface

    server_cpus, client_cpus, where = placement(pin)
    pin_self(client_cpus)
    ctx: zmq.Context[Any] = zmq.Context.instance()
    with contextlib.ExitStack() as stack:
        tmp = Path(stack.enter_context(tempfile.TemporaryDirectory(prefix="vdevd-bench-")))
        raw_server, raw_ep = start_raw_server(stack, tmp, server_cpus)
        echo_port = free_port()
        echo = stack.enter_context(child([sys.executable, str(Path(__file__).resolve()), "--tcp-echo",
                                          str(echo_port)], server_cpus, tmp / "echo.log"))
        eth_port = free_port()
        d = stack.enter_context(daemon(pmac_card(f"tcp://127.0.0.1:{eth_port}"), "lockstep", server_cpus))
        pin_self(client_cpus)  # zmq's I/O threads exist now; keep them with the client
        raw_read = checked_raw_client(stack, ctx, raw_server, raw_ep)

        rack = connect(d)  # waits until the daemon answers
        stack.callback(rack.close)
        if not pcomm.OpenPmacDevice(DEVICE, endpoint=d.endpoint):
            raise RuntimeError(f"OpenPmacDevice({DEVICE}) failed on {d.endpoint}")
        stack.callback(pcomm.ClosePmacDevice, DEVICE)
        buf = ctypes.create_string_buffer(pcomm.MAX_COMM_BUFFER)

        def dpram() -> int:
            return pcomm.PmacGetResponseA(DEVICE, buf, pcomm.MAX_COMM_BUFFER, COMMAND)

        eth = PmacEthernetInterface(timeout=10)
        eth.setConnectionParams("127.0.0.1", eth_port)
        if eth.connect() is not None:
            raise RuntimeError(f"dls-pmaclib could not connect to port {eth_port}")
        stack.callback(eth.disconnect)

        def ethernet() -> Any:
            return eth.sendCommand(COMMAND)

        tcp = None
        for _ in range(200):  # the echo server was just started
            echo.check_alive("tcp echo server")
            try:
                tcp = tcp_client(stack, echo_port)
                break
            except ConnectionRefusedError:
                rack.request("sim", action="now")  # a short pause that is not a sleep
        if tcp is None:
            raise RuntimeError("the TCP echo server did not listen")

        if dpram() != pcomm.COMM_EOT | 2 or buf.value != b"0\r":
            raise RuntimeError(f"{COMMAND!r} did not answer '0\\r': {buf.value!r}")
        if ethernet() != ("0\r\x06", True) or tcp() != REPLY:
            raise RuntimeError(f"{COMMAND!r} over Ethernet did not answer '0\\r\\x06'")
        fns: dict[str, Callable[[], Any]] = {RAW: raw_read, DPRAM: dpram, TCP_RAW: tcp, ETHERNET: ethernet}
        if diag:
            region = rack.card(CARD).region("dpram")
            fns[READ] = lambda: region.read(RESP_CONTROL, 4)

        series, counts, card_ns, stats = measure_commands(
            rack, Rack, fns, {DPRAM: dpram}, n, repeats, warmup, block, seed)

    dpram_series = {k: v for k, v in series.items() if k not in (TCP_RAW, ETHERNET)}
    dpram_measured = ratios_to_raw(dpram_series, {"dpram": DPRAM})
    eth_measured = ratios_to_raw({RAW: series[TCP_RAW], ETHERNET: series[ETHERNET]},
                                 {"ethernet": ETHERNET})
    ratios, eth_ratios = dpram_measured[2], eth_measured[2]
    params = {"n": n, "repeats": repeats, "warmup": warmup, "block": block, "command": COMMAND,
              "clock": "lockstep"}
    figures = {
        "pmac-dpram": command_figure(
            "pmac-dpram", where, {**params, "transport": "zmq tcp loopback"}, dpram_measured,
            counts, card_ns, stats, f"p50 <= {GOAL_P50}x raw REQ/REP",
            ratios[DPRAM]["p50"] <= GOAL_P50),
        "pmac-ethernet": command_figure(
            "pmac-ethernet", where, {**params, "transport": "tcp loopback"}, eth_measured,
            {ETHERNET: {"mean": 1.0, "max": 1}}, 0, stats, f"p50 <= {GOAL_P50}x raw TCP",
            eth_ratios[ETHERNET]["p50"] <= GOAL_P50),
    }
    return {"figure": "pmac", "placement": where, "params": params, "figures": figures,
            "ratios": {**ratios, **eth_ratios},
            "pass": all(f["pass"] for f in figures.values())}


def report(r: dict[str, Any]) -> None:
    p = r["params"]
    dp, eth = r["figures"]["pmac-dpram"], r["figures"]["pmac-ethernet"]
    report_against_raw(dp, f'pmac-dpram: PComm "{p["command"]}" round trip (lockstep), us; '
                           f'{p["repeats"]} x {p["n"]} per series, placement {r["placement"]}',
                       {"dpram": "PmacGetResponseA"})
    report_against_raw(eth, f'pmac-ethernet: dls-pmaclib "{p["command"]}" over the card\'s Ethernet '
                            f'port, us; baseline {TCP_RAW}', {"ethernet": "sendCommand"})
    report_ratio_goals(r, GOAL_P50)


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--n", type=int, default=3000, help="calls per series per repeat")
    ap.add_argument("--repeats", type=int, default=3)
    ap.add_argument("--warmup", type=int, default=1000)
    ap.add_argument("--block", type=int, default=5, help="calls per alternating block")
    ap.add_argument("--pin", choices=("split", "same", "none"), default="split")
    ap.add_argument("--quick", action="store_true", help="n=1000, 2 repeats, 300 warm-up calls")
    ap.add_argument("--no-diag", action="store_true", help="skip the diagnostic series")
    ap.add_argument("--json", nargs="?", const="", help="write JSON (default: bench/results/)")
    ap.add_argument("--tcp-echo", type=int, metavar="PORT", help=argparse.SUPPRESS)
    a = ap.parse_args()
    if a.tcp_echo:
        tcp_echo(a.tcp_echo)
        return
    install_signal_handlers()
    if a.quick:
        a.n, a.repeats, a.warmup = 1000, 2, 300
    r = run(a.n, a.repeats, a.warmup, a.block, a.pin, diag=not a.no_diag)
    report(r)
    if a.json is not None:
        print(f"results: {write_json(r, a.json, 'pmac')}")


if __name__ == "__main__":
    main()
