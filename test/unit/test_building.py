"""The building model and the map check (building/, check_world), on two rooms of known
geometry joined by one door."""
from __future__ import annotations

import re

import numpy as np
import pytest
from shapely.geometry import Point

from bullet_floor_sim.building import Building, person_footprint, robot_footprint
from bullet_floor_sim.building.check import check_building, study_problems
from bullet_floor_sim.data.rois import roi_polygon
from bullet_floor_sim.errors import ConfigError
from bullet_floor_sim.people.evaluation import EvalConfig, EvaluationError, run
from bullet_floor_sim.ros import check_world
from bullet_floor_sim.paths import worlds_dir
from bullet_floor_sim.sim.config import load_world_config, resolve_world, world_label
from bullet_floor_sim.sim.floormap import load_map
from bullet_floor_sim.sim.solidmap import cleaned_map, served_handling, solid_map

RES = 0.05


def two_rooms(tmp_path, door: float, speck: bool = False, clean: str = "",
              robot2=(6.0, 2.0)) -> str:
    """Two 3.95 x 4 m rooms (x 0.1-4.05 and 4.15-8.1, y 0.1-4.1) split by a 0.1 m wall with
    a door ``door`` wide from y = 1.8; ``speck``: a 2 x 2 cell blob (0.01 m^2, twice the
    default clean.speckle) in the door's middle."""
    h, w = 84, 164
    occ = np.zeros((h, w), dtype=bool)   # row 0 = y 0 (flipped when written)
    occ[:2, :] = occ[-2:, :] = occ[:, :2] = occ[:, -2:] = True
    occ[:, 81:83] = True                         # x 4.05-4.15
    r0, r1 = int(round(1.8 / RES)), int(round((1.8 + door) / RES))
    occ[r0:r1, 81:83] = False
    if speck:
        occ[(r0 + r1) // 2:(r0 + r1) // 2 + 2, 81:83] = True
    img = np.where(occ, 0, 254).astype(np.uint8)
    (tmp_path / "map.pgm").write_bytes(b"P5\n%d %d\n255\n" % (w, h) + np.flipud(img).tobytes())
    (tmp_path / "map.yaml").write_text("image: map.pgm\nresolution: 0.05\norigin: [0, 0, 0]\n"
                                       "negate: 0\noccupied_thresh: 0.65\nfree_thresh: 0.196\n")
    (tmp_path / "rois.yaml").write_text(
        'map_name: rooms\nconfig: "1"\nrois:\n'
        '  - {id: "1", type: office, points: [[0.1, 0.1], [4.1, 0.1], [4.1, 4.1], [0.1, 4.1]]}\n'
        '  - {id: "2", type: lab, points: [[4.1, 0.1], [8.1, 0.1], [8.1, 4.1], [4.1, 4.1]]}\n')
    (tmp_path / "world.yaml").write_text(
        "map: map.yaml\nrois: rois.yaml\n%s\nrobots:\n"
        "  - {name: robot1, pose: [2.0, 2.0, 0.0]}\n"
        "  - {name: robot2, pose: [%g, %g, 0.0]}\n" % (clean, robot2[0], robot2[1]))
    return str(tmp_path / "world.yaml")


def test_a_door_wider_than_the_footprint_joins_the_rooms(tmp_path):
    b = Building(load_world_config(two_rooms(tmp_path, door=1.0)))
    report = check_building(b)
    robot = report.footprint("robot")
    assert [s.reachable for s in robot.starts] == [["1", "2"], ["1", "2"]]
    assert all(s.share == pytest.approx(1.0) for s in robot.starts)
    (p,) = robot.passages
    # the narrowest point of the route is the door: 1.0 m wide, at x = 4.1, y = 2.3
    assert p.width == pytest.approx(1.0, abs=0.1) and not p.no_route
    assert p.at[0] == pytest.approx(4.1, abs=0.1) and p.at[1] == pytest.approx(2.3, abs=0.15)
    assert study_problems(report, "robot1", "robot2") == []


def test_a_door_narrower_than_the_footprint_cuts_the_second_room_off(tmp_path):
    b = Building(load_world_config(two_rooms(tmp_path, door=0.6)))
    report = check_building(b)
    robot, person = report.footprint("robot"), report.footprint("person")
    r1, r2 = robot.starts
    assert r1.reachable == ["1"] and r1.unreachable == ["2"]
    assert r2.reachable == ["2"] and r2.unreachable == ["1"]
    assert r1.share == pytest.approx(0.5, abs=0.05)        # two rooms of one size
    (p,) = robot.passages
    assert p.no_route and p.width == pytest.approx(0.6, abs=0.1)   # where it narrows: the door
    assert p.at[0] == pytest.approx(4.1, abs=0.1) and p.at[1] == pytest.approx(2.1, abs=0.15)
    # a person (0.5 m wide) passes the 0.6 m door
    assert person.starts[0].reachable == ["1", "2"] and not person.passages[0].no_route
    problems = study_problems(report, "robot1", "robot2")
    assert len(problems) == 3
    assert 'cannot reach region(s) "2" (lab 2)' in problems[0] and "blocked: narrows to 0.6" \
        in problems[0]
    assert problems[1] == "robot1 reaches 1 region(s) (1): a walk between regions needs 2"
    assert "robot2" in problems[2] and "never reach the walker" in problems[2]
    text = "\n".join(report.lines())
    assert 'cut off: "2" (lab 2)' in text and "0.68" not in text


def test_the_study_refuses_to_start_unless_allowed(tmp_path):
    path = two_rooms(tmp_path, door=0.6)
    with pytest.raises(EvaluationError, match=r'cannot reach region\(s\) "2" \(lab 2\).*'
                                              r"clean: \{speckle.*--allow-unreachable"):
        run(EvalConfig(world=path, legs=1))
    # allowed: it runs, and its result says what it went on without
    r = run(EvalConfig(world=path, legs=1, allow_unreachable=True, max_sim_time=1.0))
    notes = [w for w in r.warnings if w.startswith("going on as allowed (--allow-unreachable)")]
    assert len(notes) == 3 and 'region(s) "2"' in notes[0] and "robot2" in notes[2]


def test_the_demos_simulator_refuses_an_observer_cut_off_unless_allowed(tmp_path, caplog):
    """demo.launch names its walker and observer to the simulator (~study_walker,
    ~study_observer): the map check's problems stop it (ConfigError: the required node exits)
    unless ~allow_unreachable; without a study named, they are warnings only."""
    from types import SimpleNamespace

    from bullet_floor_sim.ros.simulator import _log_check

    cfg = load_world_config(two_rooms(tmp_path, door=0.6))
    world = SimpleNamespace(config=cfg, fmap=load_map(cfg.map_yaml))
    with pytest.raises(ConfigError, match=r"the demo would degrade: .*region\(s\) \"2\".*robot2 "
                                          r".*never reach the walker.*allow_unreachable:=true"):
        _log_check(world, "robot1", "robot2")
    with pytest.raises(ConfigError, match=r"no robot 'robot9' \(the world has robot1, robot2\)"):
        _log_check(world, "robot1", "robot9")
    _log_check(world, "robot1", "robot2", allow=True)      # goes on, and says so
    assert caplog.text.count("(going on: allow_unreachable)") == 3
    _log_check(world)                                        # sim.launch: warnings only


def test_a_floor_no_doorway_divides_is_one_auto_room_and_the_study_says_so(tmp_path):
    path = two_rooms(tmp_path, door=2.3)         # an opening wider than a door (2 m)
    yml = tmp_path / "world.yaml"
    yml.write_text(yml.read_text().replace("rois: rois.yaml", "rois: auto"))
    report = check_building(Building(load_world_config(path)))
    assert len(report.regions) == 1
    problems = study_problems(report, "robot1", "robot2")
    assert len(problems) == 1 and problems[0].startswith("the world has 1 region(s) in all")
    assert 'in all ("1"): a walk between regions needs 2; draw more' in problems[0]
    with pytest.raises(EvaluationError, match=r"1 region\(s\) in all.*copy the ROI file"):
        run(EvalConfig(world=path, legs=1))


def test_specks_in_a_door_block_it_until_cleaned(tmp_path):
    blocked = check_building(Building(load_world_config(two_rooms(tmp_path, 1.2, speck=True))))
    assert blocked.footprint("robot").starts[0].unreachable == ["2"]
    clean = two_rooms(tmp_path, 1.2, speck=True, clean="clean: {speckle: 0.01}")
    b = Building(load_world_config(clean))
    report = check_building(b)
    assert report.footprint("robot").starts[0].reachable == ["1", "2"]
    assert any("1 occupied blobs (4 cells)" in line for line in report.handling)
    # the cleaned map has the speck as floor, and a node that applies the handling served
    # with it (only unknown) gets the simulator's solid cells
    served = cleaned_map(b.fmap, b.config.map_handling)
    assert int((np.asarray(b.fmap.grid) == 100).sum()) - int(
        (np.asarray(served.grid) == 100).sum()) == 4
    again = solid_map(served, served_handling(b.config.map_handling))
    assert np.array_equal(again.fmap.grid, b.solid.fmap.grid)


def test_a_cleaned_real_map_gives_the_same_solid_cells_with_the_served_handling():
    """malaga_corridor (a real SLAM map): its handling applied again to its own output clears
    more (slivers and specks the first pass exposed), so a node given the cleaned map applies
    only ``unknown`` (served_handling) and gets exactly the solid cells of the map itself."""
    cfg = load_world_config(resolve_world("malaga_corridor", worlds_dir()))
    raw = load_map(cfg.map_yaml)
    solid = np.asarray(solid_map(raw, cfg.map_handling).fmap.grid) == 100
    served = cleaned_map(raw, cfg.map_handling)
    twice = np.asarray(solid_map(served, cfg.map_handling).fmap.grid) == 100
    assert int((solid & ~twice).sum()) > 100 and not (twice & ~solid).any()
    once = np.asarray(solid_map(served, served_handling(cfg.map_handling)).fmap.grid) == 100
    assert np.array_equal(once, solid)


def test_the_plot_draws_what_the_map_handling_cleared(tmp_path):
    """The speck speckle removes is drawn magenta at the door (x 4.05-4.15, y 2.4); without
    the rule nothing is."""
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    from bullet_floor_sim.building.plot import draw_panel

    def magenta(world: str):
        b = Building(load_world_config(world))
        report = check_building(b)
        fig, ax = plt.subplots(figsize=(8, 4), dpi=100)
        try:
            draw_panel(ax, b, report, report.footprint("robot"))
            ax.set_xlim(3.6, 4.6)                 # 1 m round the door: a cell is 5 pixels
            ax.set_ylim(1.9, 2.9)
            fig.canvas.draw()
            px = np.asarray(fig.canvas.buffer_rgba())[..., :3].astype(int)
        finally:
            plt.close(fig)
        return int(((px[..., 0] > 230) & (px[..., 1] < 30) & (px[..., 2] > 230)).sum())

    raw = tmp_path / "raw"
    raw.mkdir()
    assert magenta(two_rooms(raw, 1.2, speck=True)) == 0
    assert magenta(two_rooms(tmp_path, 1.2, speck=True, clean="clean: {speckle: 0.01}")) > 20


def test_rois_auto_writes_the_rooms_of_a_bare_map_and_of_a_world(tmp_path, capsys):
    """``rois auto``: the two rooms of a bare map.yaml (a 1.0 m door), sharing the door's
    vertices (the chain rule); from a world whose 0.6 m door robot1 cannot pass, only robot1's
    room, and the other named as left out."""
    from bullet_floor_sim.data.rois import load_rois
    from bullet_floor_sim.people.markov.chain import MarkovChain
    from bullet_floor_sim.ros import rois as rois_cli

    two_rooms(tmp_path, door=1.0)
    out = tmp_path / "auto.yaml"
    assert rois_cli.main(["auto", str(tmp_path / "map.yaml"), "-o", str(out)]) == 0
    rooms = load_rois(str(out))
    assert len(rooms) == 2
    # each a room of 15.8 m^2 of floor, traced a cell or two inside its walls
    assert all(13.5 < roi_polygon(r).area < 15.8 for r in rooms)
    assert {roi_polygon(r).contains(Point(2.0, 2.0)) for r in rooms} == {True, False}
    assert len(MarkovChain.from_rois(rooms).components()) == 1    # joined at the door
    assert "wrote 2 rooms" in capsys.readouterr().err
    narrow = tmp_path / "narrow"
    narrow.mkdir()
    world = two_rooms(narrow, door=0.6)
    assert rois_cli.main(["auto", world, "-o", str(out)]) == 0
    (room,) = load_rois(str(out))
    assert roi_polygon(room).contains(Point(2.0, 2.0))            # robot1's room
    err = capsys.readouterr().err
    assert "left out room 2" in err and "not reachable from robot1" in err
    assert rois_cli.main(["auto", str(tmp_path / "none.yaml"), "-o", str(out)]) == 1
    assert "none.yaml" in capsys.readouterr().err


def test_check_world_cli(tmp_path, capsys):
    path = two_rooms(tmp_path, 0.6)
    assert check_world.main([path, "--plot", str(tmp_path / "c.png"),
                             "--write-cleaned", str(tmp_path / "cleaned")]) == 1
    out = capsys.readouterr().out
    assert "study: would refuse" in out and (tmp_path / "c.png").stat().st_size > 10000
    served = load_map(str(tmp_path / "cleaned.yaml"))
    assert np.array_equal(served.grid, load_map(str(tmp_path / "map.yaml")).grid)
    ok = tmp_path / "ok"
    ok.mkdir()
    assert check_world.main([two_rooms(ok, 1.0)]) == 0
    assert capsys.readouterr().out.rstrip().endswith("study: ok")
    assert check_world.main([str(tmp_path / "nothing.yaml")]) == 2
    assert "no such world file" in capsys.readouterr().err


def test_footprints_and_labels(tmp_path):
    cfg = load_world_config(two_rooms(tmp_path, 1.0))
    assert robot_footprint().radius == 0.34 and robot_footprint().clearance == 0.45
    assert person_footprint(cfg).radius == 0.25
    assert world_label("office") == "office"
    assert world_label(str(tmp_path / "world.yaml")) == tmp_path.name
    assert world_label("/data/my maps/lab3.yaml") == "lab3"


def test_a_rooms_section_sets_how_auto_rooms_are_found(tmp_path):
    # the 2.3 m opening is wider than the default max_door_width (2 m): one room; with
    # rooms: {max_door_width: 3.0} it is a door (1.15 m half-width, under 0.7 of the rooms'
    # ~2 m clearance), so the two rooms stay apart
    path = two_rooms(tmp_path, door=2.3, clean="rooms: {max_door_width: 3.0}")
    yml = tmp_path / "world.yaml"
    yml.write_text(yml.read_text().replace("rois: rois.yaml", "rois: auto"))
    cfg = load_world_config(path)
    assert cfg.rooms.max_door_width == 3.0 and cfg.rooms.door_ratio == 0.7
    without = yml.read_text().replace("rooms: {max_door_width: 3.0}", "")
    (tmp_path / "plain").mkdir()
    for name in ("map.yaml", "map.pgm"):
        (tmp_path / "plain" / name).write_bytes((tmp_path / name).read_bytes())
    (tmp_path / "plain" / "world.yaml").write_text(without)
    plain = check_building(Building(load_world_config(str(tmp_path / "plain" / "world.yaml"))))
    assert len(plain.regions) == 1                # the default joins them
    report = check_building(Building(cfg))
    assert len(report.regions) == 2
    assert study_problems(report, "robot1", "robot2") == []


@pytest.mark.parametrize("rooms, words", [
    ("rooms: {max_door_width: -1}", "rooms: max_door_width must be a finite number >= 0"),
    ("rooms: {door_ratio: 1.5}", "rooms: door_ratio must be at most 1"),
    ("rooms: {door_width: 3}", "door_width"),
    ("rooms: 3", "rooms: expected a mapping"),
])
def test_a_bad_rooms_section_is_one_line_naming_it(tmp_path, rooms, words):
    path = two_rooms(tmp_path, door=1.0, clean=rooms)
    yml = tmp_path / "world.yaml"
    yml.write_text(yml.read_text().replace("rois: rois.yaml", "rois: auto"))
    with pytest.raises(ConfigError, match=re.escape(words)) as err:
        load_world_config(path)
    assert str(tmp_path / "world.yaml") in str(err.value) and "\n" not in str(err.value)


def test_a_rooms_section_without_auto_rois_is_refused(tmp_path):
    path = two_rooms(tmp_path, door=1.0, clean="rooms: {max_door_width: 3.0}")
    with pytest.raises(ConfigError, match="rooms sets how rois: auto finds the rooms; this "
                                          "world has rois: .*rois.yaml"):
        load_world_config(path)


def _regions(tmp_path, split: float) -> str:
    """two_rooms with its regions cut at x = split instead of the wall (x 0.1-8.1)."""
    path = two_rooms(tmp_path, door=1.0)
    (tmp_path / "rois.yaml").write_text(
        'map_name: rooms\nconfig: "1"\nrois:\n'
        '  - {id: "1", type: office, points: [[0.1, 0.1], [%g, 0.1], [%g, 4.1], [0.1, 4.1]]}\n'
        '  - {id: "2", type: lab, points: [[%g, 0.1], [8.1, 0.1], [8.1, 4.1], [%g, 4.1]]}\n'
        % (split, split, split, split))
    return path


def test_one_region_that_is_most_of_the_floor_is_warned_about(tmp_path):
    from bullet_floor_sim.people.evaluation.scenario import refuse_unreachable

    path = _regions(tmp_path, 6.1)              # 6 x 4 = 24 m^2 against 2 x 4 = 8 m^2
    b = Building(load_world_config(path))
    report = check_building(b)
    assert report.largest_region() == ("1", pytest.approx(0.75))
    lines = report.lines()
    summary = [line for line in lines if line.startswith("regions: ")]
    assert summary and summary[0].startswith('regions: 2; the largest, "1"')
    assert summary[0].endswith("is 24 m^2, 75 % of their area")
    assert any(line.startswith('  warning: region "1"') and "75 %" in line
               and "max_door_width" in line for line in lines)
    notes = refuse_unreachable(b, EvalConfig(world=path), b)
    assert notes == ["warning: " + report.one_region_warning()]


def test_regions_that_share_the_floor_evenly_get_no_warning(tmp_path):
    report = check_building(Building(load_world_config(_regions(tmp_path, 4.1))))
    assert report.largest_region()[1] == pytest.approx(0.5)
    assert report.one_region_warning() == ""
    assert not any("warning" in line for line in report.lines())


def test_a_start_inside_the_footprint_of_a_wall_is_warned_of_and_the_simulator_decides(
        tmp_path):
    from bullet_floor_sim.people.evaluation.scenario import refuse_unreachable
    from bullet_floor_sim.sim.world import World

    # the wall's cells start at x 8.1: robot2 at x 7.9 is 0.2 m from it (inside the 0.34 m
    # footprint; the Scitos body reaches 0.30-0.32 m: the simulator refuses it)
    path = two_rooms(tmp_path, door=1.0, robot2=(7.9, 2.0))
    cfg = load_world_config(path)
    b = Building(cfg)
    report = check_building(b)
    start = report.footprint("robot").starts[1]
    assert start.name == "robot2" and start.wall == pytest.approx(0.2)
    assert report.footprint("person").starts[0].wall == float("inf")
    warning = ("robot2 at (7.90, 2.00) starts 0.20 m from a wall, inside its 0.34 m footprint "
               "radius: if the robot's body overlaps the wall, the simulator refuses to spawn "
               "it; give it room")
    assert report.warnings() == [warning]
    assert "  warning: " + warning in report.lines()
    assert study_problems(report, "robot1", "robot2") == []       # a warning, not a refusal
    assert refuse_unreachable(b, EvalConfig(world=path), b) == ["warning: " + warning]
    with pytest.raises(ConfigError, match="robot 'robot2' spawns overlapping a wall"):
        World(cfg, seed=0)
    # 0.33 m from the wall: warned of (inside 0.34 m), and the simulator takes it
    near = load_world_config(two_rooms(tmp_path, door=1.0, robot2=(7.77, 2.0)))
    near_report = check_building(Building(near))
    assert near_report.footprint("robot").starts[1].wall == pytest.approx(0.33)
    assert len(near_report.warnings()) == 1
    World(near, seed=0).close()
    # 0.5 m from the wall: nothing to say
    ok = load_world_config(two_rooms(tmp_path, door=1.0, robot2=(7.6, 2.0)))
    assert check_building(Building(ok)).warnings() == []


def test_a_walker_whose_region_joins_no_other_stops_the_study(tmp_path):
    # the regions stop 0.6 m short of the wall on each side: no vertex of one is within 0.2 m
    # of the other's, so the chain keeps the walker in region 1 for good
    path = two_rooms(tmp_path, door=1.0)
    (tmp_path / "rois.yaml").write_text(
        'map_name: rooms\nconfig: "1"\nrois:\n'
        '  - {id: "1", type: office, points: [[0.1, 0.1], [3.5, 0.1], [3.5, 4.1], [0.1, 4.1]]}\n'
        '  - {id: "2", type: lab, points: [[4.7, 0.1], [8.1, 0.1], [8.1, 4.1], [4.7, 4.1]]}\n')
    with pytest.raises(EvaluationError, match=r'the walker starts in region "1" \(office 1\), '
                                              r"which the chain joins to no other region "
                                              r"\(no vertex within 0.2 m of another ROI's "
                                              r"vertex\)"):
        run(EvalConfig(world=path, legs=1))
    r = run(EvalConfig(world=path, legs=1, allow_unreachable=True))
    assert any(w.startswith('going on as allowed (--allow-unreachable): the walker starts in '
                            'region "1"') for w in r.warnings)
