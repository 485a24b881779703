"""The figure of ``paa-mj roa``: slices of the set x^T S x <= rho, region (68) and trajectories from its edge."""
from __future__ import annotations

import numpy as np

from .plots import LINESTYLES, new_figure, save_figure


def slice_planes(n_links):
    """The coordinate pairs drawn: (x1, x2), then each joint's angle against its speed (x_i, x_{n+i})."""
    return [(0, 1)] + [(i, n_links + i) for i in range(n_links)]


def _label(k, n):
    return f"x{k + 1} = {'q' if k < n else 'qd'}{(k % n) + 1} error [{'rad' if k < n else 'rad/s'}]"


def _ellipse(S, rho, i, j, points=241):
    """The slice x^T S x = rho of the plane (i, j), the other coordinates 0."""
    block = np.asarray(S)[np.ix_([i, j], [i, j])]
    angle = np.linspace(0.0, 2 * np.pi, points)
    unit = np.stack([np.cos(angle), np.sin(angle)])
    scale = np.sqrt(rho / np.einsum("ik,ij,jk->k", unit, block, unit))
    return unit * scale


def roa_figure(summary, errors=None):
    """The slices of ``summary`` (``paa-mj roa``'s JSON) with region (68) and the errors of trajectories
    (list of (T, 2n) arrays) projected on each plane."""
    S, rho = np.asarray(summary["S"]), float(summary["rho"])
    n = S.shape[0] // 2
    planes = slice_planes(n)
    region = summary["task"]["switch_region"]
    fig, axes = new_figure(1, len(planes), figsize=(3.1 * len(planes), 3.0), layout="constrained", squeeze=False)
    for ax, (i, j) in zip(axes[0], planes):
        half = [region["angle"] if k < n else region["speed"] for k in (i, j)]
        ax.add_patch(_rectangle(half))
        if rho > 0:
            curve = _ellipse(S, rho, i, j)
            ax.plot(curve[0], curve[1], color="#0072B2", label=f"x'Sx <= rho (slice), {summary['method']}")
        for k, e in enumerate(errors or []):
            ax.plot(e[:, i], e[:, j], color="#D55E00", lw=0.8, ls=LINESTYLES[k % len(LINESTYLES)],
                    label="from the edge (projection)" if k == 0 else None)
        ax.set_xlabel(_label(i, n))
        ax.set_ylabel(_label(j, n))
    axes[0][0].legend(loc="upper right")
    fig.suptitle(f"{summary['robot']}, {summary['goal']} goal: rho = {rho:.4g}, region (68) dashed")
    return fig


def _rectangle(half):
    from matplotlib.patches import Rectangle

    return Rectangle((-half[0], -half[1]), 2 * half[0], 2 * half[1], fill=False, ls="--", color="#009E73",
                     label="region (68)")


def write_roa_figure(folder, stem, summary, errors=None):
    """``stem.png`` and ``stem.svg`` in ``folder`` (both or neither)."""
    return save_figure(roa_figure(summary, errors), folder, stem)
