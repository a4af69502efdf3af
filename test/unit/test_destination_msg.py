"""ros/destination_predictor.destination_msg: a core Prediction as a Destination message (the
message classes only: no roscore)."""
import pytest

from bullet_floor_sim.people.search import search_plan
from bullet_floor_sim.people.prediction import Prediction

dp = pytest.importorskip("bullet_floor_sim.ros.destination_predictor")


def prediction(probs, best):
    return Prediction(t=12.0, leg_start=10.0, start_region="C", start_xy=(1.0, 2.0),
                      probabilities=probs, best=best, best_probability=probs[best],
                      observed=1.5)


@pytest.mark.parametrize("best", ["7", "3"])
def test_points_follow_the_ranked_regions_even_on_a_tie(best):
    # "3" and "7" tie: the predictor's arg-max comes first in regions and in points alike
    probs = {"3": 0.4, "7": 0.4, "9": 0.15, "5": 0.04, "C": 0.01}
    goals = {"3": [(3.0, 3.0)], "7": [(7.0, 7.0)], "9": [(9.0, 9.0)]}
    p = prediction(probs, best)
    plan = search_plan(probs, lambda r: goals.get(r, []), (0.0, 0.0), 3, 0.05, best)
    m = dp.destination_msg(4, p, dp.Destination().header, plan[0][1], plan)
    other = "3" if best == "7" else "7"
    assert list(m.regions[:3]) == [best, other, "9"]
    assert m.best == best and m.best_probability == pytest.approx(0.4)
    assert [(q.x, q.y) for q in m.points] == [goals[best][0], goals[other][0], (9.0, 9.0)]
    assert (m.best_point.x, m.best_point.y) == goals[best][0]
    assert m.track_id == 4 and m.start_region == "C" and m.observed == pytest.approx(1.5)
    assert sum(m.probabilities) == pytest.approx(1.0)


def test_the_follower_reads_every_region_and_its_own_likely_count():
    """Every region gets its point in the message; the follower node's plan keeps them all,
    most likely first, the likely ones those of its own search_regions and
    search_min_probability."""
    fo = pytest.importorskip("bullet_floor_sim.ros.follower")
    from bullet_floor_sim.people.follow import FollowConfig
    probs = {"3": 0.6, "7": 0.3, "9": 0.06, "5": 0.03, "C": 0.01}
    goals = {r: [(float(k), float(k))] for k, r in enumerate(probs)}
    p = prediction(probs, "3")
    plan = search_plan(probs, lambda r: goals[r], (0.0, 0.0), 3, 0.05, "3", rest=True)
    m = dp.destination_msg(4, p, dp.Destination().header, plan[0][1], plan)
    assert len(m.points) == len(m.regions) == 5
    got = fo.plan_of(m, FollowConfig(search_regions=3, search_min_probability=0.05))
    assert [r for r, _ in got] == ["3", "7", "9", "5", "C"] and got.likely == 3
    assert got[3] == ("5", goals["5"][0])
    assert fo.plan_of(m, FollowConfig(search_regions=3, search_min_probability=0.2)).likely == 2
    empty = dp.Destination()
    empty.best, empty.best_point.x, empty.best_point.y = "3", 1.0, 2.0
    assert fo.plan_of(empty, FollowConfig()) == [("3", (1.0, 2.0))]
