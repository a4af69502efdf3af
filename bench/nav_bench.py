#!/usr/bin/env python3
"""Navigation benchmark: room-to-room goals through the move_base action, builtin and stock,
for one robot and for two at once.

Modes ``builtin`` and ``stock`` run one robot; ``builtin2`` and ``stock2`` run
``two_robots.launch`` and drive robot1 and robot2 at the same time (robot1's goals from the west
rooms, robot2's from the east ones: ``TWO_ROBOT_ROOMS``), pooling both robots' goals. For each
navigation mode, ``navigation.launch world:=office nav:=<mode>`` (one robot with an
empty name, headless) runs under a roscore of its own on a free port, and an actionlib client
sends N goals (default 8): room centroids of worlds/office/rois.yaml (offices, lab, kitchen;
corridors excluded), each checked free on the planning grid, in an order and with goal yaws
drawn from a fixed seed. Each goal is given ``--goal-timeout`` sim seconds.

Measured per goal: the action's final state, the time to the result (sim s), the final position
error (ground truth, ``base_pose_ground_truth``, vs the goal). For stock (amcl localises the
robot), the localisation error is sampled at 5 Hz sim time during the whole run: tf
``map -> base_footprint`` looked up at each ground-truth stamp vs that ground-truth pose.
builtin localises from ground truth, so it has no amcl error (n/a).

The stock mode runs only when ``rospack find move_base`` succeeds (ros-noetic-navigation or
a source build on ROS_PACKAGE_PATH: source its setup.bash with ``--extend`` after the
workspace's, which resets the package path); otherwise it is reported as ``na``.

Real-time factors (``--rtf-builtin``, ``--rtf-stock``): 4 for both. At 4 the stock stack
(amcl, costmaps, DWA at 10 Hz sim) keeps up on a 2-core machine with no tf or control-loop
warnings; at 6 move_base logs tf extrapolation errors ("Could not transform the global plan")
and missed control-loop rates. Builtin 4 is the rostest's. About 3 minutes for both one-robot
modes, 4 for the two-robot ones.

The stock mode needs config/*.yaml as tuned for this simulator (amcl beam model: the
likelihood field biases the estimate into the walls by up to a map cell; DWA goal latch at
move_base level), see the comments there.

Prints a per-goal table, a summary table and one line::

    BENCH nav builtin_success=<x> builtin_mean_s=<x> stock_success=<x|na> stock_mean_s=<x|na> \
stock_amcl_median_m=<x|na> builtin2_success=... stock2_amcl_median_m=<x|na>

``--attach NS`` (``-`` for the empty-name robot) drives a robot of an already running launch
(the current ROS_MASTER_URI) with
the same goals instead, e.g. ``--attach robot1``; several ``--attach`` run robots at once.
"""
from __future__ import annotations

import argparse
import json
import math
import os
import random
import signal
import subprocess
import sys
import tempfile
import threading
import time
from typing import Dict, List, Optional, Sequence, Tuple

HERE = os.path.dirname(os.path.abspath(__file__))
REPO = os.path.dirname(HERE)
sys.path.insert(0, os.path.join(REPO, "src"))
sys.path.insert(0, HERE)
from ros_bench import _free_port  # noqa: E402  (one free-port helper for the ROS benches)

Goal = Tuple[str, float, float, float]   # (roi id, x, y, yaw)


