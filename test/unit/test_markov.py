"""Region adjacency, the seed transition rule, sampling, the stationary distribution and the
markov_chain command line, against hand-computed values (no ROS)."""
from __future__ import annotations

import datetime
import json
import os
from fractions import Fraction as F

import numpy as np
import pytest
from scipy.stats import chisquare

from bullet_floor_sim.people.markov import (
    STALE_BUILD_S,
    ChainError,
    MarkovChain,
    chain_collection,
    edge_adjacency,
    load_chain,
    read_rois,
    roi_adjacency,
    rois_from_documents,
    store_chain,
    transition_matrix,
    usable_rois,
    vertex_adjacency,
)
from bullet_floor_sim.data.roi_store import RoiStore
from bullet_floor_sim.data.rois import Roi, RoiError, load_rois
from bullet_floor_sim.data.store import insert_message, open_store
from bullet_floor_sim.ros.markov_chain import main

ROOT = os.path.join(os.path.dirname(os.path.abspath(__file__)), "..", "..")
OFFICE_ROIS = os.path.join(ROOT, "worlds", "office", "rois.yaml")


def box(x0, y0, x1, y1):
    return [(x0, y0), (x1, y0), (x1, y1), (x0, y1)]


def rois_of(*polys, ids=None, types=None):
    ids = ids or [str(k + 1) for k in range(len(polys))]
    types = types or ["office"] * len(polys)
    return [Roi(i, "1", t, "m", [tuple(map(float, v)) for v in p])
            for i, t, p in zip(ids, types, polys)]


def neighbours(chain):
    return {r: chain.neighbours(r) for r in chain.ids}


def brute_force_adjacent(a, b, tol=0.2):
    """The seed rule written out: some vertex pair within tol in x AND in y."""
    a, b = np.asarray(a), np.asarray(b)
    dx = np.abs(a[:, None, 0] - b[None, :, 0])
    dy = np.abs(a[:, None, 1] - b[None, :, 1])
    return bool(((dx <= tol + 1e-9) & (dy <= tol + 1e-9)).any())


# A corridor [0, 9] x [4, 5] with vertices every 3 m along its lower side, and three offices
# below it, 0.3 m apart (walls): each office corner is 0.15 m / 0.1 m from a corridor vertex.
CORRIDOR = [(0, 4), (3, 4), (6, 4), (9, 4), (9, 5), (0, 5)]
OFFICES = [box(3 * k + 0.15, 0.0, 3 * k + 2.85, 3.9) for k in range(3)]


def corridor_and_offices():
    return MarkovChain.from_rois(rois_of(CORRIDOR, *OFFICES, ids=["C", "O1", "O2", "O3"],
                                         types=["corridor"] + ["office"] * 3))


# --------------------------------------------------------------------------------------------
# hand-computed transition probabilities
# --------------------------------------------------------------------------------------------


def test_corridor_and_three_offices():
    chain = corridor_and_offices()
    assert neighbours(chain) == {"C": ["O1", "O2", "O3"], "O1": ["C"], "O2": ["C"], "O3": ["C"]}
    # n_C = 3, n_O = 1.
    # From C: candidates {C, O1, O2, O3}, S = 3 + 1 + 1 + 1 = 6, |C| - 1 = 3:
    #   P(C->C) = (1 - 3/6) / 3 = 1/6;  P(C->Ok) = (1 - 1/6) / 3 = 5/18.
    # From Ok: candidates {Ok, C}, S = 1 + 3 = 4, |C| - 1 = 1:
    #   P(Ok->Ok) = 1 - 1/4 = 3/4;  P(Ok->C) = 1 - 3/4 = 1/4.
    assert chain.probability("C", "C") == pytest.approx(1 / 6)
    for o in ("O1", "O2", "O3"):
        assert chain.probability("C", o) == pytest.approx(5 / 18)
        assert chain.probability(o, o) == pytest.approx(3 / 4)
        assert chain.probability(o, "C") == pytest.approx(1 / 4)
    assert chain.probability("O1", "O2") == 0.0
    assert chain.row("O2") == pytest.approx({"C": 0.25, "O2": 0.75})
    assert chain.matrix.sum(axis=1) == pytest.approx(np.ones(4))
    assert chain.warnings == []
    # offices are sticky, the corridor is passed through
    assert chain.expected_dwell("O1") == pytest.approx(4.0)
    assert chain.expected_dwell("C") == pytest.approx(6 / 5)


