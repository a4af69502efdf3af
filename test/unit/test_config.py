"""World files, robot models, the rospy-free core and Python 3.8 compatibility (no ROS)."""
from __future__ import annotations

import os
import shutil
import subprocess
import sys

import pytest

from bullet_floor_sim.sim.config import load_world_config, resolve_world
from bullet_floor_sim.errors import ConfigError, RobotModelError
from bullet_floor_sim.paths import package_root, worlds_dir
from bullet_floor_sim.sim.robot import expand_xacro, load_model
from bullet_floor_sim.sim.world import World

ROOT = package_root()


def write_world(tmp_path, body):
    shutil.copy(os.path.join(worlds_dir(), "simple", "map.yaml"), str(tmp_path / "map.yaml"))
    shutil.copy(os.path.join(worlds_dir(), "simple", "map.pgm"), str(tmp_path / "map.pgm"))
    path = tmp_path / "world.yaml"
    path.write_text(body)
    return str(path)


def test_office_world_has_two_robots_and_its_files():
    cfg = load_world_config(resolve_world("office", worlds_dir()))
    assert [r.name for r in cfg.robots] == ["robot1", "robot2"]
    assert cfg.robots[0].prefix == "robot1/"
    assert os.path.isfile(cfg.map_yaml) and os.path.isfile(cfg.rois)
    assert cfg.robots[0].laser.beams == 181 and cfg.robots[0].laser.range_max == 30.0


def test_world_by_path_and_unknown_world(tmp_path):
    p = write_world(tmp_path, "map: map.yaml\nrobots: []\n")
    assert resolve_world(p, worlds_dir()) == p
    with pytest.raises(ConfigError, match=r"world 'nowhere': no such world file .*known worlds: "
                                          r"corridor, malaga_campus, malaga_campus_auto, "
                                          r"malaga_corridor, malaga_corridor_auto, malaga_faculty, "
                                          r"malaga_faculty_auto, office, simple"):
        resolve_world("nowhere", worlds_dir())


@pytest.mark.parametrize("body, message", [
    ("map: map.yaml\nwalls: 3\n", r"world\.yaml: unknown key\(s\) 'walls'"),
    ("wall_height: 2\n", r"world\.yaml: missing required key 'map'"),
    ("map: map.yaml\nwall_height: -1\n", r"wall_height must be a positive number of metres"),
    ("map: map.yaml\nrobots:\n  - {name: a, laser: {range: 5}}\n",
     r"robots\[0\] \(a\): laser: unknown key\(s\) 'range'"),
    ("map: map.yaml\nrobots:\n  - {name: a, drive: {type: tank}}\n",
     r"robots\[0\] \(a\): drive: drive type 'tank' unknown, expected one of diff, omni"),
    ("map: map.yaml\nrobots:\n  - {name: a, pose: [1, 2]}\n",
     r"robots\[0\] \(a\): pose must be \[x, y, yaw\]"),
    ("map: map.yaml\nrobots:\n  - {name: /a}\n", r"robots\[0\]: name must be empty or a ROS name"),
    ("map: map.yaml\nrobots:\n  - {name: a}\n  - {name: a}\n", r"duplicate robot name\(s\): 'a'"),
    ("map: map.yaml\nrobots:\n  - {name: a, laser: {noise_std: .nan}}\n",
     r"laser: noise_std must be a finite number, got nan"),
    ("map: map.yaml\nrobots:\n  - {name: a, laser: {range_min: 40}}\n",
     r"laser: range_min must be in \[0, range_max\)"),
    ("map: [oops\n", r"world\.yaml: not valid YAML \(line \d+\)"),
])
def test_bad_world_files(tmp_path, body, message):
    with pytest.raises(ConfigError, match=message):
        load_world_config(write_world(tmp_path, body))


def test_spawn_inside_a_wall_is_refused(tmp_path):
    p = write_world(tmp_path, "map: map.yaml\nrobots:\n  - {name: a, pose: [4.25, 1.25, 0]}\n")
    with pytest.raises(ConfigError, match=r"robot 'a' spawns inside a wall at \(4\.250, 1\.250\)"):
        World(load_world_config(p))
    p = write_world(tmp_path, "map: map.yaml\nrobots:\n  - {name: a, pose: [0.3, 2.0, 0]}\n")
    with pytest.raises(ConfigError, match=r"robot 'a' spawns overlapping a wall \(0\.\d+ m deep\)"):
        World(load_world_config(p))
    p = write_world(tmp_path, "map: map.yaml\nrobots:\n  - {name: a, pose: [2.0, 2.0, 0]}\n"
                              "  - {name: b, pose: [2.3, 2.0, 0]}\n")
    with pytest.raises(ConfigError, match=r"robot 'a' spawns overlapping robot 'b'"):
        World(load_world_config(p))


def test_unknown_robot_model(tmp_path):
    p = write_world(tmp_path, "map: map.yaml\nrobots:\n  - {name: a, model: hal9000, pose: [1, 1, 0]}\n")
    with pytest.raises(RobotModelError, match=r"robot model 'hal9000': no file .*hal9000\.urdf\."
                                              r"xacro \(known models: scitos_a5\)"):
        World(load_world_config(p))


def test_xacro_prefix_names_every_link_and_joint():
    import xml.etree.ElementTree as ET

    root = ET.fromstring(expand_xacro("scitos_a5", "robot1/"))
    names = [e.get("name") for e in root if e.tag in ("link", "joint")]
    assert "robot1/base_footprint" in names and "robot1/base_laser_link" in names
    assert all(n.startswith("robot1/") for n in names)
    parents = [e.find("parent").get("link") for e in root if e.tag == "joint"]
    assert all(p.startswith("robot1/") for p in parents)


