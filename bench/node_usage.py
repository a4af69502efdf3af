"""CPU time and memory of every ROS node a roslaunch started, read from /proc (Linux).

``sample(root)`` finds a process and all its descendants (roslaunch and the nodes it
started) and names each by its ``__name:=`` argument (the node's name; other processes by
their executable). ``Usage`` keeps the samples of a
run and gives each node's share of one CPU between two samples and its resident memory over
time, for bench/demo_legs.py.
"""
from __future__ import annotations

import os
import time
from typing import Dict, List, Optional, Tuple

_TICK = os.sysconf("SC_CLK_TCK") if hasattr(os, "sysconf") else 100
_PAGE = os.sysconf("SC_PAGE_SIZE") if hasattr(os, "sysconf") else 4096


def _name(pid: str) -> str:
    with open("/proc/%s/cmdline" % pid, "rb") as f:
        args = [a.decode("utf-8", "replace") for a in f.read().split(b"\0") if a]
    for a in args:
        if a.startswith("__name:="):
            return a[len("__name:="):]
    exe = [a for a in args if not a.startswith("-")]
    return os.path.basename(exe[1] if len(exe) > 1 and "python" in exe[0] else exe[0]) \
        if exe else pid


def sample(root: int) -> Dict[str, Tuple[float, float]]:
    """{node name: (CPU seconds so far, resident MB)} of process ``root`` and all its
    descendants (roslaunch starts each node in a session of its own, so neither the process
    group nor the session holds them; several of one name are summed)."""
    stats = {}
    for pid in os.listdir("/proc"):
        if not pid.isdigit():
            continue
        try:
            with open("/proc/%s/stat" % pid) as f:
                stats[int(pid)] = f.read().rsplit(")", 1)[1].split()
        except (OSError, IndexError):
            continue                             # gone meanwhile
    children: Dict[int, List[int]] = {}
    for pid, fields in stats.items():
        children.setdefault(int(fields[1]), []).append(pid)   # fields[1]: ppid
    out: Dict[str, Tuple[float, float]] = {}
    todo = [root] if root in stats else []
    while todo:
        pid = todo.pop()
        todo.extend(children.get(pid, []))
        fields = stats[pid]
        try:
            cpu = (int(fields[11]) + int(fields[12])) / _TICK   # utime + stime
            rss = int(fields[21]) * _PAGE / 1e6
            name = _name(str(pid))
        except (OSError, IndexError, ValueError):
            continue
        c, r = out.get(name, (0.0, 0.0))
        out[name] = (c + cpu, r + rss)
    return out


class Usage:
    """The samples of one run: (wall time, {node: (CPU s, RSS MB)})."""

    def __init__(self, root: int) -> None:
        self.root = root
        self.samples: List[Tuple[float, Dict[str, Tuple[float, float]]]] = []

    def take(self) -> None:
        self.samples.append((time.time(), sample(self.root)))

    def cpu_shares(self, since: Optional[float] = None) -> Dict[str, float]:
        """Each node's CPU seconds per wall second (1.0 = one core busy) from the first
        sample at or after ``since`` (the first of all: None) to the last."""
        first = next((s for s in self.samples if since is None or s[0] >= since), None)
        if first is None or first is self.samples[-1]:
            return {}
        (t0, a), (t1, b) = first, self.samples[-1]
        return {k: (b[k][0] - a.get(k, (0.0, 0.0))[0]) / (t1 - t0) for k in b}

    def rss(self, node: str) -> List[float]:
        """The node's resident MB at each sample (0 before it started)."""
        return [s.get(node, (0.0, 0.0))[1] for _, s in self.samples]
