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

from .adjacency import MODES, edge_adjacency, roi_adjacency, transition_matrix, vertex_adjacency
from .chain import DATABASE, ChainError, MarkovChain, chain_collection
from .storage import (BUILDS_COLLECTION, ROI_COLLECTION, ROI_DATABASE, STALE_BUILD_S, load_chain,
                      read_rois, rois_from_documents, store_chain, usable_rois)

__all__ = ["DATABASE", "MODES", "ROI_DATABASE", "ROI_COLLECTION", "ChainError", "MarkovChain",
           "vertex_adjacency", "edge_adjacency", "roi_adjacency", "transition_matrix",
           "chain_collection", "store_chain", "STALE_BUILD_S", "BUILDS_COLLECTION", "load_chain",
           "rois_from_documents", "usable_rois", "read_rois"]
