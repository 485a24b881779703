"""The tables and the figure of ``paa-mj peers`` (:mod:`paa_mj.studies.peers`)."""
from __future__ import annotations

import numpy as np


def _e(value):
    return "-" if value is None else f"{value:.1e}"


def _t(value):
    return "never" if value is None else f"{value:.3f}"


def _t4(value):
    return "-" if value is None else f"{value:.4f}"


def _near(near):
    return "-" if near is None else f"{100 * near['relative_margin']:.2f} % at {near['t']:.3f} s"


def _split(split, pattern):
    return "none" if split is None else pattern.format(**split)


def _pair(values, fmt=_t):
    return f"{fmt(values['drake'])} / {fmt(values['paa_mj'])}"


def dynamics_table(rows) -> str:
    lines = ["| robot | links | M | H | G | P | qdd | largest, Drake vs MuJoCo | largest, MuJoCo vs analytic |",
             "|---|---|---|---|---|---|---|---|---|"]
    for row in rows:
        d = row["drake_vs_analytic"]
        h = d.get("H", d.get("H + G + D qd"))
        mj = row.get("drake_vs_mujoco")
        ma = row.get("mujoco_vs_analytic")
        lines.append(f"| {row['robot']} | {row['links']} | {_e(d['M'])} | {_e(h)} | {_e(d.get('G'))} | {_e(d['P'])}"
                     f" | {_e(d['qdd'])} | {_e(max(mj.values()) if mj else None)}"
                     f" | {_e(max(ma.values()) if ma else None)} |")
    return "\n".join(lines)


def held_table(loop) -> str:
    window = loop["window"]
    lines = [f"| start (theta1, theta2, theta1dot, theta2dot) | max angle difference, first {window:g} s [rad]"
             f" | max speed difference, first {window:g} s [rad/s] | first LQR [s], Drake / paa_mj"
             " | balanced from [s], Drake / paa_mj | same outcome | threshold crossings, Drake / paa_mj"
             " | nearest approach of the costs to the threshold | switch split |",
             "|---|---|---|---|---|---|---|---|---|"]
    for row in loop["starts"]:
        crossings = row["threshold_crossings"]
        near = row["closest_cost_to_threshold"]
        split = row["switch_split"]
        lines.append(
            f"| {row['start']} {tuple(row['theta0'])} | {_e(row['max_angle_difference'])}"
            f" | {_e(row['max_speed_difference'])} | {_pair(row['first_lqr'])} | {_pair(row['balanced_from'])}"
            f" | {'yes' if row['same_outcome'] else 'NO'}"
            f" | {crossings['drake']['count']} / {crossings['paa_mj']['count']}"
            f" | {_near(near)} | {_split(split, 'at {t:.3f} s, {kind} (costs {cost_drake:.6g} / {cost_paa:.6g}; states {state_difference:.1e} apart)')} |")
    return "\n".join(lines)


def no_hold_table(loop) -> str:
    window = loop["window"]
    lines = ["| start | MuJoCo dt [ms] | max difference before the first switch, angle [rad] / speed [rad/s]"
             f" (until [s]) | max difference, first {window:g} s, angle / speed | first LQR [s], Drake / paa_mj"
             " | first mode difference [s] (costs Drake / paa_mj) | balanced from [s], Drake / paa_mj"
             " | elbow leaves q2 = 0 [s], Drake / paa_mj |",
             "|---|---|---|---|---|---|---|---|"]
    for row in loop["starts"]:
        for case in row["no_hold"]:
            before = case["before_first_switch"]
            split = case["first_mode_difference"]
            leaves = case["elbow_leaves_zero"]
            lines.append(
                f"| {row['start']} | {1e3 * case['dt']:g} | {_e(before['max_angle_difference'])} /"
                f" {_e(before['max_speed_difference'])} ({before['until']:.3f}) | {_e(case['max_angle_difference'])}"
                f" / {_e(case['max_speed_difference'])} | {_pair(case['first_lqr'])}"
                f" | {_split(split, '{t:.4f}, {kind} ({cost_drake:.5g} / {cost_paa:.5g})')}"
                f" | {_pair(case['balanced_from'])} | {'-' if leaves is None else _pair(leaves, _t4)} |")
    return "\n".join(lines)