def test_chain_of_three_rooms():
    # A - B - C in a row, sharing walls: n_A = 1, n_B = 2, n_C = 1.
    chain = MarkovChain.from_rois(rois_of(box(0, 0, 1, 1), box(1, 0, 2, 1), box(2, 0, 3, 1),
                                          ids=["A", "B", "C"]))
    assert neighbours(chain) == {"A": ["B"], "B": ["A", "C"], "C": ["B"]}
    # From A: S = 1 + 2 = 3: P(A->A) = 1 - 1/3 = 2/3, P(A->B) = 1 - 2/3 = 1/3.
    # From B: S = 2 + 1 + 1 = 4, |C| - 1 = 2: P(B->B) = (1 - 2/4)/2 = 1/4,
    #         P(B->A) = P(B->C) = (1 - 1/4)/2 = 3/8.
    expected = np.array([[2 / 3, 1 / 3, 0], [3 / 8, 1 / 4, 3 / 8], [0, 1 / 3, 2 / 3]])
    assert chain.matrix == pytest.approx(expected)
    # pi_A = 2/3 pi_A + 3/8 pi_B  ->  pi_A = 9/8 pi_B = pi_C;  (9/8 + 1 + 9/8) pi_B = 1
    # -> pi_B = 8/26 = 4/13, pi_A = pi_C = 9/26.
    assert chain.stationary() == pytest.approx([9 / 26, 8 / 26, 9 / 26])


def test_transition_matrix_matches_exact_fractions():
    # a star with an extra link: 0-1, 0-2, 0-3, 1-2 ; n = [3, 2, 2, 1]
    nb = [{1, 2, 3}, {0, 2}, {0, 1}, {0}]
    p = transition_matrix(nb)
    deg = [3, 2, 2, 1]
    for i, others in enumerate(nb):
        cand = [i] + sorted(others)
        s = sum(deg[j] for j in cand)
        for j in range(4):
            want = (1 - F(deg[j], s)) / (len(cand) - 1) if j in cand else F(0)
            assert p[i, j] == pytest.approx(float(want)), (i, j)
    # e.g. row 1: candidates {1, 0, 2}, S = 2 + 3 + 2 = 7: P(1->0) = (1 - 3/7)/2 = 2/7
    assert p[1, 0] == pytest.approx(2 / 7)


def test_isolated_room_stays_and_is_reported():
    rois = rois_of(box(0, 0, 1, 1), box(1, 0, 2, 1), box(10, 10, 12, 12),
                   ids=["A", "B", "lonely"])
    chain = MarkovChain.from_rois(rois)
    assert chain.row("lonely") == {"lonely": 1.0}
    assert chain.expected_dwell("lonely") == float("inf")
    assert np.isfinite(chain.matrix).all()
    assert chain.warnings[0] == ('region "lonely" is isolated (no vertex within 0.2 m of '
                                 'another ROI\'s vertex): it keeps P(lonely -> lonely) = 1')
    assert chain.components() == [["A", "B"], ["lonely"]]
    assert chain.warnings[1].startswith('the regions form 2 separate parts ({"A", "B"}; '
                                        '{"lonely"})')
    assert chain.walk("lonely", 50, seed=0) == ["lonely"] * 51
    # reducible: each part's own distribution, weighted by its size (2/3 and 1/3)
    pi = chain.stationary()
    assert pi == pytest.approx([1 / 3, 1 / 3, 1 / 3])
    assert pi @ chain.matrix == pytest.approx(pi)


def test_single_roi_chain():
    chain = MarkovChain.from_rois(rois_of(box(0, 0, 1, 1)))
    assert chain.matrix.tolist() == [[1.0]]
    assert chain.stationary().tolist() == [1.0]
    assert len(chain.warnings) == 1  # isolated; one part only


# --------------------------------------------------------------------------------------------
# the vertex rule at its boundaries
# --------------------------------------------------------------------------------------------


@pytest.mark.parametrize("gap,connected", [(0.19, True), (0.2, True), (0.21, False), (0.5, False)])
def test_vertex_gap_in_x(gap, connected):
    a = box(0, 0, 1, 1)
    b = box(1 + gap, 0, 2 + gap, 1)
    assert vertex_adjacency([a, b]) == ([{1}, {0}] if connected else [set(), set()])


def test_decimal_tolerance_counts():
    # 0.8 - 0.6 is 0.20000000000000007 in floating point: still "within 0.2 m"
    assert 0.8 - 0.6 > 0.2
    assert vertex_adjacency([box(0, 0, 0.6, 1), box(0.8, 0, 2, 1)]) == [{1}, {0}]


def test_both_x_and_y_must_be_close():
    a = box(0, 0, 1, 1)
    # dx = 0.05 but dy = 0.5 for every vertex pair: not connected
    assert vertex_adjacency([a, box(1.05, 0.5, 2.05, 1.5)]) == [set(), set()]
    # dx = dy = 0.15: the Euclidean distance 0.212 exceeds 0.2, but x and y are each within
    assert vertex_adjacency([a, box(1.15, 1.15, 2, 2)]) == [{1}, {0}]
    # dx = 0.15, dy = 0.25: not connected
    assert vertex_adjacency([a, box(1.15, 1.25, 2, 2)]) == [set(), set()]


