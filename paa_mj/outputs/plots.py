"""Figures: the paper's redrawn, and those of the studies, in one shared style.

Every figure is written as PNG (200 dpi) and SVG beside it, byte-identical
from run to run (no dates, fixed SVG ids). Lines that may overlap get distinct
line styles and markers, so that none hides another.
"""
from __future__ import annotations

import sys

import matplotlib

if "ipykernel" not in sys.modules:  # files only, no windows; a notebook keeps its inline backend
    matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402

from ..io import write_set  # noqa: E402

DPI = 200
STYLE = {
    "figure.dpi": 100, "savefig.dpi": DPI, "font.size": 9, "axes.titlesize": 10, "axes.labelsize": 9,
    "legend.fontsize": 8, "axes.grid": True, "grid.alpha": 0.3, "axes.spines.top": False,
    "axes.spines.right": False, "lines.linewidth": 1.4, "svg.hashsalt": "paa_mj", "svg.fonttype": "none",
    "axes.prop_cycle": matplotlib.cycler(color=["#0072B2", "#D55E00", "#009E73", "#CC79A7", "#E69F00", "#56B4E9",
                                               "#000000"]),
}
#: Line styles and markers in turn, for curves that may lie on top of each other.
LINESTYLES = ["-", "--", ":", "-."]
MARKERS = ["o", "s", "^", "D", "v", "P", "X"]
#: Outcome colours of the basin (success, switched with no success, stuck at DUU, never switched, diverged).
OUTCOME_COLOURS = ["#009E73", "#E69F00", "#CC79A7", "#999999", "#D55E00"]


#: Maps of more cells than this are drawn as one image in their SVG (as in their PNG), not a path per cell: a
#: 1024 x 1024 basin would otherwise take minutes and hundreds of megabytes to write.
RASTER_CELLS = 128 * 128


def cell_map(ax, xs, ys, values, **kwargs):
    """``ax.pcolormesh`` of ``values`` on the cell centres ``xs``, ``ys`` (the mesh, for a colour bar)."""
    return ax.pcolormesh(xs, ys, values, shading="nearest", rasterized=np.size(xs) * np.size(ys) > RASTER_CELLS,
                         **kwargs)


def new_figure(*args, **kwargs):
    """``plt.subplots`` in the package's style."""
    with plt.rc_context(STYLE):
        return plt.subplots(*args, **kwargs)


def _save(fig, path, fmt, box="tight"):
    with plt.rc_context(STYLE):
        fig.savefig(path, format=fmt, dpi=DPI, bbox_inches=box,
                    metadata={"Date": None} if fmt == "svg" else {"Software": None})


def figure_writers(fig, stem) -> dict:
    """Writers (for :func:`paa_mj.io.write_set`) of ``stem.png`` and ``stem.svg``; the figure is closed after.

    The PNG is laid out and cut to its tight box as ``bbox_inches="tight"`` does. The SVG keeps that layout and
    cuts to the same drawing's tight box, instead of laying the figure out again with its own renderer: the
    layout is about a third of the cost of writing the two files.
    """
    laid_out = []

    def png(path):
        _save(fig, path, "png")
        laid_out.append(True)

    def svg(path):
        with plt.rc_context(STYLE):
            if fig.get_layout_engine() is not None:
                if not laid_out:
                    fig.draw_without_rendering()  # the layout engine runs once, here
                fig.set_layout_engine(None)  # keeps the positions it set
            box = fig.get_tightbbox().padded(plt.rcParams["savefig.pad_inches"])
        _save(fig, path, "svg", box)
        plt.close(fig)

    return {f"{stem}.png": png, f"{stem}.svg": svg}


def save_figure(fig, folder, stem):
    """Write ``stem.png`` and ``stem.svg`` into ``folder`` (both or neither)."""
    write_set(folder, figure_writers(fig, stem))
    return folder


def _mark_switch(ax, traj):
    if traj.switch_time is not None:
        ax.axvline(traj.switch_time, color="0.4", ls="--", lw=1)
        ax.text(traj.switch_time, 1.0, f" switch {traj.switch_time:.2f} s", transform=ax.get_xaxis_transform(),
                va="top", fontsize=8, color="0.3")


