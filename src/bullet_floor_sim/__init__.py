"""bullet_floor_sim: a PyBullet office-floor simulator for ROS 1.

The pure core (``bullet_floor_sim.core``) never imports rospy; ROS glue lives in
``bullet_floor_sim.ros``.
"""
