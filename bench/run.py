"""`make bench`: the three platform figures of issue 2, each against a baseline of the same run.

    python bench/run.py [--quick] [--json FILE]
"""

from __future__ import annotations

import argparse
import json
import os
import sys
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parent.parent))

from bench import lockstep, realtime, rtt  # noqa: E402


def main() -> None:
    p = argparse.ArgumentParser(description=__doc__)
    p.add_argument("--quick", action="store_true", help="short runs, for a smoke test")
    p.add_argument("--json", help="write the results to this file")
    a = p.parse_args()
    os.chdir(Path(__file__).resolve().parent.parent)
    results = {
        "rtt": rtt.run(n=1000 if a.quick else 5000, repeats=2 if a.quick else 3),
        "lockstep": lockstep.run(seconds=2.0 if a.quick else 10.0, repeats=2 if a.quick else 3),
        "realtime": realtime.run(seconds=5.0 if a.quick else 60.0),
    }
    rtt.report(results["rtt"])
    print()
    lockstep.report(results["lockstep"])
    print()
    realtime.report(results["realtime"])
    print("\nsummary: " + ", ".join(f"{k} {'PASS' if v['pass'] else 'FAIL'}"
                                   for k, v in results.items()))
    if a.json:
        Path(a.json).write_text(json.dumps(results, indent=2, default=float))


if __name__ == "__main__":
    main()
