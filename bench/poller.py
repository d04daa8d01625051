"""A polling client, one process: reads one 4-byte register by request (no shared memory) every
INTERVAL_MS on absolute deadlines for SECONDS, then writes the distribution of its round trips
(us) as JSON to OUT.

    python bench/poller.py ENDPOINT CARD REGION OFFSET SECONDS INTERVAL_MS OUT

Used by bench/default_rack.py (the eight clients polling the default rack).
"""

from __future__ import annotations

import json
import sys
import time
from pathlib import Path

if __package__ in (None, ""):  # run as a script: python bench/poller.py
    sys.path.insert(0, str(Path(__file__).resolve().parents[1]))

import vdevclient  # noqa: E402

from bench.common import dist  # noqa: E402


def main() -> None:
    endpoint, card, region, offset, seconds, interval_ms, out = sys.argv[1:8]
    rtt: list[float] = []
    with vdevclient.connect(endpoint, timeout=30.0, shm=False) as rack:
        read32 = rack.card(card).region(region).read32
        where = int(offset, 0)
        clock = time.perf_counter_ns
        step = int(float(interval_ms) * 1e6)
        deadline = start = clock()
        end = start + int(float(seconds) * 1e9)
        while deadline < end:
            t0 = clock()
            read32(where)
            rtt.append((clock() - t0) / 1000)
            deadline += step
            delay = deadline - clock()
            if delay > 0:
                time.sleep(delay / 1e9)
    Path(out).write_text(json.dumps({"rtt_us": dist(rtt), "max_us": max(rtt, default=0.0)}))


if __name__ == "__main__":
    main()
