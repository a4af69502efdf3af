"""people/agents.py: the walker, tracker, predictor and follower agents that the ROS nodes and
the evaluation both drive: legs, results, timeouts and pauses by hand; a body walking past the
lidar tracked at its true place and speed; per-track predictions with their search plans; the
follower keeping its target and its plan (no ROS)."""
from __future__ import annotations

import dataclasses
import math
import os
from types import SimpleNamespace

import numpy as np
import pytest
from shapely.geometry import Point

from bullet_floor_sim.data.rois import Roi, RoiError, load_rois, roi_polygon
from bullet_floor_sim.nav.planner import PlanningGrid
from bullet_floor_sim.people.agents import (FollowerAgent, PredictorAgent, TrackerAgent,
                                            WalkerAgent)
from bullet_floor_sim.people.follow import FollowBehaviour, FollowConfig, FollowError
from bullet_floor_sim.people.markov import MarkovChain
from bullet_floor_sim.people.prediction import DestinationModel, PredictionConfig, PredictorPool
from bullet_floor_sim.people.tracking import TrackerConfig
from bullet_floor_sim.people.walker import GoalSampler, Walker, WalkerConfig, WalkerError
from bullet_floor_sim.sim.floormap import load_map, map_from_grid

from test_follow import hall
from test_prediction import GOALS, corridor_chain, corridor_map, corridor_rois
from test_tracking import simple_room_map, synthetic_scan

ROOT = os.path.join(os.path.dirname(os.path.abspath(__file__)), "..", "..")
OFFICE = os.path.join(ROOT, "worlds", "office")


@pytest.fixture(scope="module")
def office():
    rois = load_rois(os.path.join(OFFICE, "rois.yaml"))
    grid = PlanningGrid(load_map(os.path.join(OFFICE, "map.yaml")))
    return rois, GoalSampler(grid)


# --------------------------------------------------------------------------------------------
# the walker
# --------------------------------------------------------------------------------------------


def test_walker_agent_legs_results_timeouts_and_pauses(office):
    rois, sampler = office
    cfg = WalkerConfig(goal_timeout=100.0, timeout_per_m=1.0, retry_delay=2.0,
                       max_retry_delay=30.0, dwell_min=5.0, dwell_max=20.0)
    agent = WalkerAgent(Walker(MarkovChain.from_rois(rois), rois, sampler, cfg, seed=3))
    by_id = {r.id: r for r in rois}
    pose = (3.0, 10.0, 0.0)   # robot1's start in the corridor
    s = agent.tick(0.0, pose)
    leg = s.start
    assert leg is not None and (leg.number, leg.started) == (1, 0.0) and s.finished is None
    assert roi_polygon(by_id[leg.target_region]).contains(Point(leg.goal[:2]))
    assert agent.tick(10.0, pose).start is None and agent.leg is leg   # under way
    # a failure: the detail kept, the first retry delay, no new leg before it has passed
    s = agent.tick(12.5, pose, ("aborted", "blocked by an obstacle for 30 s"))
    assert s.finished is leg and (leg.outcome, leg.detail, leg.duration) == (
        "aborted", "blocked by an obstacle for 30 s", 12.5)
    assert s.line.startswith("leg 1: ") and "aborted after 12.5 s: blocked by" in s.line
    assert (s.pause, s.cancel, agent.resume_at) == (2.0, False, 14.5)
    assert agent.tick(14.4, pose).start is None
    leg = agent.tick(14.5, pose).start
    assert leg.number == 2
    # the leg's limit: goal_timeout, or timeout_per_m a metre to its goal when longer
    far = math.hypot(leg.goal[0] - pose[0], leg.goal[1] - pose[1])
    assert leg.timeout == max(100.0, 1.0 * far)
    assert Walker(MarkovChain.from_rois(rois), rois, sampler, dataclasses.replace(
        cfg, timeout_per_m=50.0), seed=3).next_leg(pose, 0.0).timeout > 100.0
    # no result within goal_timeout: a timeout, the goal to cancel, the delay doubled
    assert agent.tick(114.5, pose).finished is None          # exactly 100 s: not yet
    s = agent.tick(114.6, pose)
    assert s.finished is leg and leg.outcome == "timeout" and s.cancel
    assert leg.detail == "no result within 100 s (~goal_timeout, ~timeout_per_m)"
    assert s.pause == 4.0
    # a success at the timeout's tick is a success, then a dwell in [dwell_min, dwell_max]
    leg = agent.tick(118.6, pose).start
    s = agent.tick(218.7, pose, ("succeeded", "ignored"))
    assert (leg.outcome, leg.detail, s.cancel) == ("succeeded", "", False)
    assert 5.0 <= s.pause <= 20.0 and agent.resume_at == pytest.approx(218.7 + s.pause)
    assert leg.target_region in agent.walker.visited
    with pytest.raises(ValueError, match="unknown goal result 'done'"):
        agent.tick(219.0 + s.pause, pose)                   # a new leg ...
        agent.tick(220.0 + s.pause, pose, ("done", ""))     # ... and a result it cannot know


