"""A diagnostic RTT server: the daemon's I/O architecture without the daemon (the `uvloop-cb`
server of ../shared/bench/zmq_rtt.py). A ROUTER on uvloop, drained from `loop.add_reader` with
NOBLOCK and ZMQ_EVENTS and read and written frame by frame like vdevd/server.py; a request is a
protocol-v1 `read` map, the reply `{"id": id, "ok": bin}` sliced from a 4 KiB buffer, with no
validation and no rack.

    python bench/floor_server.py tcp://127.0.0.1:PORT
"""

from __future__ import annotations

import asyncio
import signal
import sys

import msgpack
import uvloop
import zmq


async def serve(endpoint: str) -> None:
    loop = asyncio.get_running_loop()
    stop = asyncio.Event()
    loop.add_signal_handler(signal.SIGTERM, stop.set)
    mem = memoryview(bytes(i & 0xFF for i in range(4096)))
    sock: zmq.Socket[bytes] = zmq.Context.instance().socket(zmq.ROUTER)
    sock.linger = 0
    sock.bind(endpoint)
    recv, send = sock.recv, sock.send
    nb_more = zmq.NOBLOCK | zmq.SNDMORE
    fd = int(sock.getsockopt(zmq.FD))

    def readable() -> bool:
        return bool(int(sock.getsockopt(zmq.EVENTS)) & zmq.POLLIN)

    unpackb, packb = msgpack.unpackb, msgpack.Packer(use_bin_type=True).pack

    def receive(flags: int) -> list[bytes]:  # frame by frame, as vdevd/server.py does
        frames = [recv(flags)]
        while True:
            frame = recv(flags, copy=False)
            frames.append(frame.bytes)
            if not frame.more:
                return frames

    def handle(frames: list[bytes]) -> None:
        msg = unpackb(frames[-1])
        offset, size = msg["offset"], msg["size"]
        for frame in frames[:-1]:
            send(frame, nb_more)
        send(packb({"id": msg["id"], "ok": bytes(mem[offset : offset + size])}), zmq.NOBLOCK)

    def on_readable() -> None:
        try:
            handle(receive(zmq.NOBLOCK))
        except zmq.Again:
            return
        for _ in range(256):
            if not readable():
                return
            handle(receive(zmq.NOBLOCK))
        loop.call_soon(on_readable)

    loop.add_reader(fd, on_readable)
    on_readable()
    await stop.wait()
    loop.remove_reader(fd)
    sock.close()


if __name__ == "__main__":
    uvloop.run(serve(sys.argv[1]))
