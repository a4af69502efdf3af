"""A default chosen by leaving each world out (bench/choose_by_folds.py) and the study's
``--set`` changes it runs with (bench/eval_worlds.py, overrides.with_changes)."""
from __future__ import annotations

import contextlib
import json
import os
import shutil
import sys

import numpy as np
import pytest
from PIL import Image

# the package first, from the workspace (with its messages), before the bench scripts put
# src/ first on the path
from bullet_floor_sim.errors import BulletFloorSimError, ConfigError
from bullet_floor_sim.overrides import with_changes
from bullet_floor_sim.people.evaluation import EvalConfig
from bullet_floor_sim.people.follow_config import FollowConfig, FollowError
from bullet_floor_sim.people.tracking import TrackerConfig

@contextlib.contextmanager
def scenario(cfg):
    """The study's scenario of ``cfg`` on a fresh world (as the study makes it), closed
    afterwards."""
    from bullet_floor_sim.people.evaluation.scenario import _Scenario, study_world

    world = study_world(cfg, 1)
    try:
        yield _Scenario(cfg, world, lambda _s: None, 0.0)
    finally:
        world.close()


BENCH = os.path.join(os.path.dirname(os.path.abspath(__file__)), "..", "..", "bench")
sys.path.insert(0, BENCH)

import choose_by_folds  # noqa: E402
import choose_prediction  # noqa: E402
import eval_worlds  # noqa: E402


def test_each_fold_keeps_the_best_value_on_the_other_worlds():
    # a: 0.9 + 0.5 + 0.5 = 1.9 in all; b: 0.6 + 0.7 + 0.7 = 2.0
    scores = {"a": {"w1": 0.9, "w2": 0.5, "w3": 0.5}, "b": {"w1": 0.6, "w2": 0.7, "w3": 0.7}}
    picks = choose_by_folds.leave_one_out(scores, ["w1", "w2", "w3"])
    # w1 out: a 1.0, b 1.4 -> b; w2 out: a 1.4, b 1.3 -> a; w3 out: the same -> a
    assert picks == {"w1": "b", "w2": "a", "w3": "a"}


def test_a_tie_goes_to_the_first_value():
    scores = {"default": {"w1": 0.5, "w2": 0.8}, "other": {"w1": 0.8, "w2": 0.5}}
    # w1 out: w2 decides (default 0.8); w2 out: w1 decides (other 0.8)
    assert choose_by_folds.leave_one_out(scores, ["w1", "w2"]) == {"w1": "default", "w2": "other"}
    scores = {"default": {"w1": 0.5, "w2": 0.5}, "other": {"w1": 0.5, "w2": 0.5}}
    assert set(choose_by_folds.leave_one_out(scores, ["w1", "w2"]).values()) == {"default"}


def test_the_table_pools_seeds_and_scores_each_pick_held_out():
    def line(world, seed, trk50, tracked, given_up=0.0):
        return choose_by_folds.parse_eval_line(
            "done: EVAL world=%s seed=%d legs=100 given_up=%.3f trk50=%.3f tracked=%.3f "
            "modes=follow:90/search:10 rtf=50.1 setup=12s legs_asked=100"
            % (world, seed, given_up, trk50, tracked))
    runs = {"1.0 (default)": {("w1", 1): line("w1", 1, 0.8, 0.9), ("w1", 2): line("w1", 2, 0.6, 0.7),
                              ("w2", 1): line("w2", 1, 0.9, 0.8), ("w2", 2): line("w2", 2, 0.9, 0.8)},
            "2": {("w1", 1): line("w1", 1, 0.9, 0.9), ("w1", 2): line("w1", 2, 0.9, 0.9),
                  ("w2", 1): line("w2", 1, 0.5, 0.6, 0.05), ("w2", 2): line("w2", 2, 0.7, 0.6)}}
    out = choose_by_folds.table(runs, list(runs), ["w1", "w2"], [1, 2], "trk50")
    # pooled trk50: default w1 0.7, w2 0.9; "2" w1 0.9, w2 0.6. w1 out: default (0.9 > 0.6),
    # held out 0.7; w2 out: "2" (0.9 > 0.7), held out 0.6; mean held out 0.65
    assert "| w1 | 70.0 | 90.0 | 80.0 | 90.0 | 1.0 (default) | 70.0 |" in out
    assert "| w2 | 90.0 | 60.0 | 80.0 | 60.0 | 2 | 60.0 |" in out
    assert out[-1] == 'FOLDS score=trk50 held_out=0.6500 default=0.8000 picks="1.0 (default): 1, 2: 1"'
    assert out[-2] == "given up, worst run: 1.0 (default) none, 2 5.0 % (w2 seed 1)"


