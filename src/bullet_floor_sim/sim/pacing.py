"""Waiting for the nodes that drive the robots: sim time never runs away from a controller.

A controller (move_base, path_follower, teleop) answers the sensor data of sim time t with a
command some wall time later. When the simulator runs faster than the controller can answer
(``rtf:=0``, or a slow machine), a moving robot goes on with a stale command until the
velocity watchdog stops it, and the controller reacts to a world that has moved on: a
navigation that works at real time stutters, overshoots and gives up.

:class:`CommandGate` decides when the simulator must hold its clock. A robot *holds* the
clock while its last command was a motion (any non-zero component) received more than
``max_lag`` sim seconds ago: a controller that stops a robot sends a zero command, and after
that the robot needs nobody. While a robot holds it, the clock goes on at real time at most:
a controller that sleeps until its next period (a ``rospy.Rate`` in sim time) still gets there,
and at real time every ROS controller is meant to keep pace. A robot late for more than
``max_wait`` wall seconds is *released*: the simulator goes on without it until its next
command (its controller died, or was stopped with the robot moving, and the velocity watchdog
stops the robot as it always did), and the release is reported once. The gate keeps counts
for the simulator's periodic report: wall time spent waiting, and for which robots.

:class:`BacklogGate` holds the clock while a subscriber has not read what was sent to it
(Linux, subscribers on this machine): a node that takes the data of sim time t at t + 2 s
(the socket's receive queue holds the rest) acts on a world 2 s old, however fresh its
commands. It too lets the clock go on at real time (a callback that waits on sim time, a tf
look-up with a timeout, finishes) and lets a connection go after ``max_wait``.
:func:`tcp_unread` reads the subscribers' sockets' unread byte counts from the kernel
(sock_diag netlink: each socket looked up by its addresses, up to 64 look-ups a send).

Plain data in and out; the simulator node is the glue (``~max_command_lag``,
``~max_command_wait``, ``~wait_for_subscribers``).
"""
from __future__ import annotations

import errno
import functools
import math
import os
import socket
import struct
from typing import Any, Dict, Generic, Hashable, List, Optional, Sequence, Set, Tuple, TypeVar

from ..errors import ConfigError

__all__ = ["BacklogGate", "CommandGate", "tcp_unread", "waits_line"]

Endpoint = Tuple[str, int]   # (IPv4 address, port)
K = TypeVar("K", bound=Hashable)   # what a gate times: a robot's index, a connection


class _Gate(Generic[K]):
    """What both gates share: each late key (a robot, a connection) is timed on its own and
    released after ``max_wait`` wall seconds; while any key is late the clock goes on at real
    time at most; the wall time held is accounted per key."""

    def __init__(self, max_wait: float) -> None:
        if not (math.isfinite(max_wait) and max_wait > 0.0):
            raise ConfigError("~max_command_wait: %r is not a positive number of seconds"
                              % (max_wait,))
        self.max_wait = float(max_wait)
        self._late_since = {}  # type: Dict[K, float]  # wall time each became late
        self._released: Set[K] = set()                 # not waited for, for now
        self._crawl = None  # type: Optional[Tuple[float, float]]  # (wall, sim) it began
        self._held = []  # type: List[K]                      # held for at the last poll
        self._poll = 0.0                                      # wall time of that poll
        self.released: List[Any] = []           # released by the last poll (CommandGate: names)
        self.waited = {}  # type: Dict[K, float]              # wall seconds held, per key
        self.holds = 0                                        # holds begun

    def _decide(self, late: Sequence[K], sim_time: float, wall: float) -> List[K]:
        for k in self._held:   # the wall time since the last poll was spent holding
            self.waited[k] = self.waited.get(k, 0.0) + (wall - self._poll)
        self._held, self.released = [], []
        late = [k for k in late if k not in self._released]
        for k in [k for k in self._late_since if k not in late]:
            del self._late_since[k]
        keep = []
        for k in late:
            if wall - self._late_since.setdefault(k, wall) >= self.max_wait:
                del self._late_since[k]
                self._released.add(k)
                self.released.append(k)
            else:
                keep.append(k)
        if not keep:
            self._crawl = None
            return []
        if self._crawl is None:
            self._crawl = (wall, sim_time)
            self.holds += 1
        if sim_time - self._crawl[1] < wall - self._crawl[0]:   # behind real time: step
            return []
        self._held, self._poll = keep, wall
        return keep

    def suspend(self) -> None:
        """The simulation is paused: no hold goes on, nothing is late."""
        self._held, self._crawl = [], None
        self._late_since.clear()

    def take_report(self) -> Dict[K, float]:
        """Wall seconds held per key since the last call (and clears them)."""
        out, self.waited = self.waited, {}
        return out


