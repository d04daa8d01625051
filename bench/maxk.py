"""OMS MAXk command round trip: `Maxk.send_and_get_string("AX RP")` (vdevclient.maxk) against a
lockstep daemon with one 4-axis oms-maxk card, as a ratio of a raw pyzmq REQ/REP round trip
measured in the same run with the same placement.

Goal: p50 <= 2.5x the raw round trip.

Method as bench/galil.py (bench/rtt.py's baseline server and block timing, a fresh random order of
the series in every block). A command is one batch (PROTOCOL.md): [the release of the last reply
(0x0FC, OMISR, semaphore), a read of the ring indices, the command bytes into the ring (on this
machine they go through the daemon's shared memory before the batch, decision 0010), the insert
index (the card parses "AX RP;" on that write and posts its reply), a read of the indices and the
response ring, a read of ODBR]. The series with `defer_release=False` releases each reply at once,
in a second round trip. Diagnostics: a one-op register read of the same card (the round trip floor
through vdevd) and the command's batch sent through `Rack.call` with the client's work around it
left out (what the daemon and the card take for it). The round trips per call are counted.

    python bench/maxk.py [--quick] [--json]
"""

from __future__ import annotations

import argparse
import contextlib
import sys
import tempfile
from collections.abc import Callable
from pathlib import Path
from typing import Any

if __package__ in (None, ""):  # run as a script: python bench/maxk.py
    sys.path.insert(0, str(Path(__file__).resolve().parents[1]))

import zmq  # noqa: E402
from vdevmaps.oms import RING_SIZE, Shm  # noqa: E402

from bench.common import (  # noqa: E402
    connect,
    daemon,
    install_signal_handlers,
    pin_self,
    placement,
    write_json,
)
from bench.galil import (  # noqa: E402
    checked_raw_client,
    command_figure,
    last_request,
    measure_commands,
    start_raw_server,
)
from bench.rtt import (  # noqa: E402
    RAW,
    ratios_to_raw,
    report_against_raw,
    report_ratio_goals,
)

GOAL_P50 = 2.5
COMMAND = "AX RP"
CARD = "maxk0"

MAXK = f'Maxk.send_and_get_string("{COMMAND}")'
EAGER = f"{MAXK}, defer_release=False"
READ = "diag: Region.read of 0x0FC (one op)"
REPLAY = "diag: the command's batch via Rack.call"


def maxk_card(name: str = CARD, board: int = 1) -> str:
    """A [[card]] table of one 4-axis MAXk, its other options the defaults."""
    return f'[[card]]\ntype = "oms-maxk"\nname = "{name}"\nboard = {board}\naxes = 4\n'


def run(n: int = 3000, repeats: int = 3, warmup: int = 1000, block: int = 5, pin: str = "split",
        diag: bool = True, seed: int = 1) -> dict[str, Any]:
    from vdevclient import maxk
    from vdevclient.core import Rack

    server_cpus, client_cpus, where = placement(pin)
    pin_self(client_cpus)
    ctx: zmq.Context[Any] = zmq.Context.instance()
    with contextlib.ExitStack() as stack:
        tmp = Path(stack.enter_context(tempfile.TemporaryDirectory(prefix="vdevd-bench-")))
        raw_server, raw_ep = start_raw_server(stack, tmp, server_cpus)
        # one card per client: a host owns a card's rings (their indices live in the client)
        cards = maxk_card(CARD, 1) + maxk_card("maxk1", 2) + maxk_card("maxk2", 3)
        d = stack.enter_context(daemon(cards, "lockstep", server_cpus))
        pin_self(client_cpus)  # zmq's I/O threads exist now; keep them with the client
        raw_read = checked_raw_client(stack, ctx, raw_server, raw_ep)

        rack = connect(d)  # waits until the daemon answers
        stack.callback(rack.close)
        card = stack.enter_context(maxk.open(1, endpoint=d.endpoint))
        eager = stack.enter_context(maxk.open(2, endpoint=d.endpoint, defer_release=False))

        def command() -> str:
            return card.send_and_get_string(COMMAND)

        def command_eager() -> str:
            return eager.send_and_get_string(COMMAND)

        if command() != "0" or command_eager() != "0":
            raise RuntimeError(f"{COMMAND!r} did not answer '0'")
        fns: dict[str, Callable[[], Any]] = {RAW: raw_read, MAXK: command, EAGER: command_eager}
        batch_ops = 0
        if diag:
            shm = rack.card(CARD).region("shm")
            fns[READ] = lambda: shm.read(Shm.RESPONSE_PROCESS, 4)  # a hook: always a request
            fns[REPLAY], batch_ops = replay_of(stack.enter_context(maxk.open(3, endpoint=d.endpoint)))

        series, counts, card_ns, stats = measure_commands(
            rack, Rack, fns, {MAXK: command, EAGER: command_eager}, n, repeats, warmup, block, seed)

    measured = ratios_to_raw(series, {"maxk": MAXK, "eager": EAGER})
    return command_figure(
        "maxk", where, {"n": n, "repeats": repeats, "warmup": warmup, "block": block,
                        "command": COMMAND, "transport": "tcp loopback", "clock": "lockstep"},
        measured, counts, card_ns, stats, f"p50 <= {GOAL_P50}x raw REQ/REP",
        measured[2][MAXK]["p50"] <= GOAL_P50, batch_ops=batch_ops)

