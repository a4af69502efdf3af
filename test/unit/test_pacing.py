"""sim/pacing.py: when the simulator's clock waits for the robots' controllers."""
import math

import pytest

from bullet_floor_sim.errors import ConfigError
from bullet_floor_sim.sim.pacing import BacklogGate, CommandGate, clock_wall_bound, tcp_unread


def test_a_moving_robot_holds_the_clock_once_its_command_is_older_than_the_lag():
    g = CommandGate(["robot1", "robot2"], max_lag=0.15, max_wait=2.0)
    assert g.hold(0.0, 100.0) == []                # nobody commanded: nobody waited for
    g.command(0, 1.0, 0.5, 0.0, 0.0)
    assert g.hold(1.1, 100.0) == []                # 0.1 s old
    assert g.hold(1.15001, 100.0) == ["robot1"]    # 0.15 s old
    assert g.holds == 1
    g.command(0, 1.15001, 0.5, 0.0, 0.1)           # the controller answered
    assert g.hold(1.15001, 100.02) == []
    assert g.take_report() == {"robot1": pytest.approx(0.02)}


def test_while_a_robot_is_late_the_clock_goes_on_at_real_time_at_most():
    g = CommandGate(["a"], max_lag=0.15, max_wait=2.0)
    g.command(0, 0.0, 0.3, 0.0, 0.0)
    assert g.hold(0.2, 10.0) == ["a"]              # late: the hold begins (sim 0.2, wall 10)
    assert g.hold(0.2, 10.05) == []                # 0.05 s of wall: 0.05 s of sim may pass
    assert g.hold(0.24, 10.05) == []
    assert g.hold(0.26, 10.05) == ["a"]            # caught up with real time: hold
    assert g.hold(0.26, 10.5) == []                # a controller asleep till sim 0.3 gets there
    assert g.hold(0.8, 10.5) == ["a"]


def test_a_stopped_robot_holds_nothing():
    g = CommandGate(["a", "b"], max_lag=0.15)
    g.command(1, 0.0, 0.0, 0.0, 0.0)               # a zero command: the controller stopped it
    assert g.hold(100.0, 0.0) == []
    g.command(1, 100.0, 0.0, 0.0, -0.4)            # turning on the spot is motion
    assert g.hold(100.5, 0.0) == ["b"]


def test_a_robot_late_for_max_wait_is_released_until_its_next_command():
    g = CommandGate(["walker"], max_lag=0.15, max_wait=2.0)
    g.command(0, 0.0, 0.2, 0.0, 0.0)
    assert g.hold(1.0, 10.0) == ["walker"]
    assert g.hold(1.0, 11.9) == [] and g.released == []     # real time: it steps
    assert g.hold(3.0, 11.9) == ["walker"] and g.released == []
    assert g.hold(3.0, 12.0) == [] and g.released == ["walker"]
    assert g.take_report() == {"walker": pytest.approx(2.0)}  # from each hold to the next poll
    assert g.take_report() == {}
    assert g.hold(50.0, 20.0) == []                # released: the clock goes on
    g.command(0, 50.0, 0.2, 0.0, 0.0)              # it is back
    assert g.hold(50.4, 21.0) == ["walker"]


def test_each_robot_is_released_on_its_own_timer():
    g = CommandGate(["a", "b"], max_lag=0.15, max_wait=2.0)
    g.command(0, 0.0, 0.2, 0.0, 0.0)
    assert g.hold(1.0, 10.0) == ["a"]
    assert g.hold(1.0, 11.95) == [] and g.released == []    # (real time: it steps)
    g.command(0, 2.95, 0.2, 0.0, 0.0)              # a answers after 1.95 s ...
    g.command(1, 2.95, 0.2, 0.0, 0.0)
    assert g.hold(3.2, 11.96) == ["a", "b"]         # ... b is late now: its own timer starts
    assert g.hold(3.2, 12.1) == ["a", "b"] and g.released == []  # late 0.14 s each, not 2 s
    assert g.hold(5.0, 12.1) == ["a", "b"]


def test_a_pause_is_no_wait_and_releases_nobody():
    g = CommandGate(["a"], max_lag=0.15, max_wait=2.0)
    g.command(0, 0.0, 0.2, 0.0, 0.0)
    assert g.hold(1.0, 10.0) == ["a"]
    g.suspend()                                    # paused for 5 s
    assert g.hold(1.0, 15.0) == ["a"] and g.released == []
    assert g.take_report() == {}


