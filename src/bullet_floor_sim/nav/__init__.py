"""Navigation: the planning grid, the global and local planners and the path follower.

Pure: plain data in, plain data out, no rospy anywhere below here.
"""