def replay_of(card: Any) -> tuple[Callable[[], Any], int]:
    """A call that sends the batch of `card.send_and_get_string(COMMAND)` through its rack, with
    no library around it, and the number of ops in that batch. Each replay moves the ring
    position, the insert index and the release on as the client would (the card answers only a
    new command); `card` must not be used afterwards."""
    from vdevclient._maxk_bus import ring_pieces
    from vdevclient.core import compact

    rack = card.rack
    card.send_and_get_string(COMMAND)  # the first call after open has no reply to release
    reply, last = last_request(rack, lambda: card.send_and_get_string(COMMAND))
    # as [kind, card, region, offset, data], whichever form the client sent
    template = [op if isinstance(op, list) else compact(op) for op in last["ops"]]

    def write_at(test: Callable[[int], bool]) -> int | None:
        return next((i for i, op in enumerate(template) if op[0] == "w" and test(op[3])), None)

    # the command's bytes: an op, or (shared memory) written before the batch
    ring_at = write_at(lambda offset: Shm.COMMAND_RING <= offset < Shm.RESPONSE_RING)
    insert_at = write_at(lambda offset: offset == Shm.COMMAND_INSERT)
    release_at = write_at(lambda offset: offset == Shm.RESPONSE_PROCESS)
    assert insert_at is not None and release_at is not None
    memory = rack.card(card.card).region("shm")
    data = (COMMAND + ";").encode()
    size, reply_size = len(COMMAND) + 1, len(reply) + 1
    state = {"put": int.from_bytes(template[insert_at][4], "big"),
             "fc": (int.from_bytes(template[release_at][4], "big") + reply_size) % RING_SIZE}

    def replay() -> Any:
        put, fc = state["put"], state["fc"]
        state["put"], state["fc"] = (put + size) % RING_SIZE, (fc + reply_size) % RING_SIZE
        ops = list(template)
        ops[insert_at] = [*template[insert_at][:4], state["put"].to_bytes(4, "big")]
        ops[release_at] = [*template[release_at][:4], fc.to_bytes(4, "big")]
        pieces = [(Shm.COMMAND_RING + off, data[start:start + length])
                  for off, start, length in ring_pieces(put, size)]
        if ring_at is None:
            for offset, piece in pieces:
                memory.write(offset, piece)
        else:
            ops[ring_at:ring_at + 1] = [[*template[ring_at][:3], offset, piece]
                                        for offset, piece in pieces]
        return rack.call({"op": "batch", "ops": ops}, 1.0)

    return replay, len(template)


def report(r: dict[str, Any]) -> None:
    p = r["params"]
    report_against_raw(r, f'MAXk "{p["command"]}" round trip (lockstep), us; {p["repeats"]} x '
                          f'{p["n"]} per series, placement {r["placement"]}',
                       {"maxk": "maxk", "eager": "eager"})
    if r["batch_ops"]:
        p50 = {name: d["p50"] for name, d in r["series"].items()}
        print(f"where the p50 goes: maxk library {p50[MAXK] - p50[REPLAY]:+.1f} us (the call vs its "
              f"batch replayed), the batch's {r['batch_ops']} ops and the card's parsing "
              f"{p50[REPLAY] - p50[READ]:+.1f} us (vs a one-op read), vdevd round trip "
              f"{p50[READ] - p50[RAW]:+.1f} us (vs raw REQ/REP)")
    report_ratio_goals(r, GOAL_P50)


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--n", type=int, default=3000, help="calls per series per repeat")
    ap.add_argument("--repeats", type=int, default=3)
    ap.add_argument("--warmup", type=int, default=1000)
    ap.add_argument("--block", type=int, default=5, help="calls per alternating block")
    ap.add_argument("--pin", choices=("split", "same", "none"), default="split")
    ap.add_argument("--quick", action="store_true", help="n=1000, 2 repeats, 300 warm-up calls")
    ap.add_argument("--no-diag", action="store_true", help="skip the two diagnostic series")
    ap.add_argument("--json", nargs="?", const="", help="write JSON (default: bench/results/)")
    a = ap.parse_args()
    install_signal_handlers()
    if a.quick:
        a.n, a.repeats, a.warmup = 1000, 2, 300
    r = run(a.n, a.repeats, a.warmup, a.block, a.pin, diag=not a.no_diag)
    report(r)
    if a.json is not None:
        print(f"results: {write_json(r, a.json, 'maxk')}")


if __name__ == "__main__":
    main()