def test_a_value_that_gives_up_legs_beyond_the_bar_where_a_fold_learns_is_not_its_pick():
    scores = {"default": {"w1": 0.5, "w2": 0.5, "w3": 0.5},
              "bold": {"w1": 0.9, "w2": 0.9, "w3": 0.9}, "fair": {"w1": 0.6, "w2": 0.6, "w3": 0.6}}
    lost = {"default": {"w1": 0.0, "w2": 0.05, "w3": 0.0},      # the default may always be
            "bold": {"w1": 0.0, "w2": 0.0, "w3": 0.03}, "fair": {"w1": 0.0, "w2": 0.02, "w3": 0.0}}
    picks = choose_by_folds.leave_one_out(scores, ["w1", "w2", "w3"], lost, 0.02)
    # "bold" lost 3 % on w3: only the fold that leaves w3 out may keep it; 2 % is within the bar
    assert picks == {"w1": "fair", "w2": "fair", "w3": "bold"}
    assert choose_by_folds.leave_one_out(scores, ["w1", "w2", "w3"], lost, 0.0) == {
        "w1": "default", "w2": "fair", "w3": "bold"}   # w2 out: fair lost nothing on w1, w3
    # w1 out at 0: only the default, over the bar itself on w2, is left


def test_the_bar_takes_a_worlds_worst_seed_not_its_mean():
    def line(world, seed, given_up):
        return choose_by_folds.parse_eval_line(
            "EVAL world=%s seed=%d legs=100 given_up=%.3f trk50=%.3f tracked=0.8 "
            "modes=follow:90/search:10 legs_asked=100" % (world, seed, given_up, 0.7 + given_up))
    runs = {"2.0 (default)": {(w, s): line(w, s, 0.0) for w in ("w1", "w2") for s in (1, 2)},
            "1": {("w1", 1): line("w1", 1, 0.03), ("w1", 2): line("w1", 2, 0.0),
                  ("w2", 1): line("w2", 1, 0.0), ("w2", 2): line("w2", 2, 0.01)}}
    out = choose_by_folds.table(runs, list(runs), ["w1", "w2"], [1, 2], "trk50", 0.02)
    # w1's mean loss is 1.5 %, its worst seed 3 %: the fold that learns from w1 (w2 out) may
    # not keep "1"; the fold that learns from w2 (worst 1 %) keeps it, for its higher trk50
    assert "| w1 | 70.0 | 71.5 | 80.0 | 80.0 | 1 | 71.5 |" in out
    assert "| w2 | 70.0 | 70.5 | 80.0 | 80.0 | 2.0 (default) | 70.0 |" in out


def test_the_table_says_which_values_the_bar_kept_out_of_how_many_folds():
    def line(world, trk50, given_up):
        return choose_by_folds.parse_eval_line(
            "EVAL world=%s seed=1 legs=100 given_up=%.3f trk50=%.3f tracked=0.8 "
            "modes=follow:90/search:10 legs_asked=100" % (world, given_up, trk50))
    runs = {"2.0 (default)": {(w, 1): line(w, 0.7, 0.0) for w in ("w1", "w2", "w3")},
            "1": {("w1", 1): line("w1", 0.9, 0.03), ("w2", 1): line("w2", 0.9, 0.0),
                  ("w3", 1): line("w3", 0.9, 0.0)}}
    out = choose_by_folds.table(runs, list(runs), ["w1", "w2", "w3"], [1], "trk50", 0.02)
    assert "| w1 | 70.0 | 90.0 | 80.0 | 80.0 | 1 | 90.0 |" in out
    assert "| w2 | 70.0 | 90.0 | 80.0 | 80.0 | 2.0 (default) | 70.0 |" in out
    assert out[-2] == ("not a fold's pick for giving up more than 2 % of the legs on a world "
                       "it learns from: 1 in 2 fold(s)")


