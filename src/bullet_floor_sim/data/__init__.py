"""Data: regions of interest, trajectories and their chunks, and the stores that keep them
(MongoDB, the embedded store and the journal that covers an outage).

Pure: plain data in, plain data out, no rospy anywhere below here.
"""
