"""Destination prediction: hand-computed posteriors on a corridor with offices, the baselines,
leg cutting of a pose stream, the office world, and bad input (no ROS)."""
from __future__ import annotations

import math
import os

import numpy as np
import pytest
from shapely.geometry import Point

from bullet_floor_sim.sim.floormap import load_map, map_from_grid
from bullet_floor_sim.people.markov import MarkovChain
from bullet_floor_sim.nav.planner import PlanError, PlanningGrid
# the planning model's own posterior, uncalibrated (prior_mix 0), is what these tests work out
# by hand; calibration has its own test below
from bullet_floor_sim.people.prediction import (DestinationModel, OnlinePredictor, Prediction,
                                              PredictorPool,
                                              PredictionConfig, PredictionError, log_loss, top1)
from bullet_floor_sim.data.rois import Roi, load_rois, roi_polygon

ROOT = os.path.join(os.path.dirname(os.path.abspath(__file__)), "..", "..")
OFFICE = os.path.join(ROOT, "worlds", "office")
RES = 0.05

# --------------------------------------------------------------------------------------------
# a corridor with offices
#
#   y 11.9 +-----------+------------------+-------------------+
#          |  A        |  B               |  C                |
#      7.1 +--[door]---+-------[door]-----+-------[door]------+
#          |  corridor (y 4.5 .. 7.0, centre line y = 5.75)    |
#      4.4 +--------------------------------------+--[door]---+
#          |  solid (a sealed pocket at x 2..5,   |  D        |
#          |  y 1..3)                             |           |
#      0.1 +--------------------------------------+-----------+
#          x 0.1        8.5  8.6          19.5 19.6          27.9
#
# Doors are 1.2 m wide, centred on x = 3 (A), 14 (B), 25 (C above, D below). The corridor's
# centre line keeps 1.25 m from both walls, beyond robot_radius + inflation_radius (0.94 m):
# its cells cost nothing, so a step of d metres along it costs exactly d.
# --------------------------------------------------------------------------------------------

IDS = ["corridor", "A", "B", "C", "D"]
GOALS = {"corridor": [(14.05, 5.75)], "A": [(3.05, 9.55)], "B": [(14.05, 9.55)],
         "C": [(25.05, 9.55)], "D": [(25.05, 2.25)]}
# The seed rule by hand. Degrees: corridor 3 (A, B, C), A 1, B 1, C 2 (corridor, D), D 1.
# From the corridor, candidates {corridor, A, B, C}, S = 3 + 1 + 1 + 2 = 7, |C| - 1 = 3:
# P = (1 - n_j / 7) / 3: corridor 4/21, A 6/21, B 6/21, C 5/21; D is not a candidate: 0.
PRIOR = {"corridor": 4 / 21, "A": 6 / 21, "B": 6 / 21, "C": 5 / 21}


def cells(x):
    return int(round(x / RES))


def corridor_map():
    h, w = cells(12.0), cells(28.0)
    g = np.zeros((h, w), dtype=np.int8)
    g[:2, :] = g[-2:, :] = 100
    g[:, :2] = g[:, -2:] = 100
    g[cells(4.4):cells(4.5), :] = 100                 # corridor's lower wall
    g[cells(7.0):cells(7.1), :] = 100                 # corridor's upper wall
    g[:cells(4.4), :cells(19.6)] = 100                # solid below the corridor ...
    g[cells(1.0):cells(3.0), cells(2.0):cells(5.0)] = 0  # ... but for a sealed pocket
    for x in (8.5, 19.5):                             # office walls
        g[cells(7.1):, cells(x):cells(x + 0.1)] = 100
    for x in (3.0, 14.0, 25.0):                       # doors above
        g[cells(7.0):cells(7.1), cells(x - 0.6):cells(x + 0.6)] = 0
    g[cells(4.4):cells(4.5), cells(24.4):cells(25.6)] = 0  # D's door below
    return map_from_grid(g, RES)


def box(x0, y0, x1, y1):
    return [(x0, y0), (x1, y0), (x1, y1), (x0, y1)]


def corridor_rois():
    polys = {"corridor": box(0.1, 4.45, 27.9, 7.05), "A": box(0.1, 7.05, 8.55, 11.9),
             "B": box(8.55, 7.05, 19.55, 11.9), "C": box(19.55, 7.05, 27.9, 11.9),
             "D": box(19.55, 0.1, 27.9, 4.45)}
    return [Roi(id=r, config="1", type="corridor" if r == "corridor" else "office",
                map_name="corridor", vertices=polys[r]) for r in IDS]


def corridor_chain():
    return MarkovChain.from_neighbours(IDS, {"corridor": ["A", "B", "C"], "C": ["D"]},
                                       "corridor")


@pytest.fixture(scope="module")
def world():
    grid = PlanningGrid(corridor_map())
    return grid, corridor_rois(), corridor_chain()


@pytest.fixture(scope="module")
def model(world):
    # the progress term alone (the leg-length term has its own tests)
    return DestinationModel(*world, PredictionConfig(prior_mix=0.0, length_exponent=0.0),
                            goal_points=GOALS)


def expected(progress, beta):
    """prior * exp(beta * progress), normalised."""
    w = {g: PRIOR[g] * math.exp(beta * progress[g]) for g in PRIOR}
    total = sum(w.values())
    return {g: v / total for g, v in w.items()}


# --------------------------------------------------------------------------------------------
# hand-computed posteriors
# --------------------------------------------------------------------------------------------


