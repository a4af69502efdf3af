"""ROI model, rois.yaml roundtrip, validation messages and point queries (no ROS)."""
from __future__ import annotations

import math
import os

import numpy as np
import pytest
import yaml
from shapely.geometry import Point

from bullet_floor_sim.errors import BulletFloorSimError
from bullet_floor_sim.data.rois import (
    Roi,
    RoiError,
    centroid,
    check_bounds,
    load_rois,
    random_point_inside,
    roi_at,
    roi_polygon,
    rois_from_dict,
    save_rois,
    validate_roi,
    validate_rois,
)

ROOT = os.path.join(os.path.dirname(os.path.abspath(__file__)), "..", "..")
OFFICE_ROIS = os.path.join(ROOT, "worlds", "office", "rois.yaml")

SQUARE = [[0.0, 0.0], [4.0, 0.0], [4.0, 4.0], [0.0, 4.0]]
L_SHAPE = [[0.0, 0.0], [4.0, 0.0], [4.0, 1.0], [1.0, 1.0], [1.0, 4.0], [0.0, 4.0]]


def doc(*rois, **top):
    d = {"map_name": "m", "config": "1", "rois": list(rois)}
    d.update(top)
    return d


def entry(roi_id="1", points=None, roi_type="office", **extra):
    e = {"id": roi_id, "type": roi_type, "points": SQUARE if points is None else points}
    e.update(extra)
    return e


def write(tmp_path, text, name="rois.yaml"):
    path = tmp_path / name
    path.write_text(text)
    return str(path)


# --------------------------------------------------------------------------------------------
# files
# --------------------------------------------------------------------------------------------


def test_yaml_roundtrip(tmp_path):
    src = write(tmp_path, 'map_name: office\nconfig: "2"\nrois:\n'
                '  - {id: "a", type: corridor, points: [[0.5, 1], [3.25, 1], [3.25, 2.125]]}\n'
                '  - {id: "7", type: office, points: [[0, 0], [1.0e-3, 0], [0.001, 1.0e-3]]}\n')
    rois = load_rois(src)
    assert rois == [
        Roi("a", "2", "corridor", "office", [(0.5, 1.0), (3.25, 1.0), (3.25, 2.125)]),
        Roi("7", "2", "office", "office", [(0.0, 0.0), (1e-3, 0.0), (1e-3, 1e-3)]),
    ]
    out = str(tmp_path / "out.yaml")
    save_rois(rois, out)
    assert load_rois(out) == rois
    # the written file is the documented layout, ids and config stay strings
    data = yaml.safe_load(open(out).read())
    assert data["config"] == "2" and [r["id"] for r in data["rois"]] == ["a", "7"]
    assert data["rois"][0]["points"] == [[0.5, 1.0], [3.25, 1.0], [3.25, 2.125]]
    assert open(out).read().count("\n") == 5  # 3 header lines + one line per ROI


def test_closing_vertex_is_dropped():
    rois = rois_from_dict(doc(entry(points=SQUARE + [SQUARE[0]])))
    assert len(rois[0].vertices) == 4


def test_save_refuses_mixed_maps(tmp_path):
    rois = [Roi("1", "1", "office", "a", [(0, 0), (1, 0), (0, 1)]),
            Roi("2", "1", "office", "b", [(0, 0), (1, 0), (0, 1)])]
    with pytest.raises(RoiError, match="one map and one config, got maps a, b"):
        save_rois(rois, str(tmp_path / "x.yaml"))


def test_office_rois_load_and_validate():
    rois = load_rois(OFFICE_ROIS)
    assert len(rois) == 15
    assert [r.id for r in rois] == [str(k) for k in range(1, 16)]
    assert {r.map_name for r in rois} == {"office"} and {r.config for r in rois} == {"1"}
    assert [r.type for r in rois].count("corridor") == 4
    assert rois[8].type == "lab" and rois[14].type == "kitchen"
    assert len(rois[0].vertices) == 20 and rois[0].vertices[0] == (2.15, 8.925)
    validate_rois(rois)


def test_errors_are_bullet_floor_sim_errors():
    assert issubclass(RoiError, BulletFloorSimError)


# --------------------------------------------------------------------------------------------
# validation: one line naming the file, the ROI and the problem
# --------------------------------------------------------------------------------------------