def peers_markdown(summary) -> str:
    """``peers.md``: the settings, the dynamics table and the two closed-loop tables."""
    settings = summary["settings"]
    loop = summary["closed_loop"]
    check = loop["integration_check"]
    ignored = sorted({item for row in summary["dynamics"] for item in row.get("ignored_by_drake", [])})
    steps = ", ".join(f"{dt} s: {value:.2e}" for dt, value in check["max_difference"].items())
    return "\n".join([
        f"# paa_mj {summary['paa_mj']} against Drake {summary['drake']}",
        "",
        "## Dynamics",
        "",
        f"Drake's MultibodyPlant loading paa_mj's MJCF files, against paa_mj's analytic model (columns M to qdd)"
        f" and MuJoCo, at {settings['samples']} random states (seed {settings['seed']}): largest relative"
        f" differences ({settings['relative_difference']}). The last row is Drake's own AcrobotPlant against"
        f" paa_mj's acrobot under {settings['map']} (its H column is H + G + D qd, Drake's DynamicsBiasTerm)."
        f" Drake's MJCF parser ignored: {', '.join(ignored) or 'nothing'}.",
        "",
        dynamics_table(summary["dynamics"]),
        "",
        "## Closed loop: Drake's AcrobotPlant + AcrobotSpongController against paa_mj's spong in MuJoCo",
        "",
        f"With a ZeroOrderHold of {1e3 * loop['dt']:g} ms between Drake's controller and plant (Drake:"
        f" {settings['drake_integrator']}; MuJoCo: {settings['mujoco_integrator']}, the torque held over each step),"
        f" over {loop['t_final']:g} s. The LQR acts where its cost-to-go is below {loop['threshold']:g} (no"
        " hysteresis; Drake's cost computed with the S of Drake's own LinearQuadraticRegulator). Balanced: every"
        " angle error and speed below 1e-3 to the end. A switch split is the first sample where one loop's LQR"
        " acts and the other's does not, with why: a near-tie of the costs at the threshold, a difference grown"
        " while the loops cross the threshold back and forth, or the wrap of theta2 to [-pi, pi): the cost-to-go"
        " is a quadratic form in the wrapped errors, so the set where the LQR acts meets theta2 = +-pi with the"
        " elbow folded back, and two states a hair apart on either side of it have costs orders of magnitude"
        " apart.",
        "",
        held_table(loop),
        "",
        f"LQR: S and K differ from Drake's by {loop['lqr']['S_relative_difference']:.1e} and"
        f" {loop['lqr']['K_relative_difference']:.1e} (relative). Integration check from {check['start']}: the largest"
        f" state difference over {loop['window']:g} s with both loops held at dt and dt / 2: {steps}.",
        "",
        "## Closed loop without the hold",
        "",
        "Drake's continuous loop (no hold) against MuJoCo at several time steps. Before the first switch to the"
        " LQR the difference is the hold's, O(dt), except from a start with the elbow straight and still"
        " (theta2 = theta2dot = 0): the swing-up law keeps it so (y = 0, u_e = 0) and that set is unstable, so"
        " the continuous loop leaves it on round-off and the held loop on the O(dt^2) error of its held torque,"
        " at times that do not converge with dt. After a switch, the loops split where their costs straddle the"
        " threshold.",
        "",
        no_hold_table(loop),
        "",
    ])


def peers_figure(summary):
    """Overlaid angles of the first start (Drake with the hold, and paa_mj), the state difference of every start
    on a log scale, and the difference before the first switch without the hold against MuJoCo's time step."""
    from .plots import LINESTYLES, MARKERS, new_figure

    loop = summary["closed_loop"]
    fig, axes = new_figure(3, 1, figsize=(7.0, 9.0))
    first = loop["starts"][0]
    series = first["series"]
    t = np.asarray(series["t"])
    q_drake, q_paa = np.asarray(series["q_drake"]), np.asarray(series["q_paa"])
    ax = axes[0]
    for k in range(2):
        ax.plot(t, q_drake[:, k], ls="-", color=f"C{k}", label=f"q$_{k + 1}$ Drake")
        ax.plot(t, q_paa[:, k], ls="--", color=f"C{k + 2}", marker=MARKERS[k], markevery=max(1, len(t) // 12),
                ms=3, label=f"q$_{k + 1}$ paa_mj")
    switch = first["first_lqr"]["drake"]
    if switch is not None:
        ax.axvline(switch, color="0.4", ls=":", lw=1)
    ax.set_xlabel("t [s]")
    ax.set_ylabel("angle [rad]")
    ax.set_title(f"start {first['start']} {tuple(first['theta0'])}: Drake (hold {1e3 * loop['dt']:g} ms) and paa_mj")
    ax.legend(loc="best", ncol=2)
    ax = axes[1]
    for i, row in enumerate(loop["starts"]):
        s = row["series"]
        diff = np.maximum(np.asarray(s["difference"]), 1e-17)
        ax.semilogy(s["t"], diff, ls=LINESTYLES[i % len(LINESTYLES)], label=row["start"])
        if row["switch_split"] is not None:
            ax.axvline(row["switch_split"]["t"], color=f"C{i}", ls=":", lw=1)
    ax.axhline(1e-5, color="0.3", lw=0.8, ls="--")
    ax.axvline(loop["window"], color="0.6", lw=0.8)
    ax.set_xlabel("t [s]")
    ax.set_ylabel("max abs difference [rad, rad/s]")
    ax.set_title("with the hold, every start (dashed: 1e-5; grey: the compared window)")
    ax.legend(loc="best", ncol=2)
    ax = axes[2]
    dts = []
    for i, row in enumerate(loop["starts"]):
        if not row["no_hold"]:
            continue
        dts = [1e3 * case["dt"] for case in row["no_hold"]]
        values = [max(case["before_first_switch"]["max_angle_difference"],
                      case["before_first_switch"]["max_speed_difference"]) for case in row["no_hold"]]
        ax.loglog(dts, np.maximum(values, 1e-17), ls=LINESTYLES[i % len(LINESTYLES)], marker=MARKERS[i % len(MARKERS)],
                  label=row["start"] + (" (elbow straight, at rest)" if row["no_hold"][0]["elbow_leaves_zero"] else ""))
    if dts:
        ax.set_xticks(dts, [f"{v:g}" for v in dts])
        ax.minorticks_off()
    ax.set_xlabel("MuJoCo time step [ms]")
    ax.set_ylabel("max abs difference\nbefore the first switch")
    ax.set_title("without the hold: Drake's continuous loop against paa_mj")
    ax.legend(loc="upper center", bbox_to_anchor=(0.5, -0.2), ncol=3, fontsize=7)
    fig.tight_layout()
    return fig


def write_peers(folder, summary):
    """``peers.json``, ``peers.md`` and ``peers_closed_loop.png``/``.svg`` into ``folder``, all or none."""
    from ..io import json_writer, write_set
    from .plots import figure_writers

    text = peers_markdown(summary)
    writers = {"peers.json": json_writer(summary), "peers.md": lambda path: path.write_text(text)}
    writers.update(figure_writers(peers_figure(summary), "peers_closed_loop"))
    write_set(folder, writers)
    return text
