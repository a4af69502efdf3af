"""CLEAR MOT counts on hand-made frames (people/evaluation/mot.py)."""
from __future__ import annotations

import math

import pytest

from bullet_floor_sim.people.evaluation.mot import ClearMot


def test_a_clean_run_scores_one():
    m = ClearMot(threshold=0.5)
    for k in range(5):
        m.update({"a": (k, 0.0), "b": (k, 2.0)}, {7: (k + 0.1, 0.0), 8: (k, 2.2)})
    assert (m.truths, m.misses, m.false_positives, m.switches, m.matches) == (10, 0, 0, 0, 10)
    assert m.mota == 1.0
    assert m.motp == pytest.approx((5 * 0.1 + 5 * 0.2) / 10)


def test_misses_false_positives_and_a_switch_by_hand():
    m = ClearMot(threshold=0.5)
    m.update({"a": (0, 0), "b": (5, 0)}, {1: (0.1, 0), 2: (5.1, 0)})       # 2 matches
    m.update({"a": (0, 0), "b": (5, 0)}, {1: (0.1, 0), 3: (9, 9)})         # b missed, 3 FP
    m.update({"a": (0, 0), "b": (5, 0)}, {1: (0.1, 0), 4: (5.0, 0.2)})     # b now on 4: switch
    m.update({"a": (0, 0)}, {1: (0.1, 0), 4: (5.0, 0.1)}, dont_care=[(5, 0)])   # b out of view
    assert (m.truths, m.matches, m.misses, m.false_positives, m.switches) == (7, 6, 1, 1, 1)
    assert m.mota == pytest.approx(1 - 3 / 7)
    assert m.per_person["b"] == {"in_view": 3, "matched": 2, "switches": 1}


def test_a_kept_match_wins_over_a_nearer_track():
    """Step 1: a person keeps last frame's track while it stays within the threshold, even
    when another track comes nearer (no switch); the Hungarian step alone would swap."""
    m = ClearMot(threshold=0.5)
    m.update({"a": (0, 0)}, {1: (0.3, 0)})
    pairs = m.update({"a": (0, 0)}, {1: (0.4, 0), 2: (0.05, 0)})
    assert pairs == {"a": 1}
    assert (m.switches, m.false_positives) == (0, 1)


def test_hungarian_pairs_the_rest_by_distance():
    m = ClearMot(threshold=1.0)
    pairs = m.update({"a": (0, 0), "b": (0.6, 0)}, {1: (0.5, 0), 2: (-0.1, 0)})
    # greedy nearest-first would give a -> 2 (0.1), b -> 1 (0.1): also the optimum here
    assert pairs == {"a": 2, "b": 1}
    m = ClearMot(threshold=1.0)
    pairs = m.update({"a": (0, 0), "b": (1.0, 0)}, {1: (0.45, 0), 2: (1.5, 0)})
    assert pairs == {"a": 1, "b": 2}     # 0.45 + 0.5 beats b -> 1 (0.55) leaving a alone


def test_nothing_in_view():
    m = ClearMot()
    m.update({}, {})
    assert math.isnan(m.mota) and math.isnan(m.motp)
