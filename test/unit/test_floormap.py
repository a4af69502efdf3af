"""map_server semantics, rectangle merging, mesh extrusion and bad-input errors (no ROS)."""
from __future__ import annotations

import math
import os

import numpy as np
import pytest
from PIL import Image

from bullet_floor_sim.errors import MapError
from bullet_floor_sim.sim.floormap import (load_map, map_from_grid, merge_rectangles, outline_segments,
                                            wall_mesh, wall_outline_mesh)

MAP_YAML = """image: {image}
resolution: {res}
origin: {origin}
negate: {negate}
occupied_thresh: 0.65
free_thresh: 0.196
{extra}"""


def write_map(tmp_path, pixels, mode=None, negate=0, res=0.05, origin="[0.0, 0.0, 0.0]",
              name="m.png", extra=""):
    """Write an image (rows top first) and a map.yaml; return the yaml path."""
    arr = np.asarray(pixels, dtype=np.uint8)
    Image.fromarray(arr).save(str(tmp_path / name))
    if mode:
        extra = "mode: %s\n%s" % (mode, extra)
    path = tmp_path / "map.yaml"
    path.write_text(MAP_YAML.format(image=name, res=res, origin=origin, negate=negate, extra=extra))
    return str(path)


def test_trinary_thresholds_match_map_server(tmp_path):
    # occ = (255 - v) / 255: 89 -> 0.651 (> 0.65, wall), 90 -> 0.647 (unknown),
    # 205 -> 0.19608 (not < 0.196, unknown), 206 -> 0.1922 (free), 0 wall, 254 free
    y = write_map(tmp_path, [[0, 89, 90, 205, 206, 254]], name="m.pgm")
    m = load_map(y)
    assert m.grid.tolist() == [[100, 100, -1, -1, 0, 0]]


def test_negate_flips_colours(tmp_path):
    # negated: occ = v / 255: 0 -> free, 254 -> wall, 128 -> 0.502 unknown
    m = load_map(write_map(tmp_path, [[0, 254, 128]], negate=1, name="m.pgm"))
    assert m.grid.tolist() == [[0, 100, -1]]


def test_image_top_row_is_last_grid_row(tmp_path):
    m = load_map(write_map(tmp_path, [[0, 254], [254, 254], [254, 254]], name="m.pgm"))
    assert m.height == 3 and m.width == 2
    assert m.grid[2, 0] == 100 and m.grid[0, 0] == 0
    # cell (col 0, row 2) is the top-left pixel: its centre is at (0.025, 0.125)
    x, y = m.cell_to_world(0, 2)
    assert (float(x), float(y)) == pytest.approx((0.025, 0.125))


def test_scale_mode_and_alpha(tmp_path):
    # scale: 128 -> occ 127/255 = 0.49804 -> 1 + 98 * (0.49804 - 0.196) / (0.65 - 0.196) = 66.2 -> 66;
    # alpha 0 -> unknown (map_server's 'alpha < 1.0'); alpha excluded from the mean
    px = np.array([[[128, 128, 128, 255], [128, 128, 128, 0], [0, 0, 0, 255]]], dtype=np.uint8)
    m = load_map(write_map(tmp_path, px, mode="scale"))
    assert m.grid.tolist() == [[66, -1, 100]]


def test_scale_mode_with_equal_thresholds(tmp_path):
    # occupied_thresh == free_thresh (allowed, as map_server allows it): nothing lies between
    # the two, so nothing scales (map_server would divide by zero); it used to raise
    # AttributeError on a float ratio. (0, 0, 0) -> occ 1.0 wall; (255, 255, 255) -> 0.0 free;
    # alpha 0 does not matter above occupied_thresh (map_server's order of tests)
    px = np.array([[[0, 0, 0, 255], [255, 255, 255, 255], [0, 0, 0, 0]]], dtype=np.uint8)
    Image.fromarray(px).save(str(tmp_path / "m.png"))
    (tmp_path / "map.yaml").write_text(
        "image: m.png\nresolution: 0.05\norigin: [0.0, 0.0, 0.0]\nnegate: 0\n"
        "occupied_thresh: 0.5\nfree_thresh: 0.5\nmode: scale\n")
    assert load_map(str(tmp_path / "map.yaml")).grid.tolist() == [[100, 0, 100]]


def test_rgb_mean_of_channels(tmp_path):
    # (255, 0, 0) -> mean 85 -> occ 0.667 -> wall; (255, 255, 0) -> mean 170 -> 0.333 unknown
    px = np.array([[[255, 0, 0], [255, 255, 0], [255, 255, 255]]], dtype=np.uint8)
    assert load_map(write_map(tmp_path, px)).grid.tolist() == [[100, -1, 0]]


