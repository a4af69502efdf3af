"""The Navigator's recovery parameters (:class:`NavigatorConfig`, each with its reason) and
what it decides each update (:class:`NavStatus`); nav/navigator.Navigator reads them, the
path_follower node sets some of them from ``~<field>`` parameters (ros/path_follower.py)."""
from __future__ import annotations

from dataclasses import dataclass, fields
from typing import Optional

from ..errors import BulletFloorSimError
from ..sim.checks import check_numbers

__all__ = ["NavigatorConfig", "NavStatus"]


@dataclass
class NavigatorConfig:
    """Recovery behaviour of :class:`~bullet_floor_sim.nav.navigator.Navigator` (times in sim seconds).

    Attributes:
        replan_after: blocked this long -> plan again, around the obstacles in the scan.
        blocked_timeout: blocked this long in total since the last 0.1 m of progress towards
            the goal -> abort.
        progress_timeout: no 0.1 m of progress along the path to the goal for this long -> abort
            (a new plan, such as the long way round what blocks it, starts the count afresh
            from its length, up to 20 times a goal; the time does not restart, except after
            giving way: the time spent backing off and waiting is not a lack of progress).
            Every fold keeps 60 s against 30 s (docs/evaluation.md, session 83).
        obstacle_range: scan points farther than this (m) are ignored when replanning.
        sidestep: how far (m) to step aside when no path passes an obstacle.
        stall_time: commanded to move but moved less than 2 cm and turned less than 0.05 rad
            for this long -> stalled (pressed against another robot the scan does not show
            ahead): plan again at once, around the obstacles in the scan; stalled again soon
            after (it cannot even turn): back up 0.15 m when that brings it no nearer a wall
            of the map and the scan shows nothing behind; a back-off that did not move it
            is followed by a nudge forward, and the other way round.
        give_way: when no path passes what blocks it, yield at once (the observer): retreat
            to the nearest passing place (nav/passing.py: out of the way of the narrow
            passage's middle, within ``passing_reach`` m), else to the nearest free place (a
            roomy one first) at least ``give_way_clear`` m from every point the map does not
            know, within ``give_way_reach`` m; wait there ``give_way_wait`` s and go on to
            the goal, at most 3 times a goal. Every fold keeps 3 s against 6 s
            (docs/evaluation.md, session 83).
        heading_rule: without ``give_way``, a robot that meets another head-on in a passage
            too narrow for two yields (as above) by nav/passing.gives_way's rule (the one
            nearer its passing place, else by heading): of two robots facing each other
            exactly one does.
        keep_way: never yield by that rule (the walker, a stand-in person: the observer
            yields to it); only as the deadlock fallback.
        passing: False: no yielding to passing places at all, only ``give_way``'s, and
            progress as the crow flies, which a new plan does not restart (a map being
            built: its passing places and plans are as partial as it is, and a frontier
            that gets no nearer is given up).
        deadlock_time: no progress this long, within ``goal_taken_within`` m of the goal,
            with something the map does not show standing on it (1 s or more), the goal is
            given up with ``passing`` ("the goal is taken"; people/agents.WalkerAgent then
            draws another in the region, or ends the leg there). Blocked with no progress
            towards the goal this long, a robot the rule
            told to yield that has not (it could not) yields; one that has the right of way,
            or keeps its way, after twice as long (what blocks it does not yield: a robot
            parked, or one with another rule). Unequal, so the two do not back off at once.
            With a way round each time and still no progress (each planned past the other's
            unseen far side and stopped on it again: two robots nose to nose in a corridor
            wide enough for two, under a ROS graph's delays), it yields too (not with
            ``give_way``): when what blocks it lies west or south of it
            (nav/passing.heads_west_or_south of the bearing), after this long; any other
            after twice as long; where the nearest passing place is where it stands, it steps
            ``sidestep`` m aside (right first) and waits there; when it cannot yield it
            takes the way round.
        other_radius: the radius (m) of what it meets, for the passing places (default: its
            own).
        passing_margin: the gap (m) left between two discs passing side by side: where the
            floor is narrower than both diameters and this, the passage is too narrow for
            two (nav/passing.py); a passing place keeps both radii and this from its middle.
            0.1 m: the Scitos' two 0.34 m radii then ask for 1.46 m (about 1.5 m, as the
            clearance is read at the 0.1 m planning cells' centres), so a 1.4 m corridor is
            one-way and a 1.6 m one is not. Every fold keeps it against 0.05 and 0.2 m
            (docs/evaluation.md, session 81).
        pass_wait_max: the longest wait (s) at a passing place; it waits as long as what it
            yielded to takes to come that far at 0.4 m/s, at least ``give_way_wait``.
        goal_taken_within: see ``deadlock_time`` (WalkerAgent's ``regoal_within``: further
            off, a goal given up ends the leg; 0: never). 17 and 18 folds pick 1.0 m on
            trk50 on two machines, but it puts orebro's gt50 under the 80 % bar on both; with
            the bars (choose_by_folds.py --bars) 17 of 18 folds keep 1.5 m
            (docs/evaluation.md, sessions 80 and 84).
        detour, detour_wait: a way round what blocks it that is more than ``detour`` m longer
            than the way it was on is taken only once it has been blocked ``detour_wait`` s
            (with ``passing``): what blocks it may give way first. The walker, blocked by the
            observer for 2 s, walked 80 m round aces_austin's loop instead of waiting for it
            to step aside, and its leg timed out. 0: any way round at once.
    """

    replan_after: float = 2.0
    blocked_timeout: float = 30.0
    progress_timeout: float = 60.0
    obstacle_range: float = 3.0
    sidestep: float = 0.45
    stall_time: float = 1.5
    give_way: bool = False
    give_way_clear: float = 1.2
    give_way_reach: float = 5.0
    give_way_wait: float = 3.0
    heading_rule: bool = True
    keep_way: bool = False
    passing: bool = True
    deadlock_time: float = 10.0
    other_radius: Optional[float] = None
    passing_reach: float = 25.0
    passing_margin: float = 0.1
    pass_wait_max: float = 30.0
    detour: float = 10.0
    detour_wait: float = 10.0
    goal_taken_within: float = 1.5

    def check(self) -> None:
        """Raises BulletFloorSimError naming the first number that is not finite and > 0
        (>= 0 for the distances and waits that may be none: ``sidestep``,
        ``give_way_clear``, ``give_way_wait``, ``detour``, ``detour_wait``,
        ``goal_taken_within``, ``passing_margin``; ``other_radius`` may also be None)."""
        zero_ok = ("sidestep", "give_way_clear", "give_way_wait", "detour", "detour_wait",
                   "goal_taken_within", "passing_margin")
        numbers = [f.name for f in fields(self) if f.type in ("float", "Optional[float]")]
        check_numbers(self, [n for n in numbers if n not in zero_ok and not (
            n == "other_radius" and self.other_radius is None)], "navigator",
            error=BulletFloorSimError)
        check_numbers(self, zero_ok, "navigator", strict=False, error=BulletFloorSimError)


@dataclass
class NavStatus:
    """What :meth:`~bullet_floor_sim.nav.navigator.Navigator.update` decided: a command and the goal's state.

    ``state`` is ``active``, ``succeeded`` or ``aborted`` (``message`` says why).
    """

    v: float
    w: float
    state: str
    message: str = ""
    distance_to_goal: float = 0.0
