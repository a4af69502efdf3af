"""A default chosen by leaving each world out on the people study (bench/choose_by_crowd.py):
the kept runs it reads back and the folds it reports, by hand."""
from __future__ import annotations

import argparse
import os
import sys

import pytest

from bullet_floor_sim.errors import ConfigError

BENCH = os.path.join(os.path.dirname(os.path.abspath(__file__)), "..", "..", "bench")
sys.path.insert(0, BENCH)

import choose_by_crowd  # noqa: E402


def _args(**kw):
    base = dict(param="prediction.handover_time", people=20, seconds=600.0, seed=13,
                score="acc50")
    base.update(kw)
    return argparse.Namespace(**base)


def _line(world, value, acc50, param="prediction.handover_time", people=20, seed=13):
    return ("CROWD world=%s param=%s value=%s people=%d seconds=600 seed=%d legs=100 "
            "acc50=%.4f acc50_seen=0.5 acc50_gt=0.9 seen50=0.2 mota=0.9 switches=3 wall=60\n"
            % (world, param, value, people, seed, acc50))


def test_kept_reads_only_this_params_runs_keyed_by_value(tmp_path):
    log = tmp_path / "crowd.log"
    log.write_text(_line("office", "4", 0.10) + _line("office", "10", 0.12)
                   + _line("office", "10", 0.50, param="prediction.dwell_time")
                   + _line("office", "10", 0.60, people=5) + _line("office", "10", 0.70, seed=14)
                   + "CROWD world=broken\nnot a line\n")
    runs = choose_by_crowd.kept(str(log), _args())
    assert sorted(runs) == [("office", "10"), ("office", "4")]
    assert runs["office", "10"]["acc50"] == pytest.approx(0.12)


def test_report_leaves_each_world_out_by_hand(tmp_path, capsys):
    # 10 s leads on a and b by 0.02 each and trails on c by 0.03: left out a, the others
    # sum -0.01 for 10 s, so a's fold keeps 4 (0.10 held out); b's likewise (0.20); left out
    # c, 10 s leads by 0.04 and scores 0.27 on c
    acc = {("a", "4"): 0.10, ("a", "10"): 0.12, ("b", "4"): 0.20, ("b", "10"): 0.22,
           ("c", "4"): 0.30, ("c", "10"): 0.27}
    log = tmp_path / "crowd.log"
    log.write_text("".join(_line(w, v, x) for (w, v), x in acc.items()))
    runs = choose_by_crowd.kept(str(log), _args())
    choose_by_crowd.report(["a", "b", "c"], ["4", "10"], runs, _args())
    out = capsys.readouterr().out
    rows = {r.split(" | ")[0][2:]: r for r in out.splitlines() if r.startswith("| ")}
    assert rows["a"].split(" | ")[-2:] == ["4", "10.0 |"]
    assert rows["b"].split(" | ")[-2:] == ["4", "20.0 |"]
    assert rows["c"].split(" | ")[-2:] == ["10", "27.0 |"]
    held = (0.10 + 0.20 + 0.27) / 3
    assert 'FOLDS score=acc50 held_out=%.4f default=%.4f picks="4: 2, 10: 1"' % (
        held, 0.2) in out


def test_a_field_that_is_not_one_is_named():
    with pytest.raises(ConfigError, match="prediction.handover_tim"):
        choose_by_crowd.crowd_line("office", "prediction.handover_tim", "10", _args())


def test_a_world_without_a_score_stops_the_report_naming_it(tmp_path):
    log = tmp_path / "crowd.log"
    log.write_text(_line("a", "4", 0.1) + _line("a", "10", 0.2) + _line("b", "4", 0.1)
                   + _line("b", "10", 0.2).replace("acc50=0.2000", "acc50=nan"))
    runs = choose_by_crowd.kept(str(log), _args())
    with pytest.raises(SystemExit, match="no acc50 for b prediction.handover_time=10"):
        choose_by_crowd.report(["a", "b"], ["4", "10"], runs, _args())
