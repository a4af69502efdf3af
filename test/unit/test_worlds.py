"""Unit tests for the generated worlds (tools/make_worlds.py), no ROS needed.

The map images, world files and ROI files are read back from disk and
checked on the rasterised image: wall/pillar positions of the ``simple``
world, door widths, spawn clearance, reachability and ROI connectivity of
the ``office`` world.
"""
from __future__ import annotations

import collections
import math
import sys
from pathlib import Path

import numpy as np
import pytest
import shapely
import yaml
from PIL import Image
from shapely.geometry import Polygon, box

HERE = Path(__file__).resolve().parent
sys.path.insert(0, str(HERE / ".." / ".." / "tools"))

import make_worlds  # noqa: E402  (needs the sys.path entry above)

WORLDS_DIR = HERE / ".." / ".." / "worlds"
FILES = ("map.pgm", "map.yaml", "world.yaml", "rois.yaml")
FREE, OCCUPIED, UNKNOWN = 254, 0, 205
RES = 0.05
ADJ_TOL = 0.2
ROBOT_RADIUS = 0.35


# ---------------------------------------------------------------------------
# helpers
# ---------------------------------------------------------------------------


class MapImage:
    """A map image with its metadata, read back from a world directory."""

    def __init__(self, world_dir: Path):
        meta = yaml.safe_load((world_dir / "map.yaml").read_text())
        self.resolution = float(meta["resolution"])
        self.origin = [float(v) for v in meta["origin"]]
        self.pixels = np.array(Image.open(world_dir / meta["image"]))
        self.height, self.width = self.pixels.shape

    def cell(self, x: float, y: float):
        """Return (row, col) of the cell containing world point (x, y)."""
        col = int(math.floor((x - self.origin[0]) / self.resolution))
        up = int(math.floor((y - self.origin[1]) / self.resolution))
        return self.height - 1 - up, col

    def at(self, x: float, y: float) -> int:
        """Return the pixel value of the cell containing (x, y)."""
        row, col = self.cell(x, y)
        return int(self.pixels[row, col])

    def centres(self):
        """Return world x, y arrays of all cell centres (image layout)."""
        cols = np.arange(self.width)
        rows = np.arange(self.height)
        xs = self.origin[0] + (cols + 0.5) * self.resolution
        ys = self.origin[1] + (self.height - rows - 0.5) * self.resolution
        return np.meshgrid(xs, ys)


def load_world(name: str):
    """Return (map image, world.yaml dict, rois.yaml dict) of a world."""
    world_dir = WORLDS_DIR / name
    world = yaml.safe_load((world_dir / "world.yaml").read_text())
    rois = yaml.safe_load((world_dir / world["rois"]).read_text())
    return MapImage(world_dir), world, rois


def adjacent(a, b) -> bool:
    """Seed project rule: some vertex pair within 0.2 m in x AND in y."""
    return any(abs(p[0] - q[0]) <= ADJ_TOL and abs(p[1] - q[1]) <= ADJ_TOL
               for p in a for q in b)


def roi_graph(rois):
    """Return {roi id: set of neighbour ids} for all ROI pairs."""
    graph = {r["id"]: set() for r in rois}
    for i, a in enumerate(rois):
        for b in rois[i + 1:]:
            if adjacent(a["points"], b["points"]):
                graph[a["id"]].add(b["id"])
                graph[b["id"]].add(a["id"])
    return graph


def free_run(line: np.ndarray, index: int) -> int:
    """Return the length of the run of FREE cells through ``line[index]``."""
    if line[index] != FREE:
        return 0
    lo, hi = index, index
    while lo > 0 and line[lo - 1] == FREE:
        lo -= 1
    while hi < len(line) - 1 and line[hi + 1] == FREE:
        hi += 1
    return hi - lo + 1


