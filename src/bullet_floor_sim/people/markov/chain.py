"""The Markov chain over regions: built from ROIs, sampled, checked. See the package doc."""
from __future__ import annotations

from dataclasses import dataclass, field
from typing import Any, Dict, Iterable, List, Mapping, Optional, Sequence, Set, Union

import numpy as np

from ...errors import BulletFloorSimError
from ...data.rois import Roi, RoiError, one_map_and_config, validate_rois
from .adjacency import roi_adjacency, transition_matrix


DATABASE = "markov_chain_db"

Seed = Union[None, int, np.random.Generator]


class ChainError(BulletFloorSimError):
    """A stored chain (or the ROI documents it is built from) is missing or malformed."""


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
        isolated_reason: why a region without neighbours has none (the adjacency rule, as
            :meth:`from_rois` states it).
    """

    ids: List[str]
    matrix: np.ndarray
    map_name: str = ""
    config: str = ""
    warnings: List[str] = field(default_factory=list)
    isolated_reason: str = "no neighbour"

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
        nb: List[Set[int]] = [set() for _ in ids]
        for r, others in neighbours.items():
            for o in others:
                if r not in index or o not in index:
                    raise KeyError("unknown region %r in the adjacency" % (o if r in index else r))
                if r != o:
                    nb[index[r]].add(index[o])
                    nb[index[o]].add(index[r])
        chain = cls(ids=ids, matrix=transition_matrix(nb), map_name=map_name, config=config,
                    isolated_reason=why_isolated)
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