def test_with_bars_a_value_under_a_bar_where_a_fold_learns_is_not_its_pick():
    def line(world, trk50, gt50):
        return choose_by_folds.parse_eval_line(
            "EVAL world=%s seed=1 legs=100 given_up=0.000 trk50=%.3f gt50=%.3f tracked=0.9 "
            "margin=0.1 ll_margin=0.2 modes=follow:90/search:10 legs_asked=100"
            % (world, trk50, gt50))
    runs = {"1.5 (default)": {(w, 1): line(w, 0.8, 0.85) for w in ("w1", "w2", "w3")},
            "1.0": {("w1", 1): line("w1", 0.9, 0.78), ("w2", 1): line("w2", 0.85, 0.85),
                    ("w3", 1): line("w3", 0.82, 0.85)}}
    plain = choose_by_folds.table(runs, list(runs), ["w1", "w2", "w3"], [1], "trk50", 0.02)
    assert plain[-1].endswith('picks="1.0: 3"')
    out = choose_by_folds.table(runs, list(runs), ["w1", "w2", "w3"], [1], "trk50", 0.02,
                                bars=True)
    # gt50 78 % on w1 is under the 80 % bar: the two folds that learn from w1 keep the
    # default; the fold that leaves w1 out still picks 1.0 and scores it there (90 %)
    assert "| w1 | 80.0 | 90.0 | 90.0 | 90.0 | 1.0 | 90.0 |" in out
    assert "| w2 | 80.0 | 85.0 | 90.0 | 90.0 | 1.5 (default) | 80.0 |" in out
    assert "1.0 is under a bar on w1 (gt50 < 80 %): not the pick of the 2 fold(s) that learn " \
        "from it" in out
    assert out[-1] == ('FOLDS score=trk50 held_out=%.4f default=0.8000 picks="1.5 (default): '
                       '2, 1.0: 1"' % ((0.9 + 0.8 + 0.8) / 3))


def test_with_bars_legs_given_up_stay_max_given_ups_to_judge():
    def line(world, given_up):
        return choose_by_folds.parse_eval_line(
            "EVAL world=%s seed=1 legs=100 given_up=%.3f trk50=0.9 gt50=0.9 tracked=0.9 "
            "margin=0.1 ll_margin=0.2 modes=follow:90/search:10 legs_asked=100"
            % (world, given_up))
    runs = {"1.5 (default)": {(w, 1): line(w, 0.0) for w in ("w1", "w2")},
            "1.0": {("w1", 1): line("w1", 0.03), ("w2", 1): line("w2", 0.0)}}
    for r in runs["1.5 (default)"].values():
        r["trk50"] = 0.8
    # 3 % given up is within a --max-given-up of 5 %: --bars does not bar it at 2 %
    out = choose_by_folds.table(runs, list(runs), ["w1", "w2"], [1], "trk50", 0.05, bars=True)
    assert out[-1].endswith('picks="1.0: 2"')


def test_runs_kept_on_file_are_read_back_by_world_and_seed(tmp_path):
    path = tmp_path / "default.log"
    path.write_text("== noise\nEVAL world=a seed=3 legs=9 trk50=0.500 legs_asked=10\n"
                    "  done: EVAL world=a seed=3 legs=10 trk50=0.700 legs_asked=10\n"
                    "EVAL world=a seed=3 legs=20 trk50=0.900 legs_asked=20\n"
                    "EVAL world=2 seed=1 legs=10 trk50=0.100 legs_asked=10\n"
                    "EVAL world=b seed=1 legs=10 trk50=0.100\n"     # no legs asked: passed over
                    "EVAL world=c seed=1 legs=10 trk5")              # cut short
    runs = choose_by_folds.read_runs(str(path), 10)
    # the last line of 10 legs asked counts; a world's label stays text
    assert sorted(runs) == [("2", 1), ("a", 3)] and runs["a", 3]["trk50"] == 0.7
    assert choose_by_folds.read_runs(str(path), 20)["a", 3]["trk50"] == 0.9


