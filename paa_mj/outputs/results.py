"""The files of a study: its data (NPZ, JSON), its figures (PNG, SVG) and, for the leaderboard, its Markdown.

Each study's files are written as one set (:func:`paa_mj.io.write_set`): all of them or none.
"""
from __future__ import annotations

import math

from ..io import json_writer, npz_writer, write_set


def write_basin(out_dir, summary, arrays):
    """basin.npz, summary.json and the basin figure (PNG, SVG) in ``out_dir``, as one set."""
    from .plots import basin_figure, figure_writers

    writers = {"basin.npz": npz_writer(**arrays), "summary.json": json_writer(summary)}
    writers.update(figure_writers(basin_figure(summary, arrays), "basin"))
    return write_set(out_dir, writers)

def write_robustness(out_dir, summary, arrays):
    """robustness.npz, summary.json and one bar chart per factor (PNG, SVG), as one set."""
    from .plots import figure_writers, robustness_figure

    writers = {"robustness.npz": npz_writer(**arrays), "summary.json": json_writer(summary)}
    for factor, data in summary["factors"].items():
        writers.update(figure_writers(robustness_figure(factor, data, summary), f"robustness_{factor}"))
    return write_set(out_dir, writers)

def _cell(value, fmt):
    return "-" if value is None or (isinstance(value, float) and math.isnan(value)) else format(value, fmt)


def leaderboard_markdown(summary, written=True) -> str:
    """``leaderboard.md``: controllers as rows, as RealAIGym lays its leaderboards out; ``written``: its last line
    points to the files that hold every number (False: a run without an output folder, which writes none)."""
    from ..control.registry import BUILTIN

    goal = summary.get("goal", "folded")
    limits = ", ".join(f"{v:.1f}" for v in summary["torque_limit"])
    peaks = ", ".join(f"\\|tau{k + 2}\\|" for k in range(len(summary["torque_limit"])))
    lines = [f"# Kip leaderboard: {summary['robot']}" + (f", {goal} goal" if goal != "folded" else ""), "",
             f"From the task's start in {summary['engine']}, {summary['t_final']:g} s, every controller under the"
             " torque limit"
             f" [{limits}] N m, in every run (reach included)."
             f" Success, in every column: {summary['success_definition']}. Robustness from the task's start:"
             f" {summary['trials']} independent"
             " draws per random factor, with a 95 % Wilson interval; one run per level of a swept deterministic factor,"
             " whose rate is the share of levels that succeed (no interval: nothing is drawn). Reach: the share of a"
             f" {summary['grid']} x {summary['grid']} grid of starts over (q1, q2) that succeed.", "",
             "## Performance", "",
             f"| controller | what | success | t_region [s] | t_balanced [s] | max {peaks} [N m] |"
             " int \\|tau\\|^2 dt [N^2 m^2 s] | work [J] | smoothness [N m/s] | max speed [rad/s] |",
             "|---|---|---|---|---|---|---|---|---|---|"]
    for name, row in summary["controllers"].items():
        what = BUILTIN[name][1] if name in BUILTIN else "user's controller"
        success = "yes" if row["success"] else f"no: {row['why']}"
        lines.append(f"| {name} | {what} | {success} | {_cell(row['t_region'], '.3f')} |"
                     f" {_cell(row['t_balanced'], '.3f')} | {', '.join(f'{v:.1f}' for v in row['max_tau'])} |"
                     f" {row['int_tau2']:.4g} | {row['work']:.4g} | {row['smoothness']:.4g} | {row['max_speed']:.2f} |")
    factors = list(summary["factors"])
    lines += ["", "## Robustness (success rate [95 % Wilson interval] over random draws; share of levels over sweeps)",
              "",
              "| controller | " + " | ".join(summary["factors"][f]["label"] for f in factors)
              + " | robustness score | reach |", "|---|" + "---|" * (len(factors) + 2)]
    for name, row in summary["controllers"].items():
        cells = []
        for f in factors:
            r = row["robustness"][f]
            cells.append(_rate_cell(r))
        lines.append(f"| {name} | " + " | ".join(cells) + f" | {_cell(row['robustness_score'], '.2f')} |"
                     f" {'-' if row['reach'] is None else format(100 * row['reach'], '.0f') + ' %'} |")
    if summary["versus_vcl"]:
        lines += ["", "## Against the paper's controller", ""]
        for name, ratio in summary["versus_vcl"].items():
            lines.append(f"- **{name}** balances in {_cell(ratio['t_balanced'], '.2g')} of vcl's time, with"
                         f" {_cell(ratio['int_tau2'], '.2g')} of its integral of |tau|^2 and {_cell(ratio['work'], '.2g')}"
                         " of its work.")
    lines += ["", "Robustness levels: " + "; ".join(f"{v['label']}" for v in summary["factors"].values()) + ".",
              "Peak torques applied over every run: " + "; ".join(
                  f"{name} {', '.join(f'{v:.1f}' for v in row['max_abs_tau'])} N m"
                  for name, row in summary["controllers"].items()) + ".",
              "Every number is in `leaderboard.json`; the runs are in `studies/`." if written else
              "Nothing was written: give --out DIR for leaderboard.json, the charts and the runs.", ""]
    return "\n".join(lines)


def _rate_cell(rate):
    if rate["rate"] is None:
        return "-"
    if not rate["random"]:
        return f"{100 * rate['rate']:.0f} % of {rate['trials']} levels"
    return f"{100 * rate['rate']:.0f} % [{100 * rate['low']:.0f}, {100 * rate['high']:.0f}] of {rate['trials']}"


def write_compare(out_dir, summary, trajectories, robot, video=False):
    """leaderboard.md, leaderboard.json, the charts (PNG, SVG), the trajectories and optionally the video."""
    from .plots import figure_writers, leaderboard_figure, overlay_figure

    from ..studies.compare import folder_name

    arrays = {f"{folder_name(name)}_{key}": value for name, traj in trajectories.items() for key, value in traj.items()}
    writers = {"leaderboard.md": lambda path: path.write_text(leaderboard_markdown(summary)),
               "leaderboard.json": json_writer(summary), "kips.npz": npz_writer(**arrays)}
    writers.update(figure_writers(leaderboard_figure(summary), "leaderboard"))
    writers.update(figure_writers(overlay_figure(trajectories, summary), "kips_overlaid"))
    write_set(out_dir, writers)
    if video:
        from .video import render_side_by_side

        render_side_by_side(robot, trajectories, f"{out_dir}/kips_side_by_side.mp4")

def write_atlas(out_dir, summary, arrays):
    """atlas.json, atlas.npz and the maps (PNG, SVG) as one set."""
    from .plots import atlas_outcome_figure, atlas_theory_figure, figure_writers

    writers = {"atlas.json": json_writer(summary), "atlas.npz": npz_writer(**arrays)}
    writers.update(figure_writers(atlas_theory_figure(summary, arrays), "atlas_theory"))
    if "outcome" in arrays:
        writers.update(figure_writers(atlas_outcome_figure(summary, arrays), "atlas_outcome"))
    return write_set(out_dir, writers)
