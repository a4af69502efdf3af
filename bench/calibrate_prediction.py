#!/usr/bin/env python3
"""Choose the predictor's calibration (temperature, prior_mix) across worlds, leaving the
scored world out, and show how calibrated it is.

Reuses bench/choose_prediction.py's recorded runs (the moments the predictor was asked at in
the evaluation, cached). For every moment of every world it computes the uncalibrated
posterior once (people/prediction, temperature 1, prior_mix 0) and the chain's prior; each
candidate (temperature, prior_mix) is then applied with prediction/calibration.calibrate, the
function the predictor itself calls. For each world the pair with the least mean log-loss on
the *other* worlds (fractions from 25 % on, both pipelines) is chosen and scored on it.
Prints per world and fraction the held-out log-loss beside the uncalibrated one and the
prior's, the Brier score and top-1, a line ``CALIBRATE folds=... chosen="..."``, and with
``--plot`` a reliability diagram (the top-1 probability against how often it was right).

With ``--heading`` it folds the heading baseline's ``heading_epsilon`` instead, the same way:
each candidate is set on the world's model and the run rescored
(people/evaluation.rescore, the scoring the study runs); for each world the value with the
least mean log-loss of the heading baseline on the *other* worlds is scored on it. Every
candidate is under 1/2, so the baseline's top-1 (its pick, which the study's bars compare
the predictor with) is the same for each, and only its log-loss moves.

    .venv/bin/python bench/calibrate_prediction.py --legs 100 --seed 2 --plot /tmp/rel.png
    .venv/bin/python bench/calibrate_prediction.py --legs 100 --seed 13 --heading
"""
from __future__ import annotations

import argparse
import itertools
import os
import sys

HERE = os.path.dirname(os.path.abspath(__file__))
sys.path.insert(0, os.path.join(HERE, "..", "src"))
sys.path.insert(0, HERE)

from bullet_floor_sim.people.evaluation import (FRACTIONS, PIPELINES, rescore,  # noqa: E402
                                              world_model)
from bullet_floor_sim.people.prediction import (PredictionConfig, log_loss,  # noqa: E402
                                                posterior_or_prior, top1)
from bullet_floor_sim.people.prediction.calibration import brier, calibrate  # noqa: E402
from bullet_floor_sim.sim.config import world_label  # noqa: E402
from choose_by_folds import leave_one_out  # noqa: E402
from choose_prediction import recorded  # noqa: E402
from eval_worlds import checked, shipped  # noqa: E402

GRID = {"temperature": (1.0, 1.5, 2.0, 3.0, 4.0, 6.0), "prior_mix": (0.0, 0.05, 0.1, 0.2, 0.3)}
SCORED = tuple(k for k, f in enumerate(FRACTIONS) if f >= 0.25)
#: heading_epsilon's candidates (--heading), each under 1/2: in a row of two regions the
#: baseline's pick keeps the larger share, so its top-1 does not move
EPSILONS = (0.05, 0.1, 0.2, 0.3, 0.4)


def moments(world: str, legs: int, seed: int, cache: str) -> list:
    """(pipeline, fraction index, raw posterior, prior, truth) of every moment with a
    prediction, the posterior uncalibrated."""
    run = recorded(world, legs, seed, cache)
    model = world_model(world, PredictionConfig(temperature=1.0, prior_mix=0.0))
    out = []
    for leg in run.legs:
        for p in PIPELINES:
            for k, m in enumerate(leg.moments[p]):
                if m is None:
                    continue
                r0, sx, sy, qx, qy = m[:5]
                raw, _ = posterior_or_prior(model, r0, (sx, sy), (qx, qy))
                out.append((p, k, raw, model.prior(r0), leg.target_region))
    return out


def scores(ms: list, t: float, eps: float) -> dict:
    """(pipeline, fraction index) -> (log-loss, prior's log-loss, Brier, top-1, n), and
    "all": the mean log-loss over the scored fractions."""
    acc = {}
    for p, k, raw, prior, truth in ms:
        q = calibrate(raw, prior, t, eps)
        a = acc.setdefault((p, k), [0.0, 0.0, 0.0, 0.0, 0])
        a[0] += log_loss(q, truth)
        a[1] += log_loss(prior, truth)
        a[2] += brier(q, truth)
        a[3] += top1(q) == truth
        a[4] += 1
    out = {key: tuple(v / max(1, a[4]) for v in a[:4]) + (a[4],) for key, a in acc.items()}
    scored = [out[key][0] for key in out if key[1] in SCORED]
    out["all"] = sum(scored) / max(1, len(scored))
    return out


def heading_scores(world: str, legs: int, seed: int, cache: str) -> dict:
    """heading_epsilon -> (the heading baseline's mean log-loss over the scored fractions and
    both pipelines, the prior's, its top-1 at 50 % from the tracker) on the world's run."""
    run = recorded(world, legs, seed, cache)
    model = world_model(world)
    half = FRACTIONS.index(0.5)
    out = {}
    for eps in EPSILONS:
        model.config.heading_epsilon = eps
        tab = rescore(run, model).table()
        cells = [(p, k) for p in PIPELINES for k in SCORED]
        out[eps] = (sum(tab[p]["heading"][k][1] for p, k in cells) / len(cells),
                    sum(tab[p]["markov"][k][1] for p, k in cells) / len(cells),
                    tab["tracker"]["heading"][half][0])
    return out


