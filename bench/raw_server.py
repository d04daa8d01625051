"""The RTT baseline server: a plain blocking pyzmq REP loop, the `blocking` server of
../shared/bench/zmq_rtt.py. Request: msgpack [op, region, offset, size]; reply: msgpack bin of
`size` bytes sliced from a 64 KiB buffer.

    python bench/raw_server.py tcp://127.0.0.1:PORT
"""

from __future__ import annotations

import sys

import msgpack
import zmq


def main(endpoint: str) -> None:
    region = memoryview(bytes(i & 0xFF for i in range(65536)))
    sock: zmq.Socket[bytes] = zmq.Context.instance().socket(zmq.REP)
    sock.linger = 0
    sock.bind(endpoint)
    unpackb, packb = msgpack.unpackb, msgpack.packb
    recv, send = sock.recv, sock.send
    while True:
        _op, _region, offset, size = unpackb(recv())
        send(packb(region[offset : offset + size]))


if __name__ == "__main__":
    main(sys.argv[1])