def f54_figure(am, title):
    """Figs. 5 and 11: f(z) of (54) on [0, 2 pi].

    The y axis is fitted to f itself (so that its variation shows); the forbidden
    level f = 1 is drawn when it lies in view, otherwise its side is named.
    """
    from ..theory.conditions import f54

    z = np.linspace(0, 2 * np.pi, 2001)
    f = f54(am, z)
    fig, ax = new_figure(figsize=(6, 3.5))
    ax.plot(z, f, label="f(z)")
    low, high = float(np.min(f)), float(np.max(f))
    pad = 0.08 * (high - low) if high > low else 0.05 * max(abs(high), 1e-3)
    ax.set_ylim(low - pad, high + pad)
    if low - pad <= 1.0 <= high + pad:
        ax.axhline(1.0, color="C1", ls="--", lw=1, label="f = 1 (forbidden)")
    else:
        ax.text(0.99, 0.95 if high < 1 else 0.05, f"f = 1 (forbidden) lies {'above' if high < 1 else 'below'}",
                transform=ax.transAxes, ha="right", va="top" if high < 1 else "bottom", fontsize=8, color="C1")
    ax.set_xlabel("z [rad]")
    ax.set_ylabel("f(z) [-]")
    ax.set_xlim(0, 2 * np.pi)
    ax.set_title(title)
    ax.legend(loc="center right")
    return fig


def energy_figure(traj, title):
    """Figs. 6 and 12: V and E - E_r against t."""
    fig, axes = new_figure(2, 1, figsize=(7, 5), sharex=True)
    axes[0].plot(traj.t, traj.V)
    axes[0].set_ylabel("V [J$^2$]")
    axes[0].set_yscale("symlog", linthresh=1.0)
    axes[1].plot(traj.t, traj.E_minus_Er, color="C1")
    axes[1].set_ylabel("E - E$_r$ [J]")
    axes[1].set_xlabel("t [s]")
    for ax in axes:
        _mark_switch(ax, traj)
    axes[0].set_title(title)
    return fig


def series_figure(traj, series, ylabel, title):
    """Several curves against t on one axis, with the switch marked."""
    fig, ax = new_figure(figsize=(7, 3.8))
    for i, (values, label) in enumerate(series):
        ax.plot(traj.t, values, ls=LINESTYLES[i % len(LINESTYLES)], label=label)
    ax.set_xlabel("t [s]")
    ax.set_ylabel(ylabel)
    ax.set_title(title)
    ax.legend(loc="best")
    _mark_switch(ax, traj)
    return fig


def angles_figure(traj, title):
    """Figs. 7, 9 and 13: q1, q2 + pi, q3 against t (for any chain, each angle from its goal: q_k, or q_k + pi where
    the goal has link k folded down)."""
    goal = traj.task.goal
    series = [(traj.q[:, k] + np.pi, f"q$_{k + 1}$ + $\\pi$") if goal[k] == -np.pi else (traj.q[:, k], f"q$_{k + 1}$")
              for k in range(traj.n_links)]
    return series_figure(traj, series, "angle [rad]", title)


def torques_figure(traj, title):
    """Figs. 8, 10 and 14: tau2, tau3 against t (the gymnast's shoulders and hips; tau2..tau_n for a chain)."""
    joints = traj.driven_joints
    names = {2: " (shoulder)", 3: " (hip)"} if traj.n_links == 3 else {}
    series = [(traj.tau[:, k], f"$\\tau_{j}${names.get(j, '')}") for k, j in enumerate(joints)]
    return series_figure(traj, series, "torque [N m]", title)


def discretisation_figure(rows):
    """First switch time for each integrator and time step, with the analytic reference."""
    fig, ax = new_figure(figsize=(7, 3.8))
    names = sorted({r["integrator"] for r in rows if r["engine"] == "mujoco"})
    for i, name in enumerate(names):
        sub = [r for r in rows if r["engine"] == "mujoco" and r["integrator"] == name]
        dts = [r["dt"] * 1e3 for r in sub]
        times = [r["switch_time"] if r["switch_time"] is not None else np.nan for r in sub]
        ax.plot(dts, times, ls=LINESTYLES[i % len(LINESTYLES)], marker=MARKERS[i % len(MARKERS)],
                ms=7 - 1.5 * i, mfc="none" if i % 2 else None, color=f"C{i}", label=f"MuJoCo {name}")
        for r, dt in zip(sub, dts):
            if r["switch_time"] is None:
                ax.plot(dt, 0, "x", color=f"C{i}", ms=9)
    for r in rows:
        if r["engine"] == "analytic" and r["switch_time"] is not None:
            ax.axhline(r["switch_time"], color="k", ls=":", label="analytic, continuous control")
    ax.set_xscale("log")
    ax.set_xlabel("time step [ms]")
    ax.set_ylabel("first switch time [s]")
    ax.set_title("Switch time (68) against discretisation (x: never switched)")
    ax.legend(loc="best")
    ax.grid(True, which="both", alpha=0.3)
    return fig


