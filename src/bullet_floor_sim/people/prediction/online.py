"""Predicting online: legs cut from one entity's stream (OnlinePredictor), one predictor per
track (PredictorPool), and the scores of a prediction. See the package doc."""
from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Any, Dict, Mapping, Optional, Sequence, Set, Tuple

from ...sim.checks import is_number as _is_number
from .config import XY, PredictionConfig, PredictionError
from .model import _SLACK, DestinationModel

__all__ = ["OnlinePredictor", "Prediction", "PredictorPool", "log_loss", "posterior_or_prior", "top1"]


@dataclass
class Prediction:
    """The destination posterior of the current leg of one entity.

    Attributes:
        t: time of the observation it is based on (s).
        leg_start: time the leg started (the last time the entity stood at ``start_xy``).
        start_region: r0, the region the leg started from.
        start_xy: S, where it stood before the leg.
        probabilities: region id -> P(g | S..Q), over r0's row, summing to 1.
        best: the most probable region.
        best_probability: its probability.
        observed: metres walked since S.
        leg: leg number of this track (1, 2, ...).
        note: why the probabilities are only the prior ("" normally): the position was off
            the map's free space.
        under_way: False when no leg is under way: the entity stands (or has not yet moved
            ``min_progress`` from where it stood), and this is the prediction of the leg it
            will start next, from where it stands (``start_xy``): the chain's row of its
            region, the posterior once it moves. ``leg`` is then that next leg's number.
    """

    t: float
    leg_start: float
    start_region: str
    start_xy: XY
    probabilities: Dict[str, float]
    best: str
    best_probability: float
    observed: float
    leg: int = 1
    note: str = ""
    under_way: bool = True

    def to_dict(self) -> Dict[str, Any]:
        """The prediction as plain data (for a JSON topic or a log)."""
        return {"t": self.t, "leg": self.leg, "under_way": self.under_way,
                "leg_start": self.leg_start,
                "start_region": self.start_region,
                "start_xy": [round(v, 3) for v in self.start_xy],
                "probabilities": {g: round(p, 6) for g, p in self.probabilities.items()},
                "best": self.best, "best_probability": round(self.best_probability, 6),
                "observed": round(self.observed, 3), "note": self.note}


@dataclass
class _Leg:
    number: int
    start: float
    region: str
    xy: XY
    observed: float = 0.0
    slow_since: Optional[float] = None


class OnlinePredictor:
    """Legs and destination posteriors from one entity's pose stream.

    One OnlinePredictor per track (entity id): it keeps that track's leg state. Legs are cut
    as the walker makes them: the entity stands (speed < stop_speed) at S; a leg starts once
    it is ``min_progress`` away from S, with r0 = the region of S (:meth:`DestinationModel.
    start_region`) and leg_start the last time it stood at S; the leg ends when it has stood
    for ``dwell_time``. Moving slower than stop_speed counts as standing.

    With no leg under way, :meth:`update` predicts the next leg from where the entity stands
    (``under_way`` False): the chain's row of its region, since nothing of that leg has been
    seen. A walker leg of 3-8 s inside one office is half over before a tracker's velocity
    and 0.3 m of progress make it a leg; saying nothing there (None) was a miss on 8 % of
    200 evaluation legs, the prior is right on most of them (offices are sticky).

    Args:
        model: the destination model (shared by all tracks of one map).
    """

    def __init__(self, model: DestinationModel) -> None:
        self.model = model
        self.legs = 0
        self.last = None  # type: Optional[Prediction]
        self.reset()

    def reset(self) -> None:
        """Forget the track's state (a new entity, or a jump in time); leg numbers go on."""
        self._leg = None  # type: Optional[_Leg]
        self._anchor = None  # type: Optional[Tuple[float, float, float]]
        self._prev = None  # type: Optional[Tuple[float, float, float]]
        self._walked = 0.0

    @property
    def in_leg(self) -> bool:
        """Whether a leg is under way."""
        return self._leg is not None

    def update(self, t: float, x: float, y: float, vx: float, vy: float) -> Prediction:
        """One observation of the entity.

        Args:
            t: time (s), not before the previous update's.
            x, y: position (map frame).
            vx, vy: velocity (m/s, map frame).

        Returns:
            The current leg's prediction, or with no leg under way (before its first move,
            and once a leg has ended) the next leg's (``under_way`` False).

        Raises:
            PredictionError: a non-finite input, or time going backwards.
        """
        for name, v in (("t", t), ("x", x), ("y", y), ("vx", vx), ("vy", vy)):
            if not (_is_number(v) and math.isfinite(v)):
                raise PredictionError("prediction: update %s must be a finite number, got %r"
                                      % (name, v))
        t, x, y = float(t), float(x), float(y)
        if self._prev is not None and t < self._prev[0]:
            raise PredictionError("prediction: update t %.3f is before the previous update's "
                                  "%.3f (reset() for a new stream)" % (t, self._prev[0]))
        cfg = self.model.config
        step = 0.0 if self._prev is None else math.hypot(x - self._prev[1], y - self._prev[2])
        self._prev = (t, x, y)
        standing = math.hypot(float(vx), float(vy)) < cfg.stop_speed
        leg = self._leg
        if leg is None:
            if self._anchor is None or standing:
                self._anchor, self._walked = (t, x, y), 0.0
                return self._next_leg(t, x, y)
            self._walked += step
            at, ax, ay = self._anchor
            if math.hypot(x - ax, y - ay) < cfg.min_progress - _SLACK:
                return self._next_leg(t, x, y)
            self.legs += 1
            leg = self._leg = _Leg(self.legs, at, self.model.start_region(ax, ay), (ax, ay),
                                   self._walked)
        else:
            leg.observed += step
            if standing:
                if leg.slow_since is None:
                    leg.slow_since = t
                if t - leg.slow_since >= cfg.dwell_time:
                    self._leg = None
                    self._anchor, self._walked = (t, x, y), 0.0
                    return self._next_leg(t, x, y)
            else:
                leg.slow_since = None
        return self._predict(t, leg, x, y, True)

    def _next_leg(self, t: float, x: float, y: float) -> Prediction:
        """The prediction of the leg that starts from the anchor (no leg under way)."""
        assert self._anchor is not None   # update sets it before it calls this
        at, ax, ay = self._anchor
        leg = _Leg(self.legs + 1, at, self.model.start_region(ax, ay), (ax, ay), self._walked)
        return self._predict(t, leg, x, y, False)

    def _predict(self, t: float, leg: _Leg, x: float, y: float, under_way: bool) -> Prediction:
        probs, note = posterior_or_prior(self.model, leg.region, leg.xy, (x, y))
        best = top1(probs)
        self.last = Prediction(t, leg.start, leg.region, leg.xy, probs, best, probs[best],
                               leg.observed, leg.number, note, under_way)
        return self.last