def test_tolerance_parameter():
    a, b = box(0, 0, 1, 1), box(1.3, 0, 2, 1)
    assert vertex_adjacency([a, b], tol=0.2) == [set(), set()]
    assert vertex_adjacency([a, b], tol=0.35) == [{1}, {0}]
    with pytest.raises(ValueError, match="tol must be a finite number of metres >= 0"):
        vertex_adjacency([a, b], tol=-1)


def test_non_rectangular_polygons():
    # an L whose 5th vertex (1, 2) touches a triangle; a pentagon touching the L's 6th
    # vertex (0, 2) from the left; a far hexagon
    ell = [(0, 0), (2, 0), (2, 1), (1, 1), (1, 2), (0, 2)]
    tri = [(1.1, 2.1), (3, 2.5), (1.5, 4)]
    pent = [(-2, 1), (-0.1, 1.5), (-0.15, 2.1), (-1, 3), (-2, 2.5)]
    hexa = [(10, 10), (11, 10), (11.5, 11), (11, 12), (10, 12), (9.5, 11)]
    chain = MarkovChain.from_rois(rois_of(ell, tri, pent, hexa, ids=["L", "T", "P", "H"]))
    assert neighbours(chain) == {"L": ["T", "P"], "T": ["L"], "P": ["L"], "H": []}
    # From L: candidates {L, T, P}, n = 2, 1, 1, S = 4: P(L->L) = (1 - 2/4)/2 = 1/4,
    #   P(L->T) = P(L->P) = (1 - 1/4)/2 = 3/8.  From T: S = 1 + 2 = 3: P(T->T) = 2/3.
    assert chain.row("L") == pytest.approx({"L": 0.25, "T": 0.375, "P": 0.375})
    assert chain.row("T") == pytest.approx({"T": 2 / 3, "L": 1 / 3})
    assert chain.row("H") == {"H": 1.0}


def test_many_rois_match_brute_force():
    # 1,000 unit squares on a 40 x 25 grid, each vertex jittered by up to 0.12 m: squares
    # sharing a corner are connected when both their copies of it stayed within 0.2 m.
    rng = np.random.default_rng(42)
    polys = []
    for i in range(40):
        for j in range(25):
            sq = np.array(box(i, j, i + 1, j + 1), float) + rng.uniform(-0.12, 0.12, (4, 2))
            polys.append([tuple(p) for p in sq])
    nb = vertex_adjacency(polys)
    assert all(k not in s for k, s in enumerate(nb))
    assert all(k in nb[m] for k, s in enumerate(nb) for m in s)  # symmetric
    for k in rng.choice(len(polys), size=40, replace=False):
        expected = {m for m in range(len(polys))
                    if m != k and brute_force_adjacent(polys[k], polys[m])}
        assert nb[k] == expected, k
    degrees = [len(s) for s in nb]
    assert 3 <= np.mean(degrees) <= 8 and max(degrees) <= 8
    chain = MarkovChain.from_rois(rois_of(*polys))
    assert chain.matrix.sum(axis=1) == pytest.approx(np.ones(1000))
    pi = chain.stationary()
    assert pi @ chain.matrix == pytest.approx(pi, abs=1e-12)


# --------------------------------------------------------------------------------------------
# edge mode
# --------------------------------------------------------------------------------------------


def test_edge_mode_door_versus_corner():
    room = box(0, 0, 4, 4)
    door = box(4, 1.5, 8, 2.5)        # touches the room's east wall over 1 m only
    corner = box(4, 4, 8, 8)          # touches the room at one corner
    short = box(4.1, 0.5, 8, 1.0)     # 0.5 m of wall, 0.1 m away
    offset = box(4.1, 2.7, 8, 3.7)    # 1 m of wall, 0.1 m away (a thin wall between)
    polys = [room, door, corner, short, offset]
    # the seed's vertex rule sees the corner, not the door (no vertex of the room near it)
    assert vertex_adjacency(polys)[0] == {2}
    assert edge_adjacency(polys)[0] == {1, 4}
    assert edge_adjacency(polys, min_shared=1.2)[0] == set()
    assert edge_adjacency(polys, min_shared=0.4)[0] == {1, 3, 4}
    assert edge_adjacency(polys, tol=0.05)[0] == {1}


def test_edge_mode_run_continues_around_a_corner():
    # b wraps around a's north-east corner: 0.5 m along the east wall + 0.5 m along the north
    # wall is one continuous 1 m stretch
    a = box(0, 0, 4, 4)
    b = [(4, 3.5), (5, 3.5), (5, 5), (3.5, 5), (3.5, 4), (4, 4)]
    assert edge_adjacency([a, b]) == [{1}, {0}]
    assert edge_adjacency([a, b], min_shared=1.1) == [set(), set()]


