"""The observer's parameters (:class:`FollowConfig`), its decisions (:class:`FollowDecision`)
and their error; people/follow.FollowBehaviour reads them, the follower node sets them from
``~<field>`` parameters."""
from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Optional, Tuple

from ..errors import BulletFloorSimError
from ..sim.checks import check_integers, check_numbers

__all__ = ["FollowError", "FollowConfig", "FollowDecision", "SEARCH_AT"]

#: FollowConfig.search_at's choices.
SEARCH_AT = ("lookout", "likely_goal")


class FollowError(BulletFloorSimError):
    """A bad follower parameter."""


@dataclass
class FollowConfig:
    """Follower parameters (metres, seconds).

    Attributes:
        distance: stand-off distance kept from the target (the lidar needs it in front, and
            1.5 m leaves a person room to turn round in a doorway). Chosen over 2.0 m by
            leaving each of 16 worlds out (seeds 11-13): every fold chose 1.5 m; 2.0 m won
            in the halls but lost more in small rooms and put five worlds under 70 %
            tracked (docs/evaluation.md, session 53).
        slack: no new goal while the target stands within ``distance + slack`` and in view.
            0.7 m against 0.4 and 1.0, leaving each of 16 worlds out (seed 12): 14 folds
            kept 0.7; 0.4 put edmonton_convention's tracked at 58 %, 1.0 seattle's at 69 %
            (docs/evaluation.md, session 54).
        replan_distance: send a new goal when the target moved this far since the last one;
            a stand-off point nearer than this to the observer is turned at, not driven to
            (a back-off under way, out of a narrow passage or from a target too close, is
            kept while it is still this far off and ``distance`` - 0.2 m from the target).
            Every fold keeps 0.5 m against 0.3 m (docs/evaluation.md, session 82).
        goal_period: while the target moves, a new goal at least this often. Every fold
            keeps 2 s against 1 s (docs/evaluation.md, session 82).
        lost_after: no track for this long -> search.
        search_turn: after reaching the search point, turn this much (radians, at most pi: the
            look-round is a goal's yaw, which wraps, so 2 pi would not turn at all) to look round.
        search_wait: after looking round, wait this long before going on to the next region.
        search_regions: search at most this many of the most likely regions, in turn.
        search_rounds: after this many rounds of those regions without a sight of the target,
            search each other region of the search plan once, most likely first, then
            patrol the building: the roomiest place of every ``patrol_spacing`` block of the
            map, nearest first, each once before any again (the target walked on to regions
            its last prediction did not name, and out of sight of them).
        patrol_spacing: the side (m) of the blocks that give the patrol its places. Every
            fold keeps 4 m against 6 m (docs/evaluation.md, session 84).
        patrol_sight: a patrol place the observer sees on the way, within this many metres,
            within 90 degrees of its heading (the Scitos's 180-degree lidar) and with no
            wall between, counts as visited in this tour (the one it drives to is still
            gone to: search.PatrolTour). 8 m is within the range at which the tracker finds
            a person (3 beams, ``min_points``, on a 0.5 m body at the lidar's 1 degree:
            9.5 m).
            Going to each place in turn, it patrolled a 3600 m^2 hall for 690 s before it
            first saw the walker. 0: only the places it goes to count.
        search_sight: a region's search point is, of its goal points with the most of them
            in view within this many metres (no wall between: people/search.lookout_points)
            in the part of the floor where the target was last seen (a wall may cut a
            region in two), the one nearest to where it was; 0: of all its goal points.
            The predictor makes the points (agents.PredictorAgent): set it on the
            destination_predictor node (``~search_sight``); the follower node has no use for
            it. 8 m, as ``patrol_sight``, fixed before any run. At a long corridor's end the
            nearest goal point looked down one way of it only (aces_austin: the walker, 8-18
            m down the corridor, went unseen for 24 minutes). Seeds 4-8 on six corpus
            worlds, within the noise: docs/evaluation.md, session 47.
        search_at: where in a region the search goes for a target lost on its way:
            ``lookout``, the search point as ``search_sight`` says; ``likely_goal``, the
            region's goal point that the leg walked so far makes most likely
            (DestinationModel.likely_goals: the most progress towards it; lookouts still
            while the target stands or has not yet made ``min_progress``, and for a region
            none of whose goal points both the leg's start and the target reach). Set it on the
            destination_predictor node (``~search_at``). In a 90 m convention hall a
            corridor region's one lookout lay 16 m behind where the walker was lost going
            the other way (edmonton_convention, seed 13: 876 s unseen). Against it the
            lookouts are chosen by every fold (seed 13): the likely goal is the first goal
            point past where the target was lost, which sees less of the region.
        patrol_after: a target not seen this long from the start, with nothing predicted, is
            looked for on patrol (it may come by: a crowd's person, a walker dwelling).
        search_min_probability: ... each at least this likely (the most likely one always).
            Every fold keeps 0.05 against 0.02 (docs/evaluation.md, session 83).
        roomy: the wall clearance (m) of a place the observer waits at: a stand-off point is
            chosen with at least this much when one exists, and an observer standing still
            with less (in a doorway: 0.47-0.51 m in the office world, its corridor 0.89 m)
            moves to one. Waiting in a doorway shut the walker in (or out) for good.
        give_way: the clearance (m) kept from the target's predicted route when near it: two
            footprint radii and a margin, so that the target passes without stopping.
            0.9 m against 0.75 and 1.2, leaving each of 16 worlds out (seed 12): every fold
            kept 0.9; 1.2 put edmonton_convention's tracked at 55 % (session 54).
        give_way_reach: look for a place to give way at most this far (m) from the observer.
        give_way_hold: wait where it gave way at most this long (s) for the target to pass.
        give_way_view: of the places to give way at, one whose way from the observer sets off
            within this angle (radians) of the target's bearing comes first: driving there,
            the lidar (180 degrees ahead on the Scitos) keeps the target in view; 75 degrees
            leaves 15 for the path's bends.
            Stepping aside the other way, it turned its back on the target (a fifth of a
            200-leg run on malaga_corridor went untracked so). Before the bearing, a place
            that sees the target (no wall on the line between: nav/give_way.give_way_point)
            comes first: on freiburg_079 it gave way round a corner from a walker in a
            room, and tracked it 46 % of its time giving way. 0: neither preference.
        pass_detour: an observer on the target's way stays where it is (the target in view)
            when the target can go round it by a way at most this much longer (m): to the
            first point of its way this much and two footprint radii past the observer, or
            else to its destination; 0: it always steps aside. Stepping aside for a target
            that could pass, it lost sight of it (office: walker tracked 66.6 % of a 40-leg
            run with 0, 81.1 % with 2, checked to the destination only).
        trail: a target lost further than ``distance + slack`` off while moving is first
            looked for where it went: the observer drives to the point ``trail`` seconds on
            from where it was last seen at its last velocity (stopped short of a wall, or
            turned round it: ``trail_turn``), facing the way it went; one that stood
            still, or is not trailed, from ``look_distance`` of where it was last seen;
            then the likely regions (a target lost nearer, and more than 75 degrees off the
            observer's heading, is turned to, moving or not, where the observer has
            ``roomy`` clearance; with less, a moving one is trailed, and one not trailed is
            looked at from a roomy place near by (else turned to); one lost nearer in front,
            in the lidar's view, went behind something and is looked for as one lost
            further off). 0: it only turns to where a target lost close by was last seen
            (see ``look_lead``), in front or not.
        trail_turn: a trail that a wall cuts short of ``trail`` seconds (the target cannot
            have walked on into the wall: it turned) is turned by up to this much (radians,
            at most pi/2; used in whole steps of 15 degrees) either way, left first, to the
            least turned way free for the whole trail with a roomy point on it; with none,
            it stops short of the wall as before. A straight trail that is free but never
            roomy (a narrow corridor) is not turned. pi/2 (the default since session 66);
            0: straight on only, as before. The walker left a room by its door, turned the
            corner into a corridor and went on round a block; the track's last velocity
            pointed at the corridor's far wall, the trail stopped where it was lost, and
            the look round there saw only the block (orebro, seed 14: four losses at one
            corner, 113-302 s unseen each). pi/2 against 0, leaving each of 18 worlds out,
            seeds 13-15: every fold chose pi/2, held-out trk50 84.2 % against 83.8 %,
            tracked 85.9 % against 85.8 %; on seeds 13 and 15 (not traced) trk50 84.9
            against 84.1 %; intel_lab lost at every seed (docs/evaluation.md, session 66).
        look_lead: a target lost close by is turned to where it would be this many
            seconds after it was last seen, at its last velocity (one that stood still:
            where it was); 0: where it was last seen. A walker that passed the observer's
            side out of its lidar's 180 degrees went on west while the observer turned east
            to where it had been (edmonton_convention, seed 13: 876 s unseen after). 4 s
            against 0 and 2, leaving each of 18 worlds out (seed 13): every fold chose 4 s,
            held-out trk50 84.6 % against 83.8 %, tracked 87.1 % against 85.7 %
            (docs/evaluation.md, session 64).
        look_distance: a target that stood still when lost further off, or is not trailed,
            is looked for from this far (m) from where it was last seen, on the observer's
            side (a roomy point first; nearer when no free point lies that far), facing
            where it was (from nearer than 0.5 m: the way the observer came); then, where
            there is ``roomy`` clearance, the observer looks round there. 0: from where it
            was last seen (from the stand-off point when that is not free), the default.
            Looking from the stand-off point (``distance``, 1.5 m, before session 65), on
            its own side, the observer looked again past the door jamb that had hidden a
            walker standing 2.5 m down the corridor beyond (orebro, seed 14: 232 and 325 s
            unseen after). 0 against 1.5 m, leaving each of 18 worlds out, seeds 13-15:
            every fold chose 0, held-out trk50 83.3 % against 82.6 %, tracked 85.5 %
            against 84.9 % (docs/evaluation.md, session 65).
        blocked_way: a target lost while the observer steps out of its way by ``unblock``
            (the search starting within ``give_way_hold`` of the step, the target not seen
            more than ``distance`` from where it stood since) is looked for first, before
            the rules of ``trail`` and ``look_lead``, from where the observer stood (when
            free), facing the way from the target through that place: it stood there
            because the observer was in its way, and went on through. Once a step. True
            (the default since session 65); False: as any target lost (trailed at the
            track's last velocity, or looked at where it was).
            The walker set off past the observer as it stepped aside, out of its lidar's
            180 degrees, and the track's velocity from its first steps pointed the other way
            (aces_austin, seed 14: 485 s unseen after; belgioioso_castle 707 s). True
            against False, leaving each of 18 worlds out, seeds 13-15: every fold chose
            True, held-out trk50 84.0 % against 83.3 %, tracked 85.8 % against 85.5 %; on
            seeds 13 and 15 alone (not traced) a tie (docs/evaluation.md, session 65).
        give_way_through: a target lost while the observer steps off its predicted way
            (give way, not only ``unblock``) is looked for as ``blocked_way`` says (with
            it on): from where the observer stood, facing the way from where the target
            was through that place, once the observer got within 1 m of the place it
            stepped to (one it never got to lay across the target's way: going back, it
            stood in that way again, four times in a minute, and the walker gave its leg
            up). False (the default): trailed at the track's last velocity, or looked at
            where it was. The walker passed the observer 0.75 m off as it stepped aside,
            out of its lidar's 180 degrees; the track's last velocity pointed into the room
            it had come from, the trail went there, and the search of the regions the track
            made likely left it unseen for 319 s in the corridor it took (intel_lab, seed
            13). On against off, leaving each of 18 worlds out, seeds 13-15: every fold
            kept it off, held-out trk50 84.2 %; on, trk50 83.9 against 84.2 % and tracked
            86.0 against 85.9 %; intel_lab tracked 68.0 -> 79.3 % at seed 13, but seattle
            at seed 14 gave up 5.7 % of its legs and malaga_corridor lost 6.3 points of
            trk50 (docs/evaluation.md, session 70).
        standoff_sight: the stand-off point (following, and the places to look from or to
            turn in that are built on it: :func:`people.follow_geometry.standoff_point`) is one with
            no wall between it and the target when any free one has that (a roomy one on
            the observer's side first, else the first in the candidates' order: towards the
            observer, or to the side of an approaching target's path, then turned 15
            degrees at a time), even if not roomy; when none has, the point chosen without
            this. False (the default): as before, a roomy point first even behind a wall.
            On intel_lab (seed 13, 30 legs) 22 of 172 follow goals had a wall between them
            and the target: a roomy point turned up to 90 degrees from the observer's
            bearing can lie in the room beside the corridor. On against off, leaving each
            of 18 worlds out, seeds 13-15: every fold kept it off, held-out trk50 84.2 %;
            on, trk50 83.6 against 84.2 % and tracked 85.7 against 85.9 %; intel_lab
            tracked 68.0 -> 76.7 % at seed 13, but aces_austin at seed 15 gave up 5.7 %
            of its legs (docs/evaluation.md, session 69).
        unblock: a target that came nearer than ``distance`` - 0.2 m and has stayed within
            ``distance`` of the observer, and within ``give_way`` of where it was, this long
            (s) is taken to be blocked by it,
            wherever it is going: the observer steps to the nearest place at least
            ``give_way`` from the target, from where it stands and from the target's
            predicted routes (a roomy one in view first; with none, one that far from the
            target, where it stands and the predicted destinations), and waits there as when
            it gives way. 0: never. (intel_lab: the walker gave up a leg 0.8 m from its goal, with
            the observer, following it, standing on that goal; no prediction named a route
            through it. Counted within ``give_way`` + 0.2 m only, it never fired on
            aces_austin and mit_csail: the walker, blocked 0.9-1.2 m off in a narrow place,
            was tracked 0.3-0.5 m to and fro and gave up its leg after 30-60 s. Started
            anywhere within ``distance``, it fired on walkers dwelling at the stand-off
            distance.)
        snug: a passage whose clearance is below the observer's radius plus this (m) is too
            snug for it to turn in. A part of the floor behind such passages that is smaller
            than a disc of radius ``distance`` (where it could not keep its distance from
            the target) with one such passage into it is a pocket (a dead end): a follow,
            search or patrol goal in a pocket the observer is not in becomes the nearest
            place within ``give_way_reach`` outside pockets, facing the goal (aces_austin:
            it followed the walker into a room 1.5 m deep through a passage 2-3 cm wider
            than its footprint, wedged itself on the way out and shut the walker in for 10
            minutes). Rooms behind narrow doors that are bigger than that, or have another
            way in, are followed into as before (freiburg_079, whose 16 m^2 rooms have
            0.75 m doors, lost a sixth of its tracking when no such room was). 0 (the
            default): it goes wherever it can plan to. Off by default: with 0.04, aces_austin
            gave up 0-5 % of its legs instead of 7-17 %, but on freiburg_079 (seed 1) the
            walker spent minutes in a 1 x 3.6 m dead-end room the observer then waited
            outside of, unable to see in: tracked 74 -> 42 % (docs/evaluation.md, session 29).
            Every fold over seeds 13-14 keeps it off against 0.04 (session 84).
        watch: once the search plan's regions are done, the observer watches at the
            building's hubs (people/search.hub_points: where most ways between its roomy
            places pass), looking round, for at least this long (s) after its first look
            and wait there, then patrols at least as long, then watches at the next hub
            (a hub it cannot get within 1 m of is skipped); 0 (the default): it patrols
            only. Off by default: with 60 s (about a walker's leg and its dwell), seed 4 at
            100 legs on 16 worlds came out the same on 12, better on 3 (orebro tracked
            56 -> 76 %, trk50 57 -> 77 %; mit_csail 69 -> 75 %, 76 -> 82 %; seattle 61 -> 63 %)
            and worse on intel_lab (65 -> 55 %, 63 -> 50 %): the hubs of the whole building
            lay 15-20 m from where the walker, going between neighbouring regions, stayed for
            ten minutes, and the patrol between watches, starting at a hub each time, did not
            get there (docs/evaluation.md, session 43). Folded at seed 13 against 60 s
            (session 84): 17 of 18 runs the same, trk50 the same on all 18, so every fold
            keeps it off by the tie rule; the study's figures hardly depend on it.
        patrol_return: at the first patrol place (or hub watch) done once it has patrolled
            this long (s) since the search plan's regions were done, the observer searches
            them again from the most likely (``search_rounds`` rounds, then the others), then
            patrols again (the watches going on from the next hub), and so on; 0 (the
            default): it patrols for good. The patrol goes nearest place first from
            wherever the observer is, so it drifts away from where the target was lost: on
            mit_csail (seed 15) it toured the building for 674 s, up to 37 m off, while the
            walker walked 37 legs within 5 x 13 m of where it was lost (docs/evaluation.md,
            session 75).
    """

    distance: float = 1.5
    slack: float = 0.7
    replan_distance: float = 0.5
    goal_period: float = 2.0
    lost_after: float = 2.0
    search_turn: float = math.pi
    search_wait: float = 3.0
    search_regions: int = 3
    search_min_probability: float = 0.05
    search_rounds: int = 2
    search_sight: float = 8.0
    search_at: str = "lookout"
    patrol_spacing: float = 4.0
    patrol_after: float = 10.0
    patrol_sight: float = 8.0
    roomy: float = 0.6
    give_way: float = 0.9
    give_way_reach: float = 4.0
    give_way_hold: float = 20.0
    give_way_view: float = math.radians(75.0)
    pass_detour: float = 2.0
    trail: float = 4.0
    trail_turn: float = math.pi / 2
    look_lead: float = 4.0
    look_distance: float = 0.0
    blocked_way: bool = True
    give_way_through: bool = False
    standoff_sight: bool = False
    unblock: float = 4.0
    snug: float = 0.0
    watch: float = 0.0
    patrol_return: float = 0.0

    def check(self) -> None:
        """Raise FollowError naming the first bad parameter."""
        check_numbers(self, ("distance", "slack", "replan_distance", "goal_period", "lost_after",
                             "search_turn", "search_wait", "patrol_spacing", "patrol_after",
                             "roomy", "give_way", "give_way_reach", "give_way_hold"),
                      "follower", error=FollowError)
        check_integers(self, ("search_regions", "search_rounds"), "follower", error=FollowError)
        check_numbers(self, ("pass_detour", "trail", "trail_turn", "look_lead", "look_distance",
                             "unblock", "snug", "patrol_sight", "search_sight", "watch",
                             "patrol_return"), "follower",
                      strict=False, error=FollowError)
        for name in ("blocked_way", "give_way_through", "standoff_sight"):
            if not isinstance(getattr(self, name), bool):
                raise FollowError("follower: %s must be true or false, got %r"
                                  % (name, getattr(self, name)))
        if self.search_at not in SEARCH_AT:
            raise FollowError("follower: search_at must be one of %s, got %r"
                              % (", ".join(SEARCH_AT), self.search_at))
        if self.trail_turn > math.pi / 2 + 1e-3:   # 1.5708, as typed, is pi/2
            raise FollowError("follower: trail_turn must be at most pi/2 radians (a trail "
                              "turned further runs back the way the target came), got %r"
                              % (self.trail_turn,))
        if self.search_turn > math.pi:
            raise FollowError("follower: search_turn must be at most pi radians (the look-round's "
                              "goal yaw wraps: 2 pi turns not at all), got %r" % (self.search_turn,))
        if not (math.isfinite(self.give_way_view) and 0.0 <= self.give_way_view <= math.pi):
            raise FollowError("follower: give_way_view must be in [0, pi] radians, got %r"
                              % (self.give_way_view,))
        v = self.search_min_probability
        if not (isinstance(v, (int, float)) and 0.0 <= v <= 1.0):
            raise FollowError("follower: search_min_probability must be in [0, 1], got %r" % (v,))


@dataclass
class FollowDecision:
    """What the observer should do now.

    Attributes:
        mode: ``follow``, ``give_way``, ``search``, ``patrol`` or ``idle``.
        goal: a new navigation goal (x, y, yaw) to send now, or None (keep the current one).
        reason: one line for the log.
    """

    mode: str
    goal: Optional[Tuple[float, float, float]] = None
    reason: str = ""