# -- goals -------------------------------------------------------------------------------------
def room_goals(n: int, seed: int, world: str = "office",
               start: Optional[Tuple[float, float]] = None,
               only: Optional[Sequence[str]] = None) -> List[Goal]:
    """N goals at room centroids (no corridors), free on the planning grid, in a seeded order.

    Rooms are visited in a shuffled order, reshuffled when all have been used; never the same
    room twice in a row (nor the room holding ``start`` first). ``only``: ROI ids to use.
    """
    from bullet_floor_sim.sim.floormap import load_map
    from bullet_floor_sim.paths import worlds_dir
    from bullet_floor_sim.nav.planner import PlanningGrid
    from bullet_floor_sim.data.rois import centroid, load_rois, roi_at

    wdir = os.path.join(worlds_dir(), world)
    grid = PlanningGrid(load_map(os.path.join(wdir, "map.yaml")))
    rois = load_rois(os.path.join(wdir, "rois.yaml"))
    rooms = []
    for r in rois:
        if r.type == "corridor" or (only and r.id not in only):
            continue
        x, y = centroid(r)
        if grid.is_free(x, y):
            rooms.append((r.id, float(x), float(y)))
    if not rooms:
        raise RuntimeError("no room centroid of %s is free" % world)
    rng = random.Random(seed)
    last = None
    if start is not None:
        here = roi_at(rois, start[0], start[1])
        last = here.id if here is not None else None
    goals: List[Goal] = []
    while len(goals) < n:
        order = rooms[:]
        rng.shuffle(order)
        if len(order) > 1 and order[0][0] == last:
            order.append(order.pop(0))
        for rid, x, y in order:
            if len(goals) == n:
                break
            goals.append((rid, x, y, rng.uniform(-math.pi, math.pi)))
            last = rid
    return goals


# -- one robot under a running master -----------------------------------------------------------
def _yaw(q) -> float:
    return math.atan2(2.0 * (q.w * q.z + q.x * q.y), 1.0 - 2.0 * (q.y * q.y + q.z * q.z))


def _wrap(a: float) -> float:
    return (a + math.pi) % (2.0 * math.pi) - math.pi


class Robot:
    """Ground truth, localisation error samples and the move_base client of one robot.

    Args:
        ns: robot namespace ("" for the empty-name robot).
        amcl: sample the localisation error (tf map -> base_footprint vs ground truth).
        tf_buffer: a shared tf2 buffer (with its listener) when amcl is set.
    """

    def __init__(self, ns: str, amcl: bool, tf_buffer=None) -> None:
        import actionlib
        import rospy
        from move_base_msgs.msg import MoveBaseAction
        from nav_msgs.msg import Odometry

        self.ns = ns.strip("/")
        self.topic = ("/" + self.ns) if self.ns else ""
        self.base_frame = (self.ns + "/" if self.ns else "") + "base_footprint"
        self.lock = threading.Lock()
        self.gt: Optional[Tuple[float, float, float, object]] = None   # x, y, yaw, stamp
        self.loc_err: List[float] = []
        self.loc_yaw_err: List[float] = []
        self.tf_buffer = tf_buffer
        rospy.Subscriber(self.topic + "/base_pose_ground_truth", Odometry, self._on_gt,
                         queue_size=20)
        self.client = actionlib.SimpleActionClient(self.topic + "/move_base", MoveBaseAction)
        self._timer = rospy.Timer(rospy.Duration(0.2), self._sample) if amcl else None

    def _on_gt(self, m) -> None:
        p = m.pose.pose
        with self.lock:
            self.gt = (p.position.x, p.position.y, _yaw(p.orientation), m.header.stamp)

    def _sample(self, _event) -> None:
        import rospy

        with self.lock:
            gt = self.gt
        if gt is None:
            return
        try:
            t = self.tf_buffer.lookup_transform("map", self.base_frame, gt[3],
                                                rospy.Duration(0.1))
        except Exception:
            return
        tr = t.transform
        self.loc_err.append(math.hypot(tr.translation.x - gt[0], tr.translation.y - gt[1]))
        self.loc_yaw_err.append(abs(_wrap(_yaw(tr.rotation) - gt[2])))

    def wait_ready(self, timeout: float) -> bool:
        """Ground truth flowing, move_base up and (amcl) the robot localised in map.

        Every wait is on the wall clock: actionlib and rospy sleeps use sim time, which stands
        still (and blocks them forever) when the simulator is not running.
        """
        import rospy

        deadline = time.time() + timeout
        while self.gt is None:      # ground truth => /clock runs
            if time.time() > deadline or rospy.is_shutdown():
                return False
            time.sleep(0.2)
        while not self.client.wait_for_server(rospy.Duration(0.5)):
            if time.time() > deadline or rospy.is_shutdown():
                return False
        while time.time() < deadline:
            if self.tf_buffer is None or self.tf_buffer.can_transform(
                    "map", self.base_frame, rospy.Time(0)):
                return True
            time.sleep(0.2)
        return False

    def run_goal(self, goal: Goal, timeout: float) -> Dict:
        """Send one goal and wait for its result (``timeout`` sim s); the outcome as a dict."""
        import rospy
        from actionlib import SimpleGoalState
        from actionlib_msgs.msg import GoalStatus
        from move_base_msgs.msg import MoveBaseGoal

        rid, x, y, yaw = goal
        g = MoveBaseGoal()
        g.target_pose.header.frame_id = "map"
        g.target_pose.header.stamp = rospy.Time.now()
        g.target_pose.pose.position.x, g.target_pose.pose.position.y = x, y
        g.target_pose.pose.orientation.z = math.sin(yaw / 2.0)
        g.target_pose.pose.orientation.w = math.cos(yaw / 2.0)
        t0 = rospy.get_time()
        self.client.send_goal(g)
        # poll on the wall clock (wait_for_result never returns if /clock stops)
        wall_deadline = time.time() + timeout * 3 + 30
        last_sim, last_wall = t0, time.time()
        done = False
        while not rospy.is_shutdown():
            done = self.client.simple_state == SimpleGoalState.DONE
            now = rospy.get_time()
            if now != last_sim:
                last_sim, last_wall = now, time.time()
            if (done or now - t0 > timeout or time.time() > wall_deadline
                    or time.time() - last_wall > 20.0):     # the clock stopped: sim gone
                break
            time.sleep(0.05)
        dt = rospy.get_time() - t0
        if not done:
            self.client.cancel_goal()
            end = time.time() + 5.0
            while self.client.simple_state != SimpleGoalState.DONE and time.time() < end:
                time.sleep(0.05)
        state = self.client.get_state() if done else -1
        with self.lock:
            gx, gy, gyaw = self.gt[:3]
        names = {GoalStatus.SUCCEEDED: "SUCCEEDED", GoalStatus.ABORTED: "ABORTED",
                 GoalStatus.PREEMPTED: "PREEMPTED", GoalStatus.REJECTED: "REJECTED", -1: "TIMEOUT"}
        return {"roi": rid, "x": x, "y": y, "yaw": yaw, "state": names.get(state, str(state)),
                "ok": state == GoalStatus.SUCCEEDED, "time": dt,
                "err": math.hypot(gx - x, gy - y), "yaw_err": abs(_wrap(gyaw - yaw)),
                "text": self.client.get_goal_status_text() if done else "no result in time"}


