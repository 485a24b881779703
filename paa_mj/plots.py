"""The paper's figures redrawn with matplotlib (PAA_MODEL.md section 9)."""
from __future__ import annotations

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402

from .io import atomic_path  # noqa: E402
from .theory import f54  # noqa: E402


def _save(fig, path):
    with atomic_path(path, suffix=".png") as tmp:
        fig.savefig(tmp, dpi=120, bbox_inches="tight", format="png")
    plt.close(fig)
    return path


def _mark_switch(ax, traj):
    if traj.switch_time is not None:
        ax.axvline(traj.switch_time, color="0.4", ls="--", lw=1)
        ax.text(traj.switch_time, 1.0, f" switch {traj.switch_time:.2f} s", transform=ax.get_xaxis_transform(),
                va="top", fontsize=8, color="0.3")


def plot_f54(am, title, path):
    """Figs. 5 and 11: f(z) of (54) on [0, 2 pi], with the forbidden level f = 1."""
    z = np.linspace(0, 2 * np.pi, 2001)
    fig, ax = plt.subplots(figsize=(6, 3.5))
    ax.plot(z, f54(am, z), lw=2, label="f(z)")
    ax.axhline(1.0, color="C3", ls="--", lw=1, label="f = 1 (forbidden)")
    ax.set_xlabel("z [rad]")
    ax.set_ylabel("f(z) [-]")
    ax.set_xlim(0, 2 * np.pi)
    ax.set_title(title)
    ax.legend(loc="best")
    ax.grid(alpha=0.3)
    return _save(fig, path)


def plot_energy(traj, title, path):
    """Figs. 6 and 12: V and E - E_r against t."""
    fig, axes = plt.subplots(2, 1, figsize=(7, 5), sharex=True)
    axes[0].plot(traj.t, traj.V, lw=1.5)
    axes[0].set_ylabel("V [J$^2$]")
    axes[0].set_yscale("symlog", linthresh=1.0)
    axes[1].plot(traj.t, traj.E_minus_Er, lw=1.5, color="C1")
    axes[1].set_ylabel("E - E$_r$ [J]")
    axes[1].set_xlabel("t [s]")
    for ax in axes:
        ax.grid(alpha=0.3)
        _mark_switch(ax, traj)
    axes[0].set_title(title)
    return _save(fig, path)


def _plot_series(traj, series, ylabel, title, path):
    """Several curves against t on one axis, with the switch marked."""
    fig, ax = plt.subplots(figsize=(7, 3.8))
    for values, label in series:
        ax.plot(traj.t, values, label=label)
    ax.set_xlabel("t [s]")
    ax.set_ylabel(ylabel)
    ax.set_title(title)
    ax.legend(loc="best")
    ax.grid(alpha=0.3)
    _mark_switch(ax, traj)
    return _save(fig, path)


def plot_angles(traj, title, path):
    """Figs. 7, 9 and 13: q1, q2 + pi, q3 against t."""
    series = [(traj.q[:, 0], "q$_1$"), (traj.q[:, 1] + np.pi, "q$_2$ + $\\pi$"), (traj.q[:, 2], "q$_3$")]
    return _plot_series(traj, series, "angle [rad]", title, path)


def plot_torques(traj, title, path):
    """Figs. 8, 10 and 14: tau2, tau3 against t."""
    series = [(traj.tau[:, 0], "$\\tau_2$ (shoulder)"), (traj.tau[:, 1], "$\\tau_3$ (hip)")]
    return _plot_series(traj, series, "torque [N m]", title, path)


def plot_discretisation(rows, path):
    """First switch time for each integrator and time step (the study of section 8)."""
    fig, ax = plt.subplots(figsize=(7, 3.8))
    names = sorted({r["integrator"] for r in rows if r["engine"] == "mujoco"})
    for i, name in enumerate(names):
        sub = [r for r in rows if r["engine"] == "mujoco" and r["integrator"] == name]
        dts = [r["dt"] * 1e3 for r in sub]
        times = [r["switch_time"] if r["switch_time"] is not None else np.nan for r in sub]
        ax.plot(dts, times, "o-", color=f"C{i}", label=f"MuJoCo {name}")
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
    ax.legend(loc="best", fontsize=8)
    ax.grid(alpha=0.3, which="both")
    return _save(fig, path)


def plot_basin(summary, arrays, path):
    """Heat map of the first switch time over the grid; grey = never switched, x = not balanced."""
    grid = summary["grid"]
    xs, ys = arrays["x_values"], arrays["y_values"]
    switch = arrays["switch_time"].reshape(grid, grid)
    balanced = arrays["balanced"].reshape(grid, grid)
    fig, ax = plt.subplots(figsize=(6.4, 5.2))
    cmap = matplotlib.colormaps["viridis"].with_extremes(bad="0.75")
    mesh = ax.pcolormesh(xs, ys, np.ma.masked_invalid(switch).T, cmap=cmap, shading="nearest")
    fig.colorbar(mesh, ax=ax, label="first switch to LQR [s]")
    X, Y = np.meshgrid(xs, ys, indexing="ij")
    failed = ~balanced
    if failed.any():
        ax.plot(X[failed], Y[failed], "x", color="C3", ms=max(2, 200 / grid), label="not balanced at the end")
        ax.legend(loc="upper right", fontsize=8)
    a, b = summary["axes"]
    unit = lambda name: "[rad]" if name.startswith("q") else "[rad/s]"  # noqa: E731
    ax.set_xlabel(f"{a} {unit(a)}")
    ax.set_ylabel(f"{b} {unit(b)}")
    ax.set_title(f"{summary['robot']}: basin over ({a}, {b}), {summary['cells']} cells, "
                 f"{100 * summary['success_fraction']:.0f} % balanced")
    return _save(fig, path)


def plot_robustness(factor, data, summary, path):
    """Success rate against the levels of one factor."""
    levels = data["levels"]
    labels = ["none" if lv["level"] is None else f"{lv['level']:g}" for lv in levels]
    rates = [100 * lv["success_rate"] for lv in levels]
    fig, ax = plt.subplots(figsize=(5.5, 3.6))
    ax.bar(labels, rates, color="C0")
    for i, r in enumerate(rates):
        ax.text(i, r + 1, f"{r:.0f} %", ha="center", fontsize=9)
    ax.set_ylim(0, 110)
    ax.set_xlabel(data["label"])
    ax.set_ylabel("held by LQR in region (68) [%]")
    ax.set_title(f"{summary['robot']}: {factor}, {summary['trials']} random starts each")
    ax.grid(alpha=0.3, axis="y")
    return _save(fig, path)
