"""Scan matching against the occupancy grid being built: where, near a guess, a scan fits the
map best (the embedded mapper's correction of odometry; mapping/slam.py).

A correlative search (Olson 2009): every candidate pose on a grid of shifts and turns around
the guess is scored, then the best one is refined on a grid four times finer around it. A
candidate's score:

* the likelihood field of the occupied cells at each end point (a Gaussian of its distance to
  the nearest one, ``sigma``; gmapping's scan matcher scores the same way), interpolated
  bilinearly between the cells' centres, as Hector SLAM reads its map (since session 68:
  read at the end point's cell, every pose within a cell of the best scored the same; on
  replayed explorations of office and the malaga maps the estimate was 16 cm off on average,
  7 cm interpolated; docs/mapping.md). The centres lie half a cell beyond the faces, so
  end points are drawn into the nearer walls: from the true pose in a small room, with
  exact scans, the match lands 2 cm off (test_mapping). The field is weighted by how
  sure the map is of that cell: its log-odds over the clamp, to the power ``evidence`` (a
  wall seen from many poses counts fully, a cell hit once about a fifth). A scan placed a
  little wrong draws a second copy of a wall; weighted so, the copy does not pull the next
  scans to it, and a corridor's walls mapped earlier hold the heading (session 42: office
  explored in one process, seeds 1-10, occupied F1 0.25-0.95 without, 0.53-0.95 with),
* an end point counting only where the map is free 1.5 cells before it along its beam: a
  wall's far face does not pull a beam that meets its near face,
* less a prior on the correction, ``prior`` x points x (squared share of the search window):
  at the default (0.3) a correction to the window's edge costs 0.3 of a point per point, so
  a scan moves that far only when it fits much better there. Odometry errs by millimetres
  between two scans (0.25 m or 0.25 rad apart); in test_mapping's small room, with every
  wall cell counted alike (``evidence`` 0), a guess 3.6 cm off is corrected to 1.5 cm and
  one 10 cm off to 2.4 cm (the pull into the nearer walls above), the next scan going on
  from there; by default walls seen by one or two scans count less against the prior;
  a second copy of a wall a few cells away (the grid redraws a wall where a scan placed
  slightly wrong puts it) or a corridor's few features do not pull the scan to them.
  (0.1 until session 27: on office the estimate hopped between two copies of a wall.)

Only end points within ``trace_range - 1`` m count: the free space traced by the scans before
ends at ``trace_range``, and a shift that brought more end points inside it would win.
"""
from __future__ import annotations

from dataclasses import dataclass
from typing import Sequence, Tuple, Union

import numpy as np

from .occupancy import OccupancyMapper, SURFACE, logit

__all__ = ["MatcherConfig", "match"]

Pose = Tuple[float, float, float]


@dataclass(frozen=True)
class MatcherConfig:
    """Search and score parameters (metres, radians).

    Attributes:
        window: the search's half-widths (shift, turn).
        steps: the coarse grid's steps (shift, turn); the refinement's are a quarter.
        sigma: the likelihood field's standard deviation (gmapping's ``sigma``).
        prior: the correction's cost, in points' worth per point at the window's edge.
        min_points: fewer end points than this: the guess stands.
        evidence: the power of a wall cell's certainty (log-odds / clamp) its field is
            weighted by; 0: every occupied cell counts alike.
    """

    window: Tuple[float, float] = (0.15, 0.08)
    steps: Tuple[float, float] = (0.025, 0.01)
    sigma: float = 0.05
    prior: float = 0.3
    min_points: int = 10
    evidence: float = 1.0


def match(mapper: OccupancyMapper, guess: Sequence[float],
          ranges: Union[np.ndarray, Sequence[float]], angle_min: float,
          angle_increment: float, range_max: float,
          config: MatcherConfig = MatcherConfig()) -> Pose:
    """The laser pose near ``guess`` (x, y, yaw) at which the scan best fits ``mapper``'s
    map (see the module doc). Ties go to the smallest correction; the guess stands when
    nothing scores higher, too few end points count, or the map has no wall yet."""
    g = (float(guess[0]), float(guess[1]), float(guess[2]))
    r = np.asarray(ranges, dtype=float)
    a = angle_min + angle_increment * np.arange(len(r))
    ok = (np.isfinite(r) & (r > 0) & (r < range_max)
          & (r < mapper.config.trace_range - 1.0))
    if ok.sum() < config.min_points or not (mapper.logodds > logit(
            mapper.config.occupied_thresh)).any():
        return g
    scorer = _Scorer(mapper, g, r[ok] + SURFACE, a[ok], config)
    if not scorer.walls:
        return g
    (w_xy, w_th), (s_xy, s_th) = config.window, config.steps
    best = scorer.best(_grid(0.0, w_xy, s_xy), _grid(0.0, w_th, s_th), (0.0, 0.0, 0.0, -np.inf))
    best = scorer.best(_grid(0.0, s_xy, s_xy / 4), _grid(best[2], s_th, s_th / 4), best,
                       centre=best[:2])
    return (g[0] + best[0], g[1] + best[1], g[2] + best[2])