def test_a_leg_driven_the_long_way_round_gets_more_time_up_to_its_cap(office):
    """timeout_per_m seconds for each metre driven beyond the planned way, at most
    max_extension times the leg's limit more; standing still, no more time; a jump (a
    teleport) is not driven."""
    rois, sampler = office
    cfg = WalkerConfig(goal_timeout=100.0, timeout_per_m=2.0, max_extension=1.0)
    pose = (3.0, 10.0, 0.0)
    still = WalkerAgent(Walker(MarkovChain.from_rois(rois), rois, sampler, cfg, seed=3))
    leg = still.tick(0.0, pose).start
    assert leg.way > 0.0 and leg.timeout == max(100.0, 2.0 * leg.way)
    assert still.tick(leg.timeout + 0.1, pose).finished is leg and leg.outcome == "timeout"
    assert leg.detail == "no result within %.0f s (~goal_timeout, ~timeout_per_m)" % leg.timeout
    agent = WalkerAgent(Walker(MarkovChain.from_rois(rois), rois, sampler, cfg, seed=3))
    leg = agent.tick(0.0, pose).start
    x = pose[0]
    for k in range(1, 41):           # 0.5 m a second to and fro along y for 40 s
        agent.tick(float(k), (x, 10.0 + 0.5 * (k % 2), 0.0))
    assert leg.driven == pytest.approx(20.0)
    assert agent.limit(leg) == pytest.approx(leg.timeout + 2.0 * max(0.0, 20.0 - leg.way))
    agent.tick(41.0, (x + 30.0, 10.0, 0.0))   # a teleport
    assert leg.driven == pytest.approx(20.0)
    for k in range(42, int(2.0 * leg.timeout) + 1):     # 1 m a second: the cap
        assert agent.tick(float(k), (x + 30.0 + (k % 2), 10.0, 0.0)).finished is None
    assert agent.limit(leg) == pytest.approx(2.0 * leg.timeout)
    assert agent.leg is leg
    s = agent.tick(2.0 * leg.timeout + 0.1, (x + 30.0 + 1.0, 10.0, 0.0))
    assert s.finished is leg and leg.outcome == "timeout"
    assert leg.detail.endswith("; %.0f m driven on a planned way of %.0f m"
                               % (leg.driven, leg.way))