def reachable(image: MapImage, start, radius: float) -> np.ndarray:
    """Return cells a disc robot of ``radius`` can reach from ``start``.

    Cells whose centre is within ``radius`` of a non-free cell centre are
    blocked; the rest are flood-filled (4-connected) from the start cell.
    """
    blocked = image.pixels != FREE
    reach = int(math.ceil(radius / image.resolution))
    inflated = blocked.copy()
    h, w = blocked.shape
    for dr in range(-reach, reach + 1):
        for dc in range(-reach, reach + 1):
            if math.hypot(dr, dc) * image.resolution > radius:
                continue
            src = blocked[max(0, -dr):h - max(0, dr),
                          max(0, -dc):w - max(0, dc)]
            inflated[max(0, dr):h - max(0, -dr),
                     max(0, dc):w - max(0, -dc)] |= src
    seen = np.zeros_like(blocked)
    row, col = image.cell(*start)
    assert not inflated[row, col], "start cell is in collision"
    queue = collections.deque([(row, col)])
    seen[row, col] = True
    while queue:
        r, c = queue.popleft()
        for nr, nc in ((r + 1, c), (r - 1, c), (r, c + 1), (r, c - 1)):
            if 0 <= nr < h and 0 <= nc < w and not seen[nr, nc] \
                    and not inflated[nr, nc]:
                seen[nr, nc] = True
                queue.append((nr, nc))
    return seen


def roi_cell_mask(image: MapImage, points) -> np.ndarray:
    """Return the mask of cells whose centre lies inside an ROI polygon."""
    xs, ys = image.centres()
    return shapely.contains_xy(Polygon(points), xs, ys)


# ---------------------------------------------------------------------------
# 1. reproducibility
# ---------------------------------------------------------------------------


def test_regeneration_is_byte_identical(tmp_path):
    make_worlds.generate(tmp_path)
    for world in ("simple", "office"):
        for name in FILES:
            fresh = (tmp_path / world / name).read_bytes()
            committed = (WORLDS_DIR / world / name).read_bytes()
            assert fresh == committed, "%s/%s differs" % (world, name)


def test_map_files_follow_map_server_conventions():
    for world in ("simple", "office"):
        raw = (WORLDS_DIR / world / "map.pgm").read_bytes()
        assert raw.startswith(b"P5\n")
        meta = yaml.safe_load((WORLDS_DIR / world / "map.yaml").read_text())
        assert meta == {"image": "map.pgm", "resolution": 0.05,
                        "origin": [0.0, 0.0, 0.0], "negate": 0,
                        "occupied_thresh": 0.65, "free_thresh": 0.196,
                        "mode": "trinary"}
        image = Image.open(WORLDS_DIR / world / "map.pgm")
        assert image.mode == "L"


# ---------------------------------------------------------------------------
# 2. simple world
# ---------------------------------------------------------------------------


def test_simple_map_geometry():
    image, _, _ = load_world("simple")
    assert (image.width, image.height) == (120, 80)
    assert set(np.unique(image.pixels)) == {OCCUPIED, FREE}
    # Pillar x 4.00..4.50, y 1.00..1.50 (cell centres probed).
    assert image.at(4.225, 1.225) == OCCUPIED
    assert image.at(4.025, 1.025) == OCCUPIED
    assert image.at(4.475, 1.475) == OCCUPIED
    assert image.at(3.975, 1.225) == FREE
    assert image.at(4.525, 1.225) == FREE
    assert image.at(4.225, 0.975) == FREE
    assert image.at(4.225, 1.525) == FREE
    # Outer walls 0.10 m thick on every side.
    assert image.at(0.025, 2.025) == OCCUPIED
    assert image.at(0.075, 2.025) == OCCUPIED
    assert image.at(0.125, 2.025) == FREE
    assert image.at(5.875, 2.025) == FREE
    assert image.at(5.925, 2.025) == OCCUPIED
    assert image.at(3.025, 0.075) == OCCUPIED
    assert image.at(3.025, 0.125) == FREE
    assert image.at(3.025, 3.875) == FREE
    assert image.at(3.025, 3.925) == OCCUPIED
    # Row 0 is the top of the map: the top wall is in the first two rows.
    assert (image.pixels[:2] == OCCUPIED).all()
    assert image.pixels[2, 2] == FREE
    # Walls (120*80 - 116*76) plus the 10 x 10 pillar.
    assert int((image.pixels == OCCUPIED).sum()) == 9600 - 116 * 76 + 100


