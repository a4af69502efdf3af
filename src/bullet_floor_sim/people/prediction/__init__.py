"""Where is it going? A posterior over the destination region of a walking entity.

Planning-based prediction (Ziebart et al. 2009, "Planning-based prediction for pedestrians";
the approximation Dragan et al. use for legibility): an entity that starts a leg at S in
region r0 draws its destination region g from the Markov chain's row of r0 (g = r0 included:
a move inside the same region, as the walker does), then a goal point p in g, and walks an
efficient path to p on the inflated map. Having seen it walk from S to its current position Q,

    P(g | S..Q)  ∝  P(g | r0) · mean_{p ∈ goals(g)} exp(−β (V_p(Q) − V_p(S))) / L_p^α

where V_p is the cost-to-go to p on the :class:`~bullet_floor_sim.nav.planner.PlanningGrid`
with the planner's step cost (step length in metres × (1 + cost_weight × mean cell cost),
lethal cells impassable, 8-connected without corner cutting). The cost of the observed path
S..Q is the same under every hypothesis and cancels. V_p(S) − V_p(Q) is the *progress* made
towards p: a goal the entity walks straight at gains exp(β·distance), one it walks away from
loses as much. β (1/m) is the rationality: how strongly progress counts.

L_p = max(V_p(S), goal_spacing) is the length of the leg to p. With α = 1 it states that the
moment Q is seen is equally likely at any fraction of the leg (the walk to p passes Q once,
and Q lies on the first L_p metres): as a leg is scored at 10-90 % of its duration, or as
anyone asks "where is it going?" once per leg. With α = 0 the moment is equally likely at any
metre walked (long legs are seen more often). Left out (α = 0), a short move inside a long
corridor region loses to the region beyond it at every moment, since only the region's
points ahead of Q stay consistent while the next region's all do.

* goals(g) is a fixed set of acceptable goal points in the region, as the walker's
  :class:`~bullet_floor_sim.people.walker.GoalSampler` accepts them (inside the polygon with a
  margin, with ``clearance`` to every wall): a lattice of ``goal_spacing``, spread-thinned to
  ``max_goals_per_region``; or, per region, the points given as ``goal_points``.
* The V fields are computed once, one Dijkstra per goal point (scipy.sparse.csgraph) over the
  planning grid's free cells; the graph is undirected, so a shortest-path tree from p is the
  cost-to-go to p. Between cell centres V is refined by one step of the grid: V(Q) = the least
  V(n) + cost of the straight step from Q to the centre of n, over Q's cell and its grid
  neighbours, so that V follows the position continuously along a straight walk. A position
  in a lethal cell (the entity brushing a wall) uses the nearest free cell within
  ``snap_distance``.
* Goal points not reachable from S are dropped; a region none of whose goal points is
  reachable gets probability 0 and a reason (:meth:`DestinationModel.posterior_details`).
  Sums are taken in log space (log-sum-exp).

The posterior is then calibrated (prediction/calibration.py): the evidence tempered by
1/``temperature`` and the prior mixed back in with weight ``prior_mix``.

Baselines for evaluation: :meth:`DestinationModel.markov_baseline` (the chain row alone) and
:meth:`DestinationModel.heading_baseline` (the region the current heading points at).

:class:`OnlinePredictor` cuts one entity's stream into legs (dwell, move, dwell) and gives the
current leg's :class:`Prediction` at every update. Everything is plain numbers in, plain
numbers out; no rospy.
"""
from __future__ import annotations

from .config import PredictionConfig, PredictionError
from .model import DestinationModel
from .online import OnlinePredictor, Prediction, PredictorPool, log_loss, posterior_or_prior, top1

__all__ = ["PredictionError", "PredictionConfig", "DestinationModel", "Prediction",
           "OnlinePredictor", "PredictorPool", "log_loss", "posterior_or_prior", "top1"]