def test_prior_is_the_chain_row_by_hand(model):
    assert model.prior("corridor") == pytest.approx(PRIOR, abs=1e-12)
    assert model.markov_baseline("corridor") == model.prior("corridor")
    assert model.start_region(7.05, 5.75) == "corridor"
    assert model.start_region(3.0, 7.05) == "A"  # on the shared edge: the smaller ROI
    assert model.start_region(0.05, 5.75) == "corridor"  # in none: the nearest
    assert model.region_at(14.0, 9.0) == "B" and model.region_at(30.0, 5.0) == ""


def test_cost_to_go_along_the_centre_line_is_the_distance(model):
    # the corridor's goal lies on the centre line: V is the distance to it, to rounding
    for x in (7.05, 9.72, 12.05, 16.03, 20.0):
        assert model.cost_to_go("corridor", x, 5.75)[0] == pytest.approx(abs(14.05 - x),
                                                                          abs=1e-5)


@pytest.mark.parametrize("beta", [1.0, 3.0])
@pytest.mark.parametrize("q", [(10.05, 5.75), (9.72, 5.75)])
def test_posterior_along_the_corridor_by_hand(world, beta, q):
    """Walking east on the centre line from S = (7.05, 5.75) to Q: the optimal path from S to
    every goal runs along the centre line through Q (A's turns off west of S, the others' east
    of Q), so the progress V_p(S) - V_p(Q) is +|SQ| for the corridor, B and C goals and -|SQ|
    for A's. Tolerance: the progress to 1 cm (beta * 0.01 on log ratios); the V fields are
    float32 and the grid is exact here, the centimetre allows for the cell refinement."""
    grid, rois, chain = world
    m = DestinationModel(grid, rois, chain,
                         PredictionConfig(prior_mix=0.0, beta=beta, length_exponent=0.0),
                         goal_points=GOALS)
    s = (7.05, 5.75)
    d = q[0] - s[0]
    progress = {"corridor": d, "A": -d, "B": d, "C": d}
    post = m.posterior("corridor", s, q)
    assert list(post) == ["corridor", "A", "B", "C"]  # D has prior 0 and stays out
    assert sum(post.values()) == pytest.approx(1.0, abs=1e-12)
    want = expected(progress, beta)
    for g in post:
        got = math.log(post[g] / PRIOR[g]) - math.log(post["corridor"] / PRIOR["corridor"])
        assert got == pytest.approx(beta * (progress[g] - progress["corridor"]),
                                    abs=beta * 0.01), g
        assert post[g] == pytest.approx(want[g], rel=2 * beta * 0.01), g
    # e.g. beta 1, 3 m: corridor 4/15, A 6/15 e^-6, B 6/15, C 5/15 (before normalising)
    if beta == 1.0 and q == (10.05, 5.75):
        assert post["A"] == pytest.approx(0.4 * math.exp(-6) / (1 + 0.4 * math.exp(-6)),
                                          rel=0.02)


def test_posterior_from_many_starts_reads_each_starts_own_values(world):
    """The model keeps the values of the last few leg starts: from Q = (10.05, 5.75), the
    evidence for A against the corridor is -6 m (walked east from 7.05) or +4 m (walked west
    from 12.05; A's way runs west through Q, the corridor goal's east), however many other
    starts were asked about in between (more than it keeps)."""
    grid, rois, chain = world
    m = DestinationModel(grid, rois, chain,
                         PredictionConfig(prior_mix=0.0, beta=1.0, length_exponent=0.0),
                         goal_points=GOALS)
    q = (10.05, 5.75)

    def evidence(start):
        post = m.posterior("corridor", start, q)
        return (math.log(post["A"] / PRIOR["A"])
                - math.log(post["corridor"] / PRIOR["corridor"]))

    fresh = DestinationModel(grid, rois, chain, m.config, goal_points=GOALS)
    for _ in range(2):
        assert evidence((7.05, 5.75)) == pytest.approx(-6.0, abs=0.01)
        assert evidence((12.05, 5.75)) == pytest.approx(4.0, abs=0.01)
        for k in range(10):   # other starts along the centre line, west of Q
            assert evidence((4.05 + 0.5 * k, 5.75)) == pytest.approx(
                -2.0 * (10.05 - 4.05 - 0.5 * k), abs=0.01)
        # nearer A's door at the same x (A's way from there is 0.2-0.25 m shorter): a fresh
        # model's answer, not the centre line's
        for y in (6.0, 6.25):
            assert m.posterior("corridor", (7.05, y), q) == fresh.posterior(
                "corridor", (7.05, y), q)
            assert evidence((7.05, y)) != pytest.approx(-6.0, abs=0.01)


def test_logsumexp_is_scipys():
    # to the bit up to scipy 1.14 (Debian 12's 1.10), which takes the largest term out the
    # same way; scipy 1.15 sums with log1p, to within rounding
    import scipy
    from scipy.special import logsumexp
    from bullet_floor_sim.people.prediction.model import _logsumexp
    exact = tuple(int(v) for v in scipy.__version__.split(".")[:2]) < (1, 15)
    rng = np.random.default_rng(5)
    for n in (1, 2, 3, 7, 40):
        for _ in range(200):
            a = rng.normal(0.0, 30.0, size=n)
            want = float(logsumexp(a))
            assert _logsumexp(a) == (want if exact else pytest.approx(want, rel=1e-14))
    assert _logsumexp(np.array([math.log(2.0), math.log(3.0)])) == pytest.approx(math.log(5.0))
    for a in ([-np.inf, -np.inf], [np.inf, 1.0], [-np.inf, 2.0], [1e300, 1e300], [1.0, np.nan]):
        want, got = float(logsumexp(np.array(a))), _logsumexp(np.array(a))
        assert got == pytest.approx(want) or (math.isnan(got) and math.isnan(want)), a