def test_trinary_with_alpha_averages_all_channels(tmp_path):
    # trinary keeps alpha in the mean, as map_server does: (0, 0, 0, 255) -> mean 63.75 ->
    # occ 0.75 -> wall; (254, 254, 254, 255) -> free
    px = np.array([[[0, 0, 0, 255], [254, 254, 254, 255]]], dtype=np.uint8)
    assert load_map(write_map(tmp_path, px)).grid.tolist() == [[100, 0]]


def test_raw_mode_copies_values(tmp_path):
    m = load_map(write_map(tmp_path, [[0, 100, 250]], mode="raw", name="m.pgm"))
    assert m.grid.tolist() == [[0, 100, 250 - 256]]


def test_origin_with_yaw(tmp_path):
    y = write_map(tmp_path, [[254, 254], [254, 254]], res=0.5,
                  origin="[1.0, 2.0, %r]" % (math.pi / 2))
    m = load_map(y)
    x, yy = m.cell_to_world(1, 0)  # u = 0.75, v = 0.25 -> rotated 90 deg: (-0.25, 0.75)
    assert (float(x), float(yy)) == pytest.approx((0.75, 2.75))
    col, row = m.world_to_cell(0.75, 2.75)
    assert (int(col), int(row)) == (1, 0)
    assert m.bounds() == pytest.approx((0.0, 2.0, 1.0, 3.0))


def test_merge_rectangles_covers_every_cell_once():
    rng = np.random.default_rng(3)
    for _ in range(20):
        mask = rng.random((37, 53)) < 0.3
        cover = np.zeros(mask.shape, dtype=int)
        for c0, r0, c1, r1 in merge_rectangles(mask):
            cover[r0:r1, c0:c1] += 1
        assert np.array_equal(cover, mask.astype(int))


def test_merge_rectangles_l_shape_is_two_rectangles():
    mask = np.zeros((6, 6), dtype=bool)
    mask[0:2, 0:6] = True   # a 2-cell thick horizontal wall
    mask[2:6, 0:2] = True   # and a vertical one below its left end
    assert merge_rectangles(mask) == [(0, 0, 6, 2), (0, 2, 2, 6)]


def test_wall_mesh_extrudes_rectangles():
    grid = np.zeros((4, 4), dtype=np.int8)
    grid[1:3, 1:3] = 100
    m = map_from_grid(grid, 0.5, (10.0, 20.0, 0.0))
    verts, idx = wall_mesh(m, 2.5)
    assert verts.shape == (8, 3) and idx.shape == (30,)
    assert verts[:, 0].min() == pytest.approx(10.5) and verts[:, 0].max() == pytest.approx(11.5)
    assert verts[:, 1].min() == pytest.approx(20.5) and verts[:, 1].max() == pytest.approx(21.5)
    assert sorted(set(verts[:, 2])) == [0.0, 2.5]
    with pytest.raises(MapError, match="wall height must be a positive number"):
        wall_mesh(m, 0.0)


def test_outline_of_l_shape_is_its_six_edges_only():
    mask = np.zeros((6, 6), dtype=bool)
    mask[0:2, 0:6] = True   # the L above: two rectangles share the edge (0,2)-(2,2)
    mask[2:6, 0:2] = True
    segs = sorted(map(tuple, outline_segments(mask).tolist()))
    assert segs == sorted([(0, 0, 6, 0), (2, 2, 6, 2), (0, 6, 2, 6),     # along rows
                           (0, 0, 0, 6), (2, 2, 2, 6), (6, 0, 6, 2)])    # along columns


def test_outline_of_cells_touching_at_a_corner_has_all_eight_sides():
    mask = np.array([[True, False], [False, True]])
    segs = outline_segments(mask)
    # the two squares' sides on the middle lines run on into each other: one segment each
    assert sorted(map(tuple, segs.tolist())) == sorted([
        (0, 0, 1, 0), (0, 1, 2, 1), (1, 2, 2, 2), (0, 0, 0, 1), (1, 0, 1, 2), (2, 1, 2, 2)])
    total = np.abs(segs[:, 2] - segs[:, 0]) + np.abs(segs[:, 3] - segs[:, 1])
    assert total.sum() == 8
    assert outline_segments(np.zeros((3, 3), dtype=bool)).shape == (0, 4)


