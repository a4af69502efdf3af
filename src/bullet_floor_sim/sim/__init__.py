"""The simulated floor: the map, the Bullet scene, robots, their sensors and the clock.

Pure: plain data in, plain data out, no rospy anywhere below here.
"""