def test_nothing_observed_gives_the_prior_exactly(model):
    post = model.posterior("corridor", (7.05, 5.75), (7.05, 5.75))
    assert post == pytest.approx(PRIOR, rel=1e-12)
    post = model.posterior("C", (23.0, 9.0), (23.0, 9.0))
    assert post == pytest.approx(model.prior("C"), rel=1e-12)
    assert set(post) == {"corridor", "C", "D"}


def test_leg_length_term_by_hand(world):
    """length_exponent 1: each goal point's term is divided by its leg length L = V(S)
    (at least goal_spacing). From S = (7.05, 5.75) the corridor's goal lies 7 m along the
    centre line; B's goal is 3.8 m up through B's door from x = 14.05 on it: 10.8 m and a
    little for the turn, plus the inflation cost of the door. Nothing observed: the prior x 1/L;
    walking, the same progress ratios as without the term, times the ratio of the lengths."""
    m1 = DestinationModel(*world, PredictionConfig(prior_mix=0.0, length_exponent=1.0),
                          goal_points=GOALS)
    m0 = DestinationModel(*world, PredictionConfig(prior_mix=0.0, length_exponent=0.0),
                          goal_points=GOALS)
    s = (7.05, 5.75)
    length = {g: float(m1.cost_to_go(g, *s)[0]) for g in PRIOR}
    assert length["corridor"] == pytest.approx(7.0, abs=1e-4)
    assert 10.8 <= length["B"] <= 12.0   # and the cost of its door, near the jambs
    post = m1.posterior("corridor", s, s)
    w = {g: PRIOR[g] / length[g] for g in PRIOR}
    assert post == pytest.approx({g: v / sum(w.values()) for g, v in w.items()}, rel=1e-9)
    q = (10.05, 5.75)
    p1, p0 = m1.posterior("corridor", s, q), m0.posterior("corridor", s, q)
    for g in PRIOR:
        shift = math.log(p1[g] / p1["corridor"]) - math.log(p0[g] / p0["corridor"])
        assert shift == pytest.approx(-math.log(length[g] / length["corridor"]), abs=1e-9), g
    # a goal point nearer than goal_spacing (here 1 m) counts as 1 m away
    near = dict(GOALS, corridor=[(7.55, 5.75)])
    m = DestinationModel(*world, PredictionConfig(prior_mix=0.0, length_exponent=1.0,
                                                  goal_spacing=1.0), goal_points=near)
    post = m.posterior("corridor", s, s)
    w["corridor"] = PRIOR["corridor"] / 1.0
    assert post == pytest.approx({g: v / sum(w.values()) for g, v in w.items()}, rel=1e-9)


def test_walking_to_office_a_raises_p_a_monotonically(model):
    s = (10.05, 5.75)
    path = [(x, 5.75) for x in np.arange(10.05, 3.0, -0.1)]
    path += [(3.05, y) for y in np.arange(5.85, 9.5, 0.1)]
    pa = [model.posterior("corridor", s, q)["A"] for q in path]
    assert pa[0] == pytest.approx(PRIOR["A"])
    assert all(b > a for a, b in zip(pa[:30], pa[1:31]))  # strictly, along the centre line
    assert all(b >= a - 1e-9 for a, b in zip(pa, pa[1:]))  # and never down, through the door
    assert pa[-1] > 0.999


def test_prior_zero_stays_zero_and_sums_to_one(model):
    s = (7.05, 5.75)
    path = [(x, 5.75) for x in np.arange(7.05, 25.0, 0.5)]
    path += [(25.05, y) for y in np.arange(5.75, 2.0, -0.25)]  # into D
    for q in path:
        post = model.posterior("corridor", s, q)
        assert "D" not in post and post.get("D", 0.0) == 0.0
        assert sum(post.values()) == pytest.approx(1.0, abs=1e-12)
        assert all(0.0 <= p <= 1.0 for p in post.values())
    # from C, D is a candidate: walking down into D makes it near certain
    post = model.posterior("C", (25.05, 9.55), (25.05, 3.05))
    assert post["D"] > 0.999


def test_unreachable_goal_gives_zero_with_a_reason(world):
    goals = dict(GOALS, B=[(3.5, 2.0)], C=[(21.0, 7.05)])  # B's in the sealed pocket, C's in
    m = DestinationModel(*world, goal_points=goals)         # the wall
    assert m.goal_problems == {"C": 'region "C": goal point(s) (21.00, 7.05) not in free space'}
    assert len(m.goals("B")) == 1 and np.isinf(m.cost_to_go("B", 7.05, 5.75)).all()
    post, reasons = m.posterior_details("corridor", (7.05, 5.75), (8.05, 5.75))
    assert post["B"] == 0.0 and post["C"] == 0.0
    assert reasons == {"B": 'no goal point of region "B" is reachable from (7.05, 5.75)',
                       "C": m.goal_problems["C"]}
    assert post["corridor"] + post["A"] == pytest.approx(1.0, abs=1e-12)
    # from inside the pocket, B's goal is the only one reachable
    post, reasons = m.posterior_details("corridor", (3.0, 2.0), (3.2, 2.0))
    assert post == {"corridor": 0.0, "A": 0.0, "B": 1.0, "C": 0.0}
    assert reasons["A"] == 'no goal point of region "A" is reachable from (3.00, 2.00)'
    # with the usual goals, nothing of the row is reachable from there
    with pytest.raises(PredictionError, match='no region of "corridor"\'s row is reachable: '
                                              'no goal point of region "corridor" is'):
        DestinationModel(*world, goal_points=GOALS).posterior("corridor", (3.5, 2.0), (3.6, 2.0))


