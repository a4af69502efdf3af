"""A robot model's joints as the transforms robot_state_publisher publishes from its URDF.

Fixed joints go on /tf_static once; a revolute or continuous joint goes on /tf with every
joint_states message, as its origin followed by a rotation of the joint's angle about its
axis (what kdl_parser and KDL's ``Segment::pose`` compute). Planar joints count as fixed, as
kdl_parser makes them; floating joints are left out, as robot_state_publisher leaves them.
Mimic joints are not followed (robot_state_publisher publishes a mimic of a joint in
joint_states; the simulator's joint_states has the wheels only, and no model here mimics
them). Quaternions are (x, y, z, w). Pure: plain data in and out.
"""
from __future__ import annotations

import math
from dataclasses import dataclass, replace
from typing import Dict, List, Tuple

import numpy as np

__all__ = ["Link", "model_links", "link_to_dict", "link_from_dict"]

#: URDF joint types robot_state_publisher publishes as fixed (kdl_parser's Joint::None; it
#: skips floating joints).
FIXED_TYPES = ("fixed", "planar")
#: URDF joint types turned by an angle about their axis.
TURNING_TYPES = ("revolute", "continuous")


@dataclass(frozen=True)
class Link:
    """One joint: the transform from its parent link to its child link.

    Attributes:
        joint: the joint's name.
        parent, child: the links' names (the frame ids).
        xyz: the joint origin's translation, metres.
        quat: the joint origin's rotation (x, y, z, w).
        axis: the unit axis a turning joint turns about ((0, 0, 0) for a fixed joint).
    """

    joint: str
    parent: str
    child: str
    xyz: Tuple[float, float, float]
    quat: Tuple[float, float, float, float]
    axis: Tuple[float, float, float] = (0.0, 0.0, 0.0)

    def prefixed(self, prefix: str) -> "Link":
        """The same joint with ``prefix`` before its joint and link names (multi-robot)."""
        return replace(self, joint=prefix + self.joint, parent=prefix + self.parent,
                       child=prefix + self.child)

    def turned(self, angle: float) -> Tuple[float, float, float, float]:
        """The child's rotation in the parent at joint angle ``angle`` (radians)."""
        s = math.sin(0.5 * angle)
        ax, ay, az = self.axis
        return _multiply(self.quat, (ax * s, ay * s, az * s, math.cos(0.5 * angle)))


def _multiply(a, b) -> Tuple[float, float, float, float]:
    """Hamilton product a * b of (x, y, z, w) quaternions (b's rotation applied first)."""
    ax, ay, az, aw = a
    bx, by, bz, bw = b
    return (aw * bx + ax * bw + ay * bz - az * by,
            aw * by - ax * bz + ay * bw + az * bx,
            aw * bz + ax * by - ay * bx + az * bw,
            aw * bw - ax * bx - ay * by - az * bz)


def _quat_of(m: np.ndarray) -> Tuple[float, float, float, float]:
    from scipy.spatial.transform import Rotation

    x, y, z, w = Rotation.from_matrix(np.asarray(m, float)[:3, :3]).as_quat()
    return float(x), float(y), float(z), float(w)


def model_links(urdf) -> Tuple[List[Link], Dict[str, Link]]:
    """The fixed joints (in the URDF's order) and the turning joints by name of a yourdfpy URDF.

    Raises:
        ValueError: a turning joint whose axis has no length.
    """
    fixed: List[Link] = []
    turning: Dict[str, Link] = {}
    for j in urdf.robot.joints:
        m = np.eye(4) if j.origin is None else np.asarray(j.origin, float)
        xyz = (float(m[0, 3]), float(m[1, 3]), float(m[2, 3]))
        if j.type in FIXED_TYPES:
            fixed.append(Link(j.name, j.parent, j.child, xyz, _quat_of(m)))
        elif j.type in TURNING_TYPES:
            axis = np.asarray(j.axis if j.axis is not None else (1.0, 0.0, 0.0), float)
            n = float(np.linalg.norm(axis))
            if not n > 0.0:
                raise ValueError("joint %r: its axis %s has no length" % (j.name, axis.tolist()))
            turning[j.name] = Link(j.name, j.parent, j.child, xyz, _quat_of(m),
                                   tuple(float(v) for v in axis / n))  # type: ignore[arg-type]
    return fixed, turning


def link_to_dict(link: Link) -> dict:
    """A JSON-able dict of ``link`` (the model cache)."""
    return {"joint": link.joint, "parent": link.parent, "child": link.child,
            "xyz": list(link.xyz), "quat": list(link.quat), "axis": list(link.axis)}


def link_from_dict(d: dict) -> Link:
    """The link ``link_to_dict`` wrote (KeyError, TypeError or ValueError when malformed)."""
    xyz, quat, axis = (tuple(float(v) for v in d[k]) for k in ("xyz", "quat", "axis"))
    if len(xyz) != 3 or len(quat) != 4 or len(axis) != 3:
        raise ValueError("link %r: malformed" % d.get("joint"))
    return Link(str(d["joint"]), str(d["parent"]), str(d["child"]), xyz, quat,  # type: ignore
                axis)  # type: ignore[arg-type]
