"""sim/links.py: a model's joints as robot_state_publisher's transforms, against hand-computed
quaternions and the numbers in urdf/scitos_a5.urdf.xacro."""
from __future__ import annotations

import math
import os
import textwrap

import numpy as np
import pytest

from bullet_floor_sim.sim.links import Link, link_from_dict, link_to_dict, model_links
from bullet_floor_sim.sim.robot import load_model


def _matrix(q):
    from scipy.spatial.transform import Rotation

    return Rotation.from_quat(q).as_matrix()


def test_a_wheel_about_y_turns_by_half_angle_quaternions():
    wheel = Link("w", "base_link", "wheel", (0.0, 0.25, 0.04), (0.0, 0.0, 0.0, 1.0),
                 (0.0, 1.0, 0.0))
    for a in (0.0, 0.7, -2.5, 7.0):
        assert wheel.turned(a) == pytest.approx((0.0, math.sin(a / 2), 0.0, math.cos(a / 2)),
                                                abs=1e-15)


def test_the_origin_rotation_comes_first_then_the_axis():
    # origin: 90 degrees about z; axis x of the child (the parent's y after the origin)
    origin = (0.0, 0.0, math.sin(math.pi / 4), math.cos(math.pi / 4))
    link = Link("j", "p", "c", (1.0, 2.0, 3.0), origin, (1.0, 0.0, 0.0))
    q = link.turned(math.pi / 2)
    m = _matrix(q)
    # the child's x axis is the parent's y; its y (turned 90 degrees about its x) is the
    # parent's z
    np.testing.assert_allclose(m[:, 0], (0.0, 1.0, 0.0), atol=1e-12)
    np.testing.assert_allclose(m[:, 1], (0.0, 0.0, 1.0), atol=1e-12)
    assert sum(v * v for v in q) == pytest.approx(1.0, abs=1e-15)


def test_scitos_links_are_the_xacros():
    model = load_model("scitos_a5")
    fixed = {x.child: x for x in model.fixed_links}
    assert sorted(fixed) == ["base_laser_link", "base_link", "caster_link", "head_camera_link",
                             "head_link", "mast_link"]
    assert (fixed["base_link"].parent, fixed["base_laser_link"].parent) == ("base_footprint",
                                                                          "base_link")
    # the laser 0.3 m ahead of base_footprint and at the height laser_pose gives
    base, laser = fixed["base_link"].xyz, fixed["base_laser_link"].xyz
    assert laser[0] + base[0] == pytest.approx(model.laser_pose[0])
    assert laser[2] + base[2] == pytest.approx(model.laser_pose[2])
    assert all(x.quat == pytest.approx((0.0, 0.0, 0.0, 1.0)) for x in fixed.values())
    left, right = model.wheel_links
    assert (left.joint, right.joint) == model.wheel_joints
    assert left.axis == right.axis == pytest.approx((0.0, 1.0, 0.0))
    assert left.xyz[1] - right.xyz[1] == pytest.approx(model.wheel_separation)
    assert left.prefixed("robot1/").parent == "robot1/base_link"
    assert left.prefixed("robot1/").child == "robot1/left_wheel"


def test_links_survive_the_cache_json():
    for x in load_model("scitos_a5").fixed_links + load_model("scitos_a5").wheel_links:
        assert link_from_dict(link_to_dict(x)) == x
    with pytest.raises(ValueError, match="malformed"):
        link_from_dict(dict(link_to_dict(load_model("scitos_a5").wheel_links[0]), xyz=[1, 2]))


def _urdf(tmp_path, joints: str):
    import yourdfpy

    path = os.path.join(str(tmp_path), "m.urdf")
    with open(path, "w") as f:
        f.write(textwrap.dedent("""\
            <robot name="m">
              <link name="a"/><link name="b"/><link name="c"/><link name="d"/>
              %s
            </robot>""") % joints)
    return yourdfpy.URDF.load(path, load_meshes=False, build_collision_scene_graph=False,
                              load_collision_meshes=False)


def test_joint_types_and_axes(tmp_path):
    urdf = _urdf(tmp_path, """
      <joint name="f" type="fixed"><parent link="a"/><child link="b"/>
        <origin xyz="1 0 0" rpy="0 0 1.5707963267948966"/></joint>
      <joint name="r" type="revolute"><parent link="a"/><child link="c"/>
        <axis xyz="0 0 2"/><limit lower="-1" upper="1" effort="1" velocity="1"/></joint>
      <joint name="p" type="prismatic"><parent link="a"/><child link="d"/>
        <axis xyz="1 0 0"/><limit lower="0" upper="1" effort="1" velocity="1"/></joint>""")
    fixed, turning = model_links(urdf)
    assert [x.joint for x in fixed] == ["f"]
    assert fixed[0].quat == pytest.approx((0.0, 0.0, math.sin(math.pi / 4),
                                           math.cos(math.pi / 4)))
    assert sorted(turning) == ["r"]                  # a prismatic joint is not turned
    assert turning["r"].axis == pytest.approx((0.0, 0.0, 1.0))     # made unit


def test_an_axis_of_no_length_is_refused(tmp_path):
    urdf = _urdf(tmp_path, """
      <joint name="w" type="continuous"><parent link="a"/><child link="b"/>
        <axis xyz="0 0 0"/></joint>""")
    with pytest.raises(ValueError, match="joint 'w': its axis"):
        model_links(urdf)


def test_planar_joints_are_fixed_and_floating_ones_left_out(tmp_path):
    """As robot_state_publisher: kdl_parser makes both fixed, and its tree skips a floating
    joint's segment."""
    urdf = _urdf(tmp_path, """
      <joint name="pl" type="planar"><parent link="a"/><child link="b"/>
        <origin xyz="0 1 0"/><axis xyz="0 0 1"/></joint>
      <joint name="fl" type="floating"><parent link="a"/><child link="c"/></joint>""")
    fixed, turning = model_links(urdf)
    assert [(x.joint, x.xyz) for x in fixed] == [("pl", (0.0, 1.0, 0.0))]
    assert turning == {}
