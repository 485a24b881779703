"""deltabar of (30) for the acrobot made by freezing joints 3..n (Sect. 2.4), over every frozen posture: its range,
and whether it keeps its sign (Lemma 1: the up-down point of each frozen acrobot is linearly controllable iff
deltabar != 0), decided by a branch and bound.

With alpha = (alpha_3, ..., alpha_n) the absolute angles of links 3..n from link 2 (alpha_2 = 0, alpha_k = q3 + ...
+ qk), the frozen links 2..n are one rigid link about joint 2:

.. math::

    \\bar a_2 = \\sum_{i,k \\ge 2} A_{ik} \\cos(\\alpha_i - \\alpha_k), \\qquad
    s = \\bar b_2 = \\Big|\\sum_{k \\ge 2} b_k e^{i \\alpha_k}\\Big|, \\qquad \\bar a_3 = l_1 s / g,

    \\bar\\delta = (\\bar a_2 - \\bar a_3) b_1 + (a_{11} - \\bar a_3) s
               = b_1 \\bar a_2 + (a_{11} - b_1 l_1 / g)\\, s - (l_1 / g)\\, s^2,

deltabar [J kg m^2] even in alpha. On a box alpha = c + delta, abs(delta_j) <= r_j, it is bounded three ways
(:meth:`Deltabar.box_bounds`), the tightest kept:

1. intervals: each cos(alpha_i - alpha_k) over its arc exactly, s between the projection of z(c + delta) on z(c)
   and abs(z(c)) + sum_k b_k abs(e^{i delta_k} - 1), the concave c s - kappa s^2 at the ends or the vertex;
2. second order: deltabar(c) + G . delta, G its gradient, the linear part maximised exactly and each pair's
   cosine off its tangent by at most Omega^2 / 2 (Omega = r_i + r_k); s >= Re(z e^{-i theta_c}) and
   s <= abs(z(c)) + Re((z - z(c)) e^{-i theta_c}) + abs(z - z(c))^2 / (2 abs(z(c)));
3. arcs: with eps_i = e^{i delta_i} - 1, a pair form sum_ik W_ik cos(alpha_i - alpha_k) changes by exactly
   Re sum_i omega_i eps_i + eps^H C eps (omega_i = 2 u_i sum_k W_ik conj(u_k), C_ik = W_ik conj(u_i) u_k,
   u = e^{i alpha(c)}); the same two bounds of s make c s such a form too (abs(z - z(c))^2 is one). The
   off-diagonal part of eps^H C eps lies within sum_i D_i abs(eps_i)^2, D_i = sum_{k != i} abs(W_ik) e_k / e_i
   (e_i = 2 sin(r_i / 2), the largest abs(eps_i)), and abs(eps_i)^2 = -2 Re(eps_i): the change is then
   Re sum_i w_i eps_i, each term's extreme over its arc exact.

:func:`merged_acrobot` finds the extremes from a grid or random postures and the straight and folded ones
(alpha in {0, pi}), refined by gradient steps; a sign change found is a witness. Where none is found, the branch
and bound of :func:`~paa_mj.theory.maxima.branch_and_bound` proves that deltabar keeps its sign, with at least a
tenth of the smallest absolute value found, or stops at its budget undecided.
"""
from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from ..model.dynamics import AnalyticModel
from .maxima import branch_and_bound

#: CPU-seconds the branch and bound may take to decide the sign (chains of up to 6 links take well under one;
#: from 8 links a deltabar that comes close to 0 can take more).
BUDGET_CPU_S = 5.0
#: Random postures sampled beyond two frozen joints.
SAMPLES = 20001


@dataclass(frozen=True)
class MergedAcrobot:
    """What :func:`merged_acrobot` found.

    Attributes
    ----------
    controllable : bool or None
        Lemma 1's up-down point controllable for every frozen posture (deltabar never 0); None where undecided.
    minimum, maximum : float
        The extremes of deltabar found (values it takes) [J kg m^2].
    argmin, argmax : tuple of float
        The frozen relative angles (q3, ..., qn) where it takes them, in [0, 2 pi).
    method : str
        How the answer was decided, in words.
    boxes : int
        Boxes the branch and bound bounded.
    """

    controllable: bool | None
    minimum: float
    maximum: float
    argmin: tuple
    argmax: tuple
    method: str
    boxes: int = 0


