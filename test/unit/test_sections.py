"""Cross-sections measured through a probe, checked, and beams clipped to them (pure)."""
from __future__ import annotations

import math

import numpy as np

from bullet_floor_sim.sim.sections import Section, check_section, clip_beams, measure_section


def polygon_probe(parts):
    """A probe for a body made of convex polygons (counter-clockwise corner lists): the
    distance to the first one each ray meets, with the normal of the edge it enters by."""
    def probe(starts, dirs, length):
        dist = np.full(len(starts), np.inf)
        normal = np.zeros((len(starts), 2))
        for k, ((ox, oy), (dx, dy)) in enumerate(zip(starts.tolist(), dirs.tolist())):
            for pts in parts:
                t_in, t_out, n_in = -math.inf, math.inf, None
                for (ax, ay), (bx, by) in zip(pts, pts[1:] + pts[:1]):
                    e = math.hypot(bx - ax, by - ay)
                    nx, ny = (by - ay) / e, -(bx - ax) / e
                    nd = nx * dx + ny * dy
                    num = nx * (ax - ox) + ny * (ay - oy)
                    if nd == 0.0:
                        if num < 0:
                            t_in, t_out = math.inf, -math.inf
                        continue
                    t = num / nd
                    if nd < 0 and t > t_in:
                        t_in, n_in = t, (nx, ny)
                    elif nd > 0:
                        t_out = min(t_out, t)
                if t_in <= t_out and 0 <= t_in <= length and t_in < dist[k]:
                    dist[k], normal[k] = t_in, n_in
        return dist, normal
    return probe


HEXAGON = [(0.35 + 0.3 * math.cos(a), -0.1 + 0.3 * math.sin(a))
           for a in np.radians(np.arange(10.0, 370.0, 60.0))]


def test_a_convex_body_is_measured_to_its_corners():
    probe = polygon_probe([HEXAGON])
    sec = measure_section(probe, reach=0.8)
    assert sec is not None and len(sec.vertices) == 6
    for cx, cy in HEXAGON:   # every true corner is a corner of the measured polygon
        assert np.hypot(sec.vertices[:, 0] - cx, sec.vertices[:, 1] - cy).min() < 1e-6
    ok, summary = check_section(sec, probe, reach=0.8)
    assert ok, summary
    assert "6 edges" in summary and " 0 disagree" in summary


def test_a_body_that_is_not_convex_fails_the_check():
    # an L: two rectangles; the polygon measured can only be its convex hull
    ell = [[(0.0, 0.0), (0.6, 0.0), (0.6, 0.15), (0.0, 0.15)],
           [(0.0, 0.0), (0.15, 0.0), (0.15, 0.6), (0.0, 0.6)]]
    probe = polygon_probe(ell)
    sec = measure_section(probe, reach=0.9)
    if sec is not None:
        ok, summary = check_section(sec, probe, reach=0.9)
        assert not ok and " 0 disagree" not in summary, summary


def test_no_body_no_section():
    assert measure_section(polygon_probe([]), reach=0.5) is None


def test_clip_beams_enters_and_leaves_a_square():
    sq = Section(np.array([[1.0, -1.0], [3.0, -1.0], [3.0, 1.0], [1.0, 1.0]]))
    origins = np.array([[0.0, 0.0], [0.0, 0.0], [2.0, 0.0], [0.0, 1.5], [0.0, 1.0]])
    dirs = np.array([[1.0, 0.0], [-1.0, 0.0], [0.0, 1.0], [1.0, 0.0], [1.0, 0.0]])
    n = np.repeat(sq.normals[None], len(origins), 0)
    c = np.repeat(sq.offsets[None], len(origins), 0)
    t_in, t_out = clip_beams(origins, dirs, n, c)
    np.testing.assert_allclose(t_in[:1], [1.0])
    np.testing.assert_allclose(t_out[:1], [3.0])
    assert t_out[1] < 0.0                       # the square is behind the beam
    assert t_in[2] < 0.0 < t_out[2] == 1.0      # starts inside, leaves at y = 1
    assert t_in[3] > t_out[3]                   # passes above it
    assert t_in[4] <= t_out[4]                  # runs along its top edge: touching


def test_clip_beams_equals_the_half_plane_formula_on_random_polygons():
    # Cyrus-Beck by its formula in numpy: each half-plane n.x <= c cuts the beam at
    # t = (c - n.o) / (n.d), entering where n.d < 0 and leaving where n.d > 0; a beam
    # parallel to an edge (n.d = 0) and outside it misses. Padding rows (n = 0, c = 1)
    # constrain nothing. clip_beams (compiled where numba is) must give it to the bit.
    rng = np.random.default_rng(7)
    checked = crossing = 0
    for trial in range(60):
        p, k = int(rng.integers(1, 300)), int(rng.integers(3, 10))
        o = rng.uniform(-2.0, 2.0, (p, 2))
        a = rng.uniform(-math.pi, math.pi, p)
        d = np.c_[np.cos(a), np.sin(a)]
        n = rng.normal(size=(p, k, 2))
        c = rng.uniform(-0.5, 1.0, (p, k))
        n[:, 0] = (1.0, 0.0)             # an axis-aligned edge, and beams parallel to it
        d[::7] = (0.0, 1.0)
        c[::3, 0] = -5.0                 # ... some of them outside it
        n[:, -1], c[:, -1] = 0.0, 1.0    # a padding row
        nd = n[..., 0] * d[:, None, 0] + n[..., 1] * d[:, None, 1]
        num = c - (n[..., 0] * o[:, None, 0] + n[..., 1] * o[:, None, 1])
        with np.errstate(divide="ignore", invalid="ignore"):
            t = num / nd
        want_in = np.max(np.where(nd < 0.0, t, -np.inf), axis=1)
        want_out = np.min(np.where(nd > 0.0, t, np.inf), axis=1)
        want_out[np.any((nd == 0.0) & (num < 0.0), axis=1)] = -np.inf
        t_in, t_out = clip_beams(o, d, n, c)
        assert np.array_equal(t_in, want_in) and np.array_equal(t_out, want_out)
        checked += p
        crossing += int(np.sum((t_in <= t_out) & np.isfinite(t_in) & np.isfinite(t_out)))
    assert checked > 3000 and crossing > 100      # beams that cross a polygon, not only misses
