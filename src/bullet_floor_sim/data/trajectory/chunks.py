"""Chunks of a trajectory: the Chunker that cuts a pose stream, their metrics, joining them
back, and the region a pose is in. See the package doc (data/trajectory)."""
from __future__ import annotations


import math
import uuid as uuidlib
from dataclasses import dataclass, field
from typing import Any, Callable, Dict, Iterable, Iterator, List, Optional, Sequence, Tuple

from ...errors import BulletFloorSimError


SPLITS = ("period", "region")
DEFAULT_PERIOD = 30.0
# A pose is about 260 bytes of BSON in mongodb_store's layout: 20,000 poses ~ 5 MB, far below
# MongoDB's 16 MB document limit (and 100 s of a 200 Hz pose stream).
DEFAULT_MAX_POSES = 20000
DEFAULT_MAX_GAP = 10.0

Pose = Tuple[int, float, float, float, float, float, float, float]

_NS = 1000000000


class TrajectoryError(BulletFloorSimError):
    """A bad chunking setting, a malformed stored trajectory or JSON line; names the input."""


# -- metrics ----------------------------------------------------------------------------------

def path_length(poses: Sequence[Pose]) -> float:
    """Sum of the (x, y) distances between consecutive poses (0.0 for fewer than 2)."""
    return math.fsum(math.hypot(b[1] - a[1], b[2] - a[2]) for a, b in zip(poses, poses[1:]))


def displacement(poses: Sequence[Pose]) -> float:
    """(x, y) distance from the first to the last pose (0.0 for none)."""
    if not poses:
        return 0.0
    return math.hypot(poses[-1][1] - poses[0][1], poses[-1][2] - poses[0][2])


def yaw_of(pose: Pose) -> float:
    """Heading (rad) of a pose's quaternion."""
    _, _, _, _, qx, qy, qz, qw = pose
    return math.atan2(2.0 * (qw * qz + qx * qy), 1.0 - 2.0 * (qy * qy + qz * qz))


def pose_from_xy_yaw(t_ns: int, x: float, y: float, yaw: float) -> Pose:
    """A planar pose: z = 0 and the quaternion of a rotation by ``yaw`` about z."""
    return (int(t_ns), float(x), float(y), 0.0, 0.0, 0.0, math.sin(yaw / 2.0),
            math.cos(yaw / 2.0))


@dataclass
class Chunk:
    """One stored piece of a trajectory: the fields of a human_trajectory Trajectory.

    Build one with :meth:`from_poses` (metrics computed) or with explicit metrics (a stored
    or imported chunk keeps its own values).

    Attributes:
        uuid: the trajectory's id.
        sequence_id: the chunk's number within the trajectory, from 0.
        poses: its poses, at least one, stamps not decreasing.
        complete: True for the last chunk of a trajectory.
        trajectory_length, trajectory_displacement, displacement_pose_ratio: the metrics.
        frame_id: the poses' frame.
        region: the region the chunk was recorded in (``split="region"``), else None.
        closed_by: why it was closed: period, region, size, gap, time_jump, end.
        map_name: the map it belongs to (stored meta), when known.
    """

    uuid: str
    sequence_id: int
    poses: List[Pose]
    complete: bool
    trajectory_length: float
    trajectory_displacement: float
    displacement_pose_ratio: float
    frame_id: str = "map"
    region: Optional[str] = None
    closed_by: str = ""
    map_name: Optional[str] = None

    @classmethod
    def from_poses(cls, uuid: str, sequence_id: int, poses: List[Pose], complete: bool,
                   **kwargs: Any) -> "Chunk":
        """A chunk with its metrics computed from ``poses`` (see module doc)."""
        d = displacement(poses)
        return cls(uuid, sequence_id, poses, complete, path_length(poses), d,
                   d / len(poses) if poses else 0.0, **kwargs)

    @property
    def start_ns(self) -> int:
        """Stamp of the first pose, ns."""
        return self.poses[0][0]

    @property
    def end_ns(self) -> int:
        """Stamp of the last pose, ns."""
        return self.poses[-1][0]


# -- chunking ---------------------------------------------------------------------------------

