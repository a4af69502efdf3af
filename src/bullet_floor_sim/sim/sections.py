"""Horizontal cross-sections of robot bodies as convex polygons, and lidar beams against them.

A lidar beam is horizontal, so whether and where it meets another robot depends only on that
robot's cross-section at the beam's height. For the usual robot (an upright prism, boxes) the
section is convex, and a beam against a convex polygon is a few multiply-adds (Cyrus-Beck
clipping), where Bullet's ray test against a convex hull runs an iterative convex cast: about
2.2 us a beam here, a third of a scan tick with 10 robots.

``measure_section`` builds the polygon from Bullet itself (``World`` passes it a function that
casts rays at one body alone): rays toward the body from all around give points on its
boundary with their normals, whose tangent lines bound the section from outside; every corner
of the polygon so far is then probed by a ray along its bisector, and cut by the tangent
there until each corner lies on the body (to ``tol``). Collision margins and curved surfaces
come out as they are in Bullet. ``check_section`` then casts random beams at the body and
compares: a section that is not convex, or not the same at every bearing, fails, and the
caller keeps casting those beams with Bullet.
"""
from __future__ import annotations

import math
from typing import Callable, Optional, Tuple

import numpy as np

__all__ = ["Section", "measure_section", "check_section", "clip_beams", "clip_to_sections",
           "pad_sections"]

#: A probe: (ray starts (M, 2), unit directions (M, 2), length) -> (distance (M,), inf for no
#: hit; unit 2-D normals (M, 2) at the hits), in the body's own frame.
Probe = Callable[[np.ndarray, np.ndarray, float], Tuple[np.ndarray, np.ndarray]]


class Section:
    """A convex polygon as half-planes ``normals @ p <= offsets`` (outward unit normals),
    in the body's base_footprint frame.

    Attributes:
        normals: (K, 2); offsets: (K,); vertices: (K, 2) counter-clockwise.
        radius: largest distance of a vertex from the origin.
    """

    def __init__(self, vertices: np.ndarray) -> None:
        v = np.asarray(vertices, dtype=float).reshape(-1, 2)
        e = np.roll(v, -1, axis=0) - v
        n = np.column_stack((e[:, 1], -e[:, 0]))
        n /= np.linalg.norm(n, axis=1)[:, None]
        self.vertices = v
        self.normals = n
        self.offsets = np.einsum("ij,ij->i", n, v)
        self.radius = float(np.hypot(v[:, 0], v[:, 1]).max())


def _clip(poly: np.ndarray, n: np.ndarray, c: float) -> np.ndarray:
    """The part of a convex polygon where n . p <= c (Sutherland-Hodgman, one plane)."""
    s = poly @ n - c
    out = []
    k = len(poly)
    for i in range(k):
        j = (i + 1) % k
        if s[i] <= 0.0:
            out.append(poly[i])
        if (s[i] < 0.0 < s[j]) or (s[j] < 0.0 < s[i]):
            t = s[i] / (s[i] - s[j])
            out.append(poly[i] + t * (poly[j] - poly[i]))
    return np.array(out).reshape(-1, 2)


def _simplify(poly: np.ndarray, eps: float = 1e-9) -> np.ndarray:
    """Drop repeated and collinear vertices."""
    keep = []
    k = len(poly)
    for i in range(k):
        a, b, c = poly[i - 1], poly[i], poly[(i + 1) % k]
        if np.hypot(*(b - a)) < eps:
            continue
        cross = (b[0] - a[0]) * (c[1] - b[1]) - (b[1] - a[1]) * (c[0] - b[0])
        if abs(cross) > eps * eps:
            keep.append(b)
    return np.array(keep).reshape(-1, 2)


