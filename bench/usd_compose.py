"""usd-core's side of `bench ingest`: seconds to compose a stage and list what it renders.

`--mode open`: `Usd.Stage.Open` with payloads loaded (composition, C++). `--mode listing`: open plus the
traversal that computes the same gprim listing as `ingest --dump-json` (tests/python/usd_reference.py:
instance proxies, world bounds of the points, triangle counts, bound materials). One timing per process,
so no layer stays in usd-core's layer registry between runs (the caller repeats). Prints one JSON line
with wall and CPU seconds (CPU: this process, all threads).
"""

import argparse
import json
import os
import sys
import time

sys.path.insert(0, os.path.join(os.path.dirname(os.path.abspath(__file__)), "..", "tests", "python"))

from pxr import Usd  # noqa: E402

import usd_reference  # noqa: E402


def main():
    parser = argparse.ArgumentParser()
    parser.add_argument("asset")
    parser.add_argument("--mode", choices=("open", "listing"), required=True)
    args = parser.parse_args()
    wall, cpu = time.perf_counter(), time.process_time()
    if args.mode == "open":
        stage = Usd.Stage.Open(args.asset, Usd.Stage.LoadAll)
        gprims = None
    else:
        gprims = len(usd_reference.usd_listing(args.asset).gprims)
    wall, cpu = time.perf_counter() - wall, time.process_time() - cpu
    print(json.dumps({"wall_seconds": wall, "cpu_seconds": cpu, "gprims": gprims}))


if __name__ == "__main__":
    main()