def test_edge_mode_thin_region_counts_once():
    # a 0.1 m wide, 1.5 m long strip along the room's east wall: both long sides of the strip
    # run within tol of the wall, but the wall is shared over 1.5 m only
    room = box(0, 0, 4, 4)
    strip = box(4.0, 1.0, 4.1, 2.5)
    assert edge_adjacency([room, strip], min_shared=1.4) == [{1}, {0}]
    assert edge_adjacency([room, strip], min_shared=1.6) == [set(), set()]


def test_edge_mode_chain_and_errors():
    rois = rois_of(box(0, 0, 4, 4), box(4, 1.5, 8, 2.5), box(4, 4, 8, 8), ids=["R", "D", "K"])
    chain = MarkovChain.from_rois(rois, mode="edge")
    assert neighbours(chain) == {"R": ["D"], "D": ["R"], "K": []}
    assert "no wall of 0.8 m shared with another ROI" in chain.warnings[0]
    with pytest.raises(ValueError, match="mode must be one of vertex/edge, got 'walls'"):
        roi_adjacency(rois, mode="walls")


# --------------------------------------------------------------------------------------------
# sampling and the stationary distribution
# --------------------------------------------------------------------------------------------


def test_sampled_transitions_match_the_matrix():
    chain = corridor_and_offices()
    path = chain.walk("C", 20000, seed=12345)
    assert len(path) == 20001 and path[0] == "C"
    assert path == chain.walk("C", 20000, seed=12345)           # reproducible
    assert path != chain.walk("C", 20000, seed=54321)
    idx = {r: k for k, r in enumerate(chain.ids)}
    counts = np.zeros((4, 4))
    for a, b in zip(path, path[1:]):
        counts[idx[a], idx[b]] += 1
    assert (counts[chain.matrix == 0.0] == 0).all()             # never an impossible move
    for i in range(4):
        n = counts[i].sum()
        assert n > 2000                                          # enough counts per row
        nz = chain.matrix[i] > 0
        stat = chisquare(counts[i][nz], n * chain.matrix[i][nz])
        assert stat.pvalue > 0.001, (chain.ids[i], counts[i], chain.matrix[i])
    # visit frequencies approach the stationary distribution: pi_C = 3/13, pi_O = 10/39
    freq = np.bincount([idx[r] for r in path], minlength=4) / len(path)
    assert freq == pytest.approx([3 / 13, 10 / 39, 10 / 39, 10 / 39], abs=0.02)


def test_stationary_distribution():
    chain = corridor_and_offices()
    pi = chain.stationary()
    # pi_O = 3/4 pi_O + 5/18 pi_C -> pi_O = 10/9 pi_C; pi_C (1 + 30/9) = 1 -> pi_C = 9/39
    assert pi == pytest.approx([9 / 39, 10 / 39, 10 / 39, 10 / 39])
    assert pi @ chain.matrix == pytest.approx(pi)
    assert pi.sum() == pytest.approx(1.0)


def test_sample_next_with_generator():
    chain = corridor_and_offices()
    rng = np.random.default_rng(0)
    seen = {chain.sample_next("O1", rng) for _ in range(200)}
    assert seen == {"O1", "C"}
    with pytest.raises(KeyError, match="unknown region 'X'"):
        chain.sample_next("X", rng)


# --------------------------------------------------------------------------------------------
# export
# --------------------------------------------------------------------------------------------


def test_to_json_and_documents():
    chain = corridor_and_offices()
    data = chain.to_json()
    assert data["map_name"] == "m"
    assert list(data["transitions"]) == ["C", "O1", "O2", "O3"]
    assert data["transitions"]["O1"] == pytest.approx({"O1": 0.75, "C": 0.25})  # zeros left out
    stored = chain.to_documents()
    assert stored["database"] == "markov_chain_db"
    assert stored["collection"] == "roi_proba_connexions_m"
    assert chain.to_documents("office")["collection"] == "roi_proba_connexions_office"
    assert stored["documents"][1] == {"ID_region": "O1", "map_name": "m", "config": "1",
                                      "proba_connexions": [["C", pytest.approx(0.25)],
                                                           ["O1", pytest.approx(0.75)]]}
    assert chain.to_documents("office")["documents"][0]["map_name"] == "office"
    assert len(stored["documents"][0]["proba_connexions"]) == 4
    with pytest.raises(ValueError, match="cannot name a collection"):
        chain_collection("a$b")


def test_from_rois_refuses_mixed_maps_and_empty():
    a = Roi("1", "1", "office", "m1", box(0, 0, 1, 1))
    b = Roi("2", "1", "office", "m2", box(1, 0, 2, 1))
    with pytest.raises(RoiError, match="one chain per map and config: got maps m1, m2"):
        MarkovChain.from_rois([a, b])
    with pytest.raises(RoiError, match="no ROIs"):
        MarkovChain.from_rois([])


# --------------------------------------------------------------------------------------------
# the office world
# --------------------------------------------------------------------------------------------


