"""The prediction study: scoring by hand, and the evaluate_prediction CLI on a short real run."""
import math
import os
import re

import pytest

from bullet_floor_sim.people import evaluation as ev
from bullet_floor_sim.people.prediction import Prediction
from bullet_floor_sim.people.walker import Leg
from bullet_floor_sim.ros import evaluate_prediction


class FakeModel:
    """Only the two baselines are asked of the model when scoring: fixed answers."""

    def markov_baseline(self, r0):
        return {"A": 0.5, "B": 0.3, "C": 0.2}

    def heading_baseline(self, r0, xy, velocity):
        return {"A": 0.1, "B": 0.8, "C": 0.1} if velocity[0] > 0 else {"A": 0.8, "B": 0.1,
                                                                      "C": 0.1}


def record(t, probs, v=(1.0, 0.0)):
    best = max(probs, key=probs.get)
    p = Prediction(t=t, leg_start=10.0, start_region="A", start_xy=(0.0, 0.0),
                   probabilities=probs, best=best, best_probability=probs[best], observed=1.0)
    return ev.Record(t, p, (0.0, 0.0), v)


def test_scoring_picks_the_latest_prediction_at_each_fraction_and_counts_gaps_as_misses():
    leg = Leg(1, "A", "B", (5.0, 0.0, 0.0), started=10.0, ended=20.0, outcome="succeeded")
    uniform = {"A": 1 / 3, "B": 1 / 3, "C": 1 / 3}
    # 10 % (t=11) and 25 % (t=12.5): nothing yet; then a wrong guess at 13, a right one at 16
    recs = [record(13.0, {"A": 0.6, "B": 0.3, "C": 0.1}),
            record(16.0, {"A": 0.2, "B": 0.7, "C": 0.1}, v=(-1.0, 0.0))]
    s = ev.score_leg(leg, recs, recs[:1], FakeModel(), uniform)
    gt = s.scores["ground_truth"]
    # fractions 10 25 50 75 90 -> t = 11, 12.5, 15, 17.5, 19
    assert [c for c, _, _ in gt["predictor"]] == [False, False, False, True, True]
    assert [h for _, _, h in gt["predictor"]] == [False, False, True, True, True]
    lls = [ll for _, ll, _ in gt["predictor"]]
    assert lls[0] == pytest.approx(math.log(3)) and lls[1] == pytest.approx(math.log(3))
    assert lls[2] == pytest.approx(-math.log(0.3))
    assert lls[3] == pytest.approx(-math.log(0.7))
    # the baselines answer from the same record: markov never says B, heading does while v > 0
    assert [c for c, _, _ in gt["markov"]] == [False] * 5
    assert [c for c, _, _ in gt["heading"]] == [False, False, True, False, False]
    assert gt["heading"][2][1] == pytest.approx(-math.log(0.8))
    # the tracker pipeline only ever had the first, wrong record
    assert [c for c, _, _ in s.scores["tracker"]["predictor"]] == [False] * 5


def test_a_prediction_of_the_coming_leg_made_while_the_walker_stood_is_carried_into_it():
    def rec(t, under_way):
        r = record(t, {"A": 0.2, "B": 0.5, "C": 0.3})
        r.prediction.under_way = under_way
        return r
    ended = 5.0   # the previous leg ended then; the walker stood until the next started
    assert ev.carried([], ended) == []
    # the last record is of the next leg, made during the stand: carried, alone
    recs = [rec(3.0, True), rec(6.0, False), rec(8.0, False)]
    assert ev.carried(recs, ended) == recs[2:]
    # made before the stand (the walker lost during the last leg): not carried
    assert ev.carried([rec(3.0, False)], ended) == []
    # made at the moment the last leg ended: carried (at or after it)
    at_end = [rec(ended, False)]
    assert ev.carried(at_end, ended) == at_end
    # of a leg under way (the predictor had not yet seen it stand dwell_time): not carried
    assert ev.carried([rec(6.0, False), rec(7.0, True)], ended) == []


def test_a_carried_prediction_scores_every_fraction_until_a_newer_one():
    leg = Leg(1, "A", "B", (5.0, 0.0, 0.0), started=10.0, ended=20.0, outcome="succeeded")
    uniform = {"A": 1 / 3, "B": 1 / 3, "C": 1 / 3}
    before = record(8.0, {"A": 0.2, "B": 0.5, "C": 0.3})   # the next leg's, at t = 8
    before.prediction.under_way = False
    later = record(18.0, {"A": 0.1, "B": 0.1, "C": 0.8})
    trk = ev.carried([before], 7.0) + [later]
    s = ev.score_leg(leg, [later], trk, FakeModel(), uniform)
    # fractions 10 25 50 75 -> t = 11, 12.5, 15, 17.5: the carried record; 90 % (t = 19): later
    assert [c for c, _, _ in s.scores["tracker"]["predictor"]] == [True] * 4 + [False]
    lls = [ll for _, ll, _ in s.scores["tracker"]["predictor"]]
    assert lls[:4] == [pytest.approx(-math.log(0.5))] * 4
    assert lls[4] == pytest.approx(-math.log(0.1))
    # the ground truth's only record is the later one: no prediction until 90 %
    assert [h for _, _, h in s.scores["ground_truth"]["predictor"]] == [False] * 4 + [True]


