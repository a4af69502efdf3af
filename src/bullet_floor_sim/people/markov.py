"""The Markov chain over regions of interest that the walker follows, by the seed project's rule.

Adjacency, the seed rule (``mode="vertex"``): two ROIs are connected when some vertex of one
lies within ``tol`` (0.2 m) of some vertex of the other in x AND in y (|dx| <= tol and
|dy| <= tol, i.e. Chebyshev distance; 1e-9 m of slack so that a decimal 0.2 counts). Every
vertex of every polygon is used, through one k-d tree over all vertices.

``mode="edge"``: two ROIs are connected when their boundaries run along each other (within
``tol``) over one stretch at least ``min_shared`` long (0.8 m, a door width); a corner touch is
not a connection. Candidate pairs come from a shapely STRtree.

Transition rule, the seed rule, exact: from region i with neighbours N(i), the candidates are
C = {i} ∪ N(i); n_j = number of neighbours of j; S = Σ_{j∈C} n_j;
P(i→j) = (1 − n_j/S) / (|C| − 1). Offices (few connections) are sticky, corridors (many) are
passed through. A region with no neighbour keeps P(i→i) = 1 and is reported in ``warnings``.

The chain is stored as documents of database ``markov_chain_db``, collection
``roi_proba_connexions_<map>``, one per region, as the seed stored it: ``{"ID_region": id,
"proba_connexions": [[id, p], ...], "map_name": ..., "config": ...}`` (the seed's pairs held
percentages; here p is a probability in [0, 1]). :func:`store_chain` replaces a map's previous
chain, :func:`load_chain` reads it back.

ROIs come from the store as the ROI manager keeps them (:mod:`.roi_store`, SOMA's layout:
database ``somadata``, collection ``roi``, one document per ROI version): :func:`read_rois`
gives the current ROIs of a map and config; :func:`rois_from_documents` turns SOMAROIObject
documents into :class:`~bullet_floor_sim.data.rois.Roi`; :func:`usable_rois` leaves out the
ones an edit broke.
"""
from __future__ import annotations

import datetime
import uuid
from dataclasses import dataclass, field
from typing import Any, Dict, Iterable, List, Mapping, Optional, Sequence, Set, Tuple, Union

import numpy as np

from ..errors import BulletFloorSimError
from ..data.rois import Roi, RoiError, one_map_and_config, validate_roi, validate_rois

__all__ = [
    "DATABASE",
    "MODES",
    "ROI_DATABASE",
    "ROI_COLLECTION",
    "ChainError",
    "MarkovChain",
    "vertex_adjacency",
    "edge_adjacency",
    "roi_adjacency",
    "transition_matrix",
    "chain_collection",
    "store_chain",
    "STALE_BUILD_S",
    "BUILDS_COLLECTION",
    "load_chain",
    "rois_from_documents",
    "usable_rois",
    "read_rois",
]

DATABASE = "markov_chain_db"
ROI_DATABASE = "somadata"  # where SOMA's soma_roi_manager (and data/roi_store) keeps ROIs
ROI_COLLECTION = "roi"
MODES = ("vertex", "edge")
_SLACK = 1e-9  # metres: |dx| = 0.2 written in decimal must count as within tol = 0.2

Seed = Union[None, int, np.random.Generator]


class ChainError(BulletFloorSimError):
    """A stored chain (or the ROI documents it is built from) is missing or malformed."""


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
    runs = []  # (segment, lo, hi) merged per segment, in ring order
    for k in np.flatnonzero(keep.any(axis=1)).tolist():
        for lo, hi in sorted(zip(s_lo[k][keep[k]].tolist(), s_hi[k][keep[k]].tolist())):
            if runs and runs[-1][0] == k and lo <= runs[-1][2] + eps:
                runs[-1][2] = max(runs[-1][2], hi)
            else:
                runs.append([k, lo, hi])
    # join runs that continue across a vertex onto the next segment (cyclically)
    m = len(length)
    chains = []  # [length, first run, last run]
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


def chain_collection(map_name: str) -> str:
    """The collection name of a map's chain: ``roi_proba_connexions_<map_name>``.

    Raises:
        ValueError: the map name is empty or cannot be part of a MongoDB collection name.
    """
    if not isinstance(map_name, str) or not map_name or "$" in map_name or "\0" in map_name:
        raise ValueError("map name %r cannot name a collection (empty, or has '$' or NUL)"
                         % (map_name,))
    return "roi_proba_connexions_" + map_name


# --------------------------------------------------------------------------------------------
# the chain
# --------------------------------------------------------------------------------------------


