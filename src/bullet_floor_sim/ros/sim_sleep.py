"""Sleeping on sim time without waking on every /clock.

rospy's ``rospy.sleep`` (and so ``rospy.Rate`` and ``rospy.Timer``) waits on one condition
that every /clock message notifies: each thread asleep on sim time wakes at every tick, looks
at the time and sleeps again. At 100 ticks a second of sim time and 10x, that is 1000 wake-ups
a wall second per sleeping thread; in the 20-person demo the nodes' sleeping threads spent
0.1 of a core on them (session 42, per-thread CPU). :func:`install` replaces the sleep that
rospy.sleep, Rate and Timer use (``rospy.timer.sleep``) in this process by one that wakes a
thread only at the first /clock at or past its deadline (or when time goes back, or at
shutdown, once rospy.is_shutdown() is true). What a sleep returns or raises is rospy's: the
same deadline (the time at the call plus the duration), ROSTimeMovedBackwardsException when
the clock goes back, ROSInterruptException at shutdown. A node on wall-clock time at install
keeps rospy's sleep.

:class:`Deadlines` is the pure part: which sleepers a clock reading wakes.
"""
from __future__ import annotations

import heapq
import itertools
import threading
from typing import Any, List, Tuple

__all__ = ["Deadlines", "install"]


class Deadlines:
    """Sleepers' deadlines (ns of sim time), each with the event that wakes it."""

    def __init__(self) -> None:
        # reentrant: rospy's SIGINT handler runs the shutdown hook (wake_all) in the main
        # thread, which may be inside add() (one heappush: the heap is whole between them)
        self._lock = threading.RLock()
        self._heap: List[Tuple[int, int, threading.Event]] = []
        self._seq = itertools.count()
        self._last = 0

    def add(self, deadline_ns: int, event: threading.Event) -> None:
        """Wake ``event`` at the first clock reading >= ``deadline_ns``."""
        with self._lock:
            heapq.heappush(self._heap, (int(deadline_ns), next(self._seq), event))

    def tick(self, now_ns: int) -> int:
        """A clock reading: set the events whose deadline it reached, every event when the
        clock went back; how many were set."""
        with self._lock:
            back = now_ns < self._last
            self._last = now_ns
            due = []
            while self._heap and (back or self._heap[0][0] <= now_ns):
                due.append(heapq.heappop(self._heap)[2])
        for e in due:
            e.set()
        return len(due)

    def wake_all(self) -> None:
        """Set every event (shutdown)."""
        with self._lock:
            due = [e for _, _, e in self._heap]
            del self._heap[:]
        for e in due:
            e.set()

    def __len__(self) -> int:
        return len(self._heap)


_installed: List[Any] = []


def install() -> None:
    """Make rospy.sleep, Rate and Timer in this process wake only when due (module doc).
    Call once, after rospy.init_node; nothing changes with wall-clock time."""
    import rospy
    import rospy.timer
    from rosgraph_msgs.msg import Clock

    if _installed or rospy.rostime.is_wallclock():
        return
    deadlines = Deadlines()
    # rospy's own /clock callback (rospy.impl.simtime) was added to this topic first and the
    # callbacks run in order on one thread: when a sleeper wakes, rospy's time has moved
    rospy.Subscriber("/clock", Clock, lambda m: deadlines.tick(m.clock.to_nsec()),
                     queue_size=1)
    # (rospy's internal hooks run once is_shutdown() is true; on_shutdown's run before)
    rospy.core.add_shutdown_hook(lambda _reason: deadlines.wake_all())

    def sleep(duration: Any) -> None:
        _sleep(rospy, deadlines, duration)

    _installed.append((rospy.timer.sleep, sleep))
    rospy.timer.sleep = sleep       # what Rate.sleep (and so Timer) calls
    rospy.sleep = sleep


def _sleep(rospy: Any, deadlines: Deadlines, duration: Any) -> None:
    """rospy.timer.sleep on sim time (same deadline, returns and raises), woken by
    ``deadlines``."""
    import genpy

    if not isinstance(duration, genpy.Duration):
        duration = genpy.Duration.from_sec(duration)
    now = rospy.rostime.get_rostime
    initial = now()
    zero = genpy.Time(0)
    while initial == zero and not rospy.core.is_shutdown():     # no /clock yet
        cond = rospy.rostime.get_rostime_cond()
        with cond:
            cond.wait(0.3)
        initial = now()
    until = initial + duration
    woken = threading.Event()
    waiting = False             # on the deadlines, woken not yet set
    while not rospy.core.is_shutdown():
        t = now()
        if t >= until or t < initial:
            break
        if not waiting or woken.is_set():
            woken.clear()
            deadlines.add(until.to_nsec(), woken)
            waiting = True
            t = now()               # a /clock between the look and the add: not missed
            if t >= until or t < initial or rospy.core.is_shutdown():
                break
        woken.wait(0.5)             # (a timeout: shutdown is looked at twice a second)
    t = now()
    if t < initial:
        raise rospy.exceptions.ROSTimeMovedBackwardsException((initial - t).to_sec())
    if rospy.core.is_shutdown():
        raise rospy.exceptions.ROSInterruptException("ROS shutdown request")