def drive(namespaces: Sequence[str], amcl: bool, n: int, seed: int, timeout: float,
          ready_timeout: float = 90.0, log=None,
          rooms: Optional[Dict[str, Sequence[str]]] = None) -> Dict[str, Dict]:
    """Drive robots (at once, one thread each) through their goals; results per namespace.

    ``rooms``: namespace -> the ROI ids its goals are drawn from (default: every room).
    """
    import rospy

    tf_buffer = None
    if amcl:
        import tf2_ros

        tf_buffer = tf2_ros.Buffer(rospy.Duration(30.0))
        tf2_ros.TransformListener(tf_buffer)
    robots = [Robot(ns, amcl, tf_buffer) for ns in namespaces]
    out: Dict[str, Dict] = {}

    def one(i: int, r: Robot) -> None:
        res = {"ns": r.ns, "ready": False, "goals": []}
        out[r.ns] = res
        if not r.wait_ready(ready_timeout):
            return
        res["ready"] = True
        with r.lock:
            start = r.gt[:2]
        only = (rooms or {}).get(r.ns)
        for k, g in enumerate(room_goals(n, seed + 101 * i, start=start, only=only)):
            row = r.run_goal(g, timeout)
            res["goals"].append(row)
            if log:
                log("%s goal %d %s" % (r.ns or "(empty)", k, _row_text(row)))
        res["loc_err"] = list(r.loc_err)
        res["loc_yaw_err"] = list(r.loc_yaw_err)

    threads = [threading.Thread(target=one, args=(i, r), daemon=True)
               for i, r in enumerate(robots)]
    for t in threads:
        t.start()
    for t in threads:
        t.join()
    return out


def _row_text(row: Dict) -> str:
    return "room %-3s (%5.2f, %5.2f) %-9s %6.1f s  err %.3f m  yaw %.2f  %s" % (
        row["roi"], row["x"], row["y"], row["state"], row["time"], row["err"], row["yaw_err"],
        row["text"] if not row["ok"] else "")