def test_office_chain_is_connected_and_offices_open_on_corridors():
    rois = load_rois(OFFICE_ROIS)
    chain = MarkovChain.from_rois(rois)
    assert chain.warnings == [] and len(chain.components()) == 1
    corridors = {r.id for r in rois if r.type == "corridor"}
    assert corridors == {"1", "2", "3", "4"}
    for r in rois:
        if r.type != "corridor":
            # each room opens on exactly one corridor segment and touches no other room
            assert len(chain.neighbours(r.id)) == 1, r.id
            assert chain.neighbours(r.id)[0] in corridors, r.id
    # read off the file: office_1 ("5") and corridor_west ("1") share the doorway corners
    # (2.15, 8.925) and (3.15, 8.925); the lab ("9") and corridor_centre_east ("3") share
    # (20.1, 8.925) and (21.5, 8.925); the kitchen ("15") and corridor_east ("4") share
    # (24.6, 11.075); corridor segments share their end vertices, e.g. (8.875, 9.25).
    assert chain.neighbours("5") == ["1"]
    assert chain.neighbours("9") == ["3"]
    assert chain.neighbours("15") == ["4"]
    assert chain.neighbours("1") == ["2", "5", "6", "10", "11"]
    assert chain.neighbours("4") == ["3", "15"]
    # From office_1: candidates {5, 1}, n_5 = 1, n_1 = 5, S = 6: P(5->5) = 5/6, P(5->1) = 1/6.
    assert chain.row("5") == pytest.approx({"5": 5 / 6, "1": 1 / 6})
    # From corridor_west: candidates {1, 2, 5, 6, 10, 11}, n = 5, 6, 1, 1, 1, 1, S = 15:
    #   P(1->1) = (1 - 5/15)/5 = 2/15, P(1->2) = (1 - 6/15)/5 = 3/25, P(1->5) = (14/15)/5
    assert chain.row("1") == pytest.approx({"1": 2 / 15, "2": 3 / 25, "5": 14 / 75,
                                            "6": 14 / 75, "10": 14 / 75, "11": 14 / 75})
    # the edge rule (1 m doorways, 1.5 m corridor joints) gives the same graph here
    assert roi_adjacency(rois, mode="edge") == roi_adjacency(rois, mode="vertex")


# --------------------------------------------------------------------------------------------
# command line
# --------------------------------------------------------------------------------------------


def test_cli_prints_the_chain(capsys):
    assert main([OFFICE_ROIS]) == 0
    out, err = capsys.readouterr()
    data = json.loads(out)
    assert data["map_name"] == "office" and len(data["transitions"]) == 15
    for row in data["transitions"].values():
        assert sum(row.values()) == pytest.approx(1.0)
        assert all(p > 0 for p in row.values())
    assert data["transitions"]["5"] == pytest.approx({"5": 5 / 6, "1": 1 / 6})
    assert err == ""


def test_cli_warnings_go_to_stderr(tmp_path, capsys):
    path = tmp_path / "r.yaml"
    path.write_text('map_name: m\nconfig: "1"\nrois:\n'
                    '  - {id: "a", type: office, points: [[0, 0], [1, 0], [1, 1], [0, 1]]}\n'
                    '  - {id: "b", type: office, points: [[5, 0], [6, 0], [6, 1], [5, 1]]}\n')
    assert main([str(path), "--tol", "0.1", "__name:=markov_chain"]) == 0
    out, err = capsys.readouterr()
    assert json.loads(out)["transitions"] == {"a": {"a": 1.0}, "b": {"b": 1.0}}
    lines = err.splitlines()
    assert lines[0] == ('markov_chain: warning: %s: region "a" is isolated (no vertex within '
                        '0.1 m of another ROI\'s vertex): it keeps P(a -> a) = 1' % path)
    assert len(lines) == 3  # a, b, and the two separate parts


def test_cli_edge_mode_and_bounds(capsys):
    map_yaml = os.path.join(ROOT, "worlds", "office", "map.yaml")
    assert main([OFFICE_ROIS, "--mode", "edge", "--min-shared", "0.9", "--map-yaml",
                 map_yaml]) == 0
    out, err = capsys.readouterr()
    assert json.loads(out)["transitions"]["5"] == pytest.approx({"5": 5 / 6, "1": 1 / 6})
    assert err == ""