def test_mean_over_goal_points_and_unreachable_ones_dropped(world):
    """Two corridor goals, 7 m east and 6 m west of S: walking 3 m east they make +3 and -3
    m of progress, so the corridor's likelihood is the mean (e^3b + e^-3b) / 2; B's second goal
    lies in the sealed pocket and is left out of B's mean."""
    goals = dict(GOALS, corridor=[(14.05, 5.75), (1.05, 5.75)], B=[(14.05, 9.55), (3.5, 2.0)])
    beta = 1.0
    m = DestinationModel(*world, PredictionConfig(prior_mix=0.0, beta=beta, length_exponent=0.0),
                         goal_points=goals)
    post = m.posterior("corridor", (7.05, 5.75), (10.05, 5.75))
    w = {"corridor": PRIOR["corridor"] * (math.exp(3 * beta) + math.exp(-3 * beta)) / 2,
         "A": PRIOR["A"] * math.exp(-3 * beta), "B": PRIOR["B"] * math.exp(3 * beta),
         "C": PRIOR["C"] * math.exp(3 * beta)}
    total = sum(w.values())
    assert post == pytest.approx({g: v / total for g, v in w.items()}, rel=1e-5)


def test_no_corner_cutting_like_the_planner():
    """A staircase of lethal cells across the corridor: diagonal steps between two lethal
    cells are not taken (as the planner's A*), so it is a wall."""
    grid = PlanningGrid(corridor_map())
    c0, r0 = grid.to_cell(10.05, 4.0)
    for k in range(40):
        grid.cost[r0 + k, c0 + k] = np.inf
    m = DestinationModel(grid, corridor_rois(), corridor_chain(), goal_points=GOALS)
    assert np.isinf(m.cost_to_go("corridor", 7.05, 5.75)).all()
    assert np.isfinite(m.cost_to_go("corridor", 13.05, 5.75)).all()
    with pytest.raises(PlanError, match="unreachable"):
        grid.plan((7.05, 5.75), (14.05, 5.75))
    post, reasons = m.posterior_details("corridor", (7.05, 5.75), (8.05, 5.75))
    assert post["corridor"] == post["B"] == post["C"] == 0.0 and post["A"] == 1.0
    assert set(reasons) == {"corridor", "B", "C"}


def test_cost_to_go_is_the_planners_path_cost(office):
    """V at a few start points equals the cost of the planner's A* path to the goal point."""
    m = office
    grid = m.grid
    w = grid.config.cost_weight
    for region, start in (("5", (3.0, 10.0)), ("15", (3.0, 10.0)), ("9", (12.0, 10.0)),
                          ("10", (27.0, 3.0))):
        goal = m.goals(region)[0]
        cells = grid._astar(set(), grid.to_cell(*start), grid.to_cell(*goal))
        cost = 0.0
        for (c0, r0), (c1, r1) in zip(cells[:-1], cells[1:]):
            cost += (math.hypot(c1 - c0, r1 - r0) * grid.resolution
                     * (1.0 + w * 0.5 * (grid.cost[r0, c0] + grid.cost[r1, c1])))
        sx, sy = grid.to_world(*grid.to_cell(*start))  # the start cell's centre
        assert m.cost_to_go(region, sx, sy)[0] == pytest.approx(cost, rel=1e-5), region


def test_lattice_goals_are_inside_clear_and_capped(world):
    grid, rois, chain = world
    cfg = PredictionConfig(prior_mix=0.0, max_goals_per_region=7)
    m = DestinationModel(grid, rois, chain, cfg)
    assert m.goal_problems == {}
    for roi in rois:
        pts = m.goals(roi.id)
        assert 1 <= len(pts) <= 7, roi.id
        poly = roi_polygon(roi)
        for x, y in pts:
            assert poly.contains(Point(x, y)) and poly.exterior.distance(Point(x, y)) >= 0.25
            assert grid.clearance_at(x, y) >= cfg.clearance
        assert np.isfinite(m.cost_to_go(roi.id, 7.05, 5.75)).all(), roi.id
    again = DestinationModel(grid, rois, chain, cfg)
    assert all(np.array_equal(m.goals(r), again.goals(r)) for r in IDS)  # deterministic


# --------------------------------------------------------------------------------------------
# baselines
# --------------------------------------------------------------------------------------------


def test_heading_baseline_picks_the_office_the_ray_enters(model):
    eps = model.config.heading_epsilon
    # from (10.05, 5.75) along (2, 1): the ray crosses y = 7.05 at x = 12.65, inside B
    h = model.heading_baseline("corridor", (10.05, 5.75), (0.4, 0.2))
    assert h == pytest.approx({"corridor": eps / 3, "A": eps / 3, "B": 1 - eps, "C": eps / 3})
    h = model.heading_baseline("corridor", (10.05, 5.75), (-0.4, 0.2))  # x = 7.45: A
    assert top1(h) == "A" and h["A"] == pytest.approx(1 - eps)
    # along the centre line the ray enters no candidate: the smallest bearing to an anchor
    # (A at (4.33, 9.48) is 147 deg off, B (14.05, 9.48) 43 deg, C (23.73, 9.48) 15 deg)
    assert top1(model.heading_baseline("corridor", (10.05, 5.75), (0.5, 0.0))) == "C"
    # standing still: the prior
    assert model.heading_baseline("corridor", (10.05, 5.75), (0.05, 0.0)) == model.prior(
        "corridor")
    assert sum(h.values()) == pytest.approx(1.0)
    assert log_loss(h, "B") == pytest.approx(-math.log(eps / 3))