def test_missing_file(tmp_path):
    path = str(tmp_path / "nope.yaml")
    with pytest.raises(RoiError, match=r"nope\.yaml: ROI file not found"):
        load_rois(path)


def test_not_yaml(tmp_path):
    path = write(tmp_path, "map_name: [\n")
    with pytest.raises(RoiError, match=r"rois\.yaml: not valid YAML \(line 2\)"):
        load_rois(path)


def test_binary_file_is_named(tmp_path):
    path = tmp_path / "rois.yaml"
    path.write_bytes(b"map_name: m\n" + bytes(range(128, 256)))
    with pytest.raises(RoiError, match=r"rois\.yaml: not a text ROI file \(byte 0x80 at offset "
                                       r"12 is not UTF-8\)$"):
        load_rois(str(path))


def test_too_few_vertices(tmp_path):
    path = write(tmp_path, 'map_name: m\nconfig: "1"\nrois:\n'
                 '  - {id: "k3", type: office, points: [[0, 0], [1, 0]]}\n')
    with pytest.raises(RoiError, match=r'rois\.yaml: ROI "k3": a polygon needs at least 3 '
                                       r'vertices, got 2$'):
        load_rois(path)


def test_self_intersection_says_where():
    bowtie = [[0, 0], [2, 2], [2, 0], [0, 2]]
    with pytest.raises(RoiError, match=r'^f\.yaml: ROI "b": polygon edges cross or touch '
                                       r'\(self-intersection at \(1, 1\)\)'):
        rois_from_dict(doc(entry("b", bowtie)), source="f.yaml")


def test_ring_touching_itself():
    # vertex (2, 0) is visited twice: the ring touches itself there
    pts = [[0, 0], [2, 0], [4, 0], [4, 2], [2, 0], [0, 2]]
    with pytest.raises(RoiError, match=r'ROI "t": polygon edges cross or touch '
                                       r'\(ring self-intersection at \(2, 0\)\)'):
        rois_from_dict(doc(entry("t", pts)))


def test_collinear_vertices():
    with pytest.raises(RoiError, match=r'ROI "z": all 3 vertices lie on one line'):
        rois_from_dict(doc(entry("z", [[0, 0], [1, 1], [2, 2]])))


def test_duplicate_id():
    with pytest.raises(RoiError, match=r'^f\.yaml: ROI "2": duplicate id in map "m" config "1" '
                                       r'\(ROIs number 2 and 3\)$'):
        rois_from_dict(doc(entry("1"), entry("2"), entry("2")), source="f.yaml")


def test_same_id_in_other_config_is_fine():
    a = Roi("1", "1", "office", "m", [(0, 0), (1, 0), (0, 1)])
    b = Roi("1", "2", "office", "m", [(0, 0), (1, 0), (0, 1)])
    validate_rois([a, b])


@pytest.mark.parametrize("bad", [float("nan"), float("inf"), -float("inf")])
def test_non_finite_coordinate(bad):
    pts = [[0.0, 0.0], [1.0, 0.0], [1.0, bad]]
    with pytest.raises(RoiError, match=r'ROI "n": vertex 2 \(1.0, -?(nan|inf)\) is not finite'):
        rois_from_dict(doc(entry("n", pts)))


def test_non_finite_in_yaml_file(tmp_path):
    path = write(tmp_path, 'map_name: m\nconfig: "1"\nrois:\n'
                 '  - {id: "n", type: office, points: [[0, 0], [1, .nan], [1, 1]]}\n')
    with pytest.raises(RoiError, match=r'rois\.yaml: ROI "n": vertex 1 \(1.0, nan\) is not '
                                       r'finite'):
        load_rois(path)


def test_missing_and_unknown_top_keys():
    with pytest.raises(RoiError, match=r"^f\.yaml: missing key\(s\): config$"):
        rois_from_dict({"map_name": "m", "rois": []}, source="f.yaml")
    with pytest.raises(RoiError, match=r"^f\.yaml: unknown key\(s\): colour \(expected "
                                       r"map_name, config, rois\)$"):
        rois_from_dict(doc(colour="red"), source="f.yaml")


