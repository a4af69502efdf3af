"""The simulator's outbox writes to rospy's TCPROS sockets itself: rospy must still have them."""
from rospy.impl.tcpros_base import TCPROSTransport, TCPROSTransportProtocol
from std_msgs.msg import String

from bullet_floor_sim.ros.sim.outbox import raw_sockets_usable


def test_the_installed_rospy_has_the_connection_attributes_the_outbox_writes_through():
    assert raw_sockets_usable()
    # a real (unconnected) connection carries them from construction
    conn = TCPROSTransport(TCPROSTransportProtocol("/chatter", String), "/chatter")
    assert conn.socket is None and conn.done is False
    assert callable(conn.write_data)
