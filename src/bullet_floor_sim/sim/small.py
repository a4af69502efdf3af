"""How many robots count as few.

Up to ``SMALL_N`` robots, the per-robot models (drives, integration, wheels, odometry) step in
plain floats or compiled loops (kinematics, odometry) instead of numpy arrays: for a few
robots numpy's per-call cost dominates. Both paths use the same formulas and the same random
draws (test_world checks they agree).
"""

SMALL_N = 4
