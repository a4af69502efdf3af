"""Which sleepers a clock reading wakes (ros/sim_sleep.Deadlines): only those whose deadline
it reached, every one when the clock goes back or at shutdown."""
from __future__ import annotations

import threading

from bullet_floor_sim.ros.sim_sleep import Deadlines


def _events(n):
    return [threading.Event() for _ in range(n)]


def test_a_reading_wakes_the_sleepers_whose_deadline_it_reached_and_no_other():
    d = Deadlines()
    e100, e200, e300, also200 = _events(4)
    for t, e in ((300, e300), (100, e100), (200, e200), (200, also200)):
        d.add(t, e)
    assert d.tick(50) == 0 and not any(e.is_set() for e in (e100, e200, e300, also200))
    assert d.tick(100) == 1 and e100.is_set()              # at the deadline itself
    assert not (e200.is_set() or also200.is_set() or e300.is_set())
    assert d.tick(299) == 2 and e200.is_set() and also200.is_set() and not e300.is_set()
    assert d.tick(10_000) == 1 and e300.is_set() and len(d) == 0


def test_the_clock_going_back_or_shutdown_wakes_everyone():
    d = Deadlines()
    late, later = _events(2)
    d.add(5_000, late)
    d.add(9_000, later)
    assert d.tick(1_000) == 0
    assert d.tick(999) == 2 and late.is_set() and later.is_set()     # back by 1 ns
    again = threading.Event()
    d.add(2_000, again)
    assert d.tick(1_500) == 0                      # forward from the new reading: no jump
    d.wake_all()
    assert again.is_set() and len(d) == 0