# -- one mode under its own roscore -------------------------------------------------------------
def _stop(p: Optional[subprocess.Popen], timeout: float = 30.0) -> None:
    """SIGINT to a process group, SIGKILL after ``timeout`` (roslaunch itself escalates to
    SIGKILL for its nodes after ~17 s: give it the time)."""
    if p is None or p.poll() is not None:
        return
    try:
        os.killpg(p.pid, signal.SIGINT)
    except ProcessLookupError:
        return
    try:
        p.wait(timeout)
    except subprocess.TimeoutExpired:
        os.killpg(p.pid, signal.SIGKILL)
        p.wait()


def _kill_leftovers(tag: str) -> int:
    """SIGKILL processes whose command line holds ``tag`` (this run's private ROS_HOME, which
    every node of its roslaunch gets in ``__log:=``): roslaunch starts nodes in their own
    process groups, and one that hangs in shutdown would outlive it. Returns how many."""
    n = 0
    for pid in os.listdir("/proc"):
        if not pid.isdigit() or int(pid) == os.getpid():
            continue
        try:
            with open("/proc/%s/cmdline" % pid, "rb") as f:
                cmd = f.read().decode(errors="replace")
        except OSError:
            continue
        if tag in cmd:
            try:
                os.kill(int(pid), signal.SIGKILL)
                n += 1
            except OSError:
                pass
    return n


#: Two-robot runs: each robot's goals come from its own half of the office (robot1 the west
#: rooms, robot2 the east ones), so both cross the shared corridor at once but do not have to
#: pass head-on through the same door (two stock move_bases deadlock there; see docs/simulator.md).
TWO_ROBOT_ROOMS = {"robot1": ["5", "6", "7", "10", "11", "12"],
                   "robot2": ["8", "9", "13", "14", "15"]}


def run_case(mode: str, n: int, seed: int, rtf: float, timeout: float) -> Dict:
    """navigation.launch (mode ``builtin``/``stock``) or two_robots.launch (``builtin2``/
    ``stock2``) under a private roscore; drive the robot(s); results (per namespace for two)."""
    import rosgraph

    two = mode.endswith("2")
    nav = mode[:-1] if two else mode

    tmp = tempfile.mkdtemp(prefix="bfs_nav_bench_%s_" % mode)
    uri = "http://127.0.0.1:%d" % _free_port()
    env = dict(os.environ, ROS_MASTER_URI=uri, ROS_HOME=tmp)
    os.environ.update(ROS_MASTER_URI=uri, ROS_HOME=tmp)
    log_path = os.path.join(tmp, "launch.log")
    core = launch = None
    try:
        core = subprocess.Popen(["roscore", "-p", uri.rsplit(":", 1)[1]], env=env,
                                stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL,
                                start_new_session=True)
        for _ in range(150):
            if rosgraph.is_master_online(uri):
                break
            time.sleep(0.1)
        # before this process's init_node (the launch sets it too, maybe later): sim time
        subprocess.call(["rosparam", "set", "/use_sim_time", "true"], env=env)
        with open(log_path, "w") as logf:
            launch = subprocess.Popen(
                ["roslaunch", "bullet_floor_sim",
                 "two_robots.launch" if two else "navigation.launch", "world:=office",
                 "nav:=" + nav, "rtf:=%g" % rtf, "seed:=%d" % seed],
                env=env, stdout=logf, stderr=subprocess.STDOUT, start_new_session=True)
        import rospy
        from std_msgs.msg import Float64

        rospy.init_node("nav_bench_" + mode, anonymous=True, disable_signals=True)
        achieved: List[float] = []
        rospy.Subscriber("/simulator/real_time_factor_achieved", Float64,
                         lambda m: achieved.append(m.data))
        out = drive(list(TWO_ROBOT_ROOMS) if two else [""], nav == "stock", n, seed, timeout,
                    log=lambda s: print(s, file=sys.stderr, flush=True),
                    rooms=TWO_ROBOT_ROOMS if two else None)
        res = merge(out) if two else out[""]
        res["log"] = log_path
        res["rtf"] = rtf
        res["rtf_achieved"] = min(achieved) if achieved else None
        rospy.signal_shutdown("done")
        return res
    finally:
        _stop(launch)
        _stop(core)
        left = _kill_leftovers(tmp)
        if left:
            print("nav_bench: killed %d process(es) still running after roslaunch and roscore "
                  "shut down" % left, file=sys.stderr)