def test_log_loss_and_top1():
    p = {"a": 0.2, "b": 0.5, "c": 0.3}
    assert top1(p) == "b" and top1({"x": 0.5, "y": 0.5}) == "x"
    assert log_loss(p, "b") == pytest.approx(math.log(2.0))
    assert log_loss(p, "zzz") == pytest.approx(-math.log(1e-6))
    assert log_loss({"a": 0.0}, "a", floor=1e-3) == pytest.approx(-math.log(1e-3))


# --------------------------------------------------------------------------------------------
# online: legs from a stream
# --------------------------------------------------------------------------------------------


def stream(segments, t0=0.0, dt=0.1):
    """(t, x, y, vx, vy) samples: each segment is ("stand", (x, y), seconds) or
    ("walk", (x0, y0), (x1, y1), speed)."""
    t = t0
    out = []
    for seg in segments:
        if seg[0] == "stand":
            for _ in range(int(round(seg[2] / dt))):
                t += dt
                out.append((round(t, 6), seg[1][0], seg[1][1], 0.0, 0.0))
        else:
            (x0, y0), (x1, y1), v = seg[1], seg[2], seg[3]
            length = math.hypot(x1 - x0, y1 - y0)
            n = int(round(length / (v * dt)))
            vx, vy = v * (x1 - x0) / length, v * (y1 - y0) / length
            for k in range(1, n + 1):
                t += dt
                out.append((round(t, 6), x0 + (x1 - x0) * k / n, y0 + (y1 - y0) * k / n,
                            vx, vy))
    return out


def test_online_predictor_cuts_legs_and_predicts_office_b(model):
    s, door, goal = (7.05, 5.75), (14.05, 7.05), (14.05, 9.55)
    samples = stream([("stand", s, 2.0), ("walk", s, (12.05, 5.75), 0.5),
                      ("walk", (12.05, 5.75), (14.05, 5.75), 0.5),
                      ("walk", (14.05, 5.75), goal, 0.5), ("stand", goal, 5.0),
                      ("walk", goal, (14.05, 7.55), 0.5)])
    pred = OnlinePredictor(model)
    out = [(row, pred.update(*row)) for row in samples]
    assert all(p is not None for _, p in out)
    first = [k for k, (_, p) in enumerate(out) if p.under_way][0]
    # standing 2 s, then 0.3 m at 0.5 m/s (0.6 s) before the leg counts as started
    assert out[first][0][0] == pytest.approx(2.6)
    # until then, the next leg's prediction from where it stands: the corridor's row
    for row, p in out[:first]:
        assert (p.under_way, p.leg, p.start_region, p.start_xy) == (False, 1, "corridor", s)
    assert out[0][1].probabilities == pytest.approx(model.prior("corridor"), abs=1e-12)
    p = out[first][1]
    assert (p.leg, p.start_region, p.start_xy, p.leg_start) == (1, "corridor", s, 2.0)
    assert p.observed == pytest.approx(0.3)
    leg1 = [(row, p) for row, p in out if p.under_way and p.leg == 1]
    # along the corridor A falls steadily; B leads (prior) and takes over at its door
    on_axis = [p for row, p in leg1 if row[2] == 5.75 and row[1] <= 12.05]
    assert all(b.probabilities["A"] < a.probabilities["A"] for a, b in zip(on_axis, on_axis[1:]))
    at_door = [p for row, p in leg1 if (row[1], row[2]) == pytest.approx(door)][0]
    assert at_door.best == "B" and at_door.best_probability > 0.95
    arrived = [p for row, p in leg1 if (row[1], row[2]) == pytest.approx(goal)]
    assert arrived[0].best == "B" and arrived[0].observed == pytest.approx(5.0 + 2.0 + 3.8)
    # standing at the goal: predictions go on for dwell_time (3 s), then the leg has ended
    standing = [(row, p) for row, p in out if (row[1], row[2]) == goal and row[3:] == (0, 0)]
    assert len(standing) == 50  # 5 s at 10 Hz; the first at t0, the 31st at t0 + 3 s
    assert all(p.under_way and p.leg == 1 for _, p in standing[:30])
    # ... then it predicts leg 2 from B, where it stands: B's row of the chain
    waiting = [p for _, p in standing[30:]]
    assert all((p.under_way, p.leg, p.start_region) == (False, 2, "B") for p in waiting)
    assert waiting[0].probabilities == pytest.approx(model.prior("B"), abs=1e-12)
    assert waiting[0].best == max(model.prior("B").items(), key=lambda kv: kv[1])[0]
    # the next leg starts from B, where it stood
    second = [p for _, p in out if p.under_way and p.leg == 2]
    assert second and second[0].start_region == "B" and second[0].start_xy == goal
    assert second[0].leg_start == standing[-1][0][0]  # its last standing sample
    assert pred.legs == 2 and pred.last is second[-1]
    d = second[-1].to_dict()
    assert d["leg"] == 2 and d["start_region"] == "B" and d["start_xy"] == [14.05, 9.55]
    assert sum(d["probabilities"].values()) == pytest.approx(1.0, abs=1e-5)
    assert d["best"] == second[-1].best and d["note"] == "" and d["under_way"] is True
    pred.reset()
    again = pred.update(100.0, 7.05, 5.75, 0.5, 0.0)
    assert not pred.in_leg and (again.under_way, again.leg) == (False, 3)