@pytest.mark.parametrize("argv,message", [
    (["nope.yaml"], "markov_chain: error: nope.yaml: ROI file not found"),
    (["x.yaml", "--tol", "abc"], "markov_chain: error: argument --tol: invalid float value: "
                                 "'abc'"),
    (["x.yaml", "--mode", "walls"], "markov_chain: error: argument --mode: invalid choice: "
                                    "'walls' (choose from 'vertex', 'edge')"),
    ([], "markov_chain: error: give a ROIS_YAML file (e.g. worlds/office/rois.yaml) or --db "
         "URI"),
    (["x.yaml", "--db", "/tmp/db"], "markov_chain: error: give a ROIS_YAML file or --db, not "
                                    "both"),
    (["x.yaml", "--map", "office"], "markov_chain: error: --map and --config select ROIs in "
                                    "the store: add --db URI"),
    (["--db", "http://localhost/"], "markov_chain: error: store http://localhost/: unsupported "
                                    "URI scheme 'http' (use mongodb://host[:port]/ or a "
                                    "directory path)"),
    (["x.yaml", "--tol", "-1"], "markov_chain: error: --tol must be a finite number of metres "
                                ">= 0, got -1.0"),
])
def test_cli_errors_are_one_line(argv, message, capsys):
    assert main(argv) == 2
    out, err = capsys.readouterr()
    assert out == ""
    if "invalid choice" in message:  # argparse quotes choices differently across versions
        assert err.startswith("markov_chain: error: argument --mode: invalid choice: ")
    else:
        assert err == message + "\n"
    assert err.count("\n") == 1


def test_cli_bad_roi_file(tmp_path, capsys):
    path = tmp_path / "bad.yaml"
    path.write_text('map_name: m\nconfig: "1"\nrois:\n'
                    '  - {id: "7", type: office, points: [[0, 0], [2, 2], [2, 0], [0, 2]]}\n')
    assert main([str(path)]) == 2
    out, err = capsys.readouterr()
    assert out == ""
    assert err == ('markov_chain: error: %s: ROI "7": polygon edges cross or touch '
                   '(self-intersection at (1, 1)); list the vertices in order around the '
                   'region\n' % path)


def test_cli_plot(tmp_path, capsys):
    png = tmp_path / "chain.png"
    map_yaml = os.path.join(ROOT, "worlds", "office", "map.yaml")
    code = main([OFFICE_ROIS, "--plot", str(png), "--map-yaml", map_yaml])
    out, err = capsys.readouterr()
    try:
        import matplotlib  # noqa: F401
    except ImportError:
        assert code == 2 and out == ""
        assert err == ("markov_chain: error: --plot needs matplotlib, which is not installed "
                       "(apt install python3-matplotlib)\n")
        return
    assert code == 0 and err == ""
    assert png.read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"


# --------------------------------------------------------------------------------------------
# storage: the chain and the ROIs in the embedded store
# --------------------------------------------------------------------------------------------


@pytest.fixture
def store(tmp_path):
    with open_store(str(tmp_path / "db"), journal_dir=str(tmp_path / "journal")) as s:
        yield s


def test_store_chain_roundtrip(store):
    chain = corridor_and_offices()
    assert store_chain(store, chain) == 4
    docs = store.find("markov_chain_db", "roi_proba_connexions_m", sort=[("_id", 1)])
    assert [d["ID_region"] for d in docs] == ["C", "O1", "O2", "O3"]
    # the seed's document shape: [id, probability] pairs; C: candidates {C, O1, O2, O3},
    # n = 3, 1, 1, 1, S = 6: P(C->C) = (1 - 3/6)/3 = 1/6, P(C->Ok) = (1 - 1/6)/3 = 5/18
    assert docs[0]["proba_connexions"] == [["C", pytest.approx(1 / 6)],
                                           ["O1", pytest.approx(5 / 18)],
                                           ["O2", pytest.approx(5 / 18)],
                                           ["O3", pytest.approx(5 / 18)]]
    assert (docs[0]["map_name"], docs[0]["config"]) == ("m", "1")
    back = load_chain(store, "m")
    assert back.ids == chain.ids and (back.map_name, back.config) == ("m", "1")
    np.testing.assert_allclose(back.matrix, chain.matrix, rtol=0, atol=1e-15)


def test_store_chain_replaces_the_previous_chain_of_that_map_only(store):
    t0 = datetime.datetime(2026, 1, 1, 12, 0, 0)
    store_chain(store, corridor_and_offices(), now=t0)
    store_chain(store, corridor_and_offices(), map_name="other", now=t0)
    two = MarkovChain.from_rois(rois_of(box(0, 0, 1, 1), box(1, 0, 2, 1), ids=["A", "B"]))
    later = t0 + datetime.timedelta(seconds=STALE_BUILD_S + 1)
    assert store_chain(store, two, extra={"built_by": "/test", "ID_region": "ignored"},
                       now=later) == 2
    docs = store.find("markov_chain_db", "roi_proba_connexions_m")
    assert sorted(d["ID_region"] for d in docs) == ["A", "B"]
    assert {d["built_by"] for d in docs} == {"/test"}
    assert load_chain(store, "m").row("A") == pytest.approx({"A": 0.5, "B": 0.5})
    assert load_chain(store, "other").ids == ["C", "O1", "O2", "O3"]