class Deltabar:
    """deltabar of (30) for one chain: values, gradients and bounds on boxes of absolute angles alpha (module
    docstring)."""

    def __init__(self, am: AnalyticModel):
        A, b, p = am.inertia_constants, am.gravity_constants, am.params
        self.tail, self.b_tail, self.b1 = np.asarray(A[1:, 1:], float), np.asarray(b[1:], float), float(b[0])
        self.kappa = float(p.l[0]) / float(p.g)
        self.c = float(A[0, 0]) - self.b1 * self.kappa
        self.bb = np.outer(self.b_tail, self.b_tail)
        self.pair = self.b1 * self.tail - self.kappa * self.bb  # deltabar's pair weights, s^2 = sum bb cos
        total = float(np.sum(np.abs(self.b_tail)))
        #: The size of deltabar's terms [J kg m^2], for its rounding.
        self.scale = abs(self.b1) * float(np.sum(np.abs(self.tail))) + (abs(self.c) + self.kappa * total) * total

    def _phi(self, alpha):
        alpha = np.atleast_2d(np.asarray(alpha, float))
        return np.concatenate([np.zeros((len(alpha), 1)), alpha], axis=1)

    def parts(self, alpha):
        """abar2, s, the angle theta of z and deltabar at each row of alpha (K, m)."""
        phi = self._phi(alpha)
        abar2 = np.einsum("ij,rij->r", self.tail, np.cos(phi[:, :, None] - phi[:, None, :]))
        z = np.sum(self.b_tail * np.exp(1j * phi), axis=1)
        s = np.abs(z)
        return phi, abar2, s, np.angle(z), self.b1 * abar2 + self.c * s - self.kappa * s * s

    def values(self, alpha):
        return self.parts(alpha)[-1]

    def gradient(self, alpha):
        """deltabar and its gradient at each row of alpha: (K,), (K, m)."""
        phi, _, s, theta, value = self.parts(alpha)
        return value, self._gradient(phi, s, theta)

    def _gradient(self, phi, s, theta):
        dabar2 = -2.0 * np.einsum("jk,rjk->rj", self.tail, np.sin(phi[:, :, None] - phi[:, None, :]))
        ds = -self.b_tail * np.sin(phi - theta[:, None])
        return (self.b1 * dabar2 + (self.c - 2.0 * self.kappa * s)[:, None] * ds)[:, 1:]

    def box_bounds(self, centres, radii):
        """(lower, upper) of deltabar on the boxes centres +- radii (K, m), its values at the centres, and each
        radius's share of the bounds (K, m)."""
        phi, abar2, s, theta, value = self.parts(centres)
        rho = np.concatenate([np.zeros((len(phi), 1)), radii], axis=1)
        omega = np.minimum(rho[:, :, None] + rho[:, None, :], math.pi)
        theta_ik = phi[:, :, None] - phi[:, None, :]
        cos_hi, cos_lo = _cos_range(theta_ik, omega)
        base = np.cos(theta_ik)
        W = self.tail
        a_hi = abar2 + np.einsum("ik,rik->r", W, np.where(W >= 0, cos_hi - base, cos_lo - base))
        a_lo = abar2 + np.einsum("ik,rik->r", W, np.where(W >= 0, cos_lo - base, cos_hi - base))
        chord = np.sum(self.b_tail * 2.0 * np.sin(np.minimum(rho, math.pi) / 2.0), axis=1)  # >= |z - z(c)|
        proj = np.sum(self.b_tail * (_cos_range(phi - theta[:, None], rho)[1] - np.cos(phi - theta[:, None])), axis=1)
        s_lo, s_hi = np.maximum(s + proj, 0.0), s + chord
        q_ends = np.minimum(self._q(s_lo), self._q(s_hi))
        vertex = np.clip(self.c / (2.0 * self.kappa), s_lo, s_hi) if self.kappa > 0 else s_hi
        q_top = np.maximum(np.maximum(self._q(s_lo), self._q(s_hi)), self._q(vertex))
        lower1, upper1 = self.b1 * a_lo + q_ends, self.b1 * a_hi + q_top
        if self.b1 < 0:
            lower1, upper1 = self.b1 * a_hi + q_ends, self.b1 * a_lo + q_top
        grad = self._gradient(phi, s, theta)
        linear = np.sum(np.abs(grad) * radii, axis=1)
        pairs = 0.5 * omega * omega
        rem_a = abs(self.b1) * np.einsum("ik,rik->r", np.abs(W), pairs)
        rem_s2 = self.kappa * np.einsum("ik,rik->r", self.bb, pairs)
        reach = np.sum(self.b_tail * rho, axis=1)
        s_down = 0.5 * np.sum(self.b_tail * rho * rho, axis=1)
        with np.errstate(divide="ignore", invalid="ignore"):
            s_up = np.where(s > 0, reach * reach / (2.0 * s), np.inf) + s_down
        up_s, down_s = (s_up, s_down) if self.c >= 0 else (s_down, s_up)
        upper2 = value + linear + rem_a + rem_s2 + abs(self.c) * up_s
        lower2 = value - linear - rem_a - rem_s2 - abs(self.c) * down_s
        scale = 1e-12 * self.scale  # the rounding of the sums
        score = np.abs(grad) * radii + radii * radii * (np.abs(self.b1) * np.sum(np.abs(W[1:]), axis=1)
                                                          + self.b_tail[1:] * (abs(self.c) + self.kappa
                                                                               * np.sum(self.b_tail)))
        with np.errstate(divide="ignore", invalid="ignore"):  # where z(c) = 0 bound 3 is infinite on one side
            down, up = self._arcs(phi, rho, s, theta)
        lower3, upper3 = value + down, value + up
        lower, upper = np.maximum(np.maximum(lower1, lower2), lower3), np.minimum(np.minimum(upper1, upper2), upper3)
        return lower - scale, upper + scale, value, score

    def _arcs(self, phi, rho, s, theta):
        """Bound 3 of the module's docstring: the least and the largest change of deltabar on each box, with
        eps_i = e^{i delta_i} - 1, as sums over i of the extremes of Re(w_i eps_i) over their arcs."""
        u = np.exp(1j * phi)
        omega = 2.0 * u * np.einsum("ik,rk->ri", self.pair, np.conj(u))  # P's linear part: Re sum_i omega_i eps_i
        one = self.c * self.b_tail * u * np.exp(-1j * theta)[:, None]  # c s against its projection on z(c)
        reach = 2.0 * np.sin(np.minimum(rho, math.pi) / 2.0)  # max |eps_i|
        ratio = np.where(reach[:, None, :] > 0, reach[:, None, :] / reach[:, :, None], 0.0)
        m = len(self.b_tail)
        changes = []
        for side in (-1.0, 1.0):
            # c s beyond its projection, on the side that needs it: c |z - z(c)|^2 / (2 s(c)), a pair form as well
            gamma = np.where(side * self.c > 0, self.c / (2.0 * s), 0.0)
            weights = self.pair[None] + gamma[:, None, None] * self.bb[None]
            off = np.abs(weights) * ratio
            off[:, np.arange(m), np.arange(m)] = 0.0
            gersh = np.sum(off, axis=2)  # |sum_{i != k} conj(eps_i) C_ik eps_k| <= sum_i gersh_i |eps_i|^2
            diagonal = np.einsum("rii->ri", weights) + side * gersh  # times |eps_i|^2 = -2 Re(eps_i)
            w = side * (omega + one - 2.0 * diagonal)
            change = np.sum(np.where(rho > 0, _arc_max(w, rho) - w.real, 0.0), axis=1)
            changes.append(side * np.where(np.isfinite(change), change, np.inf))
        return changes

    def _q(self, s):
        return self.c * s - self.kappa * s * s


