#!/usr/bin/env python3
"""The destination-prediction study on every shipped world, one table (``make eval``).

Runs people/evaluation.py (the code ``evaluate_prediction`` runs) on each world under worlds/
and each seed with the same legs: one task per (world, seed). The tasks run ``--workers`` at a
time on this machine (processes; default: one per core), or on a Ray cluster with ``--ray
ADDRESS``; a task's result does not depend on where or beside what it ran (the same seed gives
the same table), only its real-time factor does (``rtf``: sim seconds per wall second of the
run's ticks; ``setup``: the wall seconds before them, loading the world, checking it and the
predictor's distances). ``--workers 1`` runs them one after the other in this process, so the
real-time factors are measured side by side. Prints one row per task and an
``EVAL world=<name> ...`` line each (and a ``done:`` line on stderr as each ends, so a run cut
short keeps what it measured); ``--results URI`` also stores each row in a database (a
MongoDB or the embedded store) as it ends, so runs on many machines fill one table
(``--show-results URI`` prints it). ``margin`` is the predictor's least lead in top-1 over the
better of the two baselines at any fraction from 25 % on, from tracker and from ground-truth
tracks:

    make eval                      # 200 legs, seed 1, every world (the corpus's too, once built)
    .venv/bin/python bench/eval_worlds.py --legs 40 --seed 5 6 --worlds office malaga_campus
    .venv/bin/python bench/eval_worlds.py --legs 40 --ray auto     # on a running Ray cluster
"""
from __future__ import annotations

import argparse
import os
import sys
import time
from typing import Callable, Dict, List, Optional, Tuple

HERE = os.path.dirname(os.path.abspath(__file__))
sys.path.insert(0, os.path.join(HERE, "..", "src"))
sys.path.insert(0, HERE)

from bullet_floor_sim.people.evaluation import FRACTIONS, EvalConfig, run  # noqa: E402
from bullet_floor_sim.errors import BulletFloorSimError  # noqa: E402
from bullet_floor_sim.paths import corpus_dir, corpus_worlds, worlds_dir  # noqa: E402
from bullet_floor_sim.sim.config import world_label  # noqa: E402
from bullet_floor_sim.people.walker import OUTCOMES  # noqa: E402
from eval_results import ResultSink, show_results  # noqa: E402

COLUMNS = ("world", "seed", "legs", "given_up", "trk25", "trk50", "trk75", "gt25", "gt50", "gt75",
           "markov50", "heading50", "margin", "tracked", "ll50", "markov_ll50", "ll_margin",
           "rtf")


#: Worlds made for tests, not buildings: simple's one room, corridor's one corridor.
TEST_WORLDS = ("simple", "corridor")


def shipped() -> list:
    """The shipped buildings (worlds/), then the corpus buildings built (tools/corpus.py);
    a note on stderr when the corpus has not been built."""
    d = worlds_dir()
    out = sorted(w for w in os.listdir(d) if os.path.isfile(os.path.join(d, w, "world.yaml"))
                 and w not in TEST_WORLDS)
    corpus = corpus_worlds()
    if not corpus:
        print("note: the corpus of real buildings is not built (make corpus; %s): the shipped "
              "worlds only" % corpus_dir(), file=sys.stderr)
    return out + corpus


def study_check(worlds: list, allow: bool,
                sets: Optional[Dict[str, Dict[str, str]]] = None) -> tuple:
    """The map check of every world before any runs (building/check.py), on the map
    handling and planner the runs use (``sets``' ``clean`` and ``planner``): (notes,
    refused), refused mapping each world that would refuse (unless ``allow``) to its one
    line."""
    from bullet_floor_sim.people.evaluation.scenario import refuse_unreachable, study_building

    notes, refused = [], {}
    for w in worlds:
        try:
            cfg = eval_config(w, 1, 1, allow, sets or {})
            b = study_building(cfg)
            notes += ["%s: %s" % (w, n) for n in refuse_unreachable(b, cfg, b)]
        except BulletFloorSimError as e:
            refused[w] = str(e)
    return notes, refused


def checked(worlds: list, named: bool, allow: bool,
            sets: Optional[Dict[str, Dict[str, str]]] = None) -> tuple:
    """The worlds a study runs on and the notes: worlds the user named that would refuse
    stop it (exit with their lines); of the default list they are left out, each with a note
    that says why."""
    notes, refused = study_check(worlds, allow, sets)
    if refused and named:
        sys.exit("\n".join(refused.values()))
    notes += ["left out %s: %s" % (w, why) for w, why in refused.items()]
    return [w for w in worlds if w not in refused], notes