def basin_figure(summary, arrays):
    """The basin: how each start ended (left) beside the first switch time (right)."""
    from matplotlib.colors import BoundaryNorm, ListedColormap

    from ..studies.basin import OUTCOME_NAMES

    grid = summary["grid"]
    xs, ys = arrays["x_values"], arrays["y_values"]
    outcome = np.where(arrays["completed"], arrays["outcome"], -1).reshape(grid, grid).astype(float)
    switch = arrays["switch_time"].reshape(grid, grid)
    fig, (left, right) = new_figure(1, 2, figsize=(11, 4.6), constrained_layout=True)
    cmap = ListedColormap(OUTCOME_COLOURS).with_extremes(bad="white")
    norm = BoundaryNorm(np.arange(-0.5, len(OUTCOME_NAMES) + 0.5), cmap.N)
    cell_map(left, xs, ys, np.ma.masked_less(outcome, 0).T, cmap=cmap, norm=norm)
    counts = summary.get("outcomes", {})
    handles = [plt.Rectangle((0, 0), 1, 1, color=c) for c in OUTCOME_COLOURS]
    left.legend(handles, [f"{n} ({counts.get(n, 0)})" for n in OUTCOME_NAMES], loc="upper center",
                bbox_to_anchor=(0.5, -0.14), ncol=2, fontsize=7, frameon=False)
    cmap2 = matplotlib.colormaps["viridis"].with_extremes(bad="0.85")
    mesh = cell_map(right, xs, ys, np.ma.masked_invalid(switch).T, cmap=cmap2)
    fig.colorbar(mesh, ax=right, label="first switch to the balance controller [s] (grey: never)")
    a, b = summary["axes"]
    unit = lambda name: "[rad]" if name.startswith("q") else "[rad/s]"  # noqa: E731
    for ax in (left, right):
        ax.set_xlabel(f"{a} {unit(a)}")
        ax.set_ylabel(f"{b} {unit(b)}")
        ax.grid(False)
    left.set_title(f"{summary['robot']}, {summary.get('controller', 'vcl')}: outcome, "
                   f"{100 * summary['success']:.0f} % success")
    right.set_title(f"first switch time, {summary['cells']} starts, {summary['t_final']:g} s")
    return fig


def _bound(value, rate):
    """An interval bound in percent; a rate without an interval (a deterministic run) is its own bound."""
    chosen = rate if value is None else value
    return np.nan if chosen is None else 100 * chosen


def robustness_figure(factor, data, summary):
    """Success rate against the levels of one factor, with 95 % Wilson intervals."""
    levels = data["levels"]
    labels = ["none" if lv["level"] is None else f"{lv['level']:g}" for lv in levels]
    rates = np.array([np.nan if lv["success_rate"] is None else 100 * lv["success_rate"] for lv in levels])
    low = np.array([_bound(lv.get("low"), lv["success_rate"]) for lv in levels])
    high = np.array([_bound(lv.get("high"), lv["success_rate"]) for lv in levels])
    fig, ax = new_figure(figsize=(5.5, 3.6))
    x = np.arange(len(labels))
    ax.bar(x, rates, color="C0", yerr=[np.clip(np.nan_to_num(rates - low), 0, None),
                                       np.clip(np.nan_to_num(high - rates), 0, None)], capsize=4,
           error_kw={"elinewidth": 1, "ecolor": "0.25"})
    for i, r in enumerate(rates):
        if np.isfinite(r):
            ax.text(i, min(high[i], 100) + 2, f"{r:.0f} %", ha="center", fontsize=8)
    ax.set_xticks(x, labels)
    ax.set_ylim(0, 112)
    ax.set_xlabel(data["label"])
    ax.set_ylabel("success [%] (95 % interval over random draws)")
    runs = sorted({lv["trials"] for lv in levels})
    ax.set_title(f"{summary['robot']}, {summary.get('controller', 'vcl')}: {factor},"
                 f" {'/'.join(map(str, runs))} run(s) per level")
    ax.grid(True, axis="y", alpha=0.3)
    ax.grid(False, axis="x")
    return fig


