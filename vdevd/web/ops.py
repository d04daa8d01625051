"""The page's requests, served as protocol requests of the rack (issue 23 §3; PROTOCOL.md).

A button on the page sends `{"op": ..., fields}` as JSON; `Operations.call` checks it with the
protocol's own validation (`protocol.validate`) and runs it with `Rack.execute`, as the ZeroMQ
server does a msgpack request: the same checks, the same error codes and messages, the same
effects. Only the ops a page needs are served: `hello`, `stats`, `sim` (the lockstep clock),
`control` (the backdoor) and `scope` (the recorder); register access stays with clients.

`ClockRun` is the page's "run": the lockstep clock stepped continuously at real-time pace,
one `sim step` after another, until paused.
"""

from __future__ import annotations

import asyncio
import contextlib
import logging
import math
from collections.abc import Callable
from typing import Any

import numpy as np

from vdevd import protocol
from vdevd.errors import ErrorCode, VdevError
from vdevd.rack import Rack

log = logging.getLogger("vdevd.web")

#: the ops the page may send
WEB_OPS = ("hello", "stats", "sim", "control", "scope")
#: requests of all pages served at once (a `sim step` replies later); past it `busy`
MAX_IN_FLIGHT = 16
#: the client identity of the page's requests (the limits per client count by it)
CLIENT = b"web"
#: the most samples a scope read of the page returns (a page reads a longer trace in pieces)
MAX_SCOPE_READ = 10_000
#: wall seconds between two steps of a clock run
RUN_PERIOD_S = 0.02
#: the most simulated time one step of a run takes: a rack that ticks slower than real time
#: falls behind instead of taking ever longer steps
MAX_RUN_STEP_NS = 100_000_000


class Operations:
    """Serves the page's requests on the rack `rack_of()` returns (the served one: a daemon
    that swaps its rack, `DaemonThread.reset`, is followed)."""

    def __init__(self, rack_of: Callable[[], Rack]) -> None:
        self.rack_of = rack_of
        self.in_flight = 0

    async def call(self, body: Any) -> Any:
        """The result of one request, JSON-able; a `VdevError` as the protocol has it."""
        if not isinstance(body, dict):
            raise VdevError(ErrorCode.MALFORMED, "a request is a JSON object with an \"op\"")
        op = body.get("op")
        if op not in WEB_OPS:
            raise VdevError(ErrorCode.UNKNOWN_OP, f"the web view does not serve op {op!r} "
                            f"(ops: {', '.join(WEB_OPS)})")
        req = protocol.validate(op, body)
        req.client = CLIENT
        if op == "scope" and req.args.get("action") == "read":
            count = req.args.get("count", MAX_SCOPE_READ)
            req.args["count"] = min(count, MAX_SCOPE_READ) if isinstance(count, int) else count
        if self.in_flight >= MAX_IN_FLIGHT:
            raise VdevError(ErrorCode.BUSY, f"the web view serves {MAX_IN_FLIGHT} requests at "
                            "once; try again when one has been answered")
        answer: asyncio.Future[Any] = asyncio.get_running_loop().create_future()

        def reply(result: Any) -> None:
            if not answer.done():
                answer.set_result(result)

        self.in_flight += 1
        try:
            self.rack_of().execute(req, reply)
            result = await answer
        finally:
            self.in_flight -= 1
        if isinstance(result, VdevError):
            raise result
        return jsonable(result)


def jsonable(value: Any) -> Any:
    """A result as JSON can carry it: a scope read's byte columns as numbers (`time_s` and
    one list a column), other bytes as lists of byte values, numpy scalars as numbers,
    non-finite floats as null."""
    if isinstance(value, dict):
        if isinstance(value.get("time_ns"), bytes) and isinstance(value.get("columns"), dict):
            return _scope_read(value)
        return {str(k): jsonable(v) for k, v in value.items()}
    if isinstance(value, list | tuple):
        return [jsonable(v) for v in value]
    if isinstance(value, bytes | bytearray):
        return list(value)
    if isinstance(value, np.generic):
        return jsonable(value.item())
    if isinstance(value, float) and not math.isfinite(value):
        return None
    return value


def _scope_read(result: dict[str, Any]) -> dict[str, Any]:
    """A `scope` read (PROTOCOL.md "Scope"): little-endian int64 times and f8/i8 columns."""
    out = {k: jsonable(v) for k, v in result.items() if k not in ("time_ns", "columns")}
    times = np.frombuffer(result["time_ns"], dtype="<i8")
    out["time_s"] = (times / 1e9).tolist()
    types = result.get("types", {})
    columns = {}
    for name, data in result["columns"].items():
        values = np.frombuffer(data, dtype="<f8" if types.get(name) == "f8" else "<i8")
        columns[name] = jsonable(values.tolist())
    out["columns"] = columns
    return out


class ClockRun:
    """Steps the lockstep clock at real-time pace while running: every RUN_PERIOD_S, a `sim
    step` of the wall time since the last (at most MAX_RUN_STEP_NS), through `Operations`."""

    def __init__(self, ops: Operations) -> None:
        self.ops = ops
        self._task: asyncio.Task[None] | None = None
        self._stopping = False
        self._wake = asyncio.Event()
        #: why the last run stopped by itself ("" while running or paused)
        self.error = ""

    @property
    def running(self) -> bool:
        return self._task is not None and not self._task.done()

    def start(self) -> None:
        """Run the clock (nothing new if it runs); `wrong_mode` on a realtime rack."""
        rack = self.ops.rack_of()
        if rack.mode != "lockstep":
            raise VdevError(ErrorCode.WRONG_MODE, "run steps the lockstep clock; this daemon's "
                            f"clock is {rack.mode}")
        if not self.running:
            self.error = ""
            self._task = asyncio.get_running_loop().create_task(self._run())

    async def pause(self) -> None:
        """Stop running; returns once the step under way has ended, so the clock stands
        still from then on."""
        task, self._task = self._task, None
        if task is None:
            return
        self._stopping = True
        self._wake.set()
        try:
            await task
        finally:
            self._stopping = False

    async def _run(self) -> None:
        loop = asyncio.get_running_loop()
        last = loop.time()
        self._wake.clear()
        while not self._stopping:
            with contextlib.suppress(TimeoutError):  # a pause ends the wait at once
                await asyncio.wait_for(self._wake.wait(), RUN_PERIOD_S)
            if self._stopping:
                return
            now = loop.time()
            ns = min(round((now - last) * 1e9), MAX_RUN_STEP_NS)
            last = now
            try:
                await self.ops.call({"op": "sim", "action": "step", "ns": ns})
            except VdevError as exc:
                self.error = exc.message
                log.warning("web view: the clock run stopped: %s", exc.message)
                return