def test_missing_and_unknown_roi_keys():
    with pytest.raises(RoiError, match=r'^ROI "4": missing key\(s\): type$'):
        rois_from_dict(doc({"id": "4", "points": SQUARE}))
    with pytest.raises(RoiError, match=r'^rois\[0\]: missing key\(s\): id$'):
        rois_from_dict(doc({"type": "office", "points": SQUARE}))
    with pytest.raises(RoiError, match=r'^ROI "4": unknown key\(s\): name, posearray '
                                       r'\(expected id, type, points\)$'):
        rois_from_dict(doc(entry("4", name="x", posearray=[])))


def test_wrong_types():
    with pytest.raises(RoiError, match=r'^rois\[0\]: id must be a string \(quote it: "3"\), '
                                       r'got int$'):
        rois_from_dict(doc(entry(3)))
    with pytest.raises(RoiError, match=r'^config must be a string \(quote it: "1"\), got int$'):
        rois_from_dict(doc(config=1))
    with pytest.raises(RoiError, match=r'^ROI "1": points must be a list of \[x, y\], got str$'):
        rois_from_dict(doc(entry(points="0 0 1 1")))
    with pytest.raises(RoiError, match=r"^ROI \"1\": point 1 must be \[x, y\] \(two numbers\), "
                                       r"got \[1, 'a'\]$"):
        rois_from_dict(doc(entry(points=[[0, 0], [1, "a"], [1, 1]])))
    with pytest.raises(RoiError, match=r"^ROI \"1\": point 0 must be \[x, y\] \(two numbers\), "
                                       r"got \[True, 0\]$"):
        rois_from_dict(doc(entry(points=[[True, 0], [1, 0], [1, 1]])))
    with pytest.raises(RoiError, match=r"^ROI \"1\": point 1 must be \[x, y\] \(two numbers\), "
                                       r"got \[1, '1e-3'\] \(YAML reads 1e-3 as text: write it "
                                       r"with a dot, e\.g\. 1\.0e-3\)$"):
        rois_from_dict(doc(entry(points=yaml.safe_load("[[0, 0], [1, 1e-3], [1, 1]]"))))
    with pytest.raises(RoiError, match=r"^rois must be a list of \{id, type, points\}, got dict$"):
        rois_from_dict(doc(rois={"1": SQUARE}))
    with pytest.raises(RoiError, match=r"^f\.yaml: expected a mapping with keys map_name, "
                                       r"config, rois, got list$"):
        rois_from_dict([], source="f.yaml")
    with pytest.raises(RoiError, match=r'^ROI "1": type must not be empty$'):
        rois_from_dict(doc(entry(roi_type="")))


def test_validate_roi_built_in_code():
    with pytest.raises(RoiError, match=r'^ROI "x": vertex 1 must be \(x, y\) \(two numbers\), '
                                       r'got \(1, 2, 3\)$'):
        validate_roi(Roi("x", "1", "office", "m", [(0, 0), (1, 2, 3), (0, 1)]))
    with pytest.raises(RoiError, match=r"^ROI id must be a non-empty string, got 5$"):
        validate_roi(Roi(5, "1", "office", "m", [(0, 0), (1, 0), (0, 1)]))


def test_messages_are_one_line(tmp_path):
    path = write(tmp_path, "map_name: [\n")
    with pytest.raises(RoiError) as info:
        load_rois(path)
    assert "\n" not in str(info.value)


# --------------------------------------------------------------------------------------------
# bounds and queries
# --------------------------------------------------------------------------------------------


def test_check_bounds_warns_per_roi():
    inside = Roi("in", "1", "office", "m", [(1, 1), (2, 1), (2, 2)])
    edge = Roi("edge", "1", "office", "m", [(0, 0), (10, 0), (10, 5)])  # on the bounds: fine
    out = Roi("out", "1", "office", "m", [(9, 1), (10.5, 1), (11, 6), (9, 4)])
    warnings = check_bounds([inside, edge, out], (0.0, 0.0, 10.0, 5.0))
    assert warnings == ['ROI "out": vertex 1 (10.5, 1) and 1 more outside the map bounds '
                        'x 0..10, y 0..5']


def test_office_rois_inside_office_map():
    from bullet_floor_sim.sim.floormap import load_map

    fmap = load_map(os.path.join(ROOT, "worlds", "office", "map.yaml"))
    assert check_bounds(load_rois(OFFICE_ROIS), fmap.bounds()) == []