def _arc_max(w, rho):
    """max over abs(t) <= rho of Re(w e^{i t}), elementwise (:func:`paa_mj.theory.bounds._arc_max` over arrays):
    abs(w) where the arc reaches the direction of w, else at the nearer end."""
    rho = np.minimum(rho, math.pi)
    size = np.abs(w)
    return np.where(w.real >= size * np.cos(rho), size, w.real * np.cos(rho) + np.abs(w.imag) * np.sin(rho))


def _cos_range(theta, omega):
    """(max, min) of cos over [theta - omega, theta + omega]."""
    u = np.exp(1j * theta)
    return _arc_max(u, omega), -_arc_max(-u, omega)


def _ascend(d: Deltabar, sign, alpha, iters=60):
    """A local maximum of sign * deltabar from alpha by gradient steps, halved until it does not fall: (value, alpha)
    with value = sign * deltabar."""
    x = np.array(alpha, float)
    value, grad = d.gradient(x[None])
    f, g = sign * value[0], sign * grad[0]
    step = 1.0 / d.scale
    for _ in range(iters):
        for _ in range(40):
            trial = x + step * g
            value, grad = d.gradient(trial[None])
            if sign * value[0] >= f:
                break
            step /= 2
        else:
            break
        moved = np.max(np.abs(trial - x))
        x, f, g, step = trial, sign * value[0], sign * grad[0], 2 * step
        if moved < 1e-14:
            break
    return float(f), x