def posterior_or_prior(model: DestinationModel, r0: str, start_xy: Sequence[float],
                       current_xy: Sequence[float]) -> Tuple[Dict[str, float], str]:
    """The posterior, or the chain's row of r0 with the reason when a position is off the
    map's free space (what :class:`OnlinePredictor` publishes then): (probabilities, note)."""
    try:
        return model.posterior(r0, start_xy, current_xy), ""
    except PredictionError as e:
        return model.prior(r0), str(e)


# --------------------------------------------------------------------------------------------
# evaluation
# --------------------------------------------------------------------------------------------


def log_loss(probs: Mapping[str, float], truth: str, floor: float = 1e-6) -> float:
    """-ln P(truth), with P floored at ``floor`` (a region the distribution left out counts
    as ``floor``), in nats.

    Raises:
        PredictionError: floor not in (0, 1].
    """
    if not (_is_number(floor) and 0.0 < floor <= 1.0):
        raise PredictionError("log_loss: floor must be in (0, 1], got %r" % (floor,))
    return -math.log(max(float(probs.get(truth, 0.0)), float(floor)))


def top1(probs: Mapping[str, float]) -> str:
    """The most probable region (the first one on a tie).

    Raises:
        PredictionError: no probabilities.
    """
    if not probs:
        raise PredictionError("top1: no probabilities")
    best, best_p = "", -math.inf
    for g, p in probs.items():
        if p > best_p:
            best, best_p = g, p
    return best


# --------------------------------------------------------------------------------------------
# helpers
# --------------------------------------------------------------------------------------------