def test_a_value_runs_only_what_is_not_kept(tmp_path):
    path = str(tmp_path / "v.log")
    with open(path, "w") as f:   # another world's run, and a line a cut run left unfinished
        f.write("EVAL world=elsewhere seed=1 legs=2 trk50=0.500 legs_asked=2\nEVAL world=x")
    save = str(tmp_path / "moments")
    runs = choose_by_folds.run_value(path, {}, ["simple"], [1], 2, 1, save)
    assert list(runs) == [("simple", 1)] and runs["simple", 1]["legs"] == 2
    lines = open(path).read().splitlines()
    assert lines[1] == "EVAL world=x" and lines[2].startswith("EVAL world=simple seed=1 legs=2 ")
    # the run done now kept its moments, as eval_worlds.py --save keeps them
    with open(choose_prediction.cache_path(save, "simple", 2, 1)) as f:
        kept = json.load(f)
    assert len(kept["legs"]) == runs["simple", 1]["legs"] == 2
    again = choose_by_folds.run_value(path, {}, ["simple"], [1], 2, 1)   # nothing to run
    assert again == runs and open(path).read().splitlines() == lines


def test_candidates_drop_repeats_and_the_default():
    assert choose_by_folds.candidates("follow.pass_detour", ["1", "2", "1.0", "3"], 2.0) == ["1", "3"]
    with pytest.raises(BulletFloorSimError, match="no value to try beside the default 2.0"):
        choose_by_folds.candidates("follow.pass_detour", ["2", "2.0"], 2.0)
    assert choose_by_folds.shipped_default("follow.pass_detour") == FollowConfig().pass_detour


def test_changes_together_are_one_candidate_beside_the_shipped_defaults():
    tries = choose_by_folds.together(["drive.lookahead=0.8", "follow.pass_detour = 3"])
    assert [label for label, _, _ in tries] == ["default", "together"]
    assert tries[0][1] == {} and tries[0][2] == "default"
    # both changes at once, and a log of their own whatever order they are given in
    assert tries[1][1] == {"drive": {"lookahead": "0.8"}, "follow": {"pass_detour": "3"}}
    assert tries[1][2] == "together_drive.lookahead=0.8,follow.pass_detour=3"
    again = choose_by_folds.together(["follow.pass_detour=3", "drive.lookahead=0.8"])
    assert again[1][2] == tries[1][2]


def test_a_change_together_that_is_the_shipped_default_is_refused():
    default = FollowConfig().pass_detour
    with pytest.raises(BulletFloorSimError,
                       match="follow.pass_detour is already the shipped default"):
        choose_by_folds.together(["drive.lookahead=0.8", "follow.pass_detour=%r" % default])
    with pytest.raises(BulletFloorSimError, match="no section 'nope'"):
        choose_by_folds.together(["nope.x=1"])


def test_one_field_labels_the_default_and_each_value():
    tries = choose_by_folds.one_field("follow.pass_detour", ["1", "1.0", "3"])
    default = FollowConfig().pass_detour
    assert tries == [("%r (default)" % default, {}, "default"),
                     ("1", {"follow": {"pass_detour": "1"}}, "follow.pass_detour=1"),
                     ("3", {"follow": {"pass_detour": "3"}}, "follow.pass_detour=3")]


def test_a_set_change_reaches_the_config_converted_and_checked():
    sets = eval_worlds.parse_sets(["follow.pass_detour=1", "prediction.beta=5"])
    cfg = eval_worlds.eval_config("office", 3, 4, False, sets)
    assert cfg.follow_config.pass_detour == 1.0 and type(cfg.follow_config.pass_detour) is float
    assert cfg.prediction.beta == 5.0 and cfg.follow_config.trail == FollowConfig().trail
    assert eval_worlds.set_notes(sets) == [
        "follow.pass_detour=1: not the shipped default (2.0)",
        "prediction.beta=5: not the shipped default (3.0)"]


@pytest.mark.parametrize("item, message", [
    ("follow.pass_detour", "expected SECTION.FIELD=VALUE"),
    ("pass_detour=1", "expected SECTION.FIELD=VALUE"),
    ("walker.speed=1", "no section 'walker'"),
    ("follow.speed=1", r"follow.speed: no such parameter \(FollowConfig has: .*pass_detour"),
    ("follow.search_regions=2.5", "follow.search_regions: expected a whole number"),
    ("follow.pass_detour=-1", "follower: pass_detour must be a finite number >= 0"),
    ("follow.trail=1,follow.trail=2", "expected a number")])
def test_a_bad_set_is_one_error_naming_it(item, message):
    with pytest.raises(BulletFloorSimError, match=message):
        eval_worlds.parse_sets([item])


def test_a_field_set_twice_is_refused():
    with pytest.raises(BulletFloorSimError, match="follow.trail is set twice"):
        eval_worlds.parse_sets(["follow.trail=1", "follow.trail=2"])