def sensitivity_figure(rows, t_exact, t_nominal, t_paper):
    """Histograms of the first switch time under perturbations of (65), one panel per size."""
    fig, axes = new_figure(len(rows), 1, figsize=(7, 1.9 * len(rows) + 0.6), sharex=True, squeeze=False)
    times_all = [t for row in rows for t in row["times"] if t is not None]
    low = min(times_all + [t_exact, t_paper]) - 0.5
    high = max(times_all + [t_exact, t_paper]) + 0.5
    bins = np.linspace(low, high, 80)
    for ax, row in zip(axes[:, 0], rows):
        times = np.array([t for t in row["times"] if t is not None])
        ax.hist(times, bins=bins, color="C0", alpha=0.85)
        never = row["n"] - len(times)
        ax.set_ylabel("runs")
        ax.set_title(f"(65) perturbed by {row['perturbation']:g} rad: {row['n']} runs"
                     + (f", {never} never switched" if never else ""), fontsize=9)
        for t, style, label in ((t_exact, "-", "exact closed loop"), (t_nominal, "--", "MuJoCo RK4 1 ms from (65)"),
                                (t_paper, ":", "the paper")):
            if t is not None:
                ax.axvline(t, color="k", ls=style, lw=1, label=label)
    axes[0, 0].legend(loc="upper left", fontsize=7)
    axes[-1, 0].set_xlabel("first switch time [s]")
    return fig


def leaderboard_figure(summary):
    """Robustness per factor (bars with 95 % intervals) and the performance metrics relative to the best."""
    names = list(summary["controllers"])
    factors = list(summary["factors"])
    fig, (top, bottom) = new_figure(2, 1, figsize=(9, 7.5), constrained_layout=True)
    width = 0.8 / max(1, len(names))
    x = np.arange(len(factors))
    for i, name in enumerate(names):
        rob = summary["controllers"][name]["robustness"]
        rates = np.array([np.nan if rob[f]["rate"] is None else 100 * rob[f]["rate"] for f in factors])
        low = np.array([_bound(rob[f]["low"], rob[f]["rate"]) for f in factors])
        high = np.array([_bound(rob[f]["high"], rob[f]["rate"]) for f in factors])
        top.bar(x + (i - (len(names) - 1) / 2) * width, rates, width, label=name, color=f"C{i}",
                yerr=[np.clip(np.nan_to_num(rates - low), 0, None), np.clip(np.nan_to_num(high - rates), 0, None)],
                capsize=2,
                error_kw={"elinewidth": 0.8, "ecolor": "0.3"}, hatch=["", "//", "..", "xx", "\\\\", "++"][i % 6])
    top.set_xticks(x, [summary["factors"][f]["label"] for f in factors], fontsize=8)
    top.set_ylim(0, 110)
    top.set_ylabel("success [%] (95 % interval over random draws)")
    top.set_title(f"{summary['robot']}: robustness from (65), {summary['trials']} draws per random factor,"
                  " share of levels per sweep")
    top.legend(ncol=len(names), fontsize=8, loc="lower right", bbox_to_anchor=(1.0, 1.06), frameon=False)
    metrics = [("t_balanced", "time to balance"), ("int_tau2", "int |tau|^2 dt"), ("work", "work"),
               ("smoothness", "torque change"), ("max_speed", "peak speed")]
    x = np.arange(len(metrics))
    for i, name in enumerate(names):
        row = summary["controllers"][name]
        values = []
        for key, _ in metrics:
            column = [summary["controllers"][n][key] for n in names if summary["controllers"][n][key] is not None]
            best = min(column) if column else None
            values.append(np.nan if row[key] is None or not best else row[key] / best)
        bottom.bar(x + (i - (len(names) - 1) / 2) * width, values, width, label=name, color=f"C{i}",
                   hatch=["", "//", "..", "xx", "\\\\", "++"][i % 6])
    bottom.set_yscale("log")
    bottom.set_xticks(x, [label for _, label in metrics], fontsize=8)
    bottom.set_ylabel("relative to the best (1 = best)")
    bottom.set_title("performance of the kip from (65) (lower is better; missing: did not balance)")
    return fig