def fold_heading(worlds: list, args) -> None:
    """Leave each world out: the heading_epsilon with the least summed log-loss on the
    others (choose_by_folds.leave_one_out; a tie: the shipped value), scored on it; then a
    ``HEADING`` line."""
    shipped_eps = PredictionConfig.heading_epsilon
    table = {w: heading_scores(w, args.legs, args.seed, args.cache) for w in worlds}
    order = [shipped_eps] + [e for e in EPSILONS if e != shipped_eps]
    picks = leave_one_out({e: {w: -table[w][e][0] for w in worlds} for e in order}, worlds)
    print("| left out | chosen on the others | heading log-loss | at %g (shipped) | best on it "
          "| prior's | heading top-1 50 %% (tracker) |" % shipped_eps)
    print("|---|---|---|---|---|---|---|")
    for w in worlds:
        best = min(EPSILONS, key=lambda e: table[w][e][0])
        got = table[w][picks[w]]
        print("| %s | %g | %.3f | %.3f | %g (%.3f) | %.3f | %.1f %% |" % (
            world_label(w), picks[w], got[0], table[w][shipped_eps][0], best,
            table[w][best][0], got[1], 100 * got[2]))
    votes = {e: sum(1 for w in worlds if picks[w] == e) for e in order}
    chosen = max(order, key=lambda e: (votes[e], -order.index(e)))
    print("\nHEADING folds=%d chosen=\"heading_epsilon=%g\" votes=\"%s\" held_out_ll=%.3f "
          "shipped_ll=%.3f" % (len(worlds), chosen, " ".join(
              "%g:%d" % (e, votes[e]) for e in EPSILONS if votes[e]),
              sum(table[w][picks[w]][0] for w in worlds) / len(worlds),
              sum(table[w][shipped_eps][0] for w in worlds) / len(worlds)))


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--legs", type=int, default=100)
    ap.add_argument("--seed", type=int, default=2)
    ap.add_argument("--worlds", nargs="*", default=None,
                    help="names or world.yaml paths (default: every shipped world)")
    ap.add_argument("--cache", default=os.path.join(os.environ.get("ROS_HOME", os.path.expanduser(
        "~/.ros")), "bullet_floor_sim", "choose_prediction"))
    ap.add_argument("--plot", help="reliability diagram PNG")
    ap.add_argument("--heading", action="store_true",
                    help="fold the heading baseline's heading_epsilon on its log-loss instead")
    args = ap.parse_args()
    # of the default list, a world the map check refuses is left out with a line saying so
    worlds, notes = checked(args.worlds or shipped(), bool(args.worlds), False)
    for line in notes:
        print("note: %s" % line, file=sys.stderr)
    if args.heading:
        fold_heading(worlds, args)
        return 0
    data = {w: moments(w, args.legs, args.seed, args.cache) for w in worlds}
    cands = list(itertools.product(GRID["temperature"], GRID["prior_mix"]))
    table = {(c, w): scores(data[w], *c) for c in cands for w in worlds}
    picks = {}
    print("| left out | chosen on the others (T, mix) | fraction | pipeline | log-loss | "
          "uncalibrated | prior | Brier | top-1 | moments |")
    print("|---|---|---|---|---|---|---|---|---|---|")
    for w in worlds:
        others = [o for o in worlds if o != w] or [w]
        best = min(cands, key=lambda c: sum(table[c, o]["all"] for o in others))
        picks[w] = best
        got, raw = table[best, w], table[(1.0, 0.0), w]
        for k in SCORED:
            for p in PIPELINES:
                if (p, k) not in got:
                    continue
                ll, pl, br, t1, n = got[p, k]
                print("| %s | %g, %g | %d %% | %s | %.3f | %.3f | %.3f | %.3f | %.1f %% | %d |"
                      % (world_label(w), best[0], best[1], round(100 * FRACTIONS[k]), p, ll,
                         raw[p, k][0], pl, br, 100 * t1, n))
    below = all(table[picks[w], w][p, k][0] < table[picks[w], w][p, k][1]
                for w in worlds for p in PIPELINES for k in SCORED if (p, k) in table[picks[w], w])
    votes = {c: sum(1 for w in worlds if picks[w] == c) for c in cands}
    chosen = max(cands, key=lambda c: (votes[c], -sum(table[c, w]["all"] for w in worlds)))
    print("\nCALIBRATE folds=%d chosen=\"temperature=%g prior_mix=%g\" held_out_below_prior=%s"
          % (len(worlds), chosen[0], chosen[1], below))
    if args.plot:
        reliability(data, picks, args.plot)
        print("plot: %s" % args.plot)
    return 0


def reliability(data: dict, picks: dict, path: str) -> None:
    """Top-1 probability (10 bins) against the share right, uncalibrated and held-out
    calibrated, all worlds and fractions from 25 % pooled."""
    from bullet_floor_sim.people.plotting import pyplot, save_figure

    plt = pyplot("--plot")
    fig, ax = plt.subplots(figsize=(5.5, 5.0))
    for label, pick in (("uncalibrated", lambda w: (1.0, 0.0)),
                        ("calibrated (held out)", lambda w: picks[w])):
        bins = [[0, 0] for _ in range(10)]
        for w, ms in data.items():
            t, eps = pick(w)
            for _, k, raw, prior, truth in ms:
                if k not in SCORED:
                    continue
                q = calibrate(raw, prior, t, eps)
                g = top1(q)
                b = min(9, int(q[g] * 10))
                bins[b][0] += 1
                bins[b][1] += g == truth
        xs = [(i + 0.5) / 10 for i in range(10) if bins[i][0]]
        ys = [bins[i][1] / bins[i][0] for i in range(10) if bins[i][0]]
        ax.plot(xs, ys, marker="o", label=label)
    ax.plot([0, 1], [0, 1], "k--", lw=0.8, label="perfect")
    ax.set_xlabel("top-1 probability")
    ax.set_ylabel("share right")
    ax.legend()
    save_figure(plt, fig, path, "destination predictor: reliability")


if __name__ == "__main__":
    sys.exit(main())