def test_the_observer_and_the_predictors_search_plans_get_one_config():
    cfg = eval_worlds.eval_config("simple", 1, 1, False,
                                  eval_worlds.parse_sets(["follow.search_regions=1"]))
    with scenario(cfg) as sc:
        assert sc.predictor.follow.search_regions == 1   # the search plan the predictor makes
        assert sc.follower.behaviour.config is sc.predictor.follow


def test_with_changes_names_the_field_and_keeps_the_original():
    base = FollowConfig()
    with pytest.raises(ConfigError, match="^x.nope: no such parameter"):
        with_changes(base, {"nope": 1}, "x.")
    with pytest.raises(FollowError):
        with_changes(base, {"distance": "0"})
    assert with_changes(base, {"distance": "2.5"}).distance == 2.5 and base.distance == 1.5


def test_the_study_runs_with_the_changed_observer():
    # an observer that keeps 3 m off instead of 1.5 m sees the walker otherwise
    base = eval_worlds.run_tasks([("simple", 2)], 3)[0]
    far = eval_worlds.run_tasks([("simple", 2)], 3, sets={"follow": {"distance": "3.0"}})[0]
    same = eval_worlds.run_tasks([("simple", 2)], 3, sets={"follow": {"distance": "1.5"}})[0]
    drop = ("rtf", "setup")
    assert {k: v for k, v in same.items() if k not in drop} == \
        {k: v for k, v in base.items() if k not in drop}
    assert far["tracked"] != base["tracked"]


def test_the_observers_path_following_is_a_section_of_its_own():
    from bullet_floor_sim.people.evaluation.scenario import OBSERVER_REVERSE, OBSERVER_REVERSE_PATH

    assert choose_by_folds.shipped_default("drive.reverse_within") == OBSERVER_REVERSE
    assert choose_by_folds.shipped_default("drive.reverse_path") == OBSERVER_REVERSE_PATH
    with pytest.raises(BulletFloorSimError, match="reverse_speed must be a finite number > 0"):
        eval_worlds.parse_sets(["drive.reverse_speed=0"])
    assert eval_worlds.parse_sets(["drive.lookahead=0.8"]) == {"drive": {"lookahead": "0.8"}}
    with pytest.raises(BulletFloorSimError, match="reverse_within must be a finite number >= 0"):
        eval_worlds.parse_sets(["drive.reverse_within=-1"])
    cfg = eval_worlds.eval_config("simple", 1, 1, False,
                                  eval_worlds.parse_sets(["drive.reverse_within=1"]))
    with scenario(cfg) as sc:
        assert sc.drive.nav.follower.config.reverse_within == 1.0
        assert sc.nav_walker.follower.config.reverse_within == 0.0   # the walker never backs up
    # the study as shipped, its config built without eval_worlds
    with scenario(EvalConfig(legs=1, seed=1, world="simple")) as sc:
        assert sc.drive.nav.follower.config.reverse_within == OBSERVER_REVERSE
        assert sc.drive.nav.follower.config.reverse_path == OBSERVER_REVERSE_PATH
        assert sc.nav_walker.follower.config.reverse_path == 0.0
        # the observer's less fussy driving; the walker keeps FollowerConfig's defaults
        from bullet_floor_sim.nav.pursuit import FollowerConfig
        from bullet_floor_sim.people.evaluation.scenario import OBSERVER_DRIVE
        for field, value in OBSERVER_DRIVE.items():
            assert getattr(sc.drive.nav.follower.config, field) == value
            assert getattr(sc.nav_walker.follower.config, field) == getattr(FollowerConfig(),
                                                                            field)
            assert value != getattr(FollowerConfig(), field)