def test_simple_world_and_rois():
    _, world, rois = load_world("simple")
    assert world["map"] == "map.yaml"
    assert world["rois"] == "rois.yaml"
    assert world["wall_height"] == 2.0
    assert [(r["name"], r["model"], r["pose"]) for r in world["robots"]] == [
        ("robot1", "scitos_a5", [1.5, 2.0, 0.0]),
        ("robot2", "scitos_a5", [3.0, 3.0, 3.141592653589793])]
    assert rois["map_name"] == "simple"
    assert rois["config"] == "1"
    assert [r["points"] for r in rois["rois"]] == [
        [[0.35, 0.35], [3.0, 0.35], [3.0, 3.65], [0.35, 3.65]],
        [[3.0, 0.35], [5.65, 0.35], [5.65, 3.65], [3.0, 3.65]]]
    assert roi_graph(rois["rois"]) == {"1": {"2"}, "2": {"1"}}


# ---------------------------------------------------------------------------
# 3. office world: map, doors, spawn poses
# ---------------------------------------------------------------------------


def test_office_map_outline():
    image, _, _ = load_world("office")
    assert (image.width, image.height) == (600, 400)
    margin = 10  # 0.5 m of unknown around the building
    px = image.pixels
    for band in (px[:margin], px[-margin:], px[:, :margin], px[:, -margin:]):
        assert (band == UNKNOWN).all()
    inside = px[margin:-margin, margin:-margin]
    assert not (inside == UNKNOWN).any()
    # Exterior walls: 3 cells (0.15 m) occupied along the building outline.
    assert (inside[:3] == OCCUPIED).all() and (inside[-3:] == OCCUPIED).all()
    assert (inside[:, :3] == OCCUPIED).all()
    assert (inside[:, -3:] == OCCUPIED).all()
    assert image.at(0.675, 5.0) == FREE


def test_office_doors_are_wide_enough():
    image, _, _ = load_world("office")
    world = make_worlds.office_world()
    doors = make_worlds.all_doors(world)
    assert len(doors) == len(world.rooms) - 1
    for owner, door, _ in doors:
        x0, y0, x1, y1 = make_worlds.door_gap(owner, door)
        mid_x, mid_y = (x0 + x1) / 2.0, (y0 + y1) / 2.0
        horizontal = door.side in ("north", "south")
        depth = (y1 - y0) if horizontal else (x1 - x0)
        # Probe every row (or column) of cells across the wall thickness.
        cells = int(round(depth / RES))
        for k in range(cells):
            if horizontal:
                row, col = image.cell(mid_x, y0 + (k + 0.5) * RES)
                run = free_run(image.pixels[row, :], col)
            else:
                row, col = image.cell(x0 + (k + 0.5) * RES, mid_y)
                run = free_run(image.pixels[:, col], row)
            width = run * RES
            assert width >= 1.0 - 1e-9, "%s door too narrow" % owner.name
            assert width == pytest.approx(door.end - door.start)


def test_office_spawn_poses():
    image, world, _ = load_world("office")
    robots = world["robots"]
    assert [r["name"] for r in robots] == ["robot1", "robot2"]
    assert all(r["model"] == "scitos_a5" for r in robots)
    (ax, ay, _), (bx, by, _) = robots[0]["pose"], robots[1]["pose"]
    assert math.hypot(ax - bx, ay - by) >= 3.0
    xs, ys = image.centres()
    for robot in robots:
        x, y, _ = robot["pose"]
        near = np.hypot(xs - x, ys - y) <= 0.6 + RES / 2.0
        assert (image.pixels[near] == FREE).all(), robot["name"]
        # Spawn in the corridor.
        corridor = make_worlds.office_world().rooms[0]
        cx0, cy0, cx1, cy1 = corridor.rect
        assert corridor.kind == "corridor"
        assert cx0 < x < cx1 and cy0 < y < cy1