def test_walker_agent_gives_a_goal_given_up_close_by_one_new_goal_in_its_region(office):
    rois, sampler = office
    agent = WalkerAgent(Walker(MarkovChain.from_rois(rois), rois, sampler, WalkerConfig(),
                               seed=4), regoal_within=1.0, max_regoals=1)
    by_id = {r.id: r for r in rois}
    leg = agent.tick(0.0, (3.0, 10.0, 0.0)).start
    first = leg.goal
    near = (first[0] + 0.6, first[1], 0.0)          # blocked 0.6 m short of it
    s = agent.tick(40.0, near, ("aborted", "no progress for 60 s"))
    assert s.regoal and s.start is leg and s.finished is None and agent.leg is leg
    assert leg.regoals == 1 and math.hypot(leg.goal[0] - first[0], leg.goal[1] - first[1]) >= 1.0
    assert roi_polygon(by_id[leg.target_region]).contains(Point(leg.goal[:2]))
    assert s.info[0].startswith("leg 1: goal given up 0.60 m short (no progress for 60 s)")
    assert s.notes == []          # (information, not a warning: the leg goes on)
    # the second give-up close by gets no new goal (one a leg): in its region, the leg ends
    # there as reached, and says so
    here = (leg.goal[0] + 0.3, leg.goal[1], 0.0)
    assert agent.walker.region_at(*here[:2]) == leg.target_region
    s = agent.tick(70.0, here, ("aborted", "the goal is taken"))
    assert s.finished is leg and leg.outcome == "succeeded" and leg.duration == 70.0
    assert leg.detail == "stopped 0.30 m short (the goal is taken)"
    assert leg.end_region == leg.target_region and s.pause >= agent.walker.config.dwell_min
    assert s.info == ["leg 1: goal given up 0.30 m short (the goal is taken), no other goal: "
                      "it stops there, in %s" % agent.walker.label(leg.target_region)]
    # the next leg's goal keeps regoal_within clear of the goal it stopped short of
    taken = leg.goal
    t0 = 70.0 + s.pause
    asked = []
    draw = agent.walker.next_leg
    agent.walker.next_leg = lambda *a: asked.append(a[2:]) or draw(*a)
    nxt = agent.tick(t0, here).start
    agent.walker.next_leg = draw
    assert asked == [((taken[0], taken[1], 1.0),)]
    assert math.hypot(nxt.goal[0] - taken[0], nxt.goal[1] - taken[1]) >= 1.0
    agent.tick(t0 + 5.0, nxt.goal, ("succeeded", ""))
    # one far from the goal ends as given up
    t0 += 100.0
    leg = agent.tick(t0, (3.0, 10.0, 0.0)).start
    s = agent.tick(t0 + 10.0, (3.0, 10.0, 0.0), ("aborted", "x"))
    assert s.finished is leg and not s.regoal and leg.regoals == 0 and leg.outcome == "aborted"
    # a goal refused at once (no time on the leg) does not stop short, even at the goal
    t0 += 100.0
    leg = agent.tick(t0, (3.0, 10.0, 0.0)).start
    leg.regoals = agent.max_regoals
    s = agent.tick(t0, (leg.goal[0] + 0.3, leg.goal[1], 0.0), ("aborted", "no plan"))
    assert s.finished is leg and leg.outcome == "aborted"


def test_goals_keep_clear_of_a_spot_to_avoid_and_say_so_when_none_is_left(office):
    rois, sampler = office
    office5 = next(r for r in rois if r.id == "5")    # 3.5 m x 7.7 m
    rng = np.random.default_rng(0)
    for _ in range(50):
        x, y = sampler.sample(office5, rng, (3.0, 10.0), (2.6, 4.0, 2.0))
        assert math.hypot(x - 2.6, y - 4.0) >= 2.0
    with pytest.raises(RoiError, match="within 9.0 m of a spot taken"):
        sampler.sample(office5, rng, (3.0, 10.0), (2.6, 4.0, 9.0))


def test_a_goal_given_up_close_by_but_outside_its_region_is_given_up(office):
    """No new goal and not in the region it was going to: the leg is given up (a robot
    short of the doorway of a room it was going to has not got there)."""
    rois, sampler = office
    agent = WalkerAgent(Walker(MarkovChain.from_rois(rois), rois, sampler, WalkerConfig(),
                               seed=4), regoal_within=1.0, max_regoals=0)
    leg = agent.tick(0.0, (3.0, 10.0, 0.0)).start
    gx, gy, _ = leg.goal
    near = next((gx + dx, gy + dy, 0.0) for dx, dy in ((0.9, 0), (-0.9, 0), (0, 0.9), (0, -0.9))
                if agent.walker.region_at(gx + dx, gy + dy) != leg.target_region)
    s = agent.tick(20.0, near, ("aborted", "blocked"))
    assert s.finished is leg and leg.outcome == "aborted" and s.notes == [] == s.info


def test_walker_agent_no_leg_leaves_the_reasons_to_take(office):
    _, sampler = office
    wall = Roi("w", "1", "office", "office", [(-5.0, -5.0), (-1.0, -5.0), (-1.0, -1.0),
                                              (-5.0, -1.0)])
    agent = WalkerAgent(Walker(MarkovChain.from_rois([wall]), [wall], sampler,
                               WalkerConfig(max_picks=2), seed=0))
    with pytest.raises(WalkerError, match="no acceptable goal in the regions drawn"):
        agent.tick(0.0, (-3.0, -3.0, 0.0))
    notes = agent.take_notes()
    assert notes and notes[0].startswith('no goal in office w: ROI "w"')
    assert agent.take_notes() == [] and agent.leg is None


# --------------------------------------------------------------------------------------------
# the tracker
# --------------------------------------------------------------------------------------------


