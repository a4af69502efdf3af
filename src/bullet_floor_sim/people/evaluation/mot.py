"""Multi-object tracking scores against ground truth: the CLEAR MOT metrics (Bernardin &
Stiefelhagen 2008, "Evaluating multiple object tracking performance: the CLEAR MOT metrics").

Per frame, the people in view (ground truth) are matched to the tracks within ``threshold``
metres:

1. a person keeps the track it was matched to in the previous frame if that track is still
   within the threshold;
2. the others are matched by the Hungarian method on distance (scipy);
3. a person matched to a track other than the one it was last matched to (in any earlier
   frame) is an identity switch.

People in view without a track are misses, tracks without a person false positives, except a
track within the threshold of a person who is out of view (``dont_care``: occluded, or too
few beams on the legs): that is neither. MOTA = 1 - (misses + false positives + switches) /
people in view, summed over the frames; MOTP the mean distance of the matches.
"""
from __future__ import annotations

import math
from dataclasses import dataclass, field
from typing import Dict, Hashable, Iterable, Mapping, Sequence, Tuple

import numpy as np

__all__ = ["ClearMot"]

Point = Tuple[float, float]


@dataclass
class ClearMot:
    """Accumulated CLEAR MOT counts (call :meth:`update` once per frame)."""

    threshold: float = 0.5
    frames: int = 0
    truths: int = 0
    misses: int = 0
    false_positives: int = 0
    switches: int = 0
    matches: int = 0
    distance: float = 0.0
    matched: Dict[Hashable, Hashable] = field(default_factory=dict)   # last track of each
    per_person: Dict[Hashable, Dict[str, int]] = field(default_factory=dict)

    def update(self, truth: Mapping[Hashable, Point], tracks: Mapping[Hashable, Point],
               dont_care: Iterable[Point] = ()) -> Dict[Hashable, Hashable]:
        """Score one frame; returns this frame's matches, person -> track."""
        self.frames += 1
        self.truths += len(truth)
        pairs = self._keep(truth, tracks)
        free_t = [p for p in truth if p not in pairs]
        used = set(pairs.values())
        free_h = [h for h in tracks if h not in used]
        pairs.update(self._assign(truth, tracks, free_t, free_h))
        for person in truth:
            stats = self.per_person.setdefault(person, {"in_view": 0, "matched": 0,
                                                        "switches": 0})
            stats["in_view"] += 1
            if person not in pairs:
                self.misses += 1
                continue
            track = pairs[person]
            stats["matched"] += 1
            if person in self.matched and self.matched[person] != track:
                self.switches += 1
                stats["switches"] += 1
            self.matched[person] = track
            self.matches += 1
            self.distance += _dist(truth[person], tracks[track])
        used = set(pairs.values())
        others = [tuple(p) for p in dont_care]
        for h, xy in tracks.items():
            if h not in used and not any(_dist(xy, q) < self.threshold for q in others):
                self.false_positives += 1
        return pairs

    def _keep(self, truth: Mapping[Hashable, Point],
              tracks: Mapping[Hashable, Point]) -> Dict[Hashable, Hashable]:
        """The previous frame's matches that still hold (step 1)."""
        out: Dict[Hashable, Hashable] = {}
        taken = set()
        for person, xy in truth.items():
            track = self.matched.get(person)
            if (track is not None and track in tracks and track not in taken
                    and _dist(xy, tracks[track]) < self.threshold):
                out[person] = track
                taken.add(track)
        return out

    def _assign(self, truth: Mapping[Hashable, Point], tracks: Mapping[Hashable, Point],
                free_t: Sequence[Hashable], free_h: Sequence[Hashable]
                ) -> Dict[Hashable, Hashable]:
        """The Hungarian matching of the rest within the threshold (step 2)."""
        if not free_t or not free_h:
            return {}
        from scipy.optimize import linear_sum_assignment

        cost = np.array([[_dist(truth[p], tracks[h]) for h in free_h] for p in free_t])
        big = 1e6
        rows, cols = linear_sum_assignment(np.where(cost < self.threshold, cost, big))
        return {free_t[r]: free_h[c] for r, c in zip(rows, cols) if cost[r, c] < self.threshold}

    @property
    def mota(self) -> float:
        """1 - (misses + false positives + switches) / people in view (nan: none seen)."""
        if not self.truths:
            return math.nan
        return 1.0 - (self.misses + self.false_positives + self.switches) / self.truths

    @property
    def motp(self) -> float:
        """Mean distance (m) of the matched pairs (nan: none)."""
        return self.distance / self.matches if self.matches else math.nan


def _dist(a: Sequence[float], b: Sequence[float]) -> float:
    return math.hypot(a[0] - b[0], a[1] - b[1])