class CommandGate(_Gate[int]):
    """When the simulator waits for the robots' controllers (see the module docstring).

    Args:
        names: the robots' names, in world order (for the report; "" reads "<empty>").
        max_lag: sim seconds a moving robot may go without a new command before the clock
            holds for it (0 turns the gate off). A little longer than a controller's period
            (0.1 s at path_follower's 10 Hz, 0.05 s at move_base's 20 Hz): a command then
            answers data at most ``max_lag`` minus the period old, as on a real robot. A
            slower controller slows the clock to real time between its commands.
        max_wait: wall seconds the clock holds for one robot before it is released.

    Raises:
        ConfigError: a negative or non-finite lag, or a wait that is not positive.
    """

    def __init__(self, names: Sequence[str], max_lag: float = 0.15,
                 max_wait: float = 2.0) -> None:
        if not (math.isfinite(max_lag) and max_lag >= 0.0):
            raise ConfigError("~max_command_lag: %r is not a non-negative number of "
                              "seconds (0 = do not wait for controllers)" % (max_lag,))
        super().__init__(max_wait)
        self.names = [n or "<empty>" for n in names]
        self.max_lag = float(max_lag)
        n = len(self.names)
        self._last = [-math.inf] * n          # sim time of each robot's last command
        self._moving = [False] * n            # that command was a motion

    def command(self, robot: int, sim_time: float, vx: float, vy: float, w: float) -> None:
        """A command for a robot arrived at this sim time."""
        self._last[robot] = float(sim_time)
        self._moving[robot] = bool(vx or vy or w)
        self._released.discard(robot)
        self._late_since.pop(robot, None)   # it answered: a later lateness is timed afresh

    def reset(self) -> None:
        """Every robot stopped (a world reset): nobody is waited for."""
        n = len(self.names)
        self._last, self._moving = [-math.inf] * n, [False] * n
        self._released.clear()
        self.suspend()

    def waiting_for(self, sim_time: float) -> List[int]:
        """The robots late at this sim time (none when the gate is off)."""
        if self.max_lag <= 0.0:
            return []
        limit = sim_time - self.max_lag
        return [i for i, (t, m) in enumerate(zip(self._last, self._moving))
                if m and t < limit and i not in self._released]

    def hold(self, sim_time: float, wall: float) -> List[str]:
        """The names of the robots the clock holds for now (empty: step), polled before
        each step and while holding. Robots late for ``max_wait`` wall seconds are named in
        ``released`` (until the next call) and not waited for again until their next
        command."""
        held = self._decide(self.waiting_for(sim_time), sim_time, wall)
        self.released = [self.names[i] for i in self.released]
        return [self.names[i] for i in held]

    # keyed by robot name, not by the index the gate times: a deliberate override
    def take_report(self) -> Dict[str, float]:  # type: ignore[override]
        """Wall seconds held per robot name since the last call (and clears them)."""
        return {self.names[i]: t for i, t in super().take_report().items()}


class BacklogGate(_Gate[Hashable]):
    """Holds the clock while a subscriber has not read what it was sent (module docstring).

    The simulator asks :meth:`hold` before it steps on, with the unread bytes of each
    subscriber connection it feeds. A connection unread for ``max_wait`` wall seconds in a
    row is released (named in ``released``) until it has read everything once: a subscriber
    that stopped reading (a suspended process) does not stop the simulation.

    Args:
        max_wait: wall seconds the clock holds for one connection before it is released.
    """

    def hold(self, unread: Dict[Hashable, int], sim_time: float,
             wall: float) -> List[Hashable]:
        """The connections the clock holds for now (empty: step on).

        Args:
            unread: unread bytes per connection (connections not listed are up to date).
            sim_time, wall: sim and wall time now.
        """
        self._released = {c for c in self._released if unread.get(c, 0) > 0}
        return self._decide([c for c, n in unread.items() if n > 0], sim_time, wall)


_NETLINK_SOCK_DIAG = 4
_SOCK_DIAG_BY_FAMILY = 20
_NLMSG_ERROR = 2
_NLM_F_REQUEST = 0x1
_TCP_LISTEN = 10
_NLMSGHDR = struct.Struct("=IHHII")
_NOCOOKIE = b"\xff" * 8               # INET_DIAG_NOCOOKIE: any socket of the 4-tuple
_REPLY_ROOM = 4096   # bytes of receive buffer per look-up of a send (a reply takes 0.8-1.3 kB)
_MAX_PER_SEND = 64


def _request(seq: int, sockid: bytes) -> bytes:
    """A SOCK_DIAG_BY_FAMILY look-up: struct inet_diag_req_v2 for the IPv4 TCP socket
    ``sockid``, in any state."""
    req = struct.pack("=BBBBI", socket.AF_INET, socket.IPPROTO_TCP, 0, 0, 0xFFFFFFFF) + sockid
    return (_NLMSGHDR.pack(_NLMSGHDR.size + len(req), _SOCK_DIAG_BY_FAMILY, _NLM_F_REQUEST, seq,
                           0) + req)


def _sockid(key: Tuple[Endpoint, Endpoint]) -> bytes:
    """struct inet_diag_sockid of the socket whose own end is key[0], its peer's key[1]."""
    (src, sport), (dst, dport) = key
    return (struct.pack(">HH", sport, dport) + socket.inet_aton(src) + bytes(12)
            + socket.inet_aton(dst) + bytes(12) + bytes(4) + _NOCOOKIE)