#: The config sections ``--set SECTION.FIELD=VALUE`` changes: the observer's (FollowConfig,
#: what the follower node runs), the predictor's (PredictionConfig), the observer's path
#: following (FollowerConfig, its path_follower's), the people tracker's (TrackerConfig,
#: observer.launch's people_tracker), both robots' navigation: recovery, replanning and
#: passing (NavigatorConfig), the planning grid both robots and the predictor's distances
#: use (PlannerConfig) and each world's map handling (MapHandling: world.yaml's ``clean``
#: keys, changed on the world's own); not the FIXED fields below.
SECTIONS = ("follow", "prediction", "drive", "tracker", "nav", "planner", "clean")
_ROLE = "a robot's role (the observer gives way, the walker keeps its way)"
#: Fields that are no default to change, and why.
FIXED = {"nav.give_way": _ROLE, "nav.keep_way": _ROLE,
         "nav.passing": "the path follower's mapping mode (off only while a map is built)",
         "nav.other_radius": "None by default (the robot's own radius), not a number to change",
         "planner.robot_radius": "the robots' footprint (the Scitos A5's circumradius), not a "
                                 "choice of the planner",
         "planner.unknown_is_obstacle": "set by the world's map handling (world.yaml "
                                        "`unknown`), not by the planner",
         "clean.unknown": "what the map's unknown cells are, which only its user knows "
                          "(world.yaml `unknown`)"}


def parse_sets(items: List[str]) -> Dict[str, Dict[str, str]]:
    """``--set`` items ``section.field=value`` as {section: {field: value}}; each checked
    (a known section and field, a value of the field's type and range).

    Raises:
        BulletFloorSimError: the first bad item, named (one line).
    """
    from bullet_floor_sim.errors import ConfigError

    out: Dict[str, Dict[str, str]] = {}
    for item in items:
        key, eq, value = item.partition("=")
        section, dot, name = key.strip().partition(".")
        if not (eq and dot and name and value.strip()):
            raise ConfigError("--set %s: expected SECTION.FIELD=VALUE (sections: %s)"
                              % (item, ", ".join(SECTIONS)))
        if section not in SECTIONS:
            raise ConfigError("--set %s: no section %r (sections: %s)"
                              % (item, section, ", ".join(SECTIONS)))
        if key.strip() in FIXED:
            raise ConfigError("--set %s: %s is %s" % (item, key.strip(), FIXED[key.strip()]))
        if name in out.get(section, {}):
            raise ConfigError("--set %s: %s.%s is set twice" % (item, section, name))
        out.setdefault(section, {})[name] = value.strip()
    eval_config("office", 1, 1, False, out).check()   # every value checked before any run
    return out


def eval_config(world: str, legs: int, seed: int, allow: bool,
                sets: Dict[str, Dict[str, str]]) -> EvalConfig:
    """The study's config of one task, with ``--set``'s changes to the shipped defaults."""
    from bullet_floor_sim.nav.grid import PlannerConfig
    from bullet_floor_sim.nav.navigator import NavigatorConfig
    from bullet_floor_sim.overrides import with_changes
    from bullet_floor_sim.people.follow_config import FollowConfig
    from bullet_floor_sim.people.evaluation.scenario import observer_follower, study_tracker
    from bullet_floor_sim.people.prediction import PredictionConfig

    return EvalConfig(legs=legs, seed=seed, world=world, allow_unreachable=allow,
                      drive_config=with_changes(observer_follower(), sets.get("drive", {}),
                                                "drive."),
                      follow_config=with_changes(FollowConfig(), sets.get("follow", {}),
                                                 "follow."),
                      prediction=with_changes(PredictionConfig(), sets.get("prediction", {}),
                                              "prediction."),
                      tracker_config=with_changes(study_tracker(), sets.get("tracker", {}),
                                                  "tracker."),
                      nav_config=with_changes(NavigatorConfig(), sets.get("nav", {}), "nav."),
                      planner_config=with_changes(PlannerConfig(), sets.get("planner", {}),
                                                  "planner."),
                      clean=dict(sets.get("clean", {})) or None)


def shipped_sections() -> Dict[str, object]:
    """Each ``--set`` section's config as shipped (SECTIONS -> its dataclass; ``clean``:
    the map handling a world.yaml without ``clean`` keys has)."""
    from bullet_floor_sim.sim.solidmap import MapHandling

    cfg = eval_config("office", 1, 1, False, {})
    return {"follow": cfg.follow_config, "prediction": cfg.prediction,
            "drive": cfg.drive_config, "tracker": cfg.tracker_config, "nav": cfg.nav_config,
            "planner": cfg.planner_config, "clean": MapHandling()}


