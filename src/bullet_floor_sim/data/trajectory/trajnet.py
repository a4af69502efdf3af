"""Trajectories as trajectory-prediction benchmarks read them (``trajectories export --format
trajnet|ethucy``), each with a sidecar that says who each id is.

Both sample every trajectory at a fixed ``rate`` (2.5 Hz, the ETH/UCY and TrajNet++ rate) by
linear interpolation between its poses, count frames from the export's first sample (frame
0) and number the trajectories 1, 2, ... in export order. A sample whose poses on either side
are more than two sample periods apart is left out: a gap in the recording stays a gap (as in
the real datasets, and TrajNet++'s continuity rule then sees it).

* ``ethucy``: the plain text of the ETH/UCY sets as Social-GAN-style loaders read them:
  ``frame<TAB>id<TAB>x<TAB>y`` per line, ordered by frame then id.
* ``trajnet``: TrajNet++ ndjson, as ``trajnetplusplustools.Reader`` loads it: ``{"scene":
  {"id", "p", "s", "e", "fps", "tag"}}`` lines, then ``{"track": {"f", "p", "x", "y"}}`` lines
  (x, y rounded to the centimetre) for the frames of some scene. Scenes are cut as
  trajnetplusplusdataset's ``Scenes`` cuts them (trajnetdataset/scene.py at 00b2f24, with
  its defaults): for each person, windows of 21 samples (9 observed, 12 to predict) every 3
  samples along their track, kept when the person moves (squared displacement over the
  window above 0.2 m²), the frames have no gap (no step over 1.5 times the median), the
  window holds at least 2 x 21 rows of all people, and in one of its frames the person shares
  a 5 m grid cell with someone else. A walker alone thus makes no scene: TrajNet++ scenes are
  of people among people. ``tag`` is 0 (TrajNet++ categorises scenes afterwards).
* The sidecar (``<out>.meta.json``): the format, the rate, frame 0's time (ROS time, s; null
  when nothing was sampled) and for each id its uuid, person or robot name, kind and map.
"""
from __future__ import annotations

import json
import math
from collections import defaultdict
from dataclasses import dataclass
from fractions import Fraction
from typing import IO, Any, Dict, Iterable, Iterator, List, Mapping, Optional, Set, Tuple

from ...errors import BulletFloorSimError
from .chunks import Chunk, Pose, poses_once

__all__ = ["RATE", "Sampled", "sample", "write_ethucy", "trajnet_scenes", "write_trajnetpp",
           "sidecar", "write_sidecar"]

RATE = 2.5
CHUNK_SIZE, CHUNK_STRIDE, MIN_LENGTH = 21, 3, 0.2   # trajnetdataset/scene.py's defaults
_CELL = 5          # m: the grid of scene.py's close_pedestrians
_NS = 1_000_000_000

Row = Tuple[int, int, float, float]     # frame, id, x, y


@dataclass
class Sampled:
    """Every trajectory sampled at ``rate``: ``rows`` ordered by frame then id (frame 0 is
    the first sample, at ``frame0_ns``), ``ids`` the uuid of each id."""

    rows: List[Row]
    ids: Dict[int, str]
    frame0_ns: Optional[int]
    rate: float


def sample(chunks: Iterable[Chunk], rate: float = RATE) -> Sampled:
    """The selected chunks' trajectories sampled at ``rate`` Hz (see the module doc).

    Raises:
        BulletFloorSimError: the rate is not a positive number.
    """
    if not (math.isfinite(rate) and rate > 0):
        raise BulletFloorSimError("trajnet: rate must be a positive number of Hz, got %r"
                                  % (rate,))
    tracks: Dict[str, List[Pose]] = {}
    for uuid, p in poses_once(chunks):
        tracks.setdefault(uuid, []).append(p)
    rows: List[Row] = []
    ids: Dict[int, str] = {}
    for person, (uuid, poses) in enumerate(tracks.items(), 1):
        ids[person] = uuid
        rows.extend((k, person, x, y) for k, x, y in _samples(poses, rate))
    if not rows:
        return Sampled([], ids, None, rate)
    first = min(r[0] for r in rows)
    rows = sorted(((k - first, p, x, y) for k, p, x, y in rows), key=lambda r: (r[0], r[1]))
    return Sampled(rows, ids, round(Fraction(first) * _NS / Fraction(rate)), rate)