def overlay_figure(trajectories, summary):
    """All controllers' angles (from the goal: q1, q2 + pi, q3 for the gymnast's UDD) and torques against time."""
    from ..task import Task

    names = list(trajectories)
    n = next(iter(trajectories.values()))["q"].shape[1]
    goal = Task.from_description(summary["task"], n).goal
    fig, axes = new_figure(2 * n - 1, 1, figsize=(8, 10 * (2 * n - 1) / 5), sharex=True, constrained_layout=True)
    labels = [f"q$_{k + 1}$ + $\\pi$ [rad]" if goal[k] == -np.pi else f"q$_{k + 1}$ [rad]" for k in range(n)]
    labels += [f"$\\tau_{k + 2}$ [N m]" for k in range(n - 1)]
    for i, name in enumerate(names):
        traj = trajectories[name]
        series = [traj["q"][:, k] - goal[k] if goal[k] else traj["q"][:, k] for k in range(n)]
        series += [traj["tau"][:, k] for k in range(n - 1)]
        for ax, values in zip(axes, series):
            ax.plot(traj["t"], values, color=f"C{i}", ls=LINESTYLES[i % len(LINESTYLES)], lw=1.2, label=name)
    for ax, label in zip(axes, labels):
        ax.set_ylabel(label)
    axes[0].legend(ncol=len(names), fontsize=8, loc="upper right")
    axes[0].set_title(f"{summary['robot']}: the kips from (65), torque limit"
                      f" [{', '.join(f'{v:.0f}' for v in summary['torque_limit'])}] N m")
    axes[-1].set_xlabel("t [s]")
    return fig


def _atlas_axes(ax, summary, arrays, field_for_boundary=True):
    """Log axes of the two factors, the (54) boundary and the base robot."""
    from matplotlib.ticker import FixedLocator, NullLocator, ScalarFormatter

    f1, f2 = arrays["factors_1"], arrays["factors_2"]
    ax.set_xscale("log")
    ax.set_yscale("log")
    for axis, values in ((ax.xaxis, f1), (ax.yaxis, f2)):
        ticks = [t for t in (0.125, 0.25, 0.5, 1, 2, 4, 8, 16) if values.min() <= t <= values.max()]
        axis.set_major_locator(FixedLocator(ticks))
        axis.set_major_formatter(ScalarFormatter())
        axis.set_minor_locator(NullLocator())
    ax.set_xlabel(f"{summary['vary'][0]} factor")
    ax.set_ylabel(f"{summary['vary'][1]} factor")
    ax.grid(False)
    shape = (len(f1), len(f2))
    holds = arrays["holds_54"].reshape(shape).astype(float)
    if field_for_boundary and 0 < holds.mean() < 1:
        ax.contour(f1, f2, holds.T, levels=[0.5], colors="k", linewidths=1.2, linestyles="--")
    E_r = arrays["E_r"].reshape(shape)
    if np.nanmin(E_r) < 0 < np.nanmax(E_r):
        ax.contour(f1, f2, E_r.T, levels=[0.0], colors="0.2", linewidths=1.0, linestyles=":")
    if f1.min() <= 1 <= f1.max() and f2.min() <= 1 <= f2.max():
        ax.plot([1.0], [1.0], marker="*", ms=12, color="white", markeredgecolor="k", ls="none")


