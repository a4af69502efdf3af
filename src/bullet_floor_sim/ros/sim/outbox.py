"""Batched, non-blocking delivery of wire bytes to the subscribers of the simulator's topics.
"""
from __future__ import annotations

import socket
from typing import Any, Callable, Dict, List, Tuple


import rospy


__all__ = ["Outbox", "no_delay", "peer_key", "raw_sockets_usable"]


class Outbox:
    """Batched, non-blocking delivery of wire bytes to the subscribers of some publishers.

    rospy hands every message to one writer thread per subscriber. Here messages wait per
    connection and leave in one non-blocking ``send`` per connection per ``flush`` (or as
    soon as a connection has the publisher's queue size waiting, or at ``send_now``: the
    simulator sends each /clock so); a subscriber that does not
    keep up loses its oldest messages beyond that queue size (as with rospy's queue) and
    never stalls the simulation. Main thread only. Publishers
    used here are created without a rospy queue (raw connections) and never publish through
    rospy, so nothing else writes to their sockets.
    """

    def __init__(self) -> None:
        self._queues: Dict[object, list] = {}   # connection -> [messages, bytes sent of the first]
        self.publishers: List[rospy.Publisher] = []
        self.sent = False   # bytes went out since the owner last cleared this
        self._peers = {}  # type: Dict[object, Tuple[Any, Tuple[str, str]]]
        self.raw = raw_sockets_usable()
        if not self.raw:
            rospy.logwarn("simulator: this rospy's connections have no socket/done attributes; "
                          "every message goes through rospy's blocking write_data instead")

    def publisher(self, topic: str, cls, queue_size: int) -> rospy.Publisher:
        """A publisher for ``put``: rospy connections without rospy's per-connection queue."""
        import warnings

        with warnings.catch_warnings():
            warnings.simplefilter("ignore")     # rospy warns about a missing queue_size
            pub = rospy.Publisher(topic, cls, queue_size=None)
        pub._bfs_queue_size = queue_size
        self.publishers.append(pub)
        return pub

    def drop(self, pub: rospy.Publisher) -> None:
        """Unregister a publisher made by ``publisher`` (its topic goes when no other
        publisher of this node has it); what waited for its subscribers is dropped."""
        if pub in self.publishers:
            self.publishers.remove(pub)
        for c in list(pub.impl.connections) if pub.impl is not None else []:
            self._queues.pop(c, None)
        pub.unregister()

    @staticmethod
    def wanted(pub: rospy.Publisher) -> bool:
        """Whether anyone subscribes (build nothing otherwise)."""
        return bool(pub.impl.connections)

    def put(self, pub: rospy.Publisher, data: bytes) -> None:
        """Queue ``data`` (from a *Wire ``pack``) for every current subscriber of ``pub``.
        A queue that reaches the publisher's queue size is sent at once; only what its
        socket does not take then is dropped, oldest first."""
        limit = pub._bfs_queue_size
        queues = self._queues
        for c in pub.impl.connections:
            q = queues.get(c)
            if q is None:
                if hasattr(c, "_connection") or not self.raw:
                    # a rospy QueuedConnection (someone else in this process made a publisher
                    # on this topic with a queue, and its thread writes to the socket), or a
                    # rospy whose connections this outbox does not know: go through rospy
                    try:
                        c.write_data(data)
                    except Exception:  # noqa: BLE001  (rospy drops such connections itself)
                        pass
                    continue
                q = queues[c] = [[], 0]
                no_delay(c)
            msgs = q[0]
            msgs.append(data)
            if len(msgs) > limit and not self._send(c, q):
                del msgs[1 if q[1] else 0]      # drop the oldest not yet being sent

    def send_now(self, pub: rospy.Publisher) -> None:
        """Send what waits for ``pub``'s subscribers at once (one non-blocking send each;
        /clock). It does not set ``sent``: the clock waits for subscribers after the data
        flushes, not after each /clock."""
        sent = self.sent
        for c in pub.impl.connections:
            q = self._queues.get(c)
            if q is not None and q[0]:
                self._send(c, q)
        self.sent = sent

    def unread(self, lookup: Callable[[List[Any]], Dict[Any, int]]
               ) -> Dict[Tuple[str, str], int]:
        """Unread bytes per (subscriber, topic) of every connection on this machine, from
        the kernel's count for each subscriber's socket: ``lookup`` (sim/pacing.tcp_unread)
        gets those sockets' keys, once for all."""
        for c in [c for c in self._peers if getattr(c, "done", True)]:
            del self._peers[c]
        peers = []
        for pub in self.publishers:
            for c in pub.impl.connections:
                peer = self._peers.get(c)
                if peer is None:
                    peer = self._peers[c] = peer_key(c, pub.resolved_name)
                peers.append(peer)
        counts = lookup([key for key, _ in peers if key is not None])
        out = {}  # type: Dict[Tuple[str, str], int]
        for key, label in peers:
            if key is not None:
                out[label] = max(out.get(label, 0), counts.get(key, 0))
        return out

    def flush(self) -> None:
        """Send what each connection's socket takes now; keep the rest for the next flush."""
        for c, q in list(self._queues.items()):
            if q[0]:
                self._send(c, q)
            elif getattr(c, "done", True):
                del self._queues[c]

    def _send(self, c, q: list) -> bool:
        """One non-blocking send of a connection's queue; whether the queue is short again."""
        msgs = q[0]
        sock = getattr(c, "socket", None)
        if getattr(c, "done", True) or sock is None:
            del msgs[:]
            self._queues.pop(c, None)
            return True
        data = msgs[0] if len(msgs) == 1 else b"".join(msgs)
        try:
            n = sock.send(memoryview(data)[q[1]:] if q[1] else data, socket.MSG_DONTWAIT)
        except (BlockingIOError, InterruptedError):
            return False
        except OSError:                     # subscriber gone: rospy's own clean-up
            del msgs[:]
            self._queues.pop(c, None)
            try:
                c.close()
            except Exception:  # noqa: BLE001  (already closing)
                pass
            return True
        self.sent = True
        left = n + q[1]
        if left == len(data):
            k = len(msgs)
            del msgs[:]
            left = 0
        else:
            k = 0
            while left >= len(msgs[k]):
                left -= len(msgs[k])
                k += 1
            del msgs[:k]
        q[1] = left
        c.stat_bytes = getattr(c, "stat_bytes", 0) + n
        c.stat_num_msg = getattr(c, "stat_num_msg", 0) + k
        return not msgs