def test_result_table_averages_over_legs():
    legs = []
    for k, (correct, to) in enumerate(((True, "B"), (False, "A"), (True, "A"), (True, "B"))):
        s = ev.LegScore(k + 1, "A", to, 10.0)
        row = [(correct, 0.5 if correct else 2.0, True)] * len(ev.FRACTIONS)
        s.scores = {p: {m: row for m in ev.METHODS} for p in ev.PIPELINES}
        legs.append(s)
    r = ev.EvalResult(config=ev.EvalConfig(legs=4), legs=legs, failed_legs=0, sim_time=1.0,
                      wall_time=1.0, ticks=10, visible_ticks=8, recalled_ticks=6,
                      tracked_ticks=5, false_track_ticks=0, id_switches=0,
                      mean_track_error=0.1, follow_modes={})
    acc, ll, n = r.table()["tracker"]["predictor"][2]
    assert (acc, n) == (0.75, 4) and ll == pytest.approx((3 * 0.5 + 2.0) / 4)
    assert r.recall == 0.75 and r.tracked_share == 0.5
    # by kind: legs 1 and 4 go A -> B (both right), legs 2 and 3 stay in A (one right)
    assert [s.number for s in r.legs_of("change")] == [1, 4]
    assert r.table("change")["tracker"]["markov"][0][:2] == (1.0, 0.5)
    acc, ll, n = r.table("stay")["ground_truth"]["predictor"][4]
    assert (acc, n) == (0.5, 2) and ll == pytest.approx((0.5 + 2.0) / 2)
    with pytest.raises(ev.EvaluationError, match="leg kind must be one of all"):
        r.legs_of("moving")
    text = ev.format_table(r)
    assert "-- legs to another region (2 legs)" in text
    assert "-- legs within the start region (2 legs)" in text


def test_cli_short_run_prints_the_table_and_writes_the_plot(tmp_path, capsys):
    png = str(tmp_path / "acc.png")
    assert evaluate_prediction.main(["--legs", "3", "--seed", "2", "--plot", png,
                                     "--quiet"]) == 0
    out = capsys.readouterr().out
    assert "== tracker tracks (3 legs" in out and "== ground-truth tracks (3 legs" in out
    for m in ("predictor", "markov", "heading"):   # all, change, stay for both pipelines
        assert len(re.findall(r"^%s\s+(\d|nan)" % m, out, re.M)) == 6
    line = [x for x in out.splitlines() if x.startswith("EVAL ")][-1]
    vals = dict(kv.split("=") for kv in line.split()[1:])
    assert int(vals["legs"]) == 3
    assert 0 <= int(vals["change_legs"]) <= 3
    for k in ("acc50", "acc50_gt", "markov50", "heading50", "recall", "tracked"):
        assert 0.0 <= float(vals[k]) <= 1.0, line
    # the observer does see and track the walker on this run (it starts 9 m away, facing it)
    assert float(vals["recall"]) > 0.8, line
    # the real-time factor is of the ticks: the setup's wall seconds are said apart
    sim, wall, setup, rtf = (float(v) for v in re.search(
        r"(\d+) s sim in (\d+) s wall \((\d+) s of it setup; ([\d.]+)x real time after it\)",
        out).groups())
    assert 0 < setup < wall and rtf >= 0.95 * sim / (wall - setup + 1.0)   # (printed rounded)
    with open(png, "rb") as f:
        assert f.read(8) == b"\x89PNG\r\n\x1a\n"
    assert os.path.getsize(png) > 10000


