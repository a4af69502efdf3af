"""bench/rooms_bench.py's search grid: --grid parsing and the graph/merge split, and the ipa
metric on hand-made labels (no ipa maps needed)."""
import os
import sys

import numpy as np
import pytest

sys.path.insert(0, os.path.join(os.path.dirname(os.path.abspath(__file__)), "..", "..", "bench"))

import rooms_bench  # noqa: E402


def test_parse_grid_reads_fields_and_values():
    got = rooms_bench.parse_grid(["seed_height=0.05,0.1,0.2", "min_room_area=1,4"])
    assert got == {"seed_height": (0.05, 0.1, 0.2), "min_room_area": (1.0, 4.0)}


@pytest.mark.parametrize("item, words", [
    ("seed_height", "NAME=V1"),
    ("height=1,2", "no field 'height'"),
    ("seed_height=a,b", "numbers"),
])
def test_parse_grid_names_the_bad_item(item, words):
    with pytest.raises(ValueError, match=words):
        rooms_bench.parse_grid([item])


def test_parse_grid_refuses_a_field_twice():
    with pytest.raises(ValueError, match="twice"):
        rooms_bench.parse_grid(["wall_length=1", "wall_length=2"])


def test_grid_splits_watershed_fields_from_merge_fields():
    graphs, merges = rooms_bench.grid(False, {"seed_height": (0.05, 0.2), "wall_length": (1.0,),
                                             "min_room_area": (1.0, 2.0, 4.0)})
    assert graphs == [(("seed_height", 0.05), ("wall_length", 1.0)),
                      (("seed_height", 0.2), ("wall_length", 1.0))]
    assert merges == [(("min_room_area", 1.0),), (("min_room_area", 2.0),),
                      (("min_room_area", 4.0),)]


def test_grid_default_is_the_shipped_search_and_fixed_is_the_defaults():
    graphs, merges = rooms_bench.grid(False)
    assert len(graphs) == 2 and len(merges) == 9
    assert rooms_bench.grid(True) == ([()], [()])


def test_precision_recall_on_hand_made_labels():
    # GT: two rooms of 200 cells each; ours: one segment over both. Each room lies wholly in
    # the segment (recall 1.0); the segment's best room is half of it (precision 0.5).
    gt = np.zeros((20, 20), dtype=np.int64)
    gt[:10] = 1
    gt[10:] = 2
    seg = np.ones((20, 20), dtype=np.int64)
    r, p, rw, pw, n = rooms_bench.precision_recall(gt, 2, seg)
    assert (r, p, rw, pw, n) == (1.0, 0.5, 1.0, 0.5, 1)


def _results(scores):
    """results as score_map returns them: every map variant scores each combo (r, p) alike."""
    return {(n, v): {c: (r, p, r, p, 1, 1, 0.0) for c, (r, p) in scores.items()}
            for n in rooms_bench.MAPS for v in rooms_bench.VARIANTS}


def test_choose_takes_the_best_mean():
    low, high = (("seed_height", 0.05),), (("seed_height", 0.2),)
    got = rooms_bench.choose(_results({low: (0.9, 0.9), high: (0.95, 0.9)}), rooms_bench.MAPS)
    assert got == high


def test_choose_takes_a_better_value_over_the_shipped_one():
    shipped, high = (("seed_height", 0.1),), (("seed_height", 0.2),)
    got = rooms_bench.choose(_results({shipped: (0.9, 0.9), high: (0.95, 0.9)}), rooms_bench.MAPS)
    assert got == high


def test_choose_keeps_grid_order_between_tied_values_that_are_not_shipped():
    low, high = (("seed_height", 0.05),), (("seed_height", 0.2),)
    got = rooms_bench.choose(_results({low: (0.9, 0.9), high: (0.9, 0.9)}), rooms_bench.MAPS)
    assert got == low


@pytest.mark.parametrize("argv", [["--maps", "/nonexistent", "--grid", "x"],
                                  ["--maps", "/nonexistent", "--fixed", "--grid", "seed_height=0.1"]])
def test_main_refuses_a_bad_grid_before_reading_maps(argv, capsys):
    assert rooms_bench.main(argv) == 2
    err = capsys.readouterr().err
    assert err.startswith("rooms_bench: ") and "--" in err


def test_merge_fields_leave_the_basin_graph_alone():
    # a room and a closet joined by a door: the graph the bench builds once per graph combo must
    # not depend on the fields it treats as merge-only
    free = np.zeros((60, 100), dtype=bool)
    free[5:55, 5:60] = True
    free[20:40, 65:95] = True
    free[28:32, 60:65] = True
    ref = rooms_bench.basin_graph(free, 0.05, rooms_bench.RoomConfig())
    for field in ("door_ratio", "max_door_width", "min_room_area"):
        cfg = rooms_bench.RoomConfig(**{field: 2 * getattr(rooms_bench.RoomConfig(), field)})
        got = rooms_bench.basin_graph(free, 0.05, cfg)
        assert np.array_equal(got.basins, ref.basins) and np.array_equal(got.passes, ref.passes)
        assert field not in rooms_bench.GRAPH_FIELDS


def test_choose_keeps_the_shipped_default_on_a_tie():
    # 0.05 comes first in grid order; the shipped seed_height (0.1) ties it and is kept
    low, shipped = (("seed_height", 0.05),), (("seed_height", 0.1),)
    got = rooms_bench.choose(_results({low: (0.9, 0.9), shipped: (0.9, 0.9)}), rooms_bench.MAPS)
    assert got == shipped