def test_expanded_models_are_cached_by_content(tmp_path, monkeypatch):
    import bullet_floor_sim.sim.robot as robot

    urdf = tmp_path / "urdf"
    shutil.copytree(os.path.join(ROOT, "urdf"), str(urdf))
    cache = tmp_path / "cache"
    monkeypatch.setenv("BULLET_FLOOR_SIM_CACHE", str(cache) + "/")   # a trailing / is the same
    load_model.cache_clear()
    cold = load_model("scitos_a5", str(urdf))
    assert os.path.dirname(cold.urdf_path) == str(cache)
    assert sorted(f.rsplit(".", 1)[1] for f in os.listdir(str(cache))) == ["json", "urdf"]

    def no_xacro(*args, **kwargs):
        raise AssertionError("xacro ran on a cache hit")

    # a new process (lru cache cleared) reads the same model without running xacro
    monkeypatch.setattr(robot, "expand_xacro", no_xacro)
    load_model.cache_clear()
    assert load_model("scitos_a5", str(urdf)) == cold
    # an edit of the model's files is a new key: expanded again, the old version removed
    monkeypatch.undo()
    monkeypatch.setenv("BULLET_FLOOR_SIM_CACHE", str(cache))
    path = urdf / "scitos_a5.urdf.xacro"
    path.write_text(path.read_text().replace('xyz="0.3 0 0.386"', 'xyz="0.25 0 0.386"'))
    load_model.cache_clear()
    edited = load_model("scitos_a5", str(urdf))
    assert edited.laser_pose == pytest.approx((0.25, 0.0, 0.437, 0.0))
    assert edited.urdf_path != cold.urdf_path and not os.path.exists(cold.urdf_path)
    assert len(os.listdir(str(cache))) == 2
    # a corrupt cache entry is expanded again; an empty BULLET_FLOOR_SIM_CACHE turns it off
    json_file = edited.urdf_path[:-len("urdf")] + "json"
    with open(json_file, "w") as f:
        f.write("{not json")
    load_model.cache_clear()
    assert load_model("scitos_a5", str(urdf)) == edited
    monkeypatch.setenv("BULLET_FLOOR_SIM_CACHE", "")
    load_model.cache_clear()
    off = load_model("scitos_a5", str(urdf))
    assert os.path.dirname(off.urdf_path) != str(cache) and off.laser_pose == edited.laser_pose
    load_model.cache_clear()


def test_model_frames_and_sizes_from_urdf():
    m = load_model("scitos_a5")
    assert m.laser_pose == pytest.approx((0.3, 0.0, 0.051 + 0.386, 0.0))
    assert m.wheel_radius == pytest.approx(0.09) and m.wheel_separation == pytest.approx(0.5)
    assert m.wheel_joints == ("left_wheel_joint", "right_wheel_joint")


def test_core_imports_without_rospy():
    code = ("import sys; import bullet_floor_sim.sim.world, bullet_floor_sim.sim.floormap, "
            "bullet_floor_sim.sim.sensors, bullet_floor_sim.sim.robot, "
            "bullet_floor_sim.sim.config; "
            "bad = [m for m in ('rospy', 'tf2_ros', 'actionlib', 'rosgraph') if m in sys.modules]; "
            "print(bad); sys.exit(1 if bad else 0)")
    env = dict(os.environ, PYTHONPATH=os.path.join(ROOT, "src"))
    out = subprocess.run([sys.executable, "-c", code], env=env, stdout=subprocess.PIPE,
                         stderr=subprocess.STDOUT, universal_newlines=True)
    assert out.returncode == 0, out.stdout


def test_sources_run_on_python_3_8():
    """Noetic's interpreter is 3.8: vermin must find nothing that needs a newer Python."""
    dirs = [os.path.join(ROOT, d) for d in ("src", "tools", "bench", "test")]
    vermin = os.path.join(os.path.dirname(sys.executable), "vermin")
    out = subprocess.run([vermin, "--no-tips", "--violations",
                          "--eval-annotations", "-t=3.8-", "--backport", "dataclasses"] + dirs,
                         stdout=subprocess.PIPE, stderr=subprocess.STDOUT, universal_newlines=True)
    assert out.returncode == 0, out.stdout
    assert "Minimum required versions: 3." in out.stdout


def test_two_checkouts_keep_their_own_cached_model(tmp_path, monkeypatch):
    # a source tree and its workspace copy (two urdf/ directories): loading from one must not
    # remove the other's entry, which a running process of the other may still have to load
    cache = tmp_path / "cache"
    monkeypatch.setenv("BULLET_FLOOR_SIM_CACHE", str(cache))
    dirs = []
    for name in ("a", "b"):
        d = tmp_path / name / "urdf"
        shutil.copytree(os.path.join(ROOT, "urdf"), str(d))
        dirs.append(str(d))
    load_model.cache_clear()
    first = load_model("scitos_a5", dirs[0])
    second = load_model("scitos_a5", dirs[1])
    assert first.urdf_path != second.urdf_path
    assert os.path.exists(first.urdf_path) and os.path.exists(second.urdf_path)
    assert len(os.listdir(str(cache))) == 4
    load_model.cache_clear()


def test_setup_py_installs_every_package_under_src():
    """catkin_python_setup installs only the packages setup.py lists: a subpackage left out
    works in the devel space (which points at src/) and is missing from an install."""
    import ast

    import setuptools

    root = os.path.join(os.path.dirname(__file__), "..", "..")
    tree = ast.parse(open(os.path.join(root, "setup.py")).read())
    listed = next(ast.literal_eval(k.value) for n in ast.walk(tree) if isinstance(n, ast.Call)
                  for k in n.keywords if k.arg == "packages")
    assert sorted(listed) == sorted(setuptools.find_packages(os.path.join(root, "src")))
