"""People: the Markov chain over regions, the walker, the tracker, destination prediction,
the observer's following and the evaluation that drives them together.

Pure: plain data in, plain data out, no rospy anywhere below here.
"""