def _grid(centre: float, half: float, step: float) -> np.ndarray:
    return centre + np.arange(-half, half + 1e-9, step)


class _Scorer:
    """The score of candidate corrections of one scan (see the module doc)."""

    def __init__(self, mapper: OccupancyMapper, guess: Pose, r: np.ndarray, a: np.ndarray,
                 config: MatcherConfig) -> None:
        from scipy.ndimage import distance_transform_edt

        self.guess, self.r, self.a, self.config = guess, r, a, config
        res = self.res = mapper.config.resolution
        reach = float(r.max()) + config.window[0] + config.steps[0]
        (r0, r1), (c0, c1) = mapper.cells(np.array([[guess[0] - reach, guess[1] - reach],
                                                    [guess[0] + reach, guess[1] + reach]]))
        h, w = mapper.logodds.shape
        r0, c0 = max(0, int(r0)), max(0, int(c0))
        r1, c1 = min(h, int(r1) + 1), min(w, int(c1) + 1)
        window = mapper.logodds[r0:r1, c0:c1]
        occupied = window > logit(mapper.config.occupied_thresh)
        self.walls = bool(occupied.any())     # none near the guess: nothing to match against
        if not self.walls:
            return
        d, (ri, ci) = distance_transform_edt(~occupied, return_indices=True)
        field = np.exp(-0.5 * (d * res / config.sigma) ** 2)
        if config.evidence > 0.0:         # the nearest wall cell's certainty
            field *= np.clip(window[ri, ci] / mapper.config.clamp_high, 0.0, 1.0) ** config.evidence
        # a rim of one cell (field 0, not free) stands for everything off the window
        self.field = np.pad(field, 1)
        self.free = np.pad(window < logit(mapper.config.free_thresh), 1)
        self.corner = (mapper.origin[0] + (c0 - 1) * res, mapper.origin[1] + (r0 - 1) * res)
        self.prior = config.prior * len(r)

    def best(self, shifts: np.ndarray, turns: np.ndarray, best: Tuple[float, ...],
             centre: Tuple[float, float] = (0.0, 0.0)) -> Tuple[float, float, float, float]:
        """(dx, dy, dth, score) of the best candidate of ``centre`` + shifts x shifts and
        ``turns``, or ``best`` when none scores higher."""
        dx, dy = (v.ravel() for v in np.meshgrid(centre[0] + shifts, centre[1] + shifts))
        (w_xy, w_th) = self.config.window
        for dth in turns:
            score = self._fit(dth, dx, dy) - self.prior * (
                (dx ** 2 + dy ** 2) / w_xy ** 2 + (dth / w_th) ** 2)
            # ties go to the smallest correction (the guess itself when nothing is better)
            size = np.hypot(dx, dy) + abs(dth)
            k = int(np.lexsort((size, -score))[0])
            if score[k] > best[3] + 1e-9 or (abs(score[k] - best[3]) <= 1e-9 and size[k]
                                             < np.hypot(best[0], best[1]) + abs(best[2])):
                best = (float(dx[k]), float(dy[k]), float(dth), float(score[k]))
        return best  # type: ignore[return-value]

    def _fit(self, dth: float, dx: np.ndarray, dy: np.ndarray) -> np.ndarray:
        """The likelihood of the end points with free space before them, per shift."""
        from scipy.ndimage import map_coordinates

        th = self.guess[2] + dth
        ca, sa = np.cos(self.a + th), np.sin(self.a + th)

        def at(d: np.ndarray) -> Tuple[np.ndarray, np.ndarray]:
            """Points ``d`` along the beams, per shift, in cells of the padded window."""
            return ((self.guess[0] + d * ca - self.corner[0] + dx[:, None]) / self.res,
                    (self.guess[1] + d * sa - self.corner[1] + dy[:, None]) / self.res)

        cols, rows = at(self.r - 1.5 * self.res)
        h, w = self.free.shape
        free = self.free[np.clip(np.floor(rows), 0, h - 1).astype(np.int64),
                         np.clip(np.floor(cols), 0, w - 1).astype(np.int64)]
        # the field between the cells' centres (linear; beyond the outer centres the outer
        # cells' values, the rim's 0)
        cols, rows = at(self.r)
        field = map_coordinates(self.field, [rows - 0.5, cols - 0.5], order=1, mode="nearest")
        return (field * free).sum(axis=1)
