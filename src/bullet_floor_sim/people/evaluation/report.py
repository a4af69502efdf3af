"""The evaluation's result as text (:func:`format_table`) and as a plot (:func:`plot`)."""
from __future__ import annotations

from ..plotting import pyplot
from .result import FRACTIONS, LEG_KINDS, METHODS, PIPELINES, EvalResult

__all__ = ["format_table", "plot"]


def format_table(result: EvalResult) -> str:
    """The result as text: one block per pipeline, accuracy and log-loss per fraction."""
    lines = ["note: %s" % w for w in result.warnings]
    head = "%-12s" % "method" + "".join("   %3d%% acc  logloss" % round(100 * f)
                                        for f in FRACTIONS)
    what = {"change": "legs to another region", "stay": "legs within the start region"}
    tables = {kind: result.table(kind) for kind in LEG_KINDS}
    for p in PIPELINES:
        cov = result.coverage(p)
        lines.append("== %s tracks (%d legs; legs with a prediction: %s)" % (
            p.replace("_", "-"), len(result.legs),
            " ".join("%.0f%%" % (100 * c) for c in cov)))
        lines.append(head)
        for kind in LEG_KINDS:
            tab = tables[kind]
            if kind != "all":
                lines.append("-- %s (%d legs)" % (what[kind], len(result.legs_of(kind))))
            for m in METHODS:
                lines.append("%-12s" % m + "".join("   %7.1f%% %8.3f" % (100 * a, ll)
                                                  for a, ll, _ in tab[p][m]))
    r = result
    lines.append("tracking: recall while visible %.1f%% (%d of %d ticks), walker tracked %.1f%% "
                 "of the run, mean track error %.3f m, target id switches %d (predictor "
                 "hand-overs %d), ticks with a false track %d"
                 % (100 * r.recall, r.recalled_ticks, r.visible_ticks, 100 * r.tracked_share,
                    r.mean_track_error, r.id_switches, r.handovers, r.false_track_ticks))
    lines.append("run: %d legs scored, %d failed, %d too short to score, %.0f s sim in %.0f s "
                 "wall (%.0f s of it setup; %.1fx real time after it); follower modes %s"
                 % (len(r.legs), r.failed_legs, r.short_legs, r.sim_time, r.wall_time,
                    r.setup_time, r.rtf,
                                        ", ".join("%s %.0f%%" % (k, 100.0 * v / max(1, r.ticks))
                                                  for k, v in sorted(r.follow_modes.items()))))
    return "\n".join(lines)


def plot(result: EvalResult, path: str) -> None:
    """Accuracy vs fraction observed, one line per method and pipeline, as a PNG."""
    plt = pyplot("evaluate_prediction --plot")

    tab = result.table()
    fig, ax = plt.subplots(figsize=(7, 4.5), dpi=100)
    xs = [100 * f for f in FRACTIONS]
    colours = {"predictor": "tab:blue", "markov": "tab:grey", "heading": "tab:orange"}
    for p, style in (("tracker", "-"), ("ground_truth", "--")):
        for m in METHODS:
            ax.plot(xs, [100 * a for a, _, _ in tab[p][m]], style, marker="o",
                    color=colours[m], label="%s (%s tracks)" % (m, p.replace("_", "-")))
    ax.set_xlabel("% of the leg observed")
    ax.set_ylabel("top-1 destination accuracy (%)")
    ax.set_ylim(0, 100)
    ax.set_title("Destination prediction, %s world, %d legs, seed %d" % (
        result.config.world, len(result.legs), result.config.seed))
    ax.grid(True, alpha=0.3)
    ax.legend(fontsize=8, loc="lower right")
    fig.tight_layout()
    fig.savefig(path)
    plt.close(fig)