class PredictorPool:
    """One :class:`OnlinePredictor` per track, with hand-over across occlusions.

    A tracker gives an entity a new id when it loses it for longer than its ``max_age`` (the
    walker goes behind a door jamb, or the observer turns): without hand-over the new id's
    leg would start where it was seen again, in the wrong region (the prior's row) and with
    the walked part of the leg missing. A track id seen for the first time takes over the
    predictor of a track that is gone (not in this update), last updated at most
    ``handover_time`` seconds ago within 0.5 m + ``handover_speed`` x the gap (the nearest
    such). Predictors of tracks gone for ``forget_after`` seconds (the config's) are dropped.
    A track the observer's follower took for the one it lost takes over that one's leg when
    it was lost longer, up to ``forget_after`` (:meth:`same_entity`).

    Args:
        model: the destination model (its config gives the hand-over's times).
    """

    _NEAR = 0.5

    def __init__(self, model: DestinationModel) -> None:
        self.model = model
        self.predictors = {}  # type: Dict[int, OnlinePredictor]
        self._last = {}  # type: Dict[int, Tuple[float, float, float]]
        self._first = {}  # type: Dict[int, float]
        self._by_place: Set[int] = set()   # tracks that took a leg over by place
        self.handovers = 0
        self.errors = {}  # type: Dict[int, str]

    def update(self, t: float, tracks: Sequence[Sequence[float]]
               ) -> Dict[int, Prediction]:
        """One track update: ``tracks`` as (id, x, y, vx, vy). Returns each track's
        prediction (of the next leg while it has none under way). A track whose input
        :meth:`OnlinePredictor.update` refuses (non-finite, time going back) is left out of
        the result, with the one-line reason in ``errors[id]``; the others are updated.
        """
        cfg = self.model.config
        t = float(t)
        ids = {int(tr[0]) for tr in tracks}
        out = {}  # type: Dict[int, Prediction]
        self.errors = {}
        for tr in tracks:
            k, x, y, vx, vy = int(tr[0]), float(tr[1]), float(tr[2]), tr[3], tr[4]
            pred = self.predictors.get(k)
            if pred is None:
                pred = self._take_over(t, x, y, ids, cfg)
                if pred is None:
                    pred = OnlinePredictor(self.model)
                else:
                    self._by_place.add(k)
                self.predictors[k] = pred
            try:
                out[k] = pred.update(t, x, y, vx, vy)
            except PredictionError as e:
                self.errors[k] = "track %d: %s" % (k, e)
                if k not in self._last:   # never updated: nothing to keep
                    del self.predictors[k]
                    self._by_place.discard(k)
                continue
            self._last[k] = (t, x, y)
            self._first.setdefault(k, t)
        for k in [k for k, (tl, _, _) in self._last.items() if t - tl > cfg.forget_after]:
            self._drop(k)
            self.predictors.pop(k, None)
        return out

    def same_entity(self, old: int, new: int) -> bool:
        """Track ``new`` is the entity that track ``old`` was (the follower, having lost
        ``old``, took ``new`` as its target: agents.FollowerAgent.pick): ``new`` takes over
        ``old``'s predictor, its leg and where it started, when ``old`` was last updated
        before ``new`` first was (two tracks seen at once are two entities), within
        ``forget_after``, ``new`` is now within 0.5 m + ``handover_speed`` x the time since
        of where ``old`` was last (no faster than a person walks), and ``new`` did not take
        over another track's leg by place (that one is kept). Returns whether it took over.

        ``handover_time`` keeps the hand-over by place short, as among many people a new
        track far from a lost one is likely someone else; the follower's choice says who it
        is. The observer that gave way with its back to the walker lost it for 5-15 s while
        the walker went on with its leg: its new track started a leg from where it was seen
        again, in the middle of the old one."""
        if old == new or old not in self._last or new not in self._first \
                or new in self._by_place:
            return False
        tl, xl, yl = self._last[old]
        t, x, y = self._last[new]
        if tl >= self._first[new] or not self._within_reach(
                math.hypot(x - xl, y - yl), t - tl, self.model.config):
            return False
        self.predictors[new] = self.predictors.pop(old)
        self._drop(old)
        self.handovers += 1
        return True

    def knows(self, track: int) -> bool:
        """Whether ``track`` has been updated (and not forgotten)."""
        return track in self._last

    def _drop(self, k: int) -> None:
        """Forget track ``k``'s times (its predictor is the caller's to drop or move)."""
        del self._last[k]
        self._first.pop(k, None)
        self._by_place.discard(k)

    def _within_reach(self, d: float, gap: float, cfg: PredictionConfig) -> bool:
        """Whether a person could have walked ``d`` metres in ``gap`` seconds: 0.5 m (the
        tracker's noise) + ``handover_speed`` x the gap."""
        return d <= self._NEAR + cfg.handover_speed * gap

    def _take_over(self, t: float, x: float, y: float, alive: set,
                   cfg: PredictionConfig) -> Optional[OnlinePredictor]:
        best, best_d = None, math.inf
        for k, (tl, xl, yl) in self._last.items():
            gap = t - tl
            if k in alive or gap < 0.0 or gap > cfg.handover_time:
                continue
            d = math.hypot(x - xl, y - yl)
            if self._within_reach(d, gap, cfg) and d < best_d:
                best, best_d = k, d
        if best is None:
            return None
        self._drop(best)
        self.handovers += 1
        return self.predictors.pop(best)