def test_two_writers_rebuilding_one_map_keep_each_others_fresh_builds(store):
    t0 = datetime.datetime(2026, 1, 1, 12, 0, 0)
    first = corridor_and_offices()
    second = MarkovChain.from_rois(rois_of(box(0, 0, 1, 1), box(1, 0, 2, 1), ids=["A", "B"]))
    store_chain(store, first, now=t0)
    store_chain(store, second, now=t0 + datetime.timedelta(seconds=1))   # the other walker
    docs = store.find("markov_chain_db", "roi_proba_connexions_m")
    assert len({d["build_id"] for d in docs}) == 2 and len(docs) == 6    # neither deleted
    marker = store.find_one("markov_chain_db", "chain_builds", {"_id": "m"})
    assert marker["build_id"] == docs[-1]["build_id"]
    assert load_chain(store, "m").ids == ["A", "B"]                      # the marker's build
    store_chain(store, first, now=t0 + datetime.timedelta(seconds=STALE_BUILD_S + 5))
    docs = store.find("markov_chain_db", "roi_proba_connexions_m")
    assert len({d["build_id"] for d in docs}) == 1 and len(docs) == 4    # stale ones gone
    assert load_chain(store, "m").ids == ["C", "O1", "O2", "O3"]


def test_load_chain_errors(store):
    with pytest.raises(ChainError, match=r"markov_chain_db.roi_proba_connexions_nowhere: no "
                                         r"chain stored for map 'nowhere'"):
        load_chain(store, "nowhere")
    store.insert("markov_chain_db", "roi_proba_connexions_bad",
                 {"ID_region": "A", "proba_connexions": [["B", 1.0]]})
    with pytest.raises(ChainError, match="region 'A' leads to 'B', which has no document"):
        load_chain(store, "bad")
    store.insert("markov_chain_db", "roi_proba_connexions_half",
                 {"ID_region": "A", "proba_connexions": [["A", 0.5]]})
    with pytest.raises(ChainError, match="rows must be probabilities summing to 1"):
        load_chain(store, "half")


def soma_fields(roi_id, points, config="1", map_name="office", roi_type="office", stamp=100):
    """A SOMAROIObject as a dict (mongodb_store's msg_to_document shape)."""
    poses = [{"position": {"x": x, "y": y, "z": 0.0},
              "orientation": {"x": 0.0, "y": 0.0, "z": 0.0, "w": 1.0}} for x, y in points]
    return {"header": {"seq": 0, "stamp": {"secs": 0, "nsecs": 0}, "frame_id": "map"},
            "id": roi_id, "map_name": map_name, "map_unique_id": map_name, "config": config,
            "type": roi_type, "logtimestamp": stamp, "logday": 4, "loghour": 0,
            "logminute": 1, "logtimeminutes": 1,
            "posearray": {"header": {"seq": 0, "stamp": {"secs": 0, "nsecs": 0},
                                     "frame_id": "map"}, "poses": poses},
            "geotype": "Polygon", "geoposearray": {"header": {"seq": 0, "stamp": {
                "secs": 0, "nsecs": 0}, "frame_id": ""}, "poses": []}}


def test_rois_from_documents():
    docs = [soma_fields("1", [(0, 0), (1, 0), (1, 1), (0, 1), (0, 0)], roi_type="corridor"),
            soma_fields("2", [(1, 0), (2, 0), (2, 1)])]
    rois = rois_from_documents(docs)
    assert rois == [Roi("1", "1", "corridor", "office", [(0, 0), (1, 0), (1, 1), (0, 1)]),
                    Roi("2", "1", "office", "office", [(1, 0), (2, 0), (2, 1)])]
    with pytest.raises(RoiError, match='ROI "3": not a SOMAROIObject document: missing '
                                           'field.s. posearray'):
        rois_from_documents([{"id": "3", "config": "1", "type": "t", "map_name": "m"}])
    with pytest.raises(RoiError, match=r'ROI "4": not a SOMAROIObject document: '
                                           r'posearray.poses\[k\].position.x/y expected'):
        rois_from_documents([dict(soma_fields("4", []), posearray={"poses": [{"x": 1}]})])
    with pytest.raises(RoiError, match='ROI "5": a polygon needs at least 3 vertices, got 2'):
        rois_from_documents([soma_fields("5", [(0, 0), (1, 0)])])
    assert rois_from_documents([soma_fields("5", [(0, 0), (1, 0)])], strict=False)[0].id == "5"


def test_usable_rois_drops_bad_ones_with_a_warning():
    rois = [Roi("a", "1", "office", "m", box(0, 0, 1, 1)),
            Roi("b", "1", "office", "m", [(0, 0), (1, 1), (1, 0), (0, 1)]),  # bow tie
            Roi("a", "1", "office", "m", box(5, 5, 6, 6))]
    good, warnings = usable_rois(rois)
    assert [r.vertices for r in good] == [box(0, 0, 1, 1)]
    assert len(warnings) == 2
    assert warnings[0].startswith('ROI "b": polygon edges cross or touch')
    assert warnings[0].endswith("left out of the chain")
    assert warnings[1] == ('ROI "a": repeated id in map m config 1: the later one is left out '
                           "of the chain")