@dataclass(eq=False)
class MarkovChain:
    """Regions and their transition matrix.

    Attributes:
        ids: region ids; row/column k of ``matrix`` is region ``ids[k]``.
        matrix: (n, n) row-stochastic transition probabilities.
        map_name: the map the regions belong to ("" when unknown).
        config: the ROI config the regions belong to ("" when unknown).
        warnings: one line per problem found while building (isolated regions, separate parts).
    """

    ids: List[str]
    matrix: np.ndarray
    map_name: str = ""
    config: str = ""
    warnings: List[str] = field(default_factory=list)

    def __post_init__(self) -> None:
        self.matrix = np.asarray(self.matrix, dtype=float)
        n = len(self.ids)
        if self.matrix.shape != (n, n):
            raise ValueError("matrix must be %d x %d for %d ids, got shape %s"
                             % (n, n, n, self.matrix.shape))
        self._index = {r: k for k, r in enumerate(self.ids)}
        if len(self._index) != n:
            raise ValueError("region ids repeat: %s" % ", ".join(_dupes(self.ids)))
        if n and (np.any(self.matrix < 0.0)
                  or not np.allclose(self.matrix.sum(axis=1), 1.0, atol=1e-9)):
            raise ValueError("matrix rows must be probabilities summing to 1")
        self._cumulative = None  # type: Optional[np.ndarray]

    # ---- construction ----------------------------------------------------------------------

    @classmethod
    def from_rois(cls, rois: Sequence[Roi], tol: float = 0.2, mode: str = "vertex",
                  min_shared: float = 0.8) -> "MarkovChain":
        """Build the chain of one map's ROIs (one config) by the seed rules.

        Args:
            rois: the ROIs, all of one map and one config.
            tol: adjacency tolerance, metres.
            mode: ``vertex`` (the seed rule) or ``edge`` (shared wall of ``min_shared`` m).
            min_shared: for ``edge`` mode, metres.

        Returns:
            The chain; ``warnings`` names isolated regions and separate parts.

        Raises:
            RoiError: no ROIs, invalid ROIs, or ROIs from several maps or configs.
            ValueError: unknown mode or bad tolerance.
        """
        rois = list(rois)
        if not rois:
            raise RoiError("no ROIs: the chain needs at least one region")
        validate_rois(rois)
        map_name, config = one_map_and_config(rois, "one chain per map and config:")
        adj = roi_adjacency(rois, tol, mode, min_shared)
        rule = ("no vertex within %g m of another ROI's vertex" % tol if mode == "vertex"
                else "no wall of %g m shared with another ROI" % min_shared)
        return cls.from_neighbours([r.id for r in rois], adj, map_name, rule, config)

    @classmethod
    def from_neighbours(cls, ids: Sequence[str], neighbours: Mapping[str, Iterable[str]],
                        map_name: str = "", why_isolated: str = "no neighbour",
                        config: str = "") -> "MarkovChain":
        """Build the chain from an adjacency given by id (made symmetric).

        Args:
            ids: region ids, in matrix order.
            neighbours: id -> neighbour ids (missing ids have none; self-links are ignored).
            map_name: the map's name.
            why_isolated: reason quoted in the warning for a region without neighbours.
            config: the ROI config.

        Raises:
            KeyError: a neighbour id is not in ``ids``.
        """
        ids = [str(r) for r in ids]
        index = {r: k for k, r in enumerate(ids)}
        nb = [set() for _ in ids]  # type: List[Set[int]]
        for r, others in neighbours.items():
            for o in others:
                if r not in index or o not in index:
                    raise KeyError("unknown region %r in the adjacency" % (o if r in index else r))
                if r != o:
                    nb[index[r]].add(index[o])
                    nb[index[o]].add(index[r])
        chain = cls(ids=ids, matrix=transition_matrix(nb), map_name=map_name, config=config)
        for k, s in enumerate(nb):
            if not s:
                chain.warnings.append('region "%s" is isolated (%s): it keeps P(%s -> %s) = 1'
                                      % (ids[k], why_isolated, ids[k], ids[k]))
        parts = chain.components()
        if len(parts) > 1:
            shown = "; ".join(_short(p) for p in parts[:5])
            more = "; ..." if len(parts) > 5 else ""
            chain.warnings.append("the regions form %d separate parts (%s%s): a walk never "
                                  "leaves the part it starts in" % (len(parts), shown, more))
        return chain

    # ---- queries ---------------------------------------------------------------------------

    def index(self, region: str) -> int:
        """Row of a region id.

        Raises:
            KeyError: unknown id.
        """
        try:
            return self._index[region]
        except KeyError:
            raise KeyError("unknown region %r" % (region,)) from None

    def probability(self, i: str, j: str) -> float:
        """P(i → j)."""
        return float(self.matrix[self.index(i), self.index(j)])

    def row(self, i: str) -> Dict[str, float]:
        """The non-zero transition probabilities out of region i, by id."""
        r = self.matrix[self.index(i)]
        return {self.ids[k]: float(r[k]) for k in np.flatnonzero(r)}

    def neighbours(self, i: str) -> List[str]:
        """Regions reachable from i in one step, other than i itself."""
        k = self.index(i)
        return [self.ids[m] for m in np.flatnonzero(self.matrix[k]) if m != k]

    def expected_dwell(self, i: str) -> float:
        """Expected number of consecutive steps spent in i, 1 / (1 − P(i, i)); inf if absorbing."""
        stay = self.probability(i, i)
        return float("inf") if stay >= 1.0 else 1.0 / (1.0 - stay)

    def components(self) -> List[List[str]]:
        """Connected parts of the adjacency (each a closed class of the chain), in id order."""
        from scipy.sparse import csr_matrix
        from scipy.sparse.csgraph import connected_components

        n = len(self.ids)
        if n == 0:
            return []
        adj = self.matrix > 0.0
        np.fill_diagonal(adj, False)
        count, labels = connected_components(csr_matrix(adj | adj.T), directed=False)
        order = []  # type: List[int]
        for lab in labels.tolist():
            if lab not in order:
                order.append(lab)
        return [[self.ids[k] for k in np.flatnonzero(labels == lab)] for lab in order]

    def stationary(self) -> np.ndarray:
        """The stationary distribution π (π P = π, Σ π = 1), aligned with ``ids``.

        Each connected part is a closed, aperiodic class with its own unique stationary
        distribution. When there are several parts (a reducible chain) the one returned is
        their mixture weighted by the number of regions in each part: the long-run
        distribution of a walk that starts in a region drawn uniformly. It still satisfies
        π P = π.
        """
        n = len(self.ids)
        pi = np.zeros(n)
        for part in self.components():
            idx = np.array([self._index[r] for r in part], dtype=np.intp)
            q = self.matrix[np.ix_(idx, idx)]
            a = q.T - np.eye(len(idx))
            a[-1, :] = 1.0
            b = np.zeros(len(idx))
            b[-1] = 1.0
            sol = np.linalg.solve(a, b)
            pi[idx] = np.clip(sol, 0.0, None) / np.clip(sol, 0.0, None).sum() * len(idx) / n
        return pi

    # ---- sampling --------------------------------------------------------------------------

    def sample_next(self, i: str, rng: np.random.Generator) -> str:
        """Draw the region after i."""
        if self._cumulative is None:
            cum = np.cumsum(self.matrix, axis=1)
            self._cumulative = cum / cum[:, -1:]
        k = int(np.searchsorted(self._cumulative[self.index(i)], rng.random(), side="right"))
        return self.ids[min(k, len(self.ids) - 1)]

    def walk(self, start: str, steps: int, seed: Seed = None) -> List[str]:
        """A random walk: ``[start, x1, ..., x_steps]``.

        Args:
            start: first region.
            steps: number of transitions.
            seed: int seed, a numpy Generator, or None (fresh entropy).
        """
        rng = seed if isinstance(seed, np.random.Generator) else np.random.default_rng(seed)
        self.index(start)
        path = [start]
        for _ in range(int(steps)):
            path.append(self.sample_next(path[-1], rng))
        return path

    # ---- export ----------------------------------------------------------------------------

    def to_json(self) -> Dict[str, Any]:
        """``{"map_name": ..., "transitions": {id: {id: p, ...}, ...}}`` with zeros left out."""
        return {"map_name": self.map_name,
                "transitions": {r: self.row(r) for r in self.ids}}

    def to_documents(self, map_name: Optional[str] = None) -> Dict[str, Any]:
        """The chain as stored: where, and one document per region.

        Args:
            map_name: the map whose collection to use (default: ``self.map_name``).

        Returns:
            ``{"database": "markov_chain_db", "collection": "roi_proba_connexions_<map>",
            "documents": [{"ID_region": id, "proba_connexions": [[id, p], ...],
            "map_name": map, "config": config}, ...]}``, regions and their targets in ``ids``
            order, zeros left out (the seed's document shape; its pairs held percentages).

        Raises:
            ValueError: no usable map name.
        """
        name = self.map_name if map_name is None else map_name
        collection = chain_collection(name)
        docs = [{"ID_region": r,
                 "proba_connexions": [[j, p] for j, p in self.row(r).items()],
                 "map_name": name, "config": self.config}
                for r in self.ids]
        return {"database": DATABASE, "collection": collection, "documents": docs}