def test_tracker_agent_tracks_a_body_at_its_place_and_speed_and_restarts_on_time_going_back():
    agent = TrackerAgent.for_map(simple_room_map(), TrackerConfig())
    laser = (3.0, 2.0, math.pi)                  # looking at -x, the west wall
    step = None
    for k in range(31):                          # 3 s at 10 Hz, 0.5 m/s along -y
        t, cy = 0.1 * k, 3.0 - 0.05 * k
        ranges, amin, inc = synthetic_scan(laser, [(1.5, cy, 0.25)])
        step = agent.tick(t, SimpleNamespace(ranges=ranges, angle_min=amin,
                                             angle_increment=inc), laser)
        assert step.points.shape == (len(ranges), 2)   # every beam hits a wall or the body
    assert len(step.tracks) == 1 and step.restarted == ""
    tr = step.tracks[0]
    assert math.hypot(tr.x - 1.5, tr.y - 1.5) < 0.05
    assert tr.vx == pytest.approx(0.0, abs=0.1) and tr.vy == pytest.approx(-0.5, abs=0.1)
    ranges, amin, inc = synthetic_scan(laser, [(1.5, 1.5, 0.25)])
    back = agent.tick(1.0, SimpleNamespace(ranges=ranges, angle_min=amin,
                                           angle_increment=inc), laser)
    assert back.tracks == [] and "back" in back.restarted and agent.tracker.tracks == []


# --------------------------------------------------------------------------------------------
# the predictor
# --------------------------------------------------------------------------------------------


@pytest.fixture(scope="module")
def corridor_model():
    return DestinationModel(PlanningGrid(corridor_map()), corridor_rois(), corridor_chain(),
                            PredictionConfig(length_exponent=0.0), goal_points=GOALS)


def test_predictor_agent_predicts_per_track_with_search_plans(corridor_model):
    agent = PredictorAgent(corridor_model, FollowConfig(search_regions=2,
                                                        search_min_probability=0.0))
    pool = PredictorPool(corridor_model)     # the bare pool on the same stream
    step = None
    for k in range(60):                      # track 1 walks the corridor towards B's door,
        t = 0.1 * k                          # track 2 stands in C
        tracks = [(1, 7.05 + 0.05 * k, 5.75, 0.5, 0.0), (2, 25.05, 9.55, 0.0, 0.0)]
        step = agent.tick(t, tracks)
        want = pool.update(t, tracks)
    assert sorted(step.destinations) == [1, 2] and step.went_back == 0.0
    for tid, (p, plan) in step.destinations.items():
        assert p.probabilities == want[tid].probabilities
        assert plan.likely == 2 and plan[0][0] == p.best
        assert sorted(r for r, _ in plan) == sorted(p.probabilities)   # every region, ranked
        for region, xy in plan:               # each region's one goal point is its search point
            assert xy == GOALS[region][0]
    assert step.destinations[1][0].under_way and step.destinations[1][0].best == "B"
    back = agent.tick(2.0, [(1, 9.0, 5.75, 0.5, 0.0)])
    assert back.went_back == pytest.approx(3.9) and back.destinations[1][0].leg == 1


def test_predictor_agent_hands_the_leg_over_only_when_the_follower_switched(corridor_model):
    from bullet_floor_sim.people.agents import FollowerStep
    agent = PredictorAgent(corridor_model)
    for k in range(20):                      # track 1 walks east, then is lost
        agent.tick(0.1 * k, [(1, 7.05 + 0.05 * k, 5.75, 0.5, 0.0)])
    walker = agent.pool.predictors[1]
    # 10 s later (past handover_time), 3 m on: track 2 is new, with a leg of its own
    agent.tick(12.0, [(2, 11.0, 5.75, 0.5, 0.0)])
    new2 = SimpleNamespace(id=2, x=11.0, y=5.75, vx=0.5, vy=0.0)
    # a first pick (nothing lost) or a step that kept its target hands nothing over
    assert not agent.follower_switched(None, FollowerStep(target=new2, switched=False, new=True))
    assert not agent.follower_switched(1, FollowerStep(target=new2, switched=False))
    assert not agent.follower_switched(1, FollowerStep(target=None, switched=True, new=True))
    assert agent.handovers == 0 and agent.pool.predictors[2] is not walker
    # the follower switched from 1 to 2: 2 goes on with 1's leg
    assert agent.follower_switched(1, FollowerStep(target=new2, switched=True, new=True))
    assert agent.handovers == 1 and agent.pool.predictors[2] is walker