def set_notes(sets: Dict[str, Dict[str, str]]) -> List[str]:
    """One note per ``--set`` change, with the default it replaced."""
    now = shipped_sections()
    return ["%s.%s=%s: not the shipped default (%r)" % (s, k, v, getattr(now[s], k))
            for s, fields in sorted(sets.items()) for k, v in sorted(fields.items())]


def row(world: str, legs: int, seed: int, allow: bool = False, save: str = "",
        sets: Optional[Dict[str, Dict[str, str]]] = None) -> dict:
    t0 = time.time()
    last = [t0]

    def progress(line: str) -> None:
        # a progress line every 30 s of wall time, and every leg given up (with its reason)
        if time.time() - last[0] > 30.0 or any(" %s after " % o in line for o in OUTCOMES[1:]):
            last[0] = time.time()
            print("  %s: %s" % (world, line), file=sys.stderr, flush=True)

    r = run(eval_config(world, legs, seed, allow, sets or {}), progress)
    if save:   # the moments, for bench/calibrate_prediction.py and choose_prediction.py
        from choose_prediction import cache_path, save_moments

        save_moments(r, cache_path(save, world, legs, seed))
    tab = r.table()
    k = {f: FRACTIONS.index(f) for f in (0.25, 0.5, 0.75)}
    out = {"world": world_label(world), "seed": seed, "legs": len(r.legs),
           "given_up": r.failed_legs / max(1, len(r.legs) + r.failed_legs),
           "short": r.short_legs,
           "markov50": tab["tracker"]["markov"][k[0.5]][0],
           "heading50": tab["tracker"]["heading"][k[0.5]][0],
           "tracked": r.tracked_share, "rtf": r.rtf, "setup": r.setup_time,
           "notes": r.warnings,   # the observer's share of the run in each follower mode
           "modes": "/".join("%s:%.0f" % (m, 100.0 * n / max(1, r.ticks))
                             for m, n in sorted(r.follow_modes.items()))}
    # the predictor's least lead over the better baseline, from 25 % on, in both pipelines
    # log-loss (nats) at 50 % from tracker tracks, the prior's, and the predictor's least lead
    # in log-loss over the prior from 25 % on in both pipelines (> 0: below it everywhere)
    out["ll50"] = tab["tracker"]["predictor"][k[0.5]][1]
    out["markov_ll50"] = tab["tracker"]["markov"][k[0.5]][1]
    out["ll_margin"] = min(tab[p]["markov"][j][1] - tab[p]["predictor"][j][1]
                           for p in ("tracker", "ground_truth")
                           for j in range(FRACTIONS.index(0.25), len(FRACTIONS)))
    out["margin"] = min(tab[p]["predictor"][k][0] - max(tab[p]["markov"][k][0],
                                                        tab[p]["heading"][k][0])
                        for p in ("tracker", "ground_truth")
                        for k in range(FRACTIONS.index(0.25), len(FRACTIONS)))
    for f, name in ((0.25, "25"), (0.5, "50"), (0.75, "75")):
        out["trk" + name] = tab["tracker"]["predictor"][k[f]][0]
        out["gt" + name] = tab["ground_truth"]["predictor"][k[f]][0]
    return out


def _eval_line(r: dict, office: Optional[float]) -> str:
    """The EVAL line of one task's row (with its ratio to office's rtf when known)."""
    return ("EVAL world=%s seed=%d legs=%d given_up=%.3f trk25=%.3f trk50=%.3f trk75=%.3f "
            "gt25=%.3f gt50=%.3f gt75=%.3f markov50=%.3f heading50=%.3f margin=%.3f "
            "tracked=%.3f ll50=%.3f markov_ll50=%.3f ll_margin=%.3f modes=%s short=%d rtf=%.1f%s "
            "setup=%.0fs"
            % (r["world"], r["seed"], r["legs"], r["given_up"], r["trk25"], r["trk50"],
               r["trk75"], r["gt25"], r["gt50"], r["gt75"], r["markov50"], r["heading50"],
               r["margin"], r["tracked"], r["ll50"], r["markov_ll50"], r["ll_margin"],
               r["modes"], r["short"], r["rtf"],
               "" if office is None else " rtf_vs_office=%.2f" % (r["rtf"] / office),
               r["setup"]))


#: What a row holds that measures the machine, not the study (runs elsewhere differ in it).
TIMING = ("rtf", "setup")


