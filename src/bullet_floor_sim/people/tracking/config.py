"""The tracker's parameters, checked. See the package doc."""
from __future__ import annotations

from dataclasses import dataclass


from ...errors import BulletFloorSimError
from ...sim.checks import check_integers, check_numbers

#: TrackerConfig.edge_cut's values.
EDGE_CUT = ("use", "position", "drop")


class TrackingError(BulletFloorSimError):
    """Bad tracker parameters or inputs (the message names the field or input)."""


@dataclass
class TrackerConfig:
    """Detection and tracking parameters (metres, seconds).

    Attributes:
        static_tolerance: a scan point whose map cell is within this distance (cell centre to
            cell centre) of an occupied or unknown cell is explained by the static map. 0.2 m
            covers the map's 0.05 m cells, range noise and a little pose error.
        cluster_gap: consecutive scan points (in beam order) farther apart than this start a
            new cluster. 0.3 m: one body's points stay together (1-degree beams are 0.05 m
            apart at 3 m), two people side by side usually do not. Every fold keeps 0.3 m
            against 0.45 m (docs/evaluation.md, session 82).
        min_points: clusters with fewer points are dropped (stray returns, far thin objects).
        min_size, max_size: bounds on a cluster's extent (largest distance between two of its
            points): from a leg (0.05 m) to a robot seen from the side (1.0 m); walls that the
            map does not explain (a moved cupboard) are longer. Every fold keeps 0.05 m
            against 0.02 and 0.1 m (docs/evaluation.md, session 82).
        centre_offset: the detection's centre is the cluster's centroid moved this far away
            from the sensor. The default, 0.2 m, suits a round body about 0.5 m wide: for a
            cylinder of radius 0.25 m seen with 1-degree beams the centroid of its near arc
            lies 0.18 m (at 4 m) to 0.21 m (at 1 m) in front of the centre; a flat 0.5 m face
            would want 0.25 m. The Scitos A5 (an octagon 0.64 m across) wants 0.25 m.
        process_noise: standard deviation of the white acceleration noise of the
            constant-velocity model (m/s^2); people and robots change speed by about 1 m/s^2.
            Every fold keeps 1 m/s^2 against 0.5 m/s^2 (docs/evaluation.md, session 82).
        measurement_noise: standard deviation of a detection's centre (m), per axis. Shape
            and viewpoint move the centre by more than the range noise does.
        gate: chi-square gate on the squared Mahalanobis distance of the innovation (2 degrees
            of freedom): 9.21 keeps 99% of true detections.
        confirm_hits: a track is confirmed (reported) from this many hits on.
        max_age: a confirmed track without a hit for longer than this is deleted.
        tentative_max_age: the same for a tentative track; shorter, so that clutter dies fast.
        max_speed: the fastest entity to track (m/s): a new track's velocity prior is zero
            with standard deviation ``max_speed / 2`` per axis.
        min_travel: a track is confirmed only once its estimate has also moved this far (m)
            from where it was born: 0 reports standing bodies too; > 0 keeps out static
            clutter that the map does not explain (furniture, or door jambs smeared by a pose
            that lags the scan while the robot turns), at the price of not reporting an
            entity until it has moved. Every fold keeps 0 against 0.2 m
            (docs/evaluation.md, session 81).
        edge_cut: what a cluster on the first or last beam that reads (detection.view_edge)
            of a scan that is not a full circle counts for. The edge of the view cuts a body
            standing across it: its points lie to one side of its centre, and as it leaves
            the view their centroid slides along the edge, which a track takes for motion.
            On the ipa production plant a standing walker leaving the observer's 180-degree
            view at its side became a track going 0.35 m/s the other way; the observer
            trailed it there and lost the walker for 1384 s (docs/evaluation.md, session 78).
            ``use``: a detection like any other; ``position``: it corrects the position of
            the track it is assigned, not its velocity (a track it starts stands until a
            whole body is seen); ``drop``: it is no detection. The folds keep ``use``
            (docs/defaults.md).
    """

    static_tolerance: float = 0.2
    cluster_gap: float = 0.3
    min_points: int = 3
    min_size: float = 0.05
    max_size: float = 1.0
    centre_offset: float = 0.2
    process_noise: float = 1.0
    measurement_noise: float = 0.1
    gate: float = 9.21
    confirm_hits: int = 3
    max_age: float = 1.0
    tentative_max_age: float = 0.25
    max_speed: float = 2.0
    min_travel: float = 0.0
    edge_cut: str = "use"

    def check(self) -> None:
        """Raise TrackingError naming the first bad parameter."""
        check_numbers(self, ("static_tolerance", "min_size", "centre_offset", "min_travel"),
                      "tracker", strict=False, error=TrackingError)
        check_numbers(self, ("cluster_gap", "max_size", "process_noise", "measurement_noise",
                             "gate", "max_age", "tentative_max_age", "max_speed"),
                      "tracker", error=TrackingError)
        check_integers(self, ("min_points", "confirm_hits"), "tracker", error=TrackingError)
        if self.edge_cut not in EDGE_CUT:
            raise TrackingError("tracker: edge_cut must be one of %s, got %r"
                                % (", ".join(EDGE_CUT), self.edge_cut))
        if self.max_size < self.min_size:
            raise TrackingError("tracker: max_size (%g m) must be >= min_size (%g m)"
                                % (self.max_size, self.min_size))


# --------------------------------------------------------------------------------------------
# detection
# --------------------------------------------------------------------------------------------
