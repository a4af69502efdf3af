#!/usr/bin/env python3
"""`make bench`: run every benchmark script in bench/ and print their tables and BENCH lines."""
from __future__ import annotations

import os
import subprocess
import sys

HERE = os.path.dirname(os.path.abspath(__file__))
BENCHES = ["sim_bench.py", "ros_bench.py", "nav_bench.py", "store_bench.py", "trajectory_bench.py",
           "prediction_bench.py", "people_bench.py", "stage_bench.py", "gym_bench.py"]


def main() -> int:
    status = 0
    for name in BENCHES:
        print("== %s" % name, flush=True)
        status |= subprocess.call([sys.executable, os.path.join(HERE, name)])
    print("== rooms_bench.py", flush=True)
    maps = os.environ.get("ROOMS_BENCH_MAPS")
    if maps:   # the ipa ground-truth maps are not shipped (docs/rooms.md says where they are)
        status |= subprocess.call([sys.executable, os.path.join(HERE, "rooms_bench.py"),
                                   "--maps", maps])
    else:
        print("rooms_bench: skipped: set ROOMS_BENCH_MAPS to a directory of the ipa "
              "room-segmentation test maps (docs/rooms.md)", flush=True)
    return status


if __name__ == "__main__":
    sys.exit(main())