def atlas_theory_figure(summary, arrays):
    """Maps of the theory over the family: E_r, (54), deltabar, controllability, kD_min, eta1, eta2, Theorem 1;
    beyond Theorem 1 (other chains, the stretched goal), what is defined there."""
    f1, f2 = arrays["factors_1"], arrays["factors_2"]
    shape = (len(f1), len(f2))
    covered = summary.get("theorem1_covers", True)
    if covered:
        panels = [("E_r", "E_r [J]", "RdBu", True), ("holds_54", "(54) holds", "Greens", False),
                  ("deltabar_min", "min deltabar (30)", "RdBu", True),
                  ("udd_controllable", "UDD controllable", "Greens", False),
                  ("theorem1", "Theorem 1 applies", "Greens", False), ("kD_min", "kD_min (41)", "viridis", False),
                  ("eta1", "eta1 (59)", "viridis", False), ("eta2", "eta2 (60)", "viridis", False),
                  ("duu_growth", "growth rate at DUU [1/s]", "RdBu", True),
                  ("lqr_sampled_stable", "LQR (67) stable at the time step", "Greens", False)]
        fig, axes = new_figure(2, 5, figsize=(21, 7.6), constrained_layout=True)
    else:
        goal = summary["goal"]
        panels = [("E_r", f"E_r at the {goal} goal [J]", "RdBu", True),
                  ("deltabar_min", "min deltabar (30), merged acrobot", "RdBu", True),
                  ("deltabar_max", "max deltabar (30), merged acrobot", "RdBu", True),
                  ("udd_controllable", f"{goal} goal controllable", "Greens", False),
                  ("kD_min", "kD_min (41), by its definition", "viridis", False),
                  ("lqr_sampled_stable", "LQR stable at the time step", "Greens", False)]
        fig, axes = new_figure(2, 3, figsize=(13.5, 7.6), constrained_layout=True)
    for ax, (key, title, cmap, signed) in zip(axes.ravel(), panels):
        values = arrays[key].reshape(shape).astype(float)
        if arrays[key].dtype == bool:
            mesh = cell_map(ax, f1, f2, values.T, cmap=cmap, vmin=-0.2, vmax=1.2)
        elif signed:
            finite = values[np.isfinite(values)]
            span = float(np.max(np.abs(finite))) if finite.size else 1.0
            mesh = cell_map(ax, f1, f2, values.T, cmap=cmap, vmin=-span, vmax=span)
        else:
            from matplotlib.colors import LogNorm

            positive = values[np.isfinite(values) & (values > 0)]
            norm = None
            if positive.size and positive.max() > positive.min():
                norm = LogNorm(max(positive.min(), positive.max() * 1e-4), positive.max(), clip=True)
            mesh = cell_map(ax, f1, f2, np.where(values > 0, values, np.nan).T, cmap=cmap, norm=norm)
        fig.colorbar(mesh, ax=ax, shrink=0.85)
        _atlas_axes(ax, summary, arrays)
        ax.set_title(title)
    fig.suptitle(f"Atlas of {summary['robot']} over ({summary['vary'][0]}, {summary['vary'][1]}):"
                 + (" dashed, where (54) starts to fail;" if covered else
                    f" {summary['goal']} goal, beyond Theorem 1;") + " dotted, E_r = 0; star, the base robot")
    return fig


def atlas_outcome_figure(summary, arrays):
    """The simulated kip over the family, beside the share of random starts that balance."""
    from matplotlib.colors import BoundaryNorm, ListedColormap

    from ..studies.atlas import OUTCOMES

    f1, f2 = arrays["factors_1"], arrays["factors_2"]
    shape = (len(f1), len(f2))
    outcome = arrays["outcome"].reshape(shape).astype(float)
    fig, (left, right) = new_figure(1, 2, figsize=(12, 5), constrained_layout=True)
    colours = OUTCOME_COLOURS
    cmap = ListedColormap(colours).with_extremes(bad="white")
    cell_map(left, f1, f2, np.ma.masked_less(outcome, 0).T, cmap=cmap,
             norm=BoundaryNorm(np.arange(-0.5, len(OUTCOMES) + 0.5), cmap.N))
    counts = summary["counts"]
    left.legend([plt.Rectangle((0, 0), 1, 1, color=c) for c in colours],
                [f"{name} ({counts.get(name, 0)})" for name in OUTCOMES], loc="upper center",
                bbox_to_anchor=(0.5, -0.12), ncol=2, fontsize=8, frameon=False)
    _atlas_axes(left, summary, arrays)
    left.set_title("the kip from (65)" if summary.get("goal", "folded") == "folded" else
                   "the swing-up to the stretched goal")
    share = arrays["success_starts"].reshape(shape)
    mesh = cell_map(right, f1, f2, 100 * share.T, cmap="viridis", vmin=0, vmax=100)
    fig.colorbar(mesh, ax=right, label="success from random starts [%]")
    _atlas_axes(right, summary, arrays)
    right.set_title(f"{summary['starts']} random starts per robot")
    fig.suptitle(f"Simulated kips of {summary['robot']}'s family over ({summary['vary'][0]}, {summary['vary'][1]}),"
                 f" {summary['t_final']:g} s, {summary.get('goal', 'folded')} goal;"
                 + (" dashed: where (54) starts to fail;" if summary.get("theorem1_covers", True) else "")
                 + " dotted: E_r = 0")
    return fig