def _samples(poses: List[Pose], rate: float) -> Iterator[Tuple[int, float, float]]:
    """(sample number since t = 0, x, y) at every multiple of 1 / rate the poses span,
    interpolated linearly between the poses around it."""
    step_ns = _NS / rate
    k = math.ceil(poses[0][0] / step_ns)
    j = 0
    while k * step_ns <= poses[-1][0]:
        t = k * step_ns
        while j + 1 < len(poses) and poses[j + 1][0] < t:
            j += 1
        a = poses[j]
        b = poses[min(j + 1, len(poses) - 1)]
        if b[0] - a[0] <= 2.0 * step_ns or t in (a[0], b[0]):   # (a gap: no sample)
            f = 0.0 if b[0] == a[0] else (t - a[0]) / (b[0] - a[0])
            yield k, a[1] + f * (b[1] - a[1]), a[2] + f * (b[2] - a[2])
        k += 1


def write_ethucy(s: Sampled, out: IO[str]) -> int:
    """``frame<TAB>id<TAB>x<TAB>y`` lines; returns how many."""
    for k, person, x, y in s.rows:
        out.write("%d\t%d\t%.4f\t%.4f\n" % (k, person, x, y))
    return len(s.rows)


def trajnet_scenes(s: Sampled, chunk_size: int = CHUNK_SIZE, stride: int = CHUNK_STRIDE,
                   min_length: float = MIN_LENGTH) -> List[Tuple[int, int, int]]:
    """(primary id, first frame, last frame) of every scene, as trajnetdataset's Scenes cuts
    them (see the module doc), in id order then time."""
    count: Dict[int, int] = defaultdict(int)
    cells: Dict[int, Dict[Tuple[int, int], Set[int]]] = defaultdict(lambda: defaultdict(set))
    paths: Dict[int, List[Row]] = defaultdict(list)
    for row in s.rows:
        k, person, x, y = row
        count[k] += 1
        cells[k][(int(x // _CELL * _CELL), int(y // _CELL * _CELL))].add(person)
        paths[person].append(row)
    close = {k: {p for group in by_cell.values() if len(group) > 1 for p in group}
             for k, by_cell in cells.items()}
    out = []
    for person in sorted(paths):
        path = paths[person]
        for i in range(0, len(path) - chunk_size + 1, stride):
            a, b = path[i], path[i + chunk_size - 1]
            frames = [r[0] for r in path[i:i + chunk_size]]
            if ((a[2] - b[2]) ** 2 + (a[3] - b[3]) ** 2 > min_length
                    and _continuous(frames)
                    and sum(count[f] for f in frames) >= 2.0 * chunk_size
                    and any(person in close[f] for f in frames)):
                out.append((person, frames[0], frames[-1]))
    return out


def _continuous(frames: List[int], tolerance: float = 1.5) -> bool:
    steps = [f2 - f1 for f1, f2 in zip(frames[:-1], frames[1:])]
    return sorted(steps)[len(steps) // 2] * tolerance > max(steps)


def write_trajnetpp(s: Sampled, out: IO[str]) -> Tuple[int, int]:
    """TrajNet++ ndjson: the scenes, then the tracks of their frames; returns (scenes,
    track lines)."""
    scenes = trajnet_scenes(s)
    frames: Set[int] = set()
    for scene_id, (person, first, last) in enumerate(scenes):
        out.write(json.dumps({"scene": {"id": scene_id, "p": person, "s": first, "e": last,
                                        "fps": s.rate, "tag": 0}}) + "\n")
        frames.update(range(first, last + 1))
    n = 0
    for k, person, x, y in s.rows:
        if k in frames:
            out.write(json.dumps({"track": {"f": k, "p": person, "x": round(x, 2),
                                            "y": round(y, 2)}}) + "\n")
            n += 1
    return len(scenes), n


def sidecar(s: Sampled, fmt: str, meta: Mapping[str, Mapping[str, Any]]) -> Dict[str, Any]:
    """What the ids of an export are: ``meta`` is each uuid's stored ``_meta``."""
    ids = {}
    for person, uuid in s.ids.items():
        m = meta.get(uuid, {})
        kind = "person" if m.get("person") else "robot" if m.get("robot") else ""
        ids[str(person)] = {"uuid": uuid, "name": str(m.get("person") or m.get("robot") or ""),
                            "kind": kind, "map": str(m.get("map", ""))}
    frame0 = None
    if s.frame0_ns is not None:
        frame0 = "%d.%09d" % divmod(s.frame0_ns, _NS)
    return {"format": fmt, "rate": s.rate, "frame0_time": frame0, "ids": ids}


def write_sidecar(path: str, content: Dict[str, Any]) -> None:
    """The sidecar beside ``path`` (``<path>.meta.json``)."""
    from ...files import atomic_file

    with atomic_file(path + ".meta.json") as f:
        json.dump(content, f, indent=1, sort_keys=True)
        f.write("\n")