def test_the_people_tracker_is_a_section_of_its_own():
    from bullet_floor_sim.people.evaluation.scenario import SCITOS_CENTRE_OFFSET

    # the study's tracker is observer.launch's: the Scitos body's centre offset
    assert choose_by_folds.shipped_default("tracker.centre_offset") == SCITOS_CENTRE_OFFSET
    assert choose_by_folds.shipped_default("tracker.max_age") == TrackerConfig().max_age
    with pytest.raises(BulletFloorSimError, match="max_age must be a finite number > 0"):
        eval_worlds.parse_sets(["tracker.max_age=0"])
    with pytest.raises(BulletFloorSimError, match="tracker.confirm_hits: expected a whole number"):
        eval_worlds.parse_sets(["tracker.confirm_hits=2.5"])
    cfg = eval_worlds.eval_config("simple", 1, 1, False,
                                  eval_worlds.parse_sets(["tracker.max_age=2"]))
    with scenario(cfg) as sc:
        assert sc.tracker.config.max_age == 2.0 and sc.tracker.tracker.config.max_age == 2.0
        assert sc.tracker.config.centre_offset == SCITOS_CENTRE_OFFSET   # the rest as shipped
    # the study as shipped, its config built without eval_worlds
    with scenario(EvalConfig(legs=1, seed=1, world="simple")) as sc:
        assert sc.tracker.config.centre_offset == SCITOS_CENTRE_OFFSET
        assert sc.tracker.config.max_age == TrackerConfig().max_age


def test_the_navigation_is_a_section_of_both_robots_with_their_roles_kept():
    from bullet_floor_sim.nav.navigator import NavigatorConfig

    assert choose_by_folds.shipped_default("nav.deadlock_time") == NavigatorConfig().deadlock_time
    with pytest.raises(BulletFloorSimError, match="deadlock_time must be a finite number > 0"):
        eval_worlds.parse_sets(["nav.deadlock_time=0"])
    with pytest.raises(BulletFloorSimError, match="nav.give_way is a robot's role"):
        eval_worlds.parse_sets(["nav.give_way=false"])
    with pytest.raises(BulletFloorSimError, match="nav.other_radius is None by default"):
        eval_worlds.parse_sets(["nav.other_radius=0.3"])
    assert eval_worlds.parse_sets(["nav.detour=0"]) == {"nav": {"detour": "0"}}
    shipped = NavigatorConfig().deadlock_time
    for item, (walker_dl, observer_dl) in (("nav.deadlock_time=5", (5.0, 5.0)),
                                           (None, (shipped, shipped))):
        sets = eval_worlds.parse_sets([item] if item else [])
        cfg = eval_worlds.eval_config("simple", 1, 1, False, sets) if item else \
            EvalConfig(legs=1, seed=1, world="simple")   # as shipped, without eval_worlds
        with scenario(cfg) as sc:
            walker, observer = sc.nav_walker.config, sc.drive.nav.config
            assert (walker.deadlock_time, observer.deadlock_time) == (walker_dl, observer_dl)
            assert walker.keep_way and not walker.give_way      # the walker keeps its way
            assert observer.give_way and not observer.keep_way  # the observer gives way


def test_the_planner_is_a_section_of_both_robots_and_the_predictors_distances():
    from bullet_floor_sim.nav.grid import PlannerConfig

    shipped = PlannerConfig()
    assert choose_by_folds.shipped_default("planner.inflation_radius") == shipped.inflation_radius
    with pytest.raises(BulletFloorSimError, match="planner: cost_scaling must be a finite number > 0"):
        eval_worlds.parse_sets(["planner.cost_scaling=0"])
    with pytest.raises(BulletFloorSimError, match="planner.robot_radius is the robots' footprint"):
        eval_worlds.parse_sets(["planner.robot_radius=0.3"])
    with pytest.raises(BulletFloorSimError, match="planner.unknown_is_obstacle is set by the world"):
        eval_worlds.parse_sets(["planner.unknown_is_obstacle=false"])
    for cfg, inflation in ((eval_worlds.eval_config("simple", 1, 1, False, eval_worlds.parse_sets(
            ["planner.inflation_radius=0.2"])), 0.2),
                           (EvalConfig(legs=1, seed=1, world="simple"), shipped.inflation_radius)):
        with scenario(cfg) as sc:
            grid = sc.nav_walker.grid   # the walker's, the observer's and the predictor's
            assert sc.drive.nav.grid is grid and sc.model.grid is grid
            assert grid.config.inflation_radius == inflation
            assert grid.config.robot_radius == shipped.robot_radius   # the footprint kept
            # a free cell costs only within the inflation radius of the footprint's edge
            edge = grid.clearance - shipped.robot_radius
            free = np.isfinite(grid.cost)
            assert (grid.cost[free & (edge > inflation + 1e-6)] == 0).all()
            between = free & (edge > 0.25) & (edge < 0.55)   # inflated by 0.6 m, not 0.2 m
            assert between.any() and (grid.cost[between] > 0).all() == (inflation > 0.55)
            assert (grid.cost[between] == 0).all() == (inflation < 0.25)


