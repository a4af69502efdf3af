"""The embedded navigation default: grid A* on the inflated map, smoothing, pure pursuit.

This is what moves the simulated human (and any robot when the stock navigation stack is not
installed). It localises from ground truth: it is legs, not a SLAM system.

* :class:`PlanningGrid` turns a :class:`~bullet_floor_sim.sim.floormap.FloorMap` into a
  coarser planning grid. A cell is *lethal* when the robot's footprint circle centred on the
  cell's centre could touch a wall (or unknown space); free cells near walls carry a cost that
  decays exponentially with clearance, as costmap_2d's inflation layer does, so paths keep
  away from walls and pass through the middle of doors.
* :meth:`PlanningGrid.plan` runs 8-connected A* (no corner cutting), then shortcuts the cell
  path where a straight segment is no closer to walls than the cells it replaces, and
  resamples it. Bad goals raise :class:`PlanError` naming the goal and the reason.
* :class:`PathFollower` is a pure-pursuit controller for a differential (or omni) base with
  rotate-in-place, slow-down near the goal, final heading alignment and an obstacle stop from
  the robot's own scan points.

Everything is plain numbers in, plain numbers out; ``bullet_floor_sim.ros.path_follower``
wraps it in a move_base-compatible action server.
The parts live in :mod:`.grid` (the planning grid and A*), :mod:`.pursuit` (the path
follower), :mod:`.navigator` (goals, re-planning, giving way), :mod:`.navigator_config`
(its parameters and status) and :mod:`.give_way` (where to step out of the way); this
module is their one import for the nodes and the evaluation.
"""
from __future__ import annotations

from .grid import PlanError, PlannerConfig, PlanningGrid, disc_points, path_length
from .navigator import NavigatorConfig, NavStatus, Navigator, give_way_point
from .pursuit import FollowerCommand, FollowerConfig, PathFollower, obstacles_in_base

__all__ = ["PlanError", "PlannerConfig", "PlanningGrid", "FollowerConfig", "FollowerCommand",
           "PathFollower", "disc_points", "path_length", "obstacles_in_base", "give_way_point",
           "NavigatorConfig", "NavStatus", "Navigator"]