def test_wall_outline_mesh_stands_quads_on_the_outline():
    grid = np.zeros((4, 4), dtype=np.int8)
    grid[1:3, 1:3] = 100
    m = map_from_grid(grid, 0.5, (10.0, 20.0, 0.0))
    verts, idx = wall_outline_mesh(m, 2.5, outline_segments(m.occupied))
    assert verts.shape == (16, 3) and idx.shape == (24,)    # four sides, no top
    assert verts[:, 0].min() == pytest.approx(10.5) and verts[:, 0].max() == pytest.approx(11.5)
    assert verts[:, 1].min() == pytest.approx(20.5) and verts[:, 1].max() == pytest.approx(21.5)
    tri = verts[idx.reshape(-1, 3)]
    # every triangle is vertical: its normal has no z component
    normal = np.cross(tri[:, 1] - tri[:, 0], tri[:, 2] - tri[:, 0])
    assert np.allclose(normal[:, 2], 0.0) and np.all(np.abs(normal[:, :2]).sum(axis=1) > 0)
    assert sorted(set(verts[:, 2])) == [0.0, 2.5]


def test_unknown_cells_are_not_walls(tmp_path):
    m = load_map(write_map(tmp_path, [[205, 205], [205, 0]], name="m.pgm"))
    assert m.rectangles() == [(1, 0, 2, 1)]


# ------------------------------------------------------------------------------- bad input
def test_missing_yaml(tmp_path):
    with pytest.raises(MapError, match=r"nope\.yaml: map file not found"):
        load_map(str(tmp_path / "nope.yaml"))


def test_missing_key(tmp_path):
    y = write_map(tmp_path, [[0]], name="m.pgm")
    text = open(y).read().replace("free_thresh: 0.196\n", "")
    open(y, "w").write(text)
    with pytest.raises(MapError, match=r"map\.yaml: missing required key\(s\): free_thresh"):
        load_map(y)


def test_missing_image(tmp_path):
    y = write_map(tmp_path, [[0]], name="m.pgm")
    os.remove(str(tmp_path / "m.pgm"))
    with pytest.raises(MapError, match=r"map\.yaml: image file not found: .*m\.pgm"):
        load_map(y)


def test_corrupt_image(tmp_path):
    y = write_map(tmp_path, [[0]], name="m.pgm")
    (tmp_path / "m.pgm").write_bytes(b"P5\n12 garbage\x00\x01")
    with pytest.raises(MapError, match=r"map\.yaml: image .*m\.pgm is not a readable image"):
        load_map(y)


def test_zero_resolution(tmp_path):
    y = write_map(tmp_path, [[0]], name="m.pgm", res=0)
    with pytest.raises(MapError, match=r"map\.yaml: resolution must be a positive number"):
        load_map(y)


def test_non_square_pixels(tmp_path):
    y = write_map(tmp_path, [[0]], name="m.pgm", res="[0.05, 0.1]")
    with pytest.raises(MapError, match=r"map\.yaml: non-square pixels \(resolution \[0\.05, 0\.1\]\)"):
        load_map(y)


def test_not_yaml(tmp_path):
    y = tmp_path / "map.yaml"
    y.write_text("image: [unclosed\nresolution: 0.05\n")
    with pytest.raises(MapError, match=r"map\.yaml: not valid YAML \(line \d+\)"):
        load_map(str(y))


def test_bad_origin_and_unknown_key_and_thresholds(tmp_path):
    y = write_map(tmp_path, [[0]], name="m.pgm", origin="[0, 0]")
    with pytest.raises(MapError, match=r"origin must be \[x, y, yaw\]"):
        load_map(y)
    y = write_map(tmp_path, [[0]], name="m.pgm", extra="colour: red\n")
    with pytest.raises(MapError, match=r"unknown key\(s\): colour"):
        load_map(y)
    y = write_map(tmp_path, [[0]], name="m.pgm", mode="fancy")
    with pytest.raises(MapError, match=r"mode must be one of trinary/scale/raw, got 'fancy'"):
        load_map(y)


def test_crop_known_keeps_the_known_cells_and_a_margin_in_place():
    """A 100 x 80 map at 0.1 m, all unknown but a 3 x 4 block at rows 40-42, cols 50-53:
    cropped with a 0.2 m margin it is 7 x 8 cells, and every cell keeps its place."""
    from bullet_floor_sim.sim.floormap import crop_known

    grid = np.full((80, 100), -1, dtype=np.int8)
    grid[40:43, 50:54] = 0
    grid[41, 52] = 100
    fmap = map_from_grid(grid, 0.1, (-3.0, 2.0, 0.0))
    small = crop_known(fmap, 0.2)
    assert small.grid.shape == (7, 8)
    assert small.origin == pytest.approx((-3.0 + 4.8, 2.0 + 3.8, 0.0))
    assert small.value_at(*[float(v) for v in fmap.cell_to_world(52, 41)]) == 100
    assert (small.grid == 0).sum() == 11 and (small.grid == -1).sum() == 7 * 8 - 12
    assert crop_known(fmap, 100.0) is fmap                     # nothing cut off
    unknown = map_from_grid(np.full((5, 5), -1, dtype=np.int8), 0.1)
    assert crop_known(unknown, 0.2) is unknown
