"""bench/node_usage.py against real processes: a child that holds 80 MB and spins one core
for a second, named as a ROS node by its ``__name:=`` argument, found as a descendant of
the process it was started from."""
from __future__ import annotations

import os
import subprocess
import sys
import time

BENCH = os.path.join(os.path.dirname(os.path.abspath(__file__)), "..", "..", "bench")
sys.path.insert(0, BENCH)
import node_usage  # noqa: E402

SPIN = ("import sys, time\n"
        "x = bytearray(80 * 10 ** 6)\n"
        "t = time.time()\n"
        "while time.time() - t < 1.5:\n"
        "    pass\n"
        "time.sleep(5)\n")


def test_a_node_is_named_by_its_name_argument_with_its_cpu_and_memory():
    # a shell that starts the "node" and waits for it, as roslaunch does its nodes
    proc = subprocess.Popen(["sh", "-c", '"$0" -c "$1" __name:=spinner; true', sys.executable,
                             SPIN], start_new_session=True)
    try:
        usage = node_usage.Usage(proc.pid)
        usage.take()
        time.sleep(2.0)
        usage.take()
        assert "sh" in usage.samples[-1][1]          # the parent, by its executable
    finally:
        os.killpg(proc.pid, 9)
        proc.wait()
    assert "spinner" in usage.samples[-1][1]
    share = usage.cpu_shares()["spinner"]
    assert 0.1 < share <= 1.05    # it spun 1.5 of the 2 s (less on a busy machine), one core
    assert usage.rss("spinner")[-1] > 80.0      # the 80 MB it holds
    assert node_usage.sample(proc.pid) == {}    # gone: nothing left of it