def test_reset_and_a_zero_lag_wait_for_nobody():
    g = CommandGate(["a"], max_lag=0.15)
    g.command(0, 0.0, 1.0, 0.0, 0.0)
    g.reset()
    assert g.hold(5.0, 0.0) == []
    off = CommandGate(["a"], max_lag=0.0)
    off.command(0, 0.0, 1.0, 0.0, 0.0)
    assert off.hold(5.0, 0.0) == []


@pytest.mark.parametrize("lag,wait", [(-0.1, 2.0), (math.nan, 2.0), (0.3, 0.0), (0.3, math.inf)])
def test_bad_settings_are_named(lag, wait):
    with pytest.raises(ConfigError, match="max_command_(lag|wait)"):
        CommandGate(["a"], max_lag=lag, max_wait=wait)


def test_tcp_unread_counts_what_the_peer_has_not_read():
    import socket
    import time

    srv = socket.socket()
    srv.bind(("127.0.0.1", 0))
    srv.listen(1)
    sender = socket.create_connection(srv.getsockname())
    reader, _ = srv.accept()
    try:
        key = (reader.getsockname(), reader.getpeername())   # as the simulator keys a peer
        sender.sendall(b"x" * 1234)
        deadline = time.time() + 2.0
        while tcp_unread([key]).get(key, 0) < 1234 and time.time() < deadline:
            time.sleep(0.01)
        assert tcp_unread([key])[key] == 1234
        assert len(reader.recv(1000)) == 1000
        assert tcp_unread([key])[key] == 234
        reader.recv(1000)
        assert tcp_unread([key])[key] == 0
    finally:
        for s in (sender, reader, srv):
            s.close()


def test_the_backlog_gate_holds_for_unread_connections_and_lets_a_stuck_one_go():
    g = BacklogGate(max_wait=2.0)
    assert g.hold({"a": 0, "b": 0}, 0.0, 10.0) == []
    assert g.hold({"a": 120, "b": 0}, 0.0, 10.0) == ["a"]
    assert g.hold({"a": 0, "b": 0}, 0.0, 10.3) == []          # a read it
    assert g.take_report() == {"a": pytest.approx(0.3)}
    assert g.hold({"a": 0, "b": 50}, 0.0, 11.0) == ["b"]
    assert g.hold({"a": 0, "b": 50}, 1.95, 12.9) == ["b"]     # (at real time it may step)
    assert g.hold({"a": 0, "b": 50}, 2.05, 13.0) == [] and g.released == ["b"]  # stuck 2 s
    assert g.hold({"a": 0, "b": 80}, 2.0, 14.0) == []         # not waited for again ...
    assert g.hold({"a": 0, "b": 0}, 2.0, 14.5) == []          # ... until it has caught up
    assert g.hold({"a": 0, "b": 10}, 2.0, 14.6) == ["b"]


def test_a_reader_waiting_on_sim_time_is_not_dead_locked():
    """A callback that waits for sim time to pass (a tf look-up with a timeout) leaves its
    next message unread: the clock must go on, at real time, not stop."""
    g = BacklogGate(max_wait=2.0)
    assert g.hold({"tracker": 900}, 5.0, 100.0) == ["tracker"]
    assert g.hold({"tracker": 900}, 5.0, 100.01) == []        # 0.01 s of sim may pass
    assert g.hold({"tracker": 900}, 5.02, 100.01) == ["tracker"]


def test_the_clock_is_thinned_only_when_the_asked_pace_would_outrun_the_wall_bound():
    # 100 Hz at rtf 2 is one /clock per 5 ms of wall: every tick goes out, also in a catch-up
    assert clock_wall_bound(100.0, 2.0, 0.001) == 0.0
    assert clock_wall_bound(100.0, 10.0, 0.001) == 0.0       # exactly 1000 Hz: not above
    assert clock_wall_bound(100.0, 10.5, 0.001) == 0.001
    assert clock_wall_bound(100.0, 0.0, 0.001) == 0.001      # as fast as possible