def raw_sockets_usable() -> bool:
    """Whether rospy's TCPROS connections have what ``Outbox`` writes through: the
    ``socket`` and ``done`` attributes its constructor sets, and ``write_data``."""
    from rospy.impl.tcpros_base import TCPROSTransport

    names = set()
    for cls in TCPROSTransport.__mro__:     # done is set by rospy.transport.Transport
        init = cls.__dict__.get("__init__")
        if init is not None and hasattr(init, "__code__"):
            names.update(init.__code__.co_names)
    return "socket" in names and "done" in names and hasattr(TCPROSTransport, "write_data")



def no_delay(c) -> None:
    """TCP_NODELAY on a subscriber's socket: the batches here are small and end on a message,
    and Nagle's algorithm held each one back until the peer's delayed ACK (up to 40 ms of
    wall time), while the clock waited for the subscriber to read it."""
    sock = getattr(c, "socket", None)
    try:
        if sock is not None and sock.family in (socket.AF_INET, socket.AF_INET6):
            sock.setsockopt(socket.IPPROTO_TCP, socket.TCP_NODELAY, 1)
    except OSError:
        pass


def peer_key(c, topic: str) -> Tuple[Any, Tuple[str, str]]:
    """(the subscriber's socket as tcp_unread keys it, or None when it cannot be seen;
    (subscriber, topic)) of a publisher-side connection."""
    label = (str(getattr(c, "endpoint_id", "") or "?"), topic)
    sock = getattr(c, "socket", None)
    try:
        if sock is None or sock.family != socket.AF_INET:
            return None, label
        return (sock.getpeername(), sock.getsockname()), label
    except OSError:
        return None, label
