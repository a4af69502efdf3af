"""The simulator node's parts: message bytes (wire), batched sending (outbox), signals and the
clock subscription (signals), robot_state_publisher children (rsp). The node is ros/simulator.py."""
