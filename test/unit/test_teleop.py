"""Keyboard teleop key mapping (pure; the node itself is glue around it)."""
from __future__ import annotations

import pytest

from bullet_floor_sim.ros.teleop_keyboard import Teleop


def test_keys_map_to_velocities():
    t = Teleop(linear=0.3, angular=0.6)
    assert t.command() == (0.0, 0.0, 0.0)
    t.key("w")
    assert t.command() == (0.3, 0.0, 0.0)
    t.key("\x1b[D")            # left arrow: turn left
    assert t.command() == (0.0, 0.0, 0.6)
    t.key("E")                 # strafe right (omni)
    assert t.command() == (0.0, -0.3, 0.0)
    t.key("+")
    assert t.command() == pytest.approx((0.0, -0.33, 0.0))
    t.key(" ")
    assert t.command() == (0.0, 0.0, 0.0)
    assert t.key("x") is False and t.key("\x03") is False and t.key("s") is True
    assert t.command() == pytest.approx((-0.33, 0.0, 0.0))