class Chunker:
    """Cuts a pose stream into chunks (see module doc). Not thread-safe: one caller at a time.

    Args:
        period: seconds of stamp time after which a chunk closes (0: never, only with
            ``split="region"``).
        split: "period" or "region".
        max_poses: the most poses a chunk holds (>= 2); a full chunk closes ("size").
        max_gap: seconds without a pose after which the trajectory ends (0: never).
        region_of: ``(x, y) -> region id or None``; required with ``split="region"``.
        new_uuid: makes trajectory ids (default: random UUID4 strings).

    Raises:
        TrajectoryError: a bad setting, named.
    """

    def __init__(self, period: float = DEFAULT_PERIOD, split: str = "period",
                 max_poses: int = DEFAULT_MAX_POSES, max_gap: float = DEFAULT_MAX_GAP,
                 region_of: Optional[Callable[[float, float], Optional[str]]] = None,
                 new_uuid: Optional[Callable[[], str]] = None):
        if split not in SPLITS:
            raise TrajectoryError("split %r: use one of %s" % (split, ", ".join(SPLITS)))
        if not _finite_at_least(period, 0.0) or (split == "period" and period == 0):
            raise TrajectoryError("period %r: must be a finite number of seconds > 0 (>= 0 "
                                  "with split region)" % (period,))
        if isinstance(max_poses, bool) or not isinstance(max_poses, int) or max_poses < 2:
            raise TrajectoryError("max_poses %r: must be an integer >= 2" % (max_poses,))
        if not _finite_at_least(max_gap, 0.0):
            raise TrajectoryError("max_gap %r: must be a finite number of seconds >= 0 (0: "
                                  "never end a trajectory on a gap)" % (max_gap,))
        if split == "region" and region_of is None:
            raise TrajectoryError("split region needs regions (a ROI file or the ROI service)")
        self.period = float(period)
        self.split = split
        self.max_poses = max_poses
        self.max_gap = float(max_gap)
        self._period_ns = int(round(period * _NS))
        self._gap_ns = int(round(max_gap * _NS))
        self._region_of = region_of if split == "region" else None
        self._new_uuid = new_uuid or (lambda: str(uuidlib.uuid4()))
        self._uuid: Optional[str] = None
        self._seq = 0
        self._poses: List[Pose] = []
        self._start = 0
        self._region: Optional[str] = None
        self.poses_added = 0

    @property
    def uuid(self) -> Optional[str]:
        """The open trajectory's id (None between trajectories)."""
        return self._uuid

    @property
    def sequence_id(self) -> int:
        """The open chunk's number within its trajectory."""
        return self._seq

    @property
    def open_poses(self) -> List[Pose]:
        """The poses of the open chunk (do not modify)."""
        return self._poses

    @property
    def region(self) -> Optional[str]:
        """The open chunk's region (``split="region"``)."""
        return self._region

    def add(self, pose: Pose) -> List[Chunk]:
        """Record one pose.

        Returns:
            The chunks this pose closed, oldest first: none, one, or (after a gap or a jump
            back in time, when the new pose itself closes nothing) the ended trajectory's last.
        """
        t = pose[0]
        closed: List[Chunk] = []
        if self._uuid is not None:
            last = self._poses[-1][0]
            if t < last:
                closed.append(self._end("time_jump"))
            elif self._gap_ns and t - last > self._gap_ns:
                closed.append(self._end("gap"))
        self.poses_added += 1
        if self._uuid is None:
            self._uuid, self._seq, self._start = self._new_uuid(), 0, t
            self._poses = [pose]
            if self._region_of is not None:
                self._region = self._region_of(pose[1], pose[2])
            return closed
        self._poses.append(pose)
        region = self._region
        if self._region_of is not None:
            region = self._region_of(pose[1], pose[2])
        if region != self._region:
            closed.append(self._cut("region", pose, region))
        elif self._period_ns and t - self._start >= self._period_ns:
            closed.append(self._cut("period", pose, region))
        elif len(self._poses) >= self.max_poses:
            closed.append(self._cut("size", pose, region))
        return closed

    def check_gap(self, now_ns: int) -> Optional[Chunk]:
        """End the trajectory if its last pose is more than ``max_gap`` older than ``now_ns``.

        Returns:
            The ended trajectory's last chunk, or None.
        """
        if self._uuid is None or not self._gap_ns or now_ns - self._poses[-1][0] <= self._gap_ns:
            return None
        return self._end("gap")

    def finish(self, reason: str = "end") -> Optional[Chunk]:
        """End the open trajectory (the recorder stops, or ``reason`` says why).

        Returns:
            Its last chunk (``complete``; it may hold only the boundary pose of the previous
            chunk), or None when no trajectory is open.
        """
        if self._uuid is None:
            return None
        return self._end(reason)

    def _cut(self, reason: str, pose: Pose, region: Optional[str]) -> Chunk:
        assert self._uuid is not None   # the callers have a trajectory open
        chunk = Chunk.from_poses(self._uuid, self._seq, self._poses, False,
                                 region=self._region, closed_by=reason)
        self._seq += 1
        self._poses = [pose]
        self._start = pose[0]
        self._region = region
        return chunk

    def _end(self, reason: str) -> Chunk:
        assert self._uuid is not None   # the callers have a trajectory open
        chunk = Chunk.from_poses(self._uuid, self._seq, self._poses, True,
                                 region=self._region, closed_by=reason)
        self._uuid, self._poses, self._region = None, [], None
        return chunk


