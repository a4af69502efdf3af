#!/usr/bin/env python3
"""demo.launch from start to Ctrl-C prints no WARN and no ERROR (see demo_log.test), no
traceback, and no node dies while it runs or has to be killed at the end.

The demo runs under its own master and ROS_HOME with every node's output on the screen
(``roslaunch --screen``), so rospy's and roscpp's log lines of every node are in one stream.
It runs until the simulator's log shows 60 s of sim time, then gets SIGINT as from Ctrl-C;
the shutdown's lines count too.
"""
from __future__ import annotations

import os
import re
import shutil
import signal
import socket
import subprocess
import tempfile
import time
import unittest

import rostest

SIM_SECONDS = 60.0
# rospy: "[WARN] [wall, sim]: ..."; roscpp: "[ WARN] [wall, sim]: ..." (also ERROR, FATAL);
# and roslaunch's own: a node that failed to start, a Python traceback, a node that had to be
# killed at Ctrl-C
_BAD = re.compile(r"^\[\s*(WARN|ERROR|FATAL)\s*\]|^Traceback \(most recent call last\)|"
                  r"^ERROR: cannot launch node|escalating to SIG(TERM|KILL)")
# a node that died while the demo ran (at Ctrl-C every node ends, some with a signal's code)
_DIED = re.compile(r"process has died")
_SIM_TIME = re.compile(r"^\[\s*\w+\s*\] \[[0-9.]+, ([0-9.]+)\]")
_CONTEXT = 12
_COLOUR = re.compile(r"\x1b\[[0-9;]*m")   # the screen's colours


def _lines(path: str):
    with open(path, errors="replace") as f:
        return [_COLOUR.sub("", line.rstrip("\n")) for line in f]


def _with_context(lines, indices) -> str:
    """The lines at ``indices``, each with the _CONTEXT lines after it (a "bad callback"
    ERROR's traceback follows it on lines of its own)."""
    return "\n----\n".join("\n".join(lines[i:i + 1 + _CONTEXT]) for i in indices)


def _free_port() -> int:
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        return s.getsockname()[1]


class DemoLog(unittest.TestCase):
    def test_no_warning_and_no_error_from_start_to_ctrl_c(self):
        home = tempfile.mkdtemp(prefix="bfs_demo_log_")
        out_path = os.path.join(home, "launch.out")
        port = _free_port()
        env = dict(os.environ, ROS_HOME=home, ROS_MASTER_URI="http://127.0.0.1:%d" % port,
                   PYTHONUNBUFFERED="1", ROSCONSOLE_STDOUT_LINE_BUFFERED="1")
        cmd = ["roslaunch", "--screen", "-p", str(port), "bullet_floor_sim", "demo.launch",
               "nav:=builtin", "rviz:=false", "rtf:=2", "seed:=3"]
        try:
            with open(out_path, "w") as out:
                proc = subprocess.Popen(cmd, env=env, stdout=out, stderr=subprocess.STDOUT,
                                        start_new_session=True)
                try:
                    sim = self._wait_for_sim_time(out_path, proc, deadline=time.time() + 300)
                finally:
                    running = len(_lines(out_path))       # the lines before the Ctrl-C
                    os.killpg(proc.pid, signal.SIGINT)     # as Ctrl-C in its terminal
                    try:
                        proc.wait(60)
                    except subprocess.TimeoutExpired:
                        os.killpg(proc.pid, signal.SIGKILL)
                        proc.wait(10)
            lines = _lines(out_path)
            self.assertGreaterEqual(sim, SIM_SECONDS, "the demo did not reach %g s of sim "
                                    "time; its output ends:\n%s" % (SIM_SECONDS,
                                                                    "\n".join(lines[-30:])))
            bad = [i for i, line in enumerate(lines) if _BAD.search(line)]
            bad += [i for i, line in enumerate(lines[:running]) if _DIED.search(line)]
            self.assertEqual(bad, [], "the demo logged %d WARN/ERROR lines (each with the %d "
                             "lines after it, where a traceback goes):\n%s"
                             % (len(bad), _CONTEXT, _with_context(lines, bad[:10])))
        finally:
            shutil.rmtree(home, ignore_errors=True)

    @staticmethod
    def _wait_for_sim_time(path: str, proc: subprocess.Popen, deadline: float) -> float:
        """The latest sim time a log line shows, once it is SIM_SECONDS (or at the deadline
        or the launch's end)."""
        sim = 0.0
        while time.time() < deadline and proc.poll() is None:
            for line in _lines(path):
                m = _SIM_TIME.match(line)
                if m:
                    sim = max(sim, float(m.group(1)))
            if sim >= SIM_SECONDS:
                break
            time.sleep(1.0)
        return sim


if __name__ == "__main__":
    rostest.rosrun("bullet_floor_sim", "demo_log", DemoLog)
