#!/usr/bin/env python3
"""rostest node: with ``serve_cleaned:=true`` the simulator's latched /map is the world's map
with its map handling's changes made (sim/solidmap.cleaned_map), cell for cell: the specks
``clean.speckle`` removes are free, the gaps ``clean.close_gaps`` closes occupied, unknown
cells left unknown; and a node that applies the handling the simulator sets for it
(``/bullet_floor_sim/map_handling``: only ``unknown``, the cleaning done) gets the
simulator's solid cells back, as the path follower and the tracker do."""
from __future__ import annotations

import unittest

import numpy as np
import rospy
import rostest
from nav_msgs.msg import OccupancyGrid


class ServeCleaned(unittest.TestCase):
    def test_map_is_the_cleaned_map(self):
        from bullet_floor_sim.paths import worlds_dir
        from bullet_floor_sim.ros.convert import grid_from_msg
        from bullet_floor_sim.sim.config import load_world_config, resolve_world
        from bullet_floor_sim.sim.floormap import load_map
        from bullet_floor_sim.sim.solidmap import cleaned_map, served_handling, solid_map

        rospy.init_node("test_serve_cleaned")
        msg = rospy.wait_for_message("/map", OccupancyGrid, timeout=90)
        served = np.asarray(grid_from_msg(msg).grid)
        cfg = load_world_config(resolve_world("malaga_corridor", worlds_dir()))
        raw = load_map(cfg.map_yaml)
        grid = np.asarray(raw.grid)
        self.assertEqual(served.shape, grid.shape)
        cleared = (grid == 100) & (served == 0)
        closed = (grid == 0) & (served == 100)
        opened = (grid == -1) & (served == 0)
        # the world's handling (docs/corpus.md's table): 31 specks of 42 cells in all removed,
        # one-cell gaps closed (6175 free cells of them), unknown slivers made floor (3168
        # cells); nothing else changes
        self.assertEqual(int(cleared.sum()), 42)
        self.assertGreater(int(closed.sum()), 5000)
        self.assertGreater(int(opened.sum()), 3000)
        self.assertEqual(int((grid != served).sum()), int(cleared.sum() + closed.sum() + opened.sum()))
        self.assertTrue(np.array_equal(served, np.asarray(cleaned_map(raw, cfg.map_handling).grid)))
        from bullet_floor_sim.ros.params import map_handling

        self.assertEqual(map_handling(), served_handling(cfg.map_handling))
        self.assertEqual(map_handling().unknown, "wall")
        again = solid_map(grid_from_msg(msg), map_handling())
        self.assertTrue(np.array_equal(again.fmap.grid, solid_map(raw, cfg.map_handling).fmap.grid))


if __name__ == "__main__":
    rostest.rosrun("bullet_floor_sim", "test_serve_cleaned", ServeCleaned)