# --------------------------------------------------------------------------------------------
# storage
# --------------------------------------------------------------------------------------------


#: The collection of per-map markers naming each map's current chain build.
BUILDS_COLLECTION = "chain_builds"
#: Builds other than the current one are deleted once they are this old: two walkers that
#: rebuild one map's chain at once then never delete each other's fresh documents.
STALE_BUILD_S = 60.0


def store_chain(store: Any, chain: MarkovChain, map_name: Optional[str] = None,
                extra: Optional[Mapping[str, Any]] = None,
                now: Optional[datetime.datetime] = None) -> int:
    """Write the chain to a store, replacing the map's previous chain.

    The seed emptied the collection and then inserted one document per region. Here the new
    documents (all tagged with one fresh ``build_id`` and ``built_at``) go in first, then the
    map's marker in ``markov_chain_db.chain_builds`` (``_id`` the map) names this build, and
    builds other than this one older than :data:`STALE_BUILD_S` are deleted. A reader never
    finds the collection empty, and two writers rebuilding one map at once keep both builds
    for a while (the marker names the last) instead of deleting each other's.

    Args:
        store: a :class:`~bullet_floor_sim.data.store.Store` (or anything with its
            ``delete``/``insert``/``update``).
        chain: the chain.
        map_name: the map whose collection to use (default: ``chain.map_name``).
        extra: more fields for every document (e.g. ``{"built_by": "/markov_walker"}``);
            they never override the chain's own fields.
        now: the build time (default: now, UTC).

    Returns:
        The number of documents written (journalled while the database is down).

    Raises:
        ValueError: no usable map name.
        StoreError: the store refused the documents.
    """
    stored = chain.to_documents(map_name)
    db, coll = stored["database"], stored["collection"]
    build = uuid.uuid4().hex
    at = (now or datetime.datetime.utcnow()).replace(microsecond=0, tzinfo=None)
    for doc in stored["documents"]:
        doc["build_id"], doc["built_at"] = build, at
        if extra:
            doc = dict(doc, **{k: v for k, v in extra.items() if k not in doc})
        store.insert(db, coll, doc)
    name = stored["documents"][0]["map_name"] if stored["documents"] else coll
    store.update(db, BUILDS_COLLECTION, {"_id": name},
                 {"$set": {"build_id": build, "built_at": at, "collection": coll}},
                 upsert=True)
    stale = at - datetime.timedelta(seconds=STALE_BUILD_S)
    store.delete(db, coll, {"build_id": {"$ne": build},
                            "$or": [{"built_at": {"$lt": stale}},
                                    {"built_at": {"$exists": False}}]})
    return len(stored["documents"])