def test_cli_bad_arguments_are_one_line(capsys):
    assert evaluate_prediction.main(["--legs", "0"]) == 2
    err = capsys.readouterr().err.strip()
    assert err == "evaluate_prediction: --legs must be >= 1, got 0"
    assert evaluate_prediction.main(["--world", "/nonexistent/world.yaml", "--legs", "1",
                                     "--quiet"]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and "/nonexistent/world.yaml" in err[0]


def test_rescore_with_the_runs_own_parameters_gives_the_live_scores():
    from bullet_floor_sim.people.prediction import PredictionConfig

    r = ev.run(ev.EvalConfig(legs=3, seed=2, world="office"))
    model = ev.world_model("office", PredictionConfig())
    again = ev.rescore(r, model)
    assert len(again.legs) == len(r.legs) == 3
    moments = 0
    for a, b in zip(r.legs, again.legs):
        for p in ev.PIPELINES:
            for m in ev.METHODS:
                assert [c for c, _, _ in a.scores[p][m]] == [c for c, _, _ in b.scores[p][m]]
                assert [ll for _, ll, _ in a.scores[p][m]] == pytest.approx(
                    [ll for _, ll, _ in b.scores[p][m]], abs=1e-9)
            moments += sum(1 for x in a.moments[p] if x is not None)
    assert moments >= 20   # most of the 3 x 2 x 5 moments had a prediction
    # with another beta, each moment gets that model's posterior of (r0, S, Q)
    model.config.beta = 8.0
    other = ev.rescore(r, model)
    leg = other.legs[0]
    m = next(x for x in leg.moments["ground_truth"][2:] if x is not None)
    k = leg.moments["ground_truth"].index(m)
    probs = model.posterior(m[0], m[1:3], m[3:5])
    assert other.legs[0].scores["ground_truth"]["predictor"][k][1] == pytest.approx(
        -math.log(max(probs[leg.target_region], 1e-6)))


def test_cli_people_run_scores_every_person(tmp_path, capsys):
    png = str(tmp_path / "people.png")
    assert evaluate_prediction.main(["--people", "3", "--seconds", "90", "--seed", "2",
                                     "--quiet", "--plot", png]) == 0
    out = capsys.readouterr().out
    with open(png, "rb") as f:
        assert f.read(8) == b"\x89PNG\r\n\x1a\n"
    for name in ("person_1 *", "person_2", "person_3", "all"):
        assert re.search(r"^%s\s+\d+\s+\d+" % re.escape(name), out, re.M), out
    line = [x for x in out.splitlines() if x.startswith("EVAL ")][-1]
    vals = dict(kv.split("=") for kv in line.split()[1:])
    assert int(vals["people"]) == 3 and int(vals["legs"]) >= 3, line
    for k in ("acc50", "acc50_gt", "seen50"):
        assert 0.0 <= float(vals[k]) <= 1.0, line
    assert 0.5 < float(vals["mota"]) <= 1.0, line     # the observer does track people
    assert 0.0 < float(vals["motp"]) < 0.5, line       # within the match distance
    assert evaluate_prediction.main(["--people", "2", "--chosen", "3"]) == 2
    assert "chosen person 2 is not one of the 2" in capsys.readouterr().err


def test_people_run_is_deterministic_for_a_seed():
    from bullet_floor_sim.people.evaluation.crowd_run import CrowdEvalConfig, run_crowd

    # 90 s: the observer has people in view and tracks some (40 s held one frame with a
    # person in view, and none once the observer first looked round for its target)
    runs = [run_crowd(CrowdEvalConfig(people=2, sim_time=90.0, seed=5)) for _ in range(2)]
    a, b = (r.mot for r in runs)
    assert (a.truths, a.matches, a.misses, a.false_positives, a.switches) == \
        (b.truths, b.matches, b.misses, b.false_positives, b.switches)
    assert a.truths > 0 and a.matches > 0
    assert [len(v) for v in runs[0].legs.values()] == [len(v) for v in runs[1].legs.values()]


def test_people_run_predicts_each_leg_from_where_it_started():
    """The ground-truth predictor of each person sees the dwells too, so it starts each leg
    afresh: its prediction at half the leg is made from the leg's own start region."""
    from bullet_floor_sim.people.evaluation.crowd_run import CrowdEvalConfig, run_crowd
    from bullet_floor_sim.people.evaluation.result import FRACTIONS

    r = run_crowd(CrowdEvalConfig(people=2, sim_time=120.0, seed=3))
    k = FRACTIONS.index(0.5)
    legs = [leg for v in r.legs.values() for leg in v]
    assert len(legs) >= 8
    assert len({leg.start_region for leg in legs}) >= 3      # the people went places
    for leg in legs:
        assert leg.moments["ground_truth"][k] is not None
        assert leg.moments["ground_truth"][k][0] == leg.start_region


def test_legs_shorter_than_min_leg_path_are_counted_not_scored():
    """Every leg under a 1 km planned way: none is scored or given up, each is counted as
    too short (a stay of 0 s would be a miss for every method at every fraction)."""
    r = ev.run(ev.EvalConfig(legs=2, seed=2, min_leg_path=1000.0, max_sim_time=90.0))
    assert r.legs == [] and r.short_legs >= 2 and r.failed_legs == 0
    assert "0 legs scored, 0 failed, %d too short to score" % r.short_legs in ev.format_table(r)
    with pytest.raises(ev.EvaluationError, match="min_leg_path must be a finite number >= 0, got -1"):
        ev.run(ev.EvalConfig(legs=2, min_leg_path=-1.0))
