"""Pure simulation core: plain data in, plain data out, no rospy anywhere below here."""