def load_chain(store: Any, map_name: str) -> MarkovChain:
    """Read back the chain :func:`store_chain` wrote for a map: the build its marker names
    (else, the newest build in the collection).

    Raises:
        ChainError: no chain is stored for the map, or its documents are malformed (the
            message names the collection and the region).
        StoreUnavailable: the database is unreachable.
    """
    coll = chain_collection(map_name)
    where = "%s.%s" % (DATABASE, coll)
    docs = store.find(DATABASE, coll, {}, sort=[("_id", 1)])
    if not docs:
        raise ChainError("%s: no chain stored for map %r" % (where, map_name))
    marker = store.find_one(DATABASE, BUILDS_COLLECTION, {"_id": map_name}) or {}
    builds = {d.get("build_id") for d in docs}
    current = marker.get("build_id")
    if current not in builds:
        current = docs[-1].get("build_id")  # no marker (an older writer): the newest build
    docs = [d for d in docs if d.get("build_id") == current]
    ids = []  # type: List[str]
    rows = []  # type: List[List[Tuple[str, float]]]
    for doc in docs:
        region = doc.get("ID_region")
        pairs = doc.get("proba_connexions")
        if not isinstance(region, str) or not isinstance(pairs, list):
            raise ChainError("%s: document %s lacks ID_region (string) or proba_connexions "
                             "(list)" % (where, doc.get("_id")))
        row = []
        for pair in pairs:
            if (not isinstance(pair, (list, tuple)) or len(pair) != 2
                    or not isinstance(pair[1], (int, float))):
                raise ChainError("%s: region %r: proba_connexions entries must be [id, "
                                 "probability], got %r" % (where, region, pair))
            row.append((str(pair[0]), float(pair[1])))
        ids.append(region)
        rows.append(row)
    index = {r: k for k, r in enumerate(ids)}
    matrix = np.zeros((len(ids), len(ids)))
    for k, row in enumerate(rows):
        for j, p in row:
            if j not in index:
                raise ChainError("%s: region %r leads to %r, which has no document"
                                 % (where, ids[k], j))
            matrix[k, index[j]] = p
    configs = sorted({str(d.get("config", "")) for d in docs})
    try:
        return MarkovChain(ids=ids, matrix=matrix, map_name=map_name,
                           config=configs[0] if len(configs) == 1 else "")
    except ValueError as e:
        raise ChainError("%s: %s" % (where, e)) from None