def test_read_rois_takes_the_current_version_of_each(store):
    office = RoiStore(store, "office", clock=iter(range(1000, 2000)).__next__)
    office.save(Roi("1", "1", "corridor", "office", box(0, 0, 4, 1)))
    office.save(Roi("2", "1", "office", "office", box(0, 1, 1, 3)))
    office.save(Roi("2", "1", "office", "office", box(0.1, 1, 1, 3)))   # an edit of "2"
    office.save(Roi("10", "1", "office", "office", box(3, 1, 4, 3)))
    office.delete("1", "10")                                            # deleted: left out
    office.save(Roi("3", "2", "office", "office", box(9, 9, 10, 10)))   # another config
    RoiStore(store, "lab").save(Roi("4", "1", "office", "lab", box(9, 9, 10, 10)))
    rois = read_rois(store, "office", "1")
    assert [(r.id, r.vertices[0]) for r in rois] == [("1", (0.0, 0.0)), ("2", (0.1, 1.0))]
    assert [r.id for r in read_rois(store, "office", "2")] == ["3"]
    assert read_rois(store, "nowhere") == []
    chain = MarkovChain.from_rois(rois)
    assert chain.row("2") == pytest.approx({"2": 0.5, "1": 0.5})


def test_load_chain_reads_the_marked_build_while_another_is_being_written(store):
    store_chain(store, corridor_and_offices())
    # a writer half-way through its inserts (the marker not updated yet): the old build, whole
    doc = MarkovChain.from_rois(rois_of(box(0, 0, 1, 1), box(1, 0, 2, 1), ids=["A", "B"])
                                ).to_documents()["documents"][0]
    store.insert("markov_chain_db", "roi_proba_connexions_m", dict(doc, build_id="new"))
    assert load_chain(store, "m").ids == ["C", "O1", "O2", "O3"]
    store.delete("markov_chain_db", "chain_builds", {})     # no marker (an earlier version):
    with pytest.raises(ChainError, match="'A' leads to 'B', which has no document"):
        load_chain(store, "m")                              # the newest build is read


def test_cli_reads_rois_from_the_store(tmp_path, capsys, monkeypatch):
    db = str(tmp_path / "db")
    with open_store(db, journal_dir=str(tmp_path / "journal")) as s:
        office = RoiStore(s, "office")
        assert office.seed(load_rois(OFFICE_ROIS))
        # a later edit moved office_1's ("5") doorway away: it lost its connection
        moved = [(x, y - 1.0) for x, y in load_rois(OFFICE_ROIS)[4].vertices]
        office.save(Roi("5", "1", "office", "office", moved))
        # and a writer that does not validate left office_2 ("6") self-intersecting: it is
        # left out, with a warning
        insert_message(s, "somadata", "roi", soma_fields(
            "6", [(5, 1), (8, 8), (8, 1), (5, 8)], stamp=20), "soma_msgs/SOMAROIObject",
            meta={"map": "office", "version": 2 ** 60})
    monkeypatch.setenv("ROS_HOME", str(tmp_path / "ros_home"))  # the CLI's journal goes there
    assert main(["--db", db, "--map", "office", "--config", "1"]) == 0
    out, err = capsys.readouterr()
    data = json.loads(out)
    assert data["map_name"] == "office"
    assert sorted(data["transitions"], key=int) == [str(k) for k in range(1, 16) if k != 6]
    assert data["transitions"]["5"] == {"5": 1.0}
    # corridor_west lost 5 and 6: candidates {1, 2, 10, 11}, n = 3, 6, 1, 1, S = 11
    assert data["transitions"]["1"] == pytest.approx(
        {"1": 8 / 33, "2": 5 / 33, "10": 10 / 33, "11": 10 / 33})
    lines = err.splitlines()
    assert lines[0].startswith("markov_chain: warning: %s somadata.roi (map office, "
                               "config 1): ROI \"6\": polygon edges cross" % db)
    assert lines[1].endswith('region "5" is isolated (no vertex within 0.2 m of another '
                             "ROI's vertex): it keeps P(5 -> 5) = 1")
    # --map defaults to the only map of the config
    assert main(["--db", db]) == 0
    assert json.loads(capsys.readouterr()[0]) == data
    assert main(["--db", db, "--config", "2"]) == 2
    assert capsys.readouterr()[1] == ("markov_chain: error: %s somadata.roi: no ROIs of "
                                      "config '2': give --map NAME\n" % db)
    assert main(["--db", db, "--map", "lab"]) == 2
    assert capsys.readouterr()[1] == ("markov_chain: error: %s somadata.roi (map lab, "
                                      "config 1): no usable ROIs stored\n" % db)