def run_tasks(tasks: List[Tuple[str, int]], legs: int, allow: bool = False, save: str = "",
              workers: int = 1, ray_address: str = "",
              on_row: Optional[Callable[[dict], None]] = None,
              sets: Optional[Dict[str, Dict[str, str]]] = None) -> List[dict]:
    """The row of each (world, seed) task, in the order given: one after the other in this
    process (``workers`` 1), in ``workers`` processes, or as Ray tasks (``ray_address``:
    "local" starts Ray on this machine, else a cluster's address, e.g. "auto").
    ``on_row`` gets each row as its task ends (a ``done:`` line on stderr too); ``sets``
    changes the defaults (parse_sets)."""
    jobs = [(w, legs, seed, allow, save, sets or {}) for w, seed in tasks]

    def done(r: dict) -> dict:
        for n in r["notes"]:
            print("  note: %s" % n, file=sys.stderr)
        print("  done: %s" % _eval_line(r, None), file=sys.stderr, flush=True)
        if on_row is not None:
            on_row(r)
        return r

    if ray_address:
        return _on_ray(jobs, ray_address, done)
    if workers > 1 and len(jobs) > 1:
        return _on_processes(jobs, workers, done)
    rows = []
    for j in jobs:
        print("== %s: %d legs, seed %d" % (j[0], legs, j[2]), file=sys.stderr, flush=True)
        try:
            r = row(*j)
        except BulletFloorSimError as e:   # bad input met in a run (a world the simulator
            # refuses, a plan that fails): one line, as the worker processes give it
            sys.exit("eval_worlds: %s, seed %d: %s (the rows above were done)" % (j[0], j[2], e))
        rows.append(done(r))
    return rows


def _on_processes(jobs: list, workers: int, done: Callable[[dict], dict]) -> List[dict]:
    """``row`` of each job in a pool of ``workers`` processes (spawned: each loads its own
    simulator)."""
    import multiprocessing
    from concurrent.futures import ProcessPoolExecutor, as_completed

    out: List[Optional[dict]] = [None] * len(jobs)
    pool = ProcessPoolExecutor(max_workers=min(workers, len(jobs)),
                               mp_context=multiprocessing.get_context("spawn"))
    finished = False
    try:
        futures = {pool.submit(row, *j): k for k, j in enumerate(jobs)}
        for f in as_completed(futures):
            k = futures[f]
            try:
                r = f.result()
            except Exception as e:
                sys.exit("eval_worlds: %s, seed %d: %s (the tasks still running were stopped; "
                         "the rows above were done)" % (jobs[k][0], jobs[k][2], e))
            out[k] = done(r)
        finished = True
    finally:
        if not finished:   # an error or Ctrl-C: stop the other tasks rather than wait for them
            for proc in list((getattr(pool, "_processes", None) or {}).values()):
                proc.terminate()
        pool.shutdown(wait=finished, cancel_futures=True)
    return [r for r in out if r is not None]


def _on_ray(jobs: list, address: str, done: Callable[[dict], dict]) -> List[dict]:
    """``row`` of each job as a Ray task (one core each). The workers import the package and
    this script from this checkout's paths (PYTHONPATH): on a cluster, every node has the
    same checkout at the same path, set up with ``make setup`` (docs/evaluation.md)."""
    try:
        import ray
    except ImportError:
        sys.exit("eval_worlds: --ray needs the ray package (make setup installs it)")
    paths = [os.path.abspath(os.path.join(HERE, "..", "src")), HERE]
    env = {"PYTHONPATH": os.pathsep.join(paths + [os.environ.get("PYTHONPATH", "")])}
    try:
        ray.init(address=None if address == "local" else address, log_to_driver=True,
                 runtime_env={"env_vars": env}, include_dashboard=False)
    except (ConnectionError, RuntimeError) as e:
        sys.exit("eval_worlds: --ray %s: cannot reach the Ray cluster: %s" % (address, e))
    print("note: Ray at %s: %s CPUs" % (address, ray.cluster_resources().get("CPU", 0)),
          file=sys.stderr, flush=True)
    try:
        task = ray.remote(num_cpus=1)(row)
        refs = {task.remote(*j): k for k, j in enumerate(jobs)}
        out: List[Optional[dict]] = [None] * len(jobs)
        pending = list(refs)
        while pending:
            ready, pending = ray.wait(pending, num_returns=1)
            k = refs[ready[0]]
            try:
                r = ray.get(ready[0])
            except Exception as e:   # the task's error, or the worker or node lost
                sys.exit("eval_worlds: %s, seed %d: %s" % (jobs[k][0], jobs[k][2], e))
            out[k] = done(r)
    finally:
        ray.shutdown()
    return [r for r in out if r is not None]