def split_poses(poses: Sequence[Pose], max_poses: int) -> List[List[Pose]]:
    """Pieces of at most ``max_poses`` poses sharing their boundary poses (never drops one).

    Raises:
        TrajectoryError: ``max_poses`` < 2.
    """
    if max_poses < 2:
        raise TrajectoryError("max_poses %r: must be an integer >= 2" % (max_poses,))
    if len(poses) <= max_poses:
        return [list(poses)]
    step = max_poses - 1
    return [list(poses[i:i + max_poses]) for i in range(0, len(poses) - 1, step)]


@dataclass
class Joined:
    """A trajectory put back together from its chunks.

    Attributes:
        uuid: its id.
        poses: every pose once (boundary poses not repeated).
        chunks: how many chunks it was made of.
        complete: its last chunk is marked complete.
        map_name: the map of its chunks.
    """

    uuid: str
    poses: List[Pose] = field(default_factory=list)
    chunks: int = 0
    complete: bool = False
    map_name: Optional[str] = None

    @property
    def end_ns(self) -> int:
        return self.poses[-1][0] if self.poses else 0


def poses_once(chunks: Iterable[Chunk]) -> Iterator[Tuple[str, Pose]]:
    """(uuid, pose) of every pose of chunks in export order, each once: a chunk's first pose
    is left out when it repeats the last pose of its trajectory's chunk before it."""
    last: Dict[str, Pose] = {}
    for c in chunks:
        for k, p in enumerate(c.poses):
            if k == 0 and last.get(c.uuid) == p:
                continue
            yield c.uuid, p
        if c.poses:
            last[c.uuid] = c.poses[-1]


def join_chunks(chunks: Iterable[Chunk]) -> List[Joined]:
    """Group chunks by uuid and concatenate each group in ``sequence_id`` order, leaving out a
    chunk's first pose when it repeats the previous chunk's last one.

    Returns:
        One :class:`Joined` per uuid, ordered by the first pose's stamp (then uuid).
    """
    groups: Dict[str, List[Chunk]] = {}
    for c in chunks:
        groups.setdefault(c.uuid, []).append(c)
    out = []
    for uid, group in groups.items():
        group.sort(key=lambda c: c.sequence_id)
        j = Joined(uid, chunks=len(group), complete=group[-1].complete,
                   map_name=group[0].map_name)
        for c in group:
            start = 1 if j.poses and c.poses and c.poses[0] == j.poses[-1] else 0
            j.poses.extend(c.poses[start:])
        out.append(j)
    out.sort(key=lambda j: (j.poses[0][0] if j.poses else 0, j.uuid))
    return out


# -- regions ----------------------------------------------------------------------------------

class RegionLocator:
    """``region_of(x, y)`` for the chunker: the id of :func:`~.rois.roi_at`'s answer (the
    smallest ROI covering the point, boundary included), with a bounding-box pre-check and
    prepared shapely polygons (a few microseconds per pose).

    Args:
        rois: the regions (:class:`~.rois.Roi`).
    """

    def __init__(self, rois: Sequence[Any]):
        import shapely

        from ..rois import roi_polygon

        entries = []
        for roi in rois:
            poly = roi_polygon(roi)
            shapely.prepare(poly)
            xs = [v[0] for v in roi.vertices]
            ys = [v[1] for v in roi.vertices]
            entries.append((poly.area, min(xs), max(xs), min(ys), max(ys), poly, roi.id))
        entries.sort(key=lambda e: e[0])  # smallest first: the first hit is the answer
        self._entries = entries
        self._test = shapely.intersects_xy
        self.ids = [e[6] for e in entries]

    def __call__(self, x: float, y: float) -> Optional[str]:
        for _, x0, x1, y0, y1, poly, rid in self._entries:
            if x0 <= x <= x1 and y0 <= y <= y1 and self._test(poly, x, y):
                return rid
        return None


# -- documents (mongodb_store's layout) -------------------------------------------------------


def _finite_at_least(v: Any, low: float) -> bool:
    return (isinstance(v, (int, float)) and not isinstance(v, bool) and math.isfinite(v)
            and v >= low)