def rois_from_documents(docs: Iterable[Mapping[str, Any]], strict: bool = True) -> List[Roi]:
    """ROIs from stored SOMAROIObject documents (or dicts with the same fields).

    The vertices are ``posearray.poses[k].position.{x, y}``; a closing vertex equal to the
    first is dropped, as in rois.yaml.

    Args:
        docs: documents with ``id``, ``config``, ``type``, ``map_name`` and ``posearray``.
        strict: validate the result (polygons, duplicate ids) and raise on the first problem;
            with False, see :func:`usable_rois` to drop bad ROIs instead.

    Returns:
        The ROIs, in document order.

    Raises:
        RoiError: a document lacks a field or has a malformed one (named with the ROI id), or,
            with ``strict``, an ROI is invalid.
    """
    rois = []
    for k, doc in enumerate(docs):
        label = "ROI document %d" % k
        if isinstance(doc, Mapping) and isinstance(doc.get("id"), str):
            label = 'ROI "%s"' % doc["id"]
        if not isinstance(doc, Mapping):
            raise RoiError("%s: expected a SOMAROIObject document, got %s"
                           % (label, type(doc).__name__))
        missing = [f for f in ("id", "config", "type", "map_name", "posearray") if f not in doc]
        if missing:
            raise RoiError("%s: missing field(s) %s" % (label, ", ".join(missing)))
        try:
            poses = doc["posearray"]["poses"]
            vertices = [(float(p["position"]["x"]), float(p["position"]["y"])) for p in poses]
        except (KeyError, TypeError, ValueError) as e:
            raise RoiError("%s: posearray.poses[k].position.x/y expected (%s: %s)"
                           % (label, type(e).__name__, e)) from None
        if len(vertices) > 1 and vertices[0] == vertices[-1]:
            vertices.pop()
        rois.append(Roi(id=str(doc["id"]), config=str(doc["config"]), type=str(doc["type"]),
                        map_name=str(doc["map_name"]), vertices=vertices))
    if strict:
        validate_rois(rois)
    return rois


def usable_rois(rois: Iterable[Roi]) -> Tuple[List[Roi], List[str]]:
    """The valid ROIs, and one warning per ROI left out (invalid polygon, repeated id).

    For a live system: one ROI broken by an edit must not stop the chain of the others.
    """
    good, warnings = [], []  # type: List[Roi], List[str]
    seen = set()  # type: Set[Tuple[str, str, str]]
    for roi in rois:
        try:
            validate_roi(roi)
        except RoiError as e:
            warnings.append("%s: left out of the chain" % e)
            continue
        key = (roi.map_name, roi.config, roi.id)
        if key in seen:
            warnings.append('ROI "%s": repeated id in map %s config %s: the later one is left '
                            "out of the chain" % (roi.id, roi.map_name, roi.config))
            continue
        seen.add(key)
        good.append(roi)
    return good, warnings


def read_rois(store: Any, map_name: str, config: str = "1") -> List[Roi]:
    """The current ROIs of a map and config in the ROI store: the newest version of each ROI
    (by ``_meta.version``), deleted ROIs left out, as the ROI manager answers
    ``/soma/query_rois`` (:class:`~bullet_floor_sim.data.roi_store.RoiStore`).

    Args:
        store: a :class:`~bullet_floor_sim.data.store.Store`.
        map_name: the map.
        config: the ROI config (SOMA's ``config``).

    Returns:
        The ROIs, numeric ids in numeric order (not validated: see :func:`usable_rois`).

    Raises:
        RoiError: a stored document is malformed.
        StoreUnavailable: the database is unreachable.
    """
    from ..data.roi_store import RoiStore

    return RoiStore(store, map_name).current(config)


def _dupes(ids: Sequence[str]) -> List[str]:
    seen, dupes = set(), []
    for r in ids:
        if r in seen and r not in dupes:
            dupes.append(r)
        seen.add(r)
    return dupes


def _short(part: Sequence[str]) -> str:
    shown = ", ".join('"%s"' % r for r in part[:4])
    return "{%s%s}" % (shown, ", ..." if len(part) > 4 else "")