def test_office_room_counts():
    _, _, rois = load_world("office")
    assert rois["map_name"] == "office"
    assert rois["config"] == "1"
    kinds = collections.Counter(r["type"] for r in rois["rois"])
    assert kinds["office"] >= 8
    assert kinds["lab"] == 1
    assert kinds["kitchen"] == 1
    assert 3 <= kinds["corridor"] <= 5
    assert set(kinds) == {"corridor", "office", "lab", "kitchen"}
    ids = [r["id"] for r in rois["rois"]]
    assert ids == [str(i) for i in range(1, len(ids) + 1)]


def test_office_every_roi_reachable():
    image, world, rois = load_world("office")
    reach = reachable(image, world["robots"][0]["pose"][:2], ROBOT_RADIUS)
    other = world["robots"][1]["pose"]
    assert reach[image.cell(other[0], other[1])]
    for roi in rois["rois"]:
        mask = roi_cell_mask(image, roi["points"])
        fraction = reach[mask].mean()
        assert fraction > 0.6, "ROI %s reachable %.2f" % (roi["id"], fraction)


# ---------------------------------------------------------------------------
# 4. office ROI polygons and connectivity
# ---------------------------------------------------------------------------


def test_office_roi_polygons_are_valid_and_ccw():
    _, _, rois = load_world("office")
    for roi in rois["rois"]:
        points = roi["points"]
        assert len(points) >= 3
        polygon = Polygon(points)
        assert polygon.is_valid and polygon.area > 1.0, roi["id"]
        assert polygon.exterior.is_ccw, roi["id"]
        for x, y in points:
            assert round(x, 3) == x and round(y, 3) == y


def test_office_roi_graph_matches_doors():
    _, _, rois = load_world("office")
    rois = rois["rois"]
    graph = roi_graph(rois)
    polygons = {r["id"]: Polygon(r["points"]) for r in rois}
    corridor = [r["id"] for r in rois if r["type"] == "corridor"]
    rooms = [r["id"] for r in rois if r["type"] != "corridor"]
    world = make_worlds.office_world()
    gaps = [box(*make_worlds.door_gap(o, d))
            for o, d, _ in make_worlds.all_doors(world)]
    for room in rooms:
        # The corridor segment sharing the room's doorway gap.
        room_gaps = [g for g in gaps
                     if polygons[room].intersection(g).area > 1e-6]
        assert len(room_gaps) == 1, room
        segment = [c for c in corridor
                   if polygons[c].intersection(room_gaps[0]).area > 1e-6]
        assert len(segment) == 1, room
        assert graph[room] == set(segment), room
    # Corridor segments form a chain, west to east.
    chain = sorted(corridor, key=lambda c: polygons[c].centroid.x)
    for i, seg in enumerate(chain):
        expected = {chain[j] for j in (i - 1, i + 1) if 0 <= j < len(chain)}
        assert graph[seg] & set(corridor) == expected, seg
    # The whole graph is connected.
    seen, todo = {chain[0]}, [chain[0]]
    while todo:
        for nxt in graph[todo.pop()] - seen:
            seen.add(nxt)
            todo.append(nxt)
    assert seen == set(graph)


def test_office_rooms_do_not_touch_through_walls():
    _, _, rois = load_world("office")
    rooms = [r for r in rois["rois"] if r["type"] != "corridor"]
    for i, a in enumerate(rooms):
        for b in rooms[i + 1:]:
            assert not adjacent(a["points"], b["points"]), (a["id"], b["id"])


# ---------------------------------------------------------------------------
# 5. ROIs lie in free space
# ---------------------------------------------------------------------------


@pytest.mark.parametrize("name", ["simple", "office"])
def test_rois_lie_in_free_space(name):
    image, _, rois = load_world(name)
    for roi in rois["rois"]:
        mask = roi_cell_mask(image, roi["points"])
        assert mask.sum() > 0
        fraction = (image.pixels[mask] == FREE).mean()
        assert fraction >= 0.95, \
            "ROI %s only %.3f free" % (roi["id"], fraction)
        # Cell count matches the polygon area (the mask really covers it).
        area = Polygon(roi["points"]).area
        assert mask.sum() * RES * RES == pytest.approx(area, rel=0.05)


