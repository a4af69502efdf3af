"""Which regions of interest are neighbours (the seed's vertex rule, or shared edges), and the
seed's transition rule over them. See the package doc."""
from __future__ import annotations

from typing import Any, Dict, Iterable, List, Sequence, Set, Tuple

import numpy as np

from ...data.rois import Roi


MODES = ("vertex", "edge")
_SLACK = 1e-9  # metres: |dx| = 0.2 written in decimal must count as within tol = 0.2


# --------------------------------------------------------------------------------------------
# adjacency
# --------------------------------------------------------------------------------------------


def vertex_adjacency(polygons: Sequence[Sequence[Tuple[float, float]]],
                     tol: float = 0.2) -> List[Set[int]]:
    """The seed rule: polygons k and m are neighbours when a vertex of k and a vertex of m are
    within ``tol`` in both x and y.

    Args:
        polygons: vertex lists (any number of vertices each).
        tol: metres.

    Returns:
        For each polygon, the set of indices of its neighbours (never itself).
    """
    from scipy.spatial import cKDTree  # local: only the chain needs scipy

    _check_tol(tol)
    n = len(polygons)
    neighbours = [set() for _ in range(n)]  # type: List[Set[int]]
    counts = [len(p) for p in polygons]
    if n < 2 or sum(counts) == 0:
        return neighbours
    pts = np.concatenate([np.asarray(p, dtype=float).reshape(-1, 2) for p in polygons if len(p)])
    owner = np.repeat(np.arange(n), counts)
    pairs = cKDTree(pts).query_pairs(tol + _SLACK, p=np.inf)
    if not pairs:
        return neighbours
    idx = np.array(sorted(pairs), dtype=np.intp)
    a, b = owner[idx[:, 0]], owner[idx[:, 1]]
    keep = a != b
    for k, m in set(zip(a[keep].tolist(), b[keep].tolist())):
        neighbours[k].add(m)
        neighbours[m].add(k)
    return neighbours


def edge_adjacency(polygons: Sequence[Sequence[Tuple[float, float]]], tol: float = 0.2,
                   min_shared: float = 0.8) -> List[Set[int]]:
    """Polygons are neighbours when their boundaries run within ``tol`` of each other over one
    continuous stretch at least ``min_shared`` long (a doorway); touching corners do not count.

    Args:
        polygons: vertex lists (any number of vertices each, at least 3).
        tol: metres; walls this far apart still count as shared.
        min_shared: metres; shortest shared stretch that connects two regions.

    Returns:
        For each polygon, the set of indices of its neighbours (never itself).
    """
    import shapely
    from shapely.strtree import STRtree

    _check_tol(tol)
    if not min_shared > 0.0:
        raise ValueError("min_shared must be > 0 m, got %r" % (min_shared,))
    n = len(polygons)
    neighbours = [set() for _ in range(n)]  # type: List[Set[int]]
    if n < 2:
        return neighbours
    rings = [np.asarray(p, dtype=float).reshape(-1, 2) for p in polygons]
    lo = np.array([r.min(axis=0) for r in rings]) - tol - _SLACK
    hi = np.array([r.max(axis=0) for r in rings]) + tol + _SLACK
    boxes = shapely.box(lo[:, 0], lo[:, 1], hi[:, 0], hi[:, 1])
    tree = STRtree(boxes)
    src, dst = tree.query(boxes, predicate="intersects")
    segs = [_segments(r) for r in rings]
    for k, m in zip(src.tolist(), dst.tolist()):
        if k < m and min(_shared_run(segs[k], segs[m], tol),
                         _shared_run(segs[m], segs[k], tol)) >= min_shared - _SLACK:
            neighbours[k].add(m)
            neighbours[m].add(k)
    return neighbours


def _segments(ring: np.ndarray) -> Tuple[np.ndarray, ...]:
    """A closed ring's non-degenerate segments: starts, ends, unit directions, normals, lengths."""
    end = np.roll(ring, -1, axis=0)
    seg = end - ring
    length = np.hypot(seg[:, 0], seg[:, 1])
    good = length > 0.0
    d = seg[good] / length[good][:, None]
    nrm = np.stack([-d[:, 1], d[:, 0]], axis=1)
    return ring[good], end[good], d, nrm, length[good]