def test_predictor_pool_hands_a_leg_over_to_the_track_seen_again(model):
    s, goal = (7.05, 5.75), (14.05, 9.55)
    samples = stream([("stand", s, 2.0), ("walk", s, (12.05, 5.75), 0.5),
                      ("walk", (12.05, 5.75), (14.05, 5.75), 0.5),
                      ("walk", (14.05, 5.75), goal, 0.5)])
    whole = OnlinePredictor(model)
    truth = [whole.update(*row) for row in samples]
    # the tracker loses the entity for 2 s (track 1 dies) and then calls it track 2; a clutter
    # track 9 stands 3 m away meanwhile, and track 5 appears far away (another person)
    lost = [k for k, row in enumerate(samples) if 6.0 < row[0] <= 8.0]
    pool = PredictorPool(model)
    out = []
    for k, (t, x, y, vx, vy) in enumerate(samples):
        tracks = [] if k in lost else [(1 if k < lost[0] else 2, x, y, vx, vy)]
        tracks.append((9, 8.0, 8.5, 0.0, 0.0))
        if k > lost[-1]:
            tracks.append((5, 25.0, 5.75, -0.5, 0.0))
        res = pool.update(t, tracks)
        if k not in lost:
            out.append((k, res[tracks[0][0]]))
    assert pool.handovers == 1 and set(pool.predictors) == {2, 5, 9}
    after = [(k, p) for k, p in out if k > lost[-1]]
    # track 2 goes on with track 1's leg: same start region and start, same leg number,
    # the same posterior as one unbroken stream (to the float) once it is in view again
    for k, p in after:
        assert (p.leg, p.start_region, p.start_xy) == (1, "corridor", s)
        assert p.probabilities == pytest.approx(truth[k].probabilities, abs=1e-12)
    assert after[-1][1].best == "B"
    # without the hand-over the new track's leg would start in the corridor at (10.05, 5.75)
    fresh = OnlinePredictor(model)
    again = [fresh.update(*row) for row in samples[lost[-1] + 1:]]
    assert [p for p in again if p is not None][0].start_xy != s


def test_predictor_pool_same_entity_takes_over_a_leg_however_long_it_was_lost(model):
    s, goal = (7.05, 5.75), (14.05, 9.55)
    samples = stream([("stand", s, 2.0), ("walk", s, (12.05, 5.75), 0.5),
                      ("walk", (12.05, 5.75), (14.05, 5.75), 0.5),
                      ("walk", (14.05, 5.75), goal, 0.5)])
    one = OnlinePredictor(model)
    whole = [one.update(*row) for row in samples][-1]
    # lost for 8 s (twice handover_time), seen again 4 m on: no hand-over by place ...
    lost = [k for k, row in enumerate(samples) if 4.0 < row[0] <= 12.0]
    assert samples[lost[-1] + 1][0] - samples[lost[0] - 1][0] > 2 * model.config.handover_time
    pool = PredictorPool(model)
    first_of_2 = None
    for k, (t, x, y, vx, vy) in enumerate(samples):
        if k in lost:
            continue
        ident = 1 if k < lost[0] else 2
        res = pool.update(t, [(ident, x, y, vx, vy)])
        if ident == 2 and first_of_2 is None:
            first_of_2 = res[2]
            assert pool.handovers == 0 and first_of_2.start_xy != s
            # ... not from itself, nor from a track never seen; from 1, gone, it takes the leg
            assert not pool.same_entity(2, 2) and not pool.same_entity(7, 2)
            assert pool.same_entity(1, 2) and pool.handovers == 1
            assert not pool.same_entity(1, 2)    # 1 is gone: nothing more to take
    last = pool.predictors[2].last
    assert (last.leg, last.start_region, last.start_xy) == (1, "corridor", s)
    assert last.best == whole.best == "B"
    assert last.probabilities == pytest.approx(whole.probabilities, abs=1e-9)


def test_predictor_pool_same_entity_refuses_two_tracks_seen_at_once(model):
    pool = PredictorPool(model)
    # track 2 0.3 m from track 1, near enough in time and place: refused only because both
    # were seen in the same update
    pool.update(0.0, [(1, 5.0, 5.75, 0.5, 0.0), (2, 5.3, 5.75, 0.0, 0.0)])
    kept = pool.predictors[2]
    pool.update(0.1, [(2, 5.3, 5.75, 0.0, 0.0)])
    assert not pool.same_entity(1, 2) and pool.predictors[2] is kept
    assert 1 in pool.predictors and pool.handovers == 0
    # past handover_time (4 s), no hand-over by place; track 3, 5 s after 1 was last seen,
    # 9 m from it: farther than 0.5 + 1.5 x 5 = 8 m, as far as 1 could have walked
    pool.update(5.0, [(3, 14.0, 5.75, 0.0, 0.0)])
    assert not pool.same_entity(1, 3) and pool.handovers == 0
    # track 4, 5.5 s after, 5 m from it, could be 1
    pool.update(5.5, [(4, 10.0, 5.75, 0.0, 0.0)])
    assert pool.same_entity(1, 4) and pool.handovers == 1 and 1 not in pool.predictors


