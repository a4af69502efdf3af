"""Scoring a leg: each pipeline's latest prediction at each fraction of the leg observed,
against the predictor's two baselines; and scoring a run again under other prediction
parameters (:func:`rescore`)."""
from __future__ import annotations

from dataclasses import replace
from typing import Dict, List, Optional, Sequence, Tuple

import numpy as np

from ..prediction import DestinationModel, log_loss, posterior_or_prior, top1
from .result import FRACTIONS, METHODS, PIPELINES, EvalResult, LegScore, Moment

__all__ = ["Record", "score_leg", "moment", "score_pipeline", "rescore", "carried"]


class Record:
    """The latest prediction of one pipeline, with the observation it was made from."""

    __slots__ = ("t", "prediction", "xy", "velocity")

    def __init__(self, t, prediction, xy, velocity) -> None:
        self.t, self.prediction, self.xy, self.velocity = t, prediction, xy, velocity


def carried(records: List[Record], since: float) -> List[Record]:
    """The records a new leg starts with: the latest one made at or after ``since`` (when the
    walker's previous leg ended, so while it stood where this leg starts) if it predicts the
    leg to come (``under_way`` False: the chain's row of where the entity stands), else none.

    The observer that saw the walker stand and lost it before it set off has predicted this leg
    before the leg began; without the carry that prediction scored as none at all. A record
    of a leg under way then (the one that just ended, or one the track's jitter started
    during the stand) is not carried."""
    if records and records[-1].t >= since and not records[-1].prediction.under_way:
        return [records[-1]]
    return []


def score_leg(leg, gt: List[Record], trk: List[Record], model: DestinationModel,
           uniform: Dict[str, float]) -> LegScore:
    """Score a completed leg from each pipeline's records, and keep the moments scored."""
    out = LegScore(leg.number, leg.start_region, leg.target_region, leg.duration)
    for name, records in (("ground_truth", gt), ("tracker", trk)):
        times = [r.t for r in records]
        latest = []
        for f in FRACTIONS:
            k = int(np.searchsorted(times, leg.started + f * leg.duration, side="right")) - 1
            latest.append(records[k] if k >= 0 else None)
        out.moments[name] = [None if r is None else moment(r) for r in latest]
        seen = [None if r is None else (r.prediction.probabilities, out.moments[name][i])
                for i, r in enumerate(latest)]
        # a moment is None exactly where its record is: mypy cannot pair the two lists up
        out.scores[name] = score_pipeline(leg.target_region, seen, model, uniform)  # type: ignore[arg-type]
    return out


def moment(rec: Record) -> Moment:
    p = rec.prediction
    return (p.start_region, float(p.start_xy[0]), float(p.start_xy[1]), float(rec.xy[0]),
            float(rec.xy[1]), float(rec.velocity[0]), float(rec.velocity[1]))


def score_pipeline(truth: str, seen: Sequence[Optional[Tuple[Dict[str, float], Moment]]],
                    model: DestinationModel, uniform: Dict[str, float]
                    ) -> Dict[str, List[Tuple[bool, float, bool]]]:
    """Per method, per fraction (correct, log-loss, predicted) from the predictor's
    probabilities and the moment they were made at (None: no prediction of the leg)."""
    per = {m: [] for m in METHODS}  # type: Dict[str, List[Tuple[bool, float, bool]]]
    for item in seen:
        if item is None:
            for m in METHODS:
                per[m].append((False, log_loss(uniform, truth), False))
            continue
        probs, (r0, _sx, _sy, qx, qy, vx, vy) = item
        dists = {"predictor": probs, "markov": model.markov_baseline(r0),
                 "heading": model.heading_baseline(r0, (qx, qy), (vx, vy))}
        for m in METHODS:
            per[m].append((top1(dists[m]) == truth, log_loss(dists[m], truth), True))
    return per


def rescore(result: EvalResult, model: DestinationModel) -> EvalResult:
    """The same run scored with another destination model (other prediction parameters):
    each leg's moments (start region, S, Q, velocity at each fraction) get that model's
    posterior, as the live predictor computes it. The walk, the tracks and the leg cuts stay
    those of the run, so this measures the posterior alone (the follower, which searches
    where the live predictor pointed, is not re-run)."""
    uniform = {r: 1.0 / len(model.chain.ids) for r in model.chain.ids}
    legs = []
    for leg in result.legs:
        new = LegScore(leg.number, leg.start_region, leg.target_region, leg.duration,
                       moments=leg.moments)
        for name in PIPELINES:
            seen = [None if m is None else
                    (posterior_or_prior(model, m[0], m[1:3], m[3:5])[0], m)
                    for m in leg.moments[name]]
            new.scores[name] = score_pipeline(leg.target_region, seen, model, uniform)
        legs.append(new)
    return replace(result, legs=legs)