def test_predictor_agent_searches_a_corridor_from_its_lookouts_not_its_end():
    model = DestinationModel(PlanningGrid(corridor_map()), corridor_rois(), corridor_chain())
    agent = PredictorAgent(model)                    # search_sight 8 m
    goals, looks = model.goals("corridor"), agent.lookouts("corridor")
    # the 28 m corridor's goal points run along it; its lookouts are those with 8 m of
    # it on both sides (a point nearer an end sees fewer of them)
    lo, hi = goals[:, 0].min(), goals[:, 0].max()
    assert hi - lo > 20.0 and 0 < len(looks) < len(goals)
    assert looks[:, 0].min() >= lo + 8.0 - 1.5 and looks[:, 0].max() <= hi - 8.0 + 1.5
    with pytest.raises(ValueError):
        looks[0, 0] = 0.0                            # the cache is read-only
    # a track at the corridor's west end: the corridor's search point is the nearest
    # lookout, several metres east of the nearest goal point
    step = None
    for k in range(20):
        step = agent.tick(0.1 * k, [(1, 1.0 + 0.05 * k, 5.75, 0.5, 0.0)])
    _, plan = step.destinations[1]
    point = dict(plan)["corridor"]
    near = looks[np.argmin(np.hypot(looks[:, 0] - 1.95, looks[:, 1] - 5.75))]
    assert point == pytest.approx(tuple(near), abs=0.06)
    assert point[0] > goals[:, 0].min() + 5.0
    # search_sight 0: every goal point is a lookout (the nearest goal point, as before)
    assert len(PredictorAgent(model, FollowConfig(search_sight=0.0)).lookouts("corridor")) \
        == len(goals)


def cells_(metres):
    return int(round(metres / 0.05))


def test_a_region_a_wall_cuts_in_two_is_searched_from_the_side_the_target_was_lost_on():
    """mit_csail: a region's lookouts lay across a wall from where the walker was lost (that
    side had more goal points), nearest as the crow flies but with no way there; the observer
    took the goal that failed at once for the search point reached. The search point is now
    one of the region's lookouts on the target's side of the wall."""
    g = np.zeros((cells_(6.0), cells_(12.0)), dtype=np.int8)
    g[:2, :] = g[-2:, :] = g[:, :2] = g[:, -2:] = 100
    g[:, cells_(6.0):cells_(6.1)] = 100              # a wall from end to end: two halves
    grid = PlanningGrid(map_from_grid(g, 0.05))
    rois = [Roi(id="R", config="1", type="room", map_name="m",
                vertices=[(0.1, 0.1), (11.9, 0.1), (11.9, 5.9), (0.1, 5.9)]),
            Roi(id="L", config="1", type="room", map_name="m",
                vertices=[(0.1, 0.1), (1.0, 0.1), (1.0, 5.9), (0.1, 5.9)])]
    west, east = [(3.0, 2.0), (3.0, 4.0)], [(8.0, 2.0), (8.0, 4.0), (10.0, 2.0), (10.0, 4.0)]
    model = DestinationModel(grid, rois, MarkovChain.from_neighbours(["L", "R"], {"L": ["R"]}),
                             goal_points={"R": west + east, "L": [(0.6, 3.0)]})
    agent = PredictorAgent(model)
    assert {tuple(p) for p in agent.lookouts("R")} == set(east)   # the side with more
    for x, side in ((5.5, west), (6.6, east)):    # lost 0.5 m either side of the wall
        step = None
        for k in range(10):
            step = agent.tick(0.1 * k, [(1, x, 3.0, 0.0, 0.0)])
        _, plan = step.destinations[1]
        assert tuple(dict(plan)["R"]) in side


# --------------------------------------------------------------------------------------------
# the follower
# --------------------------------------------------------------------------------------------


def tr(id, x, y, vx=0.0, vy=0.0):
    return SimpleNamespace(id=id, x=x, y=y, vx=vx, vy=vy)