# ---------------------------------------------------------------------------------------------
# 4. every shipped world, real SLAM maps included
# ---------------------------------------------------------------------------------------------

ROOT = HERE / ".." / ".."
SHIPPED = sorted(p.parent.name for p in (ROOT / "worlds").glob("*/world.yaml")
                 if not p.parent.name.endswith("_auto"))
AUTO = sorted(p.parent.name for p in (ROOT / "worlds").glob("*_auto/world.yaml"))


def test_the_real_worlds_are_shipped():
    real = [w for w in SHIPPED if w not in ("office", "simple", "corridor")]
    assert len(real) >= 3, SHIPPED
    for w in real:
        readme = (ROOT / "worlds" / w / "README.md").read_text()
        assert "Source:" in readme and "licence" in readme, w


@pytest.mark.parametrize("name", SHIPPED)
def test_every_world_loads_and_every_region_is_walkable(name):
    from bullet_floor_sim.sim.config import load_world_config
    from bullet_floor_sim.people.markov import MarkovChain, usable_rois
    from bullet_floor_sim.nav.planner import PlanningGrid
    from bullet_floor_sim.data.rois import load_rois
    from bullet_floor_sim.people.walker import GoalSampler, WalkerConfig, walkable_regions
    from bullet_floor_sim.sim.world import World

    cfg = load_world_config(str(ROOT / "worlds" / name / "world.yaml"))
    world = World(cfg, seed=1)
    try:
        assert world.n >= (1 if name == "simple" else 2)
        rois, problems = usable_rois(load_rois(cfg.rois))
        assert problems == []
        assert len(rois) >= {"simple": 2, "corridor": 6}.get(name, 10)
        grid = PlanningGrid(world.fmap, handling=cfg.map_handling)
        wc = WalkerConfig()
        sampler = GoalSampler(grid, wc.clearance, wc.margin, wc.goal_tries)
        kept, unreachable = walkable_regions(rois, sampler)
        assert unreachable == [] and len(kept) == len(rois)
        chain = MarkovChain.from_rois(rois)
        assert chain.warnings == [] or name == "simple"
        # every region has a goal that the walker's planner reaches from the walker's spawn
        rng = np.random.default_rng(3)
        start = tuple(world.spawn[0][:2])
        for roi in rois:
            goal = sampler.sample(roi, rng, start=start)
            path = grid.plan(start, goal)
            assert np.hypot(*(path[-1] - np.array(goal))) < 1e-9, roi.id
        # no robot spawns in solid space
        for x, y, _ in world.spawn:
            assert world.solid.fmap.value_at(x, y) == 0
    finally:
        world.close()


@pytest.mark.parametrize("name", AUTO)
def test_an_auto_world_is_its_building_with_the_rooms_found_and_is_checked(name):
    from bullet_floor_sim.building import Building
    from bullet_floor_sim.building.check import check_building, world_study_problems
    from bullet_floor_sim.sim.config import load_world_config

    hand = load_world_config(str(ROOT / "worlds" / name[:-len("_auto")] / "world.yaml"))
    cfg = load_world_config(str(ROOT / "worlds" / name / "world.yaml"))
    # the same map and robots; the regions are the rooms found (a file rois: auto wrote)
    assert Path(cfg.map_yaml).resolve() == Path(hand.map_yaml).resolve()
    assert [(r.name, tuple(r.pose)) for r in cfg.robots] == \
        [(r.name, tuple(r.pose)) for r in hand.robots]
    assert Path(cfg.rois).read_text().startswith("# rois: auto")
    report = check_building(Building(cfg))
    problems = world_study_problems(report, cfg)
    # a study runs where the rooms found are two or more, and refuses where they are one:
    # malaga_campus's walkways are one room that robot1 reaches (docs/worlds.md)
    assert (len(report.regions) < 2) == (name == "malaga_campus_auto")
    if len(report.regions) >= 2:
        assert problems == []
    else:
        assert len(problems) == 1 and "region(s) in all" in problems[0]