def _log_problems(path: str) -> int:
    """WARN and ERROR lines in a launch log (tf, costmap, planner trouble)."""
    try:
        with open(path, errors="replace") as f:
            return sum(1 for line in f if "[ WARN]" in line or "[ERROR]" in line)
    except OSError:
        return -1


def merge(out: Dict[str, Dict]) -> Dict:
    """One result from several robots' (goals and amcl samples pooled, goals tagged by robot)."""
    res: Dict = {"ready": all(r.get("ready") for r in out.values()), "goals": [],
                 "loc_err": [], "loc_yaw_err": []}
    for ns, r in out.items():
        res["goals"] += [dict(g, ns=ns) for g in r.get("goals", [])]
        res["loc_err"] += r.get("loc_err", [])
        res["loc_yaw_err"] += r.get("loc_yaw_err", [])
    return res


# -- report -------------------------------------------------------------------------------------
def _median(v: Sequence[float]) -> float:
    s = sorted(v)
    if not s:
        return float("nan")
    k = len(s) // 2
    return s[k] if len(s) % 2 else 0.5 * (s[k - 1] + s[k])


def summarise(res: Optional[Dict]) -> Dict[str, float]:
    if res is None:
        return {}
    goals = res.get("goals", [])
    ok = [g for g in goals if g["ok"]]
    n = max(1, len(goals))
    errs = res.get("loc_err") or []
    return {"goals": len(goals), "success": len(ok) / n if goals else 0.0,
            "mean_s": sum(g["time"] for g in ok) / len(ok) if ok else float("nan"),
            "final_err": _median([g["err"] for g in ok]) if ok else float("nan"),
            "amcl_median": _median(errs) if errs else float("nan"),
            "amcl_worst": max(errs) if errs else float("nan"),
            "amcl_n": len(errs)}


def stock_available() -> bool:
    try:
        return subprocess.call(["rospack", "find", "move_base"], stdout=subprocess.DEVNULL,
                               stderr=subprocess.DEVNULL) == 0
    except OSError:
        return False


def _fmt(v, spec="%.2f") -> str:
    return "na" if v is None or (isinstance(v, float) and math.isnan(v)) else spec % v


def _parse(argv: Optional[List[str]]) -> argparse.Namespace:
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--goals", type=int, default=8)
    ap.add_argument("--seed", type=int, default=1)
    ap.add_argument("--rtf-builtin", type=float, default=4.0)
    ap.add_argument("--rtf-stock", type=float, default=4.0)
    ap.add_argument("--goal-timeout", type=float, default=150.0, help="sim s per goal")
    ap.add_argument("--modes", default="builtin,stock,builtin2,stock2",
                    help="builtin, stock: navigation.launch (one robot); builtin2, stock2: "
                         "two_robots.launch (both robots at once)")
    ap.add_argument("--case", help=argparse.SUPPRESS)
    ap.add_argument("--rtf", type=float, help=argparse.SUPPRESS)
    ap.add_argument("--attach", action="append", help="drive robot NS of a running launch")
    ap.add_argument("--amcl", action="store_true", help="with --attach: sample amcl error")
    ap.add_argument("--rooms", action="append", default=[],
                    help="with --attach: NS=ID,ID,... rooms that robot's goals come from")
    return ap.parse_args(argv)


def _attach(args: argparse.Namespace) -> int:
    """--attach: drive the robots of a running launch."""
    import rospy

    rospy.init_node("nav_bench_attach", anonymous=True, disable_signals=True)
    rooms = {a.split("=", 1)[0]: a.split("=", 1)[1].split(",") for a in args.rooms}
    out = drive([a if a != "-" else "" for a in args.attach], args.amcl, args.goals,
                args.seed, args.goal_timeout, log=lambda s: print(s, flush=True),
                rooms=rooms)
    for ns, res in out.items():
        s = summarise(res)
        print("%s: ready %s success %s mean %s s amcl median %s worst %s (n=%s)" % (
            ns or "(empty)", res["ready"], _fmt(s.get("success")), _fmt(s.get("mean_s")),
            _fmt(s.get("amcl_median"), "%.3f"), _fmt(s.get("amcl_worst"), "%.3f"),
            s.get("amcl_n")))
    rospy.signal_shutdown("done")
    return 0