def measure_section(probe: Probe, reach: float, directions: int = 72, tol: float = 5e-5,
                    rounds: int = 12) -> Optional[Section]:
    """The section of a body as Bullet sees it (see the module doc); None when the probes
    find no body or do not close a convex polygon.

    Args:
        probe: casts rays at the body alone (see ``Probe``).
        reach: radius of a circle about the origin that holds the whole section.
        directions: rays toward the origin from this many bearings to start with.
        tol: a corner is on the body when the bisector ray hits within this distance of it.
        rounds: corner refinement passes.
    """
    far = 2.0 * reach + 1.0
    a = np.linspace(-math.pi, math.pi, directions, endpoint=False)
    u = np.column_stack((np.cos(a), np.sin(a)))
    dist, normal = probe(u * far, -u, far)
    ok = np.isfinite(dist)
    if ok.sum() < 3:
        return None
    pts = u[ok] * far - u[ok] * dist[ok, None]
    poly = np.array([[-far, -far], [far, -far], [far, far], [-far, far]], dtype=float)
    for p, n in zip(pts, normal[ok]):
        poly = _clip(poly, n, float(n @ p))
    for _ in range(rounds):
        poly = _simplify(poly)
        if len(poly) < 3:
            return None
        prev, nxt = np.roll(poly, 1, axis=0), np.roll(poly, -1, axis=0)
        e1 = poly - prev
        e2 = nxt - poly
        n1 = np.column_stack((e1[:, 1], -e1[:, 0])) / np.hypot(e1[:, 0], e1[:, 1])[:, None]
        n2 = np.column_stack((e2[:, 1], -e2[:, 0])) / np.hypot(e2[:, 0], e2[:, 1])[:, None]
        b = n1 + n2
        b /= np.hypot(b[:, 0], b[:, 1])[:, None]           # outward bisector at each corner
        starts = poly + b * far
        dist, normal = probe(starts, -b, 2.0 * far)
        if not np.isfinite(dist).all():
            return None                                    # a corner ray missed: not convex
        hits = starts - b * dist[:, None]
        gap = dist - far                                   # how far inside the corner the hit is
        cut = gap > tol
        if not cut.any():
            return Section(poly)
        for p, n in zip(hits[cut], normal[cut]):
            poly = _clip(poly, n, float(n @ p))
    return None


def clip_beams(origins: np.ndarray, dirs: np.ndarray, normals: np.ndarray,
               offsets: np.ndarray) -> Tuple[np.ndarray, np.ndarray]:
    """Where each beam enters and leaves its convex polygon (Cyrus-Beck).

    Args:
        origins, dirs: (P, 2) beam origins and unit directions, in the polygon's frame.
        normals, offsets: (P, K, 2) and (P, K) half-planes of each beam's polygon (padding
            rows: normal 0, offset 1).

    Returns:
        (t_in, t_out) distances along the beams (P,); t_in > t_out when the line misses.
    """
    p = len(origins)
    k = np.shape(offsets)[-1]       # (half-planes shared by every beam broadcast, as numpy did)
    t_in, t_out = np.empty(p), np.empty(p)
    _cyrus_beck(np.ascontiguousarray(origins, dtype=float), np.ascontiguousarray(dirs, dtype=float),
                np.ascontiguousarray(np.broadcast_to(normals, (p, k, 2)), dtype=float),
                np.ascontiguousarray(np.broadcast_to(offsets, (p, k)), dtype=float), t_in, t_out)
    return t_in, t_out


def _cyrus_beck(origins, dirs, normals, offsets, t_in, t_out):  # type: ignore
    """``clip_beams``'s loop, into ``t_in`` and ``t_out`` (compiled by numba where it is
    installed: the same arithmetic as numpy's on (P, K) arrays, without their temporaries)."""
    for i in range(origins.shape[0]):
        t_in[i], t_out[i] = cyrus_beck_one(origins[i, 0], origins[i, 1], dirs[i, 0], dirs[i, 1],
                                           normals[i], offsets[i])


def cyrus_beck_one(ox, oy, dx, dy, normals, offsets):  # type: ignore
    """Where the beam from (ox, oy) along the unit (dx, dy) enters and leaves the convex
    polygon of half-planes ``normals`` (K, 2), ``offsets`` (K,) (compiled with numba as
    ``_cyrus_beck``, which it serves, and ``clip_to_sections``)."""
    lo, hi = -math.inf, math.inf
    outside = False
    for k in range(normals.shape[0]):
        nd = normals[k, 0] * dx + normals[k, 1] * dy
        num = offsets[k] - (normals[k, 0] * ox + normals[k, 1] * oy)
        if nd < 0.0:
            lo = max(lo, num / nd)
        elif nd > 0.0:
            hi = min(hi, num / nd)
        elif num < 0.0:     # parallel to an edge, outside it
            outside = True
    return lo, (-math.inf if outside else hi)


