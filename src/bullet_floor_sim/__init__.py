"""bullet_floor_sim: a PyBullet simulator of a building's floor for ROS 1.

The pure core never imports rospy: ``sim`` (the floor, robots, sensors, clock), ``nav``
(planning and path following), ``people`` (walker, tracker, prediction, following,
evaluation) and ``data`` (regions, trajectories, stores), over the shared ``errors``,
``files``, ``paths`` and ``yamlio``. The ROS glue, one module per node, lives in ``ros``.
"""