def _edited_simple(tmp_path, name: str, edit) -> str:
    """A copy of the simple world under ``tmp_path/name`` whose map image ``edit`` changed
    in place (a numpy array of the PGM, row 0 at the top): the world.yaml's path."""
    world = tmp_path / name
    shutil.copytree(os.path.join(BENCH, "..", "worlds", "simple"), world)
    pgm = world / "map.pgm"
    img = np.array(Image.open(pgm))
    edit(img)
    Image.fromarray(img).save(pgm)
    return str(world / "world.yaml")


def test_the_map_handling_is_a_section_of_the_simulator_planner_and_tracker(tmp_path):
    from bullet_floor_sim.sim.solidmap import MapHandling

    assert choose_by_folds.shipped_default("clean.speckle") == MapHandling().speckle
    with pytest.raises(BulletFloorSimError, match="clean.speckle must be a number of square metres"):
        eval_worlds.parse_sets(["clean.speckle=-1"])
    with pytest.raises(BulletFloorSimError, match="clean.unknown is what the map's unknown cells"):
        eval_worlds.parse_sets(["clean.unknown=free"])
    with pytest.raises(BulletFloorSimError, match="clean.gaps: no such parameter"):
        eval_worlds.parse_sets(["clean.gaps=0"])
    # simple's room with a speck: one occupied cell at (1.0, 1.0), the default removes it
    def speck(img):
        row, col = img.shape[0] - 1 - 20, 20        # origin (0, 0), 0.05 m cells
        assert img[row, col] > 250                  # floor, away from the walls
        img[row, col] = 0

    world = _edited_simple(tmp_path, "specked", speck)
    for sets, solid in (({}, False), ({"clean": {"speckle": "0"}}, True)):
        cfg = eval_worlds.eval_config(world, 1, 1, False, sets)
        with scenario(cfg) as sc:
            handling = sc.world.config.map_handling
            assert handling.speckle == (0.0 if solid else MapHandling().speckle)
            assert handling.close_gaps == MapHandling().close_gaps   # the rest as the world's
            speck = sc.world.solid.fmap.world_to_cell(1.025, 1.025)
            assert bool(sc.world.solid.fmap.occupied[speck[1], speck[0]]) is solid
            assert sc.nav_walker.grid.is_free(1.025, 1.025) is not solid   # the planner's too
            # the tracker: a point on the speck is explained by the map only when it is solid
            assert bool(sc.tracker.static.distance(np.array([[1.025, 1.025]]))[0] == 0) is solid


def _walled(tmp_path, door: float) -> str:
    """simple's room split by a wall at x = 2.4 m with a door ``door`` m wide (its robots
    one each side): the world.yaml's path."""
    def wall(img):
        h = img.shape[0]
        img[[r for r in range(h) if not 1.6 <= (h - 1 - r) * 0.05 < 1.6 + door], 48] = 0

    return _edited_simple(tmp_path, "walled", wall)


def test_the_map_check_before_any_run_sees_the_changed_map_handling_and_planner(tmp_path):
    world = _walled(tmp_path, 0.9)   # a 0.9 m door: open to the 0.68 m footprint
    assert eval_worlds.study_check([world], False) == ([], {})
    for sets in ({"clean": {"close_gaps": "1.0"}},      # the door closed as a gap
                 {"planner": {"resolution": "0.5"}}):   # no cell centre in the door is clear
        notes, refused = eval_worlds.study_check([world], False, sets)
        assert list(refused) == [world] and "cannot reach" in refused[world], refused
        # allowed, the study goes on and says so
        notes, refused = eval_worlds.study_check([world], True, sets)
        assert not refused and notes and "going on as allowed" in notes[0]


def test_a_clean_change_is_typed_as_the_map_handlings_field_not_as_the_worlds(tmp_path):
    from bullet_floor_sim.people.evaluation.scenario import study_world_config

    world = _walled(tmp_path, 0.9)
    with open(world, "a") as f:   # a whole number in the world's own clean section
        f.write("clean: {close_gaps: 0, speckle: 0.01}\n")
    cfg = eval_worlds.eval_config(world, 1, 1, False, {"clean": {"close_gaps": "0.1"}})
    handling = study_world_config(cfg).map_handling
    assert handling.close_gaps == 0.1 and handling.speckle == 0.01   # the rest the world's
