"""The baseline server: plain blocking pyzmq REP answering msgpack [op, region, offset, size]
requests with `size` bytes of a 64 KiB buffer (as ../shared/bench/zmq_rtt.py measured)."""

from __future__ import annotations

import sys

import msgpack
import zmq


def main(endpoint: str) -> None:
    region = memoryview(bytearray(i & 0xFF for i in range(65536)))
    sock = zmq.Context.instance().socket(zmq.REP)
    sock.linger = 0
    sock.bind(endpoint)
    unpackb, packb = msgpack.unpackb, msgpack.packb
    while True:
        _op, _region, offset, size = unpackb(sock.recv())
        sock.send(packb(region[offset : offset + size]))


if __name__ == "__main__":
    main(sys.argv[1])