def test_predictor_pool_same_entity_keeps_a_leg_taken_over_by_place(model):
    pool = PredictorPool(model)
    pool.update(0.0, [(1, 8.0, 5.75, 0.5, 0.0), (5, 9.0, 5.75, 0.5, 0.0)])
    walker, other = pool.predictors[1], pool.predictors[5]
    # both lost; 1 s later track 6 appears 0.3 m from where 5 was, 1.3 m from 1 (both within
    # 0.5 + 1.5 x 1 m): it takes the nearer one's, 5's, leg by place
    pool.update(1.0, [(6, 9.3, 5.75, 0.5, 0.0)])
    assert pool.handovers == 1 and pool.predictors[6] is other
    # the follower takes 6 for its lost target 1: 6 keeps the leg it took by place
    assert not pool.same_entity(1, 6) and pool.predictors[6] is other
    assert pool.predictors[1] is walker and pool.knows(1) and pool.handovers == 1


def test_predictor_pool_hands_over_only_to_a_near_new_track_soon_enough(world):
    cfg = PredictionConfig(prior_mix=0.0, length_exponent=0.0, forget_after=10.0)
    model = DestinationModel(*world, cfg, goal_points=GOALS)
    pool = PredictorPool(model)   # handover_time 4 s, handover_speed 1.5 m/s, plus 0.5 m
    pool.update(0.0, [(1, 5.0, 5.75, 0.5, 0.0)])
    pool.update(0.1, [(1, 5.05, 5.75, 0.5, 0.0)])
    first = pool.predictors[1]
    # 1 s later, 2.5 m away: farther than 0.5 + 1.5 x 1 = 2.0 m: a new entity
    pool.update(1.1, [(2, 7.55, 5.75, 0.5, 0.0)])
    assert pool.handovers == 0 and pool.predictors[2] is not first
    # 2 s after track 1's last update, 1.9 m from it: within 3.5 m, and track 1 is gone
    pool.update(2.1, [(2, 7.6, 5.75, 0.5, 0.0), (3, 6.95, 5.75, 0.5, 0.0)])
    assert pool.handovers == 1 and pool.predictors[3] is first and 1 not in pool.predictors
    # a track alive in the same update is never taken over
    pool.update(2.2, [(2, 7.65, 5.75, 0.5, 0.0), (3, 7.0, 5.75, 0.5, 0.0),
                      (4, 7.65, 5.8, 0.5, 0.0)])
    assert pool.handovers == 1
    # gone for longer than handover_time: no take-over; gone for forget_after: dropped
    gap = cfg.handover_time + 0.1
    pool.update(2.2 + gap, [(6, 7.0, 5.75, 0.5, 0.0)])
    assert pool.handovers == 1
    pool.update(2.2 + 10.5, [(6, 7.0, 5.75, 0.5, 0.0)])
    assert set(pool.predictors) == {6}
    # bad input: a one-line reason for that track, the others go on
    res = pool.update(13.0, [(6, 7.0, 5.75, 0.5, 0.0), (7, float("nan"), 1.0, 0.0, 0.0)])
    assert 6 in res and 7 not in res and 7 not in pool.predictors
    assert "track 7" in pool.errors[7] and "x" in pool.errors[7]


def test_online_predictor_falls_back_to_the_prior_off_the_map(model):
    pred = OnlinePredictor(model)
    pred.update(0.0, 7.05, 5.75, 0.0, 0.0)
    p = pred.update(1.0, 40.0, 5.75, 0.5, 0.0)  # a glitch far off the map
    assert isinstance(p, Prediction) and p.probabilities == model.prior("corridor")
    assert "current (40.00, 5.75) not within 0.6 m of the map's free space" in p.note


# --------------------------------------------------------------------------------------------
# the office world
# --------------------------------------------------------------------------------------------


@pytest.fixture(scope="module")
def office():
    rois = load_rois(os.path.join(OFFICE, "rois.yaml"))
    grid = PlanningGrid(load_map(os.path.join(OFFICE, "map.yaml")))
    chain = MarkovChain.from_rois(rois)
    # its build time: bench/prediction_bench.py
    return DestinationModel(grid, rois, chain, PredictionConfig(prior_mix=0.0))


def test_office_world_precomputes_and_every_region_has_reachable_goals(office):
    m = office
    assert m.goal_problems == {}
    for r in m.chain.ids:  # reachable from robot1's start pose
        assert np.isfinite(m.cost_to_go(r, 3.0, 10.0)).any(), r


def test_office_corridor_walk_east_from_office_1s_door(office):
    m = office
    s = (2.65, 10.0)  # corridor_west ("1"), in front of office_1's ("5") door
    r0 = m.start_region(*s)
    assert r0 == "1"
    prior = m.prior(r0)
    post = m.posterior(r0, s, (8.5, 10.0))  # 5.85 m east, near corridor_centre_west ("2")
    assert post["2"] > post["5"] and post["2"] > prior["2"] and post["5"] < prior["5"]
    assert post["2"] > 0.5 and post["5"] < 0.01
    assert top1(m.heading_baseline(r0, (8.5, 10.0), (0.5, 0.0))) != "5"


# --------------------------------------------------------------------------------------------
# bad input
# --------------------------------------------------------------------------------------------