def test_follower_agent_keeps_its_target_and_its_plan_and_searches_there_when_lost():
    agent = FollowerAgent(FollowBehaviour(hall(), FollowConfig(lost_after=2.0)))
    plans = {1: [("7", (8.0, 3.0))], 2: [("5", (1.0, 1.0))]}
    s = agent.tick(0.0, (2.0, 2.0, 0.0), [tr(2, 6.0, 1.0), tr(1, 4.8, 2.0, 0.5)], plans)
    assert s.target.id == 1                 # nothing followed or seen before: the lowest id
    assert s.new and not s.switched and s.decision.mode == "follow"
    assert agent.destination == plans[1]
    first = 1
    # the followed id is kept while it lives, whoever is nearer
    s = agent.tick(0.5, (2.0, 2.0, 0.0), [tr(1, 4.9, 2.0, 0.5), tr(2, 6.0, 1.0)], plans)
    assert s.target.id == first and not s.new
    # it is gone: the nearest to where it was last seen replaces it (a switch)
    last = (s.target.x, s.target.y)
    s = agent.pick([tr(3, last[0] + 0.3, last[1]), tr(4, 9.0, 3.5)])
    assert s.target.id == 3 and s.new and s.switched and agent.target_id == 3


def test_follower_agent_searches_where_its_targets_plan_says_when_lost():
    agent = FollowerAgent(FollowBehaviour(hall(), FollowConfig(lost_after=2.0, trail=0.0)))
    agent.tick(0.0, (2.0, 2.0, 0.0), [tr(1, 4.8, 2.0, 0.5)], {2: [("5", (1.0, 1.0))]})
    assert agent.destination is None          # another track's plan is not taken
    agent.tick(0.1, (2.0, 2.0, 0.0), [tr(1, 4.85, 2.0, 0.5)], {1: [("7", (8.0, 3.0))]})
    s = agent.tick(2.5, (2.5, 2.0, 0.0), [], {})
    assert s.target is None and s.decision.mode == "search"
    assert s.decision.goal == pytest.approx((8.0, 3.0, math.atan2(1.0, 5.5)))


def test_search_at_likely_goal_sends_the_search_ahead_of_a_walk_lost_on_its_way():
    """The 28 m corridor's lattice goal points, 1 m apart on its centre line. Walking east
    from x = 1 to 1.95: with ``lookout`` the corridor's search point is its lookout
    nearest to the track, more than 5 m from the corridor's west end; with ``likely_goal``
    it is the corridor's goal point the walk made most likely: every point ahead got the
    same 0.95 m of progress and the leg-length term prefers the shortest leg, so the
    first point past the track (2.5); walking west from 24 to 23.05, the first point
    west of it (22.5; the nearest lookout is 18.5). A track that stands (no leg under way)
    keeps the lookouts."""
    model = DestinationModel(PlanningGrid(corridor_map()), corridor_rois(), corridor_chain())
    goals = model.goals("corridor")
    spacing = model.config.goal_spacing

    def plan_after(agent, xs):
        step = None
        for k, x in enumerate(xs):
            step = agent.tick(0.1 * k, [(1, x, 5.75, 0.5, 0.0)])
        pred, plan = step.destinations[1]
        return pred, dict(plan)["corridor"]

    east = [1.0 + 0.05 * k for k in range(20)]
    _, look = plan_after(PredictorAgent(model), east)
    pred, likely = plan_after(PredictorAgent(model, FollowConfig(search_at="likely_goal")), east)
    assert pred.under_way
    assert look[0] > goals[:, 0].min() + 5.0
    ahead = goals[goals[:, 0] > 1.95]
    assert tuple(likely) in [tuple(g) for g in goals.tolist()]
    assert 1.95 < likely[0] <= ahead[:, 0].min() + 1e-9
    assert likely[0] - 1.95 <= spacing + 1e-9
    # walking west from x = 24: the first point west of the track (22.5), not the lookout
    # nearest to it (18.5)
    west = [24.0 - 0.05 * k for k in range(20)]
    _, likely_w = plan_after(PredictorAgent(model, FollowConfig(search_at="likely_goal")), west)
    assert 23.05 - spacing - 1e-9 <= likely_w[0] < 23.05
    assert plan_after(PredictorAgent(model), west)[1][0] < 23.05 - 4.0
    # standing at x = 1: no leg under way, the lookouts as with ``lookout``
    pred_s, stand = plan_after(PredictorAgent(model, FollowConfig(search_at="likely_goal")),
                               [1.0] * 20)
    assert not pred_s.under_way
    assert stand == plan_after(PredictorAgent(model), [1.0] * 20)[1]
    with pytest.raises(FollowError, match="search_at"):
        FollowConfig(search_at="nearest").check()