def print_table(rows: List[dict]) -> None:
    """The markdown table of the rows, then their EVAL lines (office's rtf the reference)."""
    print("| " + " | ".join(COLUMNS) + " |")
    print("|" + "---|" * len(COLUMNS))
    office = next((r["rtf"] for r in rows if r["world"] == "office"), None)
    for r in rows:
        cells = [r["world"], "%d" % r["seed"], "%d" % r["legs"], "%.1f %%" % (100 * r["given_up"])]
        cells += ["%.1f %%" % (100 * r[c]) for c in COLUMNS[4:14]]
        cells += ["%.2f" % r[c] for c in COLUMNS[14:17]]
        cells.append("%.1fx" % r["rtf"])
        print("| " + " | ".join(cells) + " |")
    for r in rows:
        print(_eval_line(r, office))


def main() -> int:
    p = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    p.add_argument("--legs", type=int, default=200)
    p.add_argument("--seed", type=int, nargs="+", default=[1], help="one task per world and seed")
    p.add_argument("--worlds", nargs="*", default=None,
                   help="names under worlds/ or world.yaml paths (default: the buildings under "
                        "worlds/, then the corpus built: make corpus)")
    p.add_argument("--allow-unreachable", action="store_true",
                   help="run a world whose map check finds a region the walker cannot reach "
                        "or an observer cut off (check_world); the output says so")
    p.add_argument("--save", default="", metavar="DIR",
                   help="keep each run's moments there (bench/calibrate_prediction.py --cache)")
    p.add_argument("--workers", type=int, default=os.cpu_count() or 1,
                   help="tasks at a time on this machine (default: the cores; 1: one after "
                        "the other in this process, the real-time factors side by side)")
    p.add_argument("--ray", default="", metavar="ADDRESS",
                   help="run the tasks on Ray: 'local' (start it here), 'auto' (the cluster "
                        "ray start made) or ray://HOST:10001")
    p.add_argument("--results", default="", metavar="URI",
                   help="also store each row in this database (mongodb://HOST:PORT/ or a "
                        "directory of the embedded store), as it ends")
    p.add_argument("--show-results", default="", metavar="URI",
                   help="print the table of the rows stored there, and run nothing")
    p.add_argument("--set", action="append", default=[], metavar="SECTION.FIELD=VALUE",
                   help="run with this parameter changed from its shipped default (sections: "
                        "follow, the observer's FollowConfig; prediction, PredictionConfig; "
                        "drive, the observer's path following, FollowerConfig; tracker, "
                        "the people tracker's TrackerConfig as observer.launch sets it; nav, "
                        "both robots' NavigatorConfig, their roles as launched; planner, the "
                        "PlannerConfig of both robots' and the predictor's grid; clean, each "
                        "world's map handling, world.yaml's clean keys); "
                        "repeatable; the output says so (bench/choose_by_folds.py uses it)")
    args = p.parse_args()
    if args.show_results:
        return show_results(args.show_results)
    if args.workers < 1:
        p.error("--workers must be >= 1")
    try:
        sets = parse_sets(args.set)
    except BulletFloorSimError as e:
        p.error(str(e))
    if sets and (args.save or args.results):   # neither names the parameters a row ran with
        p.error("--save and --results keep the shipped defaults' runs (the moments' cache, "
                "the results table); not with --set")
    worlds, notes = checked(args.worlds or shipped(), bool(args.worlds),
                            args.allow_unreachable, sets)   # before any runs
    notes = set_notes(sets) + notes
    for n in notes:
        print("note: %s" % n, file=sys.stderr, flush=True)
    tasks = [(w, s) for w in worlds for s in args.seed]
    if args.ray or (args.workers > 1 and len(tasks) > 1):
        notes.append("the tasks ran %s: each rtf was measured beside other tasks (--workers 1 "
                     "measures them side by side, one at a time)"
                     % ("on Ray at %s" % args.ray if args.ray else "%d at a time" % args.workers))
    sink = ResultSink(args.results) if args.results else None
    try:
        rows = run_tasks(tasks, args.legs, args.allow_unreachable, args.save, args.workers,
                         args.ray, sink.add if sink else None, sets)
    finally:
        if sink:
            notes += sink.close()
    print_table(rows)
    for n in notes:
        print("note: %s" % n)
    return 0


if __name__ == "__main__":
    sys.exit(main())