@pytest.mark.parametrize("field, value, message", [
    ("beta", -1.0, r"beta must be a finite number >= 0, got -1.0"),
    ("beta", float("nan"), r"beta must be a finite number >= 0, got nan"),
    ("goal_spacing", 0.0, r"goal_spacing must be a finite number > 0, got 0.0"),
    ("max_goals_per_region", 0, r"max_goals_per_region must be an integer >= 1, got 0"),
    ("max_goals_per_region", 2.5, r"max_goals_per_region must be an integer >= 1, got 2.5"),
    ("heading_epsilon", 1.0, r"heading_epsilon must be a number in \[0, 1\), got 1.0"),
    ("dwell_time", "3", r"dwell_time must be a finite number >= 0, got '3'"),
    ("forget_after", 3.0, r"forget_after must be a finite number >= handover_time \(4\), got 3.0"),
    ("forget_after", float("nan"), r"forget_after must be a finite number >= handover_time \(4\)"),
])
def test_bad_config_names_the_field(world, field, value, message):
    cfg = PredictionConfig(**{field: value})
    with pytest.raises(PredictionError, match=message):
        cfg.check()
    with pytest.raises(PredictionError, match=message):
        DestinationModel(*world, config=cfg)


def test_bad_input_names_it(world, model):
    with pytest.raises(PredictionError, match=r"unknown region 'E' \(regions: corridor, A, B"):
        model.posterior("E", (7.05, 5.75), (8.0, 5.75))
    with pytest.raises(PredictionError, match="unknown region 'E'"):
        model.cost_to_go("E", 7.05, 5.75)
    with pytest.raises(PredictionError, match="unknown region 'E'"):
        model.heading_baseline("E", (7.05, 5.75), (0.5, 0.0))
    with pytest.raises(PredictionError, match=r"start_xy must be a finite \(x, y\), got "
                                              r"\(nan, 5.75\)"):
        model.posterior("corridor", (float("nan"), 5.75), (8.0, 5.75))
    with pytest.raises(PredictionError, match=r"current_xy must be a finite \(x, y\)"):
        model.posterior("corridor", (7.05, 5.75), (8.0,))
    with pytest.raises(PredictionError, match=r"velocity must be a finite \(x, y\)"):
        model.heading_baseline("corridor", (7.05, 5.75), (float("inf"), 0.0))
    with pytest.raises(PredictionError, match=r"start \(40.00, 5.75\) and current \(41.00, "
                                              r"5.75\) not within 0.6 m of the map's free space"):
        model.posterior("corridor", (40.0, 5.75), (41.0, 5.75))
    with pytest.raises(PredictionError, match="goal_points names unknown region 'E'"):
        DestinationModel(*world, goal_points={"E": [(1.0, 1.0)]})
    with pytest.raises(PredictionError, match=r"goal_points\['A'\]\[0\] must be a finite"):
        DestinationModel(*world, goal_points={"A": [(float("nan"), 1.0)]})
    grid, rois, chain = world
    with pytest.raises(PredictionError, match="chain regions without ROI: D"):
        DestinationModel(grid, rois[:4], chain)
    pred = OnlinePredictor(model)
    with pytest.raises(PredictionError, match="update y must be a finite number, got nan"):
        pred.update(0.0, 1.0, float("nan"), 0.0, 0.0)
    pred.update(5.0, 7.05, 5.75, 0.0, 0.0)
    with pytest.raises(PredictionError, match=r"update t 4.000 is before the previous update's "
                                              r"5.000"):
        pred.update(4.0, 7.05, 5.75, 0.0, 0.0)
    with pytest.raises(PredictionError, match=r"floor must be in \(0, 1\]"):
        log_loss({"a": 1.0}, "a", floor=0.0)
    with pytest.raises(PredictionError, match="top1: no probabilities"):
        top1({})


def test_calibration_tempers_the_evidence_then_mixes_the_prior_in_by_hand():
    from bullet_floor_sim.people.prediction.calibration import brier, calibrate

    probs, prior = {"a": 0.9, "b": 0.1, "c": 0.0}, {"a": 0.5, "b": 0.3, "c": 0.2}
    assert calibrate(probs, prior) == probs                       # T 1, mix 0: unchanged
    # T = 2: P ∝ prior^(1/2) P^(1/2): a sqrt(.45), b sqrt(.03), c stays 0
    wa, wb = math.sqrt(0.5 * 0.9), math.sqrt(0.3 * 0.1)
    q = calibrate(probs, prior, temperature=2.0)
    assert q["a"] == pytest.approx(wa / (wa + wb)) and q["c"] == 0.0
    # then 0.2 of the prior over the live regions (a, b: 0.5 / 0.8 and 0.3 / 0.8)
    q = calibrate(probs, prior, temperature=2.0, prior_mix=0.2)
    assert q["a"] == pytest.approx(0.8 * wa / (wa + wb) + 0.2 * 0.625)
    assert q["b"] == pytest.approx(0.8 * wb / (wa + wb) + 0.2 * 0.375)
    assert sum(q.values()) == pytest.approx(1.0)
    # a wrong answer's log-loss is bounded by the mix: -ln(0.2 * 0.375)
    assert -math.log(calibrate({"a": 1.0, "b": 0.0 + 1e-12}, {"a": 0.5, "b": 0.5},
                               1.0, 0.2)["b"]) <= -math.log(0.2 * 0.5) + 1e-9
    assert brier({"a": 0.75, "b": 0.25}, "a") == pytest.approx(0.125)
    assert brier({"a": 1.0}, "b") == pytest.approx(2.0)


@pytest.mark.parametrize("field,value", [("temperature", 0.5), ("prior_mix", 1.0),
                                         ("prior_mix", -0.1)])
def test_calibration_parameters_are_checked(field, value):
    cfg = PredictionConfig(**{field: value})
    with pytest.raises(PredictionError, match=field):
        cfg.check()