def tcp_unread(keys: Sequence[Tuple[Endpoint, Endpoint]]) -> Dict[Tuple[Endpoint, Endpoint], int]:
    """Unread bytes in the receive queue of local IPv4 TCP sockets, keyed by (the socket's
    own address, its peer's address).

    Args:
        keys: the sockets to look at, each looked up by its addresses (one netlink request
            each, sent together: microseconds, where a dump walks the kernel's whole table
            of established sockets, 262 144 buckets here, in about a millisecond); a socket
            that no longer exists, or is not on this machine, is left out.

    Raises:
        OSError: sock_diag is not available (not Linux, or no netlink in this sandbox), or
            it refused the request.
    """
    if not keys:
        return {}
    keys = tuple(keys)
    with socket.socket(socket.AF_NETLINK, socket.SOCK_DGRAM, _NETLINK_SOCK_DIAG) as s:
        s.settimeout(1.0)       # the kernel answers at once; never hang the main loop
        # as many look-ups a send as their replies fit in the receive buffer, with room
        per_send = max(1, min(_MAX_PER_SEND,
                              s.getsockopt(socket.SOL_SOCKET, socket.SO_RCVBUF) // _REPLY_ROOM))
        out = {}  # type: Dict[Tuple[Endpoint, Endpoint], int]
        for first, request in zip(range(0, len(keys), per_send), _lookups(keys, per_send)):
            s.send(request)
            out.update(_looked_up(s, keys, first, min(per_send, len(keys) - first)))
        return out


@functools.lru_cache(maxsize=8)
def _lookups(keys: Tuple[Tuple[Endpoint, Endpoint], ...], per_send: int) -> List[bytes]:
    """The look-up requests of ``keys``, ``per_send`` to a send; the look-up of keys[i] has
    sequence number i + 1 (the same sockets are looked up step after step: built once)."""
    return [b"".join(_request(i + 1, _sockid(keys[i]))
                     for i in range(first, min(first + per_send, len(keys))))
            for first in range(0, len(keys), per_send)]


def _looked_up(s: socket.socket, keys: Sequence[Tuple[Endpoint, Endpoint]], first: int,
               n: int) -> Dict[Tuple[Endpoint, Endpoint], int]:
    """The replies to one send of the look-ups of keys[first:first + n], one message each
    (matched by its sequence number): the socket; or an error, ENOENT for a socket gone
    (left out), any other raised. A listening socket (what the kernel falls back to when no
    connection has the addresses) is left out."""
    out = {}  # type: Dict[Tuple[Endpoint, Endpoint], int]
    answered = 0
    while answered < n:
        data = s.recv(1 << 16)
        if not data:
            raise OSError("sock_diag closed the look-up before answering it")
        off = 0
        while off + _NLMSGHDR.size <= len(data):
            length, kind, _flags, seq = _NLMSGHDR.unpack_from(data, off)[:4]
            if length < _NLMSGHDR.size:
                break
            answered += 1
            m = off + _NLMSGHDR.size
            if kind == _SOCK_DIAG_BY_FAMILY:
                if data[m + 1] != _TCP_LISTEN and first < seq <= first + n:
                    out[keys[seq - 1]] = struct.unpack_from("=I", data, m + 56)[0]
            elif kind == _NLMSG_ERROR:
                err = -struct.unpack_from("=i", data, m)[0]
                if err != errno.ENOENT:
                    raise OSError(err, "sock_diag refused a TCP socket look-up: %s"
                                  % os.strerror(err))
            else:
                raise OSError("sock_diag answered a TCP socket look-up with message type %d"
                              % kind)
            off += (length + 3) & ~3
    return out


def waits_line(commands: Dict[str, float], subscribers: Optional[Dict[Tuple[str, str], float]],
               wall: float) -> str:
    """The report's account of the wall time the clock waited for controllers
    (CommandGate.take_report) and subscribers (BacklogGate.take_report, None when it does
    not wait for them) over ``wall`` seconds, slowest first; empty when nobody was waited for."""
    line = ""
    waited = sorted(commands.items(), key=lambda kv: -kv[1])
    if waited:
        line += "; waited for cmd_vel of %s" % ", ".join(
            "%s %.0f%%" % (n, 100.0 * t / wall) for n, t in waited)
    if subscribers is not None:
        subs = sorted(subscribers.items(), key=lambda kv: -kv[1])[:3]
        if subs:
            line += "; waited for subscribers %s" % ", ".join(
                "%s (%s) %.0f%%" % (s, t, 100.0 * w / wall) for (s, t), w in subs)
    return line


def clock_wall_bound(clock_rate: float, rtf: float, period: float) -> float:
    """The least wall seconds between two /clock messages: ``period`` when the asked pace
    (``clock_rate`` Hz of sim time at real-time factor ``rtf``, 0 = as fast as possible) would
    publish faster than once per ``period``, else 0 (every tick, also when catching up)."""
    return period if rtf <= 0 or clock_rate * rtf * period > 1.0 else 0.0