def test_roi_at_prefers_smallest():
    big = Roi("big", "1", "corridor", "m", [(0, 0), (10, 0), (10, 10), (0, 10)])
    small = Roi("small", "1", "office", "m", [(2, 2), (4, 2), (4, 4), (2, 4)])
    ell = Roi("ell", "1", "office", "m", [tuple(p) for p in L_SHAPE])
    assert roi_at([big, small], 3, 3) is small
    assert roi_at([small, big], 3, 3) is small
    assert roi_at([big, small], 5, 5) is big
    assert roi_at([big, small], 10, 10) is big  # boundary counts
    assert roi_at([big, small], 11, 5) is None
    # inside the L's bounding box but in its notch: not in the L
    assert roi_at([ell], 3, 3) is None
    assert roi_at([ell], 0.5, 3) is ell


def test_roi_at_office():
    rois = load_rois(OFFICE_ROIS)
    assert roi_at(rois, 2.0, 5.0).id == "5"      # office_1
    assert roi_at(rois, 5.0, 10.0).id == "1"     # corridor_west
    assert roi_at(rois, 2.65, 8.8).id == "5"     # office_1's doorway notch
    assert roi_at(rois, 4.7, 5.0) is None        # inside the wall between offices 1 and 2


def test_centroid_and_polygon():
    roi = Roi("ell", "1", "office", "m", [tuple(p) for p in L_SHAPE])
    # L = 4x1 bar (centroid (2, 0.5)) + 1x3 bar (centroid (0.5, 2.5)); areas 4 and 3
    assert centroid(roi) == pytest.approx(((4 * 2 + 3 * 0.5) / 7, (4 * 0.5 + 3 * 2.5) / 7))
    assert roi_polygon(roi).area == pytest.approx(7.0)


def test_random_point_inside_respects_margin():
    roi = Roi("ell", "1", "office", "m", [tuple(p) for p in L_SHAPE])
    poly = roi_polygon(roi)
    rng = np.random.default_rng(3)
    pts = [random_point_inside(roi, rng, margin=0.3) for _ in range(300)]
    for x, y in pts:
        assert poly.contains(Point(x, y)) and poly.exterior.distance(Point(x, y)) >= 0.3
    xs = np.array(pts)
    # both arms of the L are used (arm along x: y < 1, arm along y: x < 1)
    assert (xs[:, 0] > 2.0).any() and (xs[:, 1] > 2.0).any()
    # same seed, same points
    again = [random_point_inside(roi, np.random.default_rng(3), margin=0.3)]
    assert again[0] == pts[0]


def test_random_point_inside_is_free_callback():
    roi = Roi("sq", "1", "office", "m", [tuple(p) for p in SQUARE])
    rng = np.random.default_rng(0)
    calls = []

    def right_half(x, y):
        calls.append((x, y))
        return x > 3.0

    for _ in range(50):
        x, y = random_point_inside(roi, rng, margin=0.5, is_free=right_half)
        assert 3.0 < x <= 3.5 and 0.5 <= y <= 3.5
    assert len(calls) > 50  # some draws were refused by the callback


def test_random_point_inside_failures():
    thin = Roi("thin", "1", "corridor", "m", [(0, 0), (10, 0), (10, 0.5), (0, 0.5)])
    with pytest.raises(RoiError, match=r'^ROI "thin": no point lies 0.3 m inside it \(the region '
                                       r'is too narrow\)$'):
        random_point_inside(thin, np.random.default_rng(0), margin=0.3)
    with pytest.raises(RoiError, match=r'^ROI "thin": no acceptable point 0.1 m inside it after '
                                       r'20 tries \(20 of them inside but not free\)$'):
        random_point_inside(thin, np.random.default_rng(0), margin=0.1,
                            is_free=lambda x, y: False, max_tries=20)
    with pytest.raises(RoiError, match="margin must be a finite number >= 0"):
        random_point_inside(thin, np.random.default_rng(0), margin=-1.0)


def test_random_point_inside_office_rooms():
    rng = np.random.default_rng(7)
    for roi in load_rois(OFFICE_ROIS):
        x, y = random_point_inside(roi, rng, margin=0.5)
        assert math.isfinite(x) and roi_at([roi], x, y) is roi