def _shared_run(a: Tuple[np.ndarray, ...], b: Tuple[np.ndarray, ...], tol: float) -> float:
    """Longest continuous stretch of a's boundary that runs within tol of b's boundary.

    For every pair (segment s of a, segment t of b): the part of t inside the band of
    half-width tol around s's line, projected onto s and clipped to s. The pieces are merged
    along a's boundary (across vertices too) and the longest run is returned.

    Args:
        a, b: rings as returned by _segments.
    """
    p0, _, d, nrm, length = a
    q0, q1 = b[0], b[1]
    r0 = q0[None, :, :] - p0[:, None, :]                         # (Na, Nb, 2)
    r1 = q1[None, :, :] - p0[:, None, :]
    h0 = r0[..., 0] * nrm[:, None, 0] + r0[..., 1] * nrm[:, None, 1]  # lateral offsets
    h1 = r1[..., 0] * nrm[:, None, 0] + r1[..., 1] * nrm[:, None, 1]
    u0 = r0[..., 0] * d[:, None, 0] + r0[..., 1] * d[:, None, 1]      # positions along s
    u1 = r1[..., 0] * d[:, None, 0] + r1[..., 1] * d[:, None, 1]
    dh = h1 - h0
    flat = dh == 0.0  # t parallel to s: all of it in the band or none of it
    safe = np.where(flat, 1.0, dh)
    ta, tb = (-tol - h0) / safe, (tol - h0) / safe
    inside = np.abs(h0) <= tol
    t_lo = np.where(flat, np.where(inside, 0.0, 1.0), np.maximum(0.0, np.minimum(ta, tb)))
    t_hi = np.where(flat, np.where(inside, 1.0, 0.0), np.minimum(1.0, np.maximum(ta, tb)))
    ua, ub = u0 + (u1 - u0) * t_lo, u0 + (u1 - u0) * t_hi
    s_lo = np.minimum(np.maximum(np.minimum(ua, ub), 0.0), length[:, None])
    s_hi = np.minimum(np.maximum(np.maximum(ua, ub), 0.0), length[:, None])
    keep = (t_hi > t_lo) & (s_hi > s_lo + 1e-12)
    if not keep.any():
        return 0.0
    eps = 1e-9
    runs: List[List[Any]] = []  # (segment, lo, hi) merged per segment, in ring order
    for k in np.flatnonzero(keep.any(axis=1)).tolist():
        for lo, hi in sorted(zip(s_lo[k][keep[k]].tolist(), s_hi[k][keep[k]].tolist())):
            if runs and runs[-1][0] == k and lo <= runs[-1][2] + eps:
                runs[-1][2] = max(runs[-1][2], hi)
            else:
                runs.append([k, lo, hi])
    # join runs that continue across a vertex onto the next segment (cyclically)
    m = len(length)
    chains: List[List[Any]] = []  # [length, first run, last run]
    for run in runs:
        if chains:
            last = chains[-1][2]
            if (run[0] == (last[0] + 1) % m and last[2] >= length[last[0]] - eps
                    and run[1] <= eps):
                chains[-1][0] += run[2] - run[1]
                chains[-1][2] = run
                continue
        chains.append([run[2] - run[1], run, run])
    if len(chains) > 1:
        first, last = chains[0][1], chains[-1][2]
        if (first[0] == (last[0] + 1) % m and last[2] >= length[last[0]] - eps
                and first[1] <= eps):
            chains[0][0] += chains.pop()[0]
    return float(max(c[0] for c in chains))


def roi_adjacency(rois: Sequence[Roi], tol: float = 0.2, mode: str = "vertex",
                  min_shared: float = 0.8) -> Dict[str, List[str]]:
    """Neighbours of each ROI by id (in ROI order), by the vertex rule or the edge rule.

    Raises:
        ValueError: unknown mode or bad tolerance.
    """
    polygons = [r.vertices for r in rois]
    if mode == "vertex":
        nb = vertex_adjacency(polygons, tol)
    elif mode == "edge":
        nb = edge_adjacency(polygons, tol, min_shared)
    else:
        raise ValueError("mode must be one of %s, got %r" % ("/".join(MODES), mode))
    return {r.id: [rois[m].id for m in sorted(nb[k])] for k, r in enumerate(rois)}


def _check_tol(tol: float) -> None:
    if not (isinstance(tol, (int, float)) and 0.0 <= tol < float("inf")):
        raise ValueError("tol must be a finite number of metres >= 0, got %r" % (tol,))


# --------------------------------------------------------------------------------------------
# transition rule
# --------------------------------------------------------------------------------------------


def transition_matrix(neighbours: Sequence[Iterable[int]]) -> np.ndarray:
    """The seed transition rule over a symmetric adjacency.

    P(i→j) = (1 − n_j/S) / (|C| − 1) for j in C = {i} ∪ N(i), S = Σ_{j∈C} n_j; a region with
    no neighbour gets P(i→i) = 1.

    Args:
        neighbours: for each region, the indices of its neighbours (symmetric, no self).

    Returns:
        Row-stochastic (n, n) float array.
    """
    nb = [sorted(set(int(m) for m in s)) for s in neighbours]
    n = len(nb)
    deg = np.array([len(s) for s in nb], dtype=float)
    matrix = np.zeros((n, n))
    for i, others in enumerate(nb):
        if not others:
            matrix[i, i] = 1.0
            continue
        cand = np.array([i] + others, dtype=np.intp)
        total = deg[cand].sum()  # > 0: i has a neighbour, so n_i >= 1
        matrix[i, cand] = (1.0 - deg[cand] / total) / (len(cand) - 1)
    return matrix
