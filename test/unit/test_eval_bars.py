"""Each world's runs against issue 33's bars (bench/eval_bars.py), on EVAL lines written
here with values at and just past each bar."""
from __future__ import annotations

import os
import sys

BENCH = os.path.join(os.path.dirname(os.path.abspath(__file__)), "..", "..", "bench")
sys.path.insert(0, BENCH)

import eval_bars  # noqa: E402

AT_THE_BARS = dict(given_up=0.02, tracked=0.70, trk50=0.70, gt50=0.80, margin=0.01,
                   ll_margin=0.01)


def line(world: str, seed: int, prefix: str = "", **changes) -> str:
    fields = dict(AT_THE_BARS, **changes)
    return prefix + "EVAL world=%s seed=%d legs=100 %s modes=follow:90/search:10 rtf=30.0x" % (
        world, seed, " ".join("%s=%.3f" % kv for kv in fields.items()))


def test_a_run_at_every_bar_meets_them_and_one_just_past_misses_each(tmp_path):
    assert eval_bars.misses(eval_bars.parse_eval_line(line("a", 1), ("world", "seed"))) == []
    past = dict(given_up=0.021, tracked=0.699, trk50=0.699, gt50=0.799, margin=0.0,
                ll_margin=0.0)
    for field, value in past.items():
        run = eval_bars.parse_eval_line(line("a", 1, **{field: value}), ("world", "seed"))
        assert len(eval_bars.misses(run)) == 1, field
    run = eval_bars.parse_eval_line(line("a", 1), ("world", "seed"))
    del run["ll_margin"]
    assert eval_bars.misses(run) == ["ll margin <= 0"]   # not shown met: a miss


def test_the_table_keeps_each_world_seeds_last_line_and_counts_the_misses(tmp_path):
    log = tmp_path / "default.log"
    log.write_text("\n".join([
        line("hall", 13, tracked=0.5),                  # replaced by the next line
        line("hall", 13, prefix="  done: "),
        "  hall: leg 3: room 1 -> room 2 in 9.0 s",      # not an EVAL line
        line("hall", 14, tracked=0.68, margin=-0.04),
        line("lab", 13, gt50=0.95)]) + "\n")
    runs = eval_bars.read_logs([str(log)])
    assert sorted(runs) == [("hall", 13), ("hall", 14), ("lab", 13)]
    rows = eval_bars.table(runs)
    hall = next(r for r in rows if r.startswith("| hall "))
    assert "| 70.0 / 68.0 |" in hall and "| -0.04 |" in hall
    assert "seed 14: tracked < 70 %, margin <= 0" in hall
    assert next(r for r in rows if r.startswith("| lab ")).endswith("| none |")
    assert rows[-1] == "BARS runs=3 worlds=2 under=1 hall:14"