def clip_to_sections(g, j, sec, pose, cos_yaw, sin_yaw, origins, dirs, start, reach, normals,
                offsets, dist, hit):  # type: ignore
    """robot_beams' clipping: beam g[p] (``origins``, ``dirs``, ``start``) in robot j[p]'s
    frame (``pose``, its yaw's cosine and sine), clipped to section sec[p] (padded
    ``normals``, ``offsets``); where it meets the section after its start and before
    ``reach``, ``dist`` and ``hit`` take the nearest meeting (a beam that starts inside
    another robot meets it at once). In this module with ``cyrus_beck_one``: numba's cache
    sees changes to the caller's own file only."""
    for p in range(g.shape[0]):
        k, r = g[p], j[p]
        c, s = cos_yaw[r], sin_yaw[r]
        ox, oy = origins[k, 0] - pose[r, 0], origins[k, 1] - pose[r, 1]
        dx, dy = dirs[k, 0], dirs[k, 1]
        t_in, t_out = cyrus_beck_one(c * ox + s * oy, c * oy - s * ox, c * dx + s * dy,
                                     c * dy - s * dx, normals[sec[p]], offsets[sec[p]])
        t = max(t_in, start[k])
        if t_in <= t_out and t_out > start[k] and t < reach[k] and (not hit[k] or t < dist[k]):
            dist[k], hit[k] = t, True


try:   # as sim/grid_rays.py: compiled where numba is installed (the venv's requirements)
    import numba
    cyrus_beck_one = numba.njit(cache=True)(cyrus_beck_one)
    _cyrus_beck = numba.njit(cache=True)(_cyrus_beck)
    clip_to_sections = numba.njit(cache=True)(clip_to_sections)
except ImportError:   # pragma: no cover
    pass


def pad_sections(sections) -> Tuple[np.ndarray, np.ndarray]:
    """Stack sections' half-planes into (S, K, 2) normals and (S, K) offsets, padded with
    rows that constrain nothing (normal 0, offset 1)."""
    k = max((len(s.offsets) for s in sections), default=1)
    normals = np.zeros((len(sections), k, 2))
    offsets = np.ones((len(sections), k))
    for i, s in enumerate(sections):
        normals[i, :len(s.offsets)] = s.normals
        offsets[i, :len(s.offsets)] = s.offsets
    return normals, offsets


def check_section(section: Section, probe: Probe, reach: float, rays: int = 2000,
                  tol: float = 1.5e-3, seed: int = 0) -> Tuple[bool, str]:
    """Cast random beams at the body with Bullet and through the polygon, and compare.

    Beams start outside ``reach`` and cross the circle at random offsets, so they meet the
    section from every side, graze it, or miss. Every point where Bullet's beam hits must lie
    within ``tol`` of the polygon's boundary, and every beam that passes farther than ``tol``
    from the boundary must hit or miss in both. (Distances along a grazing beam are not
    compared: Bullet's convex cast rounds a corner up to about 0.5 mm wider than the hull
    and its 1 mm margin, which moves a beam nearly parallel to an edge by centimetres.)

    Returns:
        (agrees, a one-line summary for the log).
    """
    rng = np.random.default_rng(seed)
    far = 2.0 * reach + 1.0
    a = rng.uniform(-math.pi, math.pi, rays)
    d = -np.column_stack((np.cos(a), np.sin(a)))
    side = np.column_stack((-d[:, 1], d[:, 0])) * rng.uniform(-reach, reach, rays)[:, None]
    starts = -d * far + side
    dist, _ = probe(starts, d, 2.0 * far)
    n = np.repeat(section.normals[None], rays, 0)
    c = np.repeat(section.offsets[None], rays, 0)
    t_in, t_out = clip_beams(starts, d, n, c)
    t_big, o_big = clip_beams(starts, d, n, c + tol)
    t_small, o_small = clip_beams(starts, d, n, c - tol)
    graze = (t_big <= o_big) != (t_small <= o_small)
    hit_b, hit_m = np.isfinite(dist), t_in <= t_out
    wrong = (hit_b != hit_m) & ~graze
    pts = starts[hit_b] + d[hit_b] * dist[hit_b, None]
    off = np.max(pts @ section.normals.T - section.offsets[None, :], axis=1) if len(pts) else \
        np.zeros(0)
    err = float(np.abs(off).max()) if len(off) else 0.0
    summary = ("%d edges, %d beams: %d hits, %d grazing, %d disagree, Bullet's hits within "
               "%.2g m of the edges" % (len(section.offsets), rays, int(hit_b.sum()),
                                        int(graze.sum()), int(wrong.sum()), err))
    return (not wrong.any()) and err <= tol and hit_b.sum() > rays // 10, summary