def _run_modes(args: argparse.Namespace, modes: List[str]
               ) -> Tuple[Dict[str, Optional[Dict]], Dict[str, str]]:
    """Each mode in a process of its own: its results and a note on how it ran."""
    results: Dict[str, Optional[Dict]] = {}
    notes: Dict[str, str] = {}
    for mode in modes:
        if mode.startswith("stock") and not stock_available():
            results[mode] = None
            notes[mode] = "move_base not found (rospack): skipped"
            continue
        rtf = args.rtf_stock if mode.startswith("stock") else args.rtf_builtin
        t0 = time.time()
        out = subprocess.run([sys.executable, __file__, "--case", mode, "--rtf", str(rtf),
                              "--goals", str(args.goals), "--seed", str(args.seed),
                              "--goal-timeout", str(args.goal_timeout)],
                             stdout=subprocess.PIPE, universal_newlines=True)
        lines = out.stdout.strip().splitlines()
        try:
            results[mode] = json.loads(lines[-1])
            r = results[mode]
            notes[mode] = "rtf %g (lowest achieved %s), %.0f s wall, %d WARN/ERROR lines in %s" % (
                rtf, _fmt(r.get("rtf_achieved")), time.time() - t0, _log_problems(r["log"]),
                r["log"])
        except (IndexError, ValueError, KeyError):
            results[mode] = {"goals": [], "ready": False}
            notes[mode] = "run failed (exit %d)" % out.returncode
    return results, notes


def _report(modes: List[str], results: Dict[str, Optional[Dict]], notes: Dict[str, str]
            ) -> None:
    """Each goal, the table and the BENCH line."""
    for mode in modes:
        res = results.get(mode)
        if not res:
            continue
        print("-- %s (%s)" % (mode, notes[mode]))
        if not res.get("ready"):
            print("   navigation never became ready")
        for k, g in enumerate(res.get("goals", [])):
            print("   %d %s%s" % (k, g["ns"] + " " if g.get("ns") else "", _row_text(g)))
    print("%-8s %5s %8s %10s %12s %12s %11s" % ("mode", "goals", "success", "mean_s",
                                                 "final_err_m", "amcl_med_m", "amcl_max_m"))
    summ = {m: summarise(results.get(m)) for m in modes}
    for mode in modes:
        s = summ[mode]
        if not s:
            print("%-8s %s" % (mode, notes[mode]))
            continue
        amcl = mode.startswith("stock")
        print("%-8s %5d %7.0f%% %10s %12s %12s %11s" % (
            mode, s["goals"], 100 * s["success"], _fmt(s["mean_s"], "%.1f"),
            _fmt(s["final_err"], "%.3f"), _fmt(s["amcl_median"], "%.3f") if amcl else "n/a",
            _fmt(s["amcl_worst"], "%.3f") if amcl else "n/a"))
    fields = []
    for mode in modes:
        s = summ.get(mode) or {}
        fields += ["%s_success=%s" % (mode, _fmt(s.get("success"))),
                   "%s_mean_s=%s" % (mode, _fmt(s.get("mean_s"), "%.1f"))]
        if mode.startswith("stock"):
            fields.append("%s_amcl_median_m=%s" % (mode, _fmt(s.get("amcl_median"), "%.3f")))
    print("BENCH nav " + " ".join(fields))


def main(argv: Optional[List[str]] = None) -> int:
    args = _parse(argv)
    if args.case:
        res = run_case(args.case, args.goals, args.seed, args.rtf, args.goal_timeout)
        print(json.dumps(res))
        return 0
    if args.attach:
        return _attach(args)
    modes = [m for m in args.modes.split(",") if m]
    results, notes = _run_modes(args, modes)
    _report(modes, results, notes)
    return 0


if __name__ == "__main__":
    sys.exit(main())
