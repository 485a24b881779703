"""What ``paa-mj realaigym`` writes: the summary, their CSV of a run, and the charts their leaderboards draw."""
from __future__ import annotations

import numpy as np

from ..io import json_writer, write_set


def _csv_writer(T, X, U):
    """Their ``save_trajectory`` columns (time, pos_meas1.., vel_meas1.., tau_con1..) in their angles."""
    n = U.shape[1]
    header = ",".join(["time"] + [f"pos_meas{j + 1}" for j in range(n)] + [f"vel_meas{j + 1}" for j in range(n)]
                      + [f"tau_con{j + 1}" for j in range(n)])

    def write(path):
        np.savetxt(path, np.column_stack([T, X, U]), delimiter=",", header=header, comments="", fmt="%.17g")
    return write


def robustness_figure(summary):
    """Success against level for each criterion, one panel each (a row per model parameter), as their
    leaderboard's robustness plots show it."""
    from ..outputs.plots import new_figure

    criteria = summary["result"]["criteria"]
    rows = [(c, p, e) for c, entries in criteria.items() for p, e in entries.items()]
    fig, ax = new_figure(figsize=(8, 0.32 * len(rows) + 1.4))
    for i, (_criterion, _name, entry) in enumerate(rows):
        ok = np.array(entry["success"], bool)
        ax.scatter(np.arange(ok.size)[ok], np.full(ok.sum(), i), marker="s", s=28, color="C2")
        ax.scatter(np.arange(ok.size)[~ok], np.full((~ok).sum(), i), marker="s", s=28, color="C3")
    ax.set_yticks(range(len(rows)), [p if c == "model" else c for c, p, _ in rows], fontsize=7)
    ax.invert_yaxis()
    ax.set_xlabel("level (0 = their first; perturbation: run)")
    scores = summary["result"].get("scores", {})
    ax.set_title(f"{summary['robot']}, {summary['controller']}: robustness v2 (green: success)"
                 + (f", score {scores['overall']:.3f}" if scores else ""), fontsize=9)
    ax.grid(False)
    return fig


def global_figure(summary, T, height, up, threshold):
    """The tip's height over the global-policy test, the times counted as up (shaded), their threshold where the
    goal has one, and the reset times."""
    from ..outputs.plots import new_figure

    fig, ax = new_figure(figsize=(8, 3))
    ax.plot(T, height, lw=0.7, color="C0", label="tip height")
    ax.fill_between(T, 0, 1, where=up, color="C2", alpha=0.15, lw=0, transform=ax.get_xaxis_transform(),
                    label="up" if threshold is not None else "up (at the goal's pose)")
    if threshold is not None:
        ax.axhline(threshold, color="C2", lw=1, ls="--", label="up (their 0.9)")
    for t in summary["result"]["reset_times"]:
        ax.axvline(t, color="C3", lw=0.6, alpha=0.6)
    ax.set_xlabel("t [s]")
    ax.set_ylabel("height [m]")
    ax.set_title(f"{summary['robot']}, {summary['controller']}: global policy v3, time up"
                 f" {summary['result']['time_up']:.2f} s of 60 (red: resets)", fontsize=9)
    ax.legend(loc="lower right", fontsize=7)
    return fig


def write_realaigym(out_dir, summary, arrays):
    """realaigym.json (the summary), and per protocol: sim_swingup.csv (their columns), the robustness chart or the global test's
    chart (PNG, SVG), as one set."""
    from ..outputs.plots import figure_writers

    writers = {"realaigym.json": json_writer(summary)}
    if "T" in arrays:
        writers["sim_swingup.csv"] = _csv_writer(arrays["T"], arrays["X"], arrays["U"])
    if summary["protocol"] == "robustness-v2" and "scores" in summary["result"]:
        writers.update(figure_writers(robustness_figure(summary), "robustness_v2"))
    if summary["protocol"] == "global-v3":
        figure = global_figure(summary, arrays["T"], arrays["height"], arrays["up"], arrays["threshold"])
        writers.update(figure_writers(figure, "global_v3"))
    return write_set(out_dir, writers)