def _relative(alpha):
    """Absolute angles of links 3..n from link 2 to the frozen relative angles q3..qn in [0, 2 pi)."""
    return tuple(float(q) for q in np.diff(np.concatenate([[0.0], alpha])) % (2 * np.pi))


def _postures(m, seed):
    """Starting postures: a grid for one or two frozen joints, else random ones and every straight-or-folded one."""
    if m == 1:
        return np.linspace(0, 2 * np.pi, SAMPLES)[:, None]
    if m == 2:
        axis = np.linspace(0, 2 * np.pi, 201)
        return np.stack(np.meshgrid(axis, axis, indexing="ij"), -1).reshape(-1, 2)
    corners = np.array(np.meshgrid(*[[0.0, np.pi]] * min(m, 12), indexing="ij")).reshape(min(m, 12), -1).T
    corners = np.hstack([corners, np.zeros((len(corners), m - corners.shape[1]))])
    return np.vstack([corners, np.random.default_rng(seed).uniform(-np.pi, np.pi, (SAMPLES, m))])


def merged_acrobot(am: AnalyticModel, budget_cpu_s=BUDGET_CPU_S, seed=0) -> MergedAcrobot:
    """deltabar of (30) over every frozen posture of joints 3..n (module docstring): its extremes found, and
    whether it keeps its sign, proved (a branch and bound) or disproved (a posture on each side of 0).

    With a budget (up to ``budget_cpu_s`` CPU-s at ten links), the answer is kept on disk by content (the robot's
    parameters, the budget and the seed: :func:`~paa_mj.provenance.kept`), as kD_min (41) is; without one (the
    atlas's extremes, many robots at a few milliseconds each) it is computed."""
    if budget_cpu_s <= 0.0 or am.n_links == 2:
        return _merged_acrobot(am, budget_cpu_s, seed)
    from dataclasses import asdict

    from ..provenance import kept

    return kept("merged_acrobot", lambda: _merged_acrobot(am, budget_cpu_s, seed), encode=asdict,
                decode=lambda d: MergedAcrobot(**{**d, "argmin": tuple(d["argmin"]), "argmax": tuple(d["argmax"])}),
                params=list(am.key()), budget_cpu_s=float(budget_cpu_s), seed=seed)


def _merged_acrobot(am: AnalyticModel, budget_cpu_s, seed) -> MergedAcrobot:
    m = am.n_links - 2
    d = Deltabar(am)
    if m == 0:
        value = float(d.values(np.zeros((1, 0)))[0])
        return MergedAcrobot(value != 0.0, value, value, (), (), "two links: the robot itself, no frozen joint")
    starts = _postures(m, seed)
    values = d.values(starts)
    low, x_low = _ascend(d, -1.0, starts[int(np.argmin(values))])
    high, x_high = _ascend(d, 1.0, starts[int(np.argmax(values))])
    low = -low

    def result(controllable, method, boxes=0):
        return MergedAcrobot(controllable, float(low), float(high), _relative(x_low), _relative(x_high), method,
                             boxes)

    if low < 0.0 < high:
        return result(False, "deltabar takes both signs: at its minimum and its maximum found")
    sign = 1.0 if low > 0.0 else -1.0  # prove sign * deltabar > 0: the maximum of h = -sign * deltabar is < 0
    nearest, x = (low, x_low) if sign > 0 else (-high, x_high)
    if nearest <= 1e-12 * d.scale:
        return result(False, f"deltabar = {sign * nearest:.3g}, 0 to rounding, at a posture found")

    def bound(centres, radii, target):
        lower, upper, value, score = d.box_bounds(centres, radii)
        return (-lower, -value, score) if sign > 0 else (upper, value, score)

    lows, highs = np.full(m, -np.pi), np.full(m, np.pi)
    lows[0] = 0.0  # deltabar(-alpha) = deltabar(alpha)
    h, x_h, upper, boxes, finished = branch_and_bound(bound, lows, highs, -nearest, x,
                                                      lambda point: _ascend(d, -sign, point), tol=0.9,
                                                      budget_s=budget_cpu_s)
    if h >= 0.0:
        if sign > 0:
            low, x_low = -h, x_h
        else:
            high, x_high = h, x_h
        return result(False, "deltabar takes both signs (a posture on the other side found by the branch and bound)",
                      boxes)
    if finished:
        return result(True, f"a branch and bound proves |deltabar| >= {-upper:.6g} at every frozen posture", boxes)
    return result(None, f"no sign change found; the branch and bound stopped at its budget of {budget_cpu_s:g}"
                        f" CPU-s undecided (that deltabar never vanishes is not proved)", boxes)
