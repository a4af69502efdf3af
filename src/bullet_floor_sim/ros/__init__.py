"""Thin rospy glue, one module per node; each module has ``main()``."""