def test_tcp_unread_looks_up_the_sockets_asked_for_and_leaves_out_what_is_gone():
    """tcp_unread(keys): each socket looked up by its addresses gives the bytes sent to it
    and not read; one not asked for is not in the answer; a closed one, or addresses only a listening socket
    has, is left out."""
    import socket
    import time

    servers, pairs = [], []
    try:
        for _ in range(3):
            srv = socket.socket()
            srv.bind(("127.0.0.1", 0))
            srv.listen(1)
            sender = socket.create_connection(srv.getsockname())
            reader, _ = srv.accept()
            servers.append(srv)
            pairs.append((sender, reader))
        # the server side writes, the client side reads: as the simulator's publishers do
        for k, (client, accepted) in enumerate(pairs):
            accepted.sendall(b"y" * (100 + k))
        keys = [(c.getsockname(), c.getpeername()) for c, _ in pairs]
        gone = keys[2]
        pairs[2][0].close()
        deadline = time.time() + 2.0
        while tcp_unread(keys[:2]).get(keys[1], 0) < 101 and time.time() < deadline:
            time.sleep(0.01)
        both = tcp_unread(keys[:2])
        assert both[keys[0]] == 100 and both[keys[1]] == 101
        listener = (servers[0].getsockname(), ("127.0.0.1", 1))
        asked = tcp_unread([keys[0], gone, listener, keys[1]])
        assert asked == {keys[0]: 100, keys[1]: 101}
        assert tcp_unread([keys[1]]) == {keys[1]: 101}
        assert tcp_unread([]) == {}
        pairs[0][0].recv(60)
        assert tcp_unread([keys[0]]) == {keys[0]: 40}
    finally:
        for s in servers + [s for p in pairs for s in p]:
            s.close()


def test_tcp_unread_looks_up_more_sockets_than_one_send_holds():
    """150 look-ups (more than one send's worth): each distinct socket's own count, a closed
    one and a listener's addresses past the first send left out."""
    import socket
    import time

    srv = socket.socket()
    srv.bind(("127.0.0.1", 0))
    srv.listen(150)
    pairs = []
    try:
        for k in range(140):
            client = socket.create_connection(srv.getsockname())
            accepted, _ = srv.accept()
            accepted.sendall(b"q" * (10 + k))
            pairs.append((client, accepted))
        keys = [(c.getsockname(), c.getpeername()) for c, _ in pairs]
        deadline = time.time() + 2.0
        while tcp_unread([keys[-1]]).get(keys[-1], 0) < 149 and time.time() < deadline:
            time.sleep(0.01)
        pairs[100][0].close()
        listener = (srv.getsockname(), ("127.0.0.1", 1))
        asked = keys[:90] + [listener] + keys[90:] + [keys[5]] * 9
        want = {key: 10 + k for k, key in enumerate(keys) if k != 100}
        assert tcp_unread(asked) == want
    finally:
        for s in [srv] + [s for p in pairs for s in p]:
            s.close()


def test_the_outbox_looks_up_its_subscribers_unread_bytes():
    """Outbox.unread asks tcp_unread for its subscribers' sockets only, once for all, and
    reads each subscriber's backlog from the answer; real sockets, as a publisher's."""
    import socket
    import time
    from types import SimpleNamespace

    pytest.importorskip("rospy")
    from bullet_floor_sim.ros.sim.outbox import Outbox

    class Conn:      # a rospy connection's attributes the outbox reads (hashable, as rospy's)
        def __init__(self, sock, endpoint_id):
            self.socket, self.endpoint_id, self.done = sock, endpoint_id, False

    server = socket.socket()
    server.bind(("127.0.0.1", 0))
    server.listen(4)
    readers, conns = [], []
    try:
        for name in ("/a", "/b"):
            readers.append(socket.create_connection(server.getsockname()))
            sock, _ = server.accept()
            conns.append(Conn(sock, name))
        out = Outbox()
        out.publishers.append(SimpleNamespace(impl=SimpleNamespace(connections=conns),
                                              resolved_name="/t"))
        asked = []

        def lookup(keys):
            asked.append(sorted(keys))
            return tcp_unread(keys)

        assert out.unread(lookup) == {("/a", "/t"): 0, ("/b", "/t"): 0}
        assert asked == [sorted((r.getsockname(), r.getpeername()) for r in readers)]
        conns[1].socket.sendall(b"z" * 77)
        deadline = time.time() + 2.0
        while out.unread(tcp_unread)[("/b", "/t")] < 77 and time.time() < deadline:
            time.sleep(0.01)
        assert out.unread(tcp_unread) == {("/a", "/t"): 0, ("/b", "/t"): 77}
    finally:
        for s in [server] + readers + [c.socket for c in conns]:
            s.close()
