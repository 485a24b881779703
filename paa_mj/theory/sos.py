"""A sums-of-squares certificate of the LQR's region of attraction, for a Taylor model of the closed loop.

The closed loop of (1) under the LQR (67), unsaturated, in the error x = [q - q*, qd] from the goal,

.. math::

    \\dot x = f(x) = \\begin{bmatrix} \\dot q \\\\ M(q)^{-1}\\,(-B K x - H(q, \\dot q) - G(q) - D \\dot q)
    \\end{bmatrix},

is replaced by its Taylor polynomial :math:`f_d` of degree d (3 by default) about the goal (:func:`taylor_field`:
the derivatives of CasADi's exact expression of (1) at x = 0, so the polynomial is exact to rounding). With
:math:`V(x) = x^T S x`, the level :math:`\\rho` is certified for :math:`f_d` when

.. math::

    -\\dot V_d(x) - \\epsilon\\,|x|^2 + \\lambda(x)\\,(V(x) - \\rho) \\ \\text{ is a sum of squares}, \\qquad
    \\lambda \\ \\text{a sum of squares},

since then :math:`\\dot V_d(x) \\le -\\epsilon |x|^2 < 0` wherever :math:`0 < V(x) \\le \\rho` (the S-procedure).
:func:`sos_level` bisects on :math:`\\rho` over feasibility problems of Drake's ``MathematicalProgram`` (solved by
Clarabel). What this certifies is the degree-d polynomial model, not (1) itself: the remainder
:math:`f - f_d = O(|x|^{d+1})` is not bounded here, so :mod:`paa_mj.theory.roa` checks the true dynamics on the
set by sampling. Drake is the optional ``peers`` extra, imported here only.
"""
from __future__ import annotations

import itertools
import math

import numpy as np

from ..errors import PaaError

#: Degree of the Taylor model of the closed loop, and of the S-procedure's multiplier lambda(x).
TAYLOR_DEGREE = 3
MULTIPLIER_DEGREE = 2
#: Bisection steps on rho (relative precision 2^-BISECTIONS of the first bracket).
BISECTIONS = 14
#: The strict decrease asked for: epsilon = EPSILON_FRACTION * lambda_min(Q + K^T R K) (the decrease of V at
#: the goal is x^T (Q + K^T R K) x for the Riccati S).
EPSILON_FRACTION = 1e-3
#: Chains beyond this many links make SOS programs too large to solve here (the Gram matrix grows as (2n)^4).
SOS_MAX_LINKS = 4


def drake_available() -> bool:
    """Whether pydrake (the ``peers`` extra) can be imported."""
    try:
        import pydrake.solvers  # noqa: F401
    except ImportError:
        return False
    return True


def taylor_field(am, task, K, degree=TAYLOR_DEGREE):
    """Taylor coefficients of the unsaturated closed loop f(x) of (1) under tau = -K x about the task's goal.

    Parameters
    ----------
    am : AnalyticModel
    task : Task
    K : ndarray (n - 1, 2n)
        The LQR gain of (67).
    degree : int
        1 to 3.

    Returns
    -------
    list of ndarray
        ``terms[k]`` (k = 1..degree, ``terms[0]`` is None) of shape (2n,) + (2n,) * k: the symmetric tensor of
        the k-th derivatives of f at x = 0 divided by k!, so that
        :math:`f_d(x) = \\sum_k T_k[x, \\dots, x]`.
    """
    from ..model.equations import casadi_module

    ca = casadi_module()
    if not 1 <= degree <= 3:
        raise PaaError(f"the Taylor model of the closed loop has degree 1 to 3, got {degree}")
    n = am.n_links
    x = ca.SX.sym("x", 2 * n)
    state = ca.vertcat(*[x[i] + float(task.goal[i]) for i in range(n)], *[x[n + i] for i in range(n)])
    u = -ca.mtimes(ca.DM(np.asarray(K, float)), x)
    field = ca.vertcat(*[x[n + i] for i in range(n)], am.symbolic_acceleration(ca, state, u))
    terms, derivative = [None], field
    zero = np.zeros(2 * n)
    for k in range(1, degree + 1):
        derivative = ca.jacobian(derivative, x)  # rows: (i, j1, ..., j(k-1)) row-major; columns: jk
        value = np.array(ca.Function("d", [x], [derivative])(zero), dtype=float)
        terms.append(value.reshape((2 * n,) * (k + 1)) / math.factorial(k))
        derivative = ca.vec(derivative.T)  # (i, j1, ..., jk) row-major, as one column
    return terms


def polynomial_value(terms, x):
    """:math:`f_d(x)` of :func:`taylor_field` at states ``x`` (..., 2n), in NumPy."""
    x = np.asarray(x, float)
    out = np.zeros(x.shape)
    patterns = {1: "ij,...j->...i", 2: "ijk,...j,...k->...i", 3: "ijkl,...j,...k,...l->...i"}
    for k, tensor in enumerate(terms):
        if tensor is not None:
            out = out + np.einsum(patterns[k], tensor, *([x] * k))
    return out


def _monomial_field(terms, x):
    """f_d as Drake polynomials in the indeterminates ``x`` (numbers below 1e-14 of the largest dropped)."""
    from pydrake.symbolic import Polynomial

    width = x.size
    field = [Polynomial() for _ in range(width)]
    for k, tensor in enumerate(terms):
        if tensor is None:
            continue
        scale = np.max(np.abs(tensor)) if tensor.size else 0.0
        for index in itertools.product(range(width), repeat=k):
            for i in range(width):
                c = float(tensor[(i,) + index])
                if abs(c) > 1e-14 * scale:
                    monomial = Polynomial(1)
                    for j in index:
                        monomial = monomial * Polynomial(x[j])
                    field[i] = field[i] + c * monomial
    return field


def whitened(S, terms, radius):
    """The Taylor terms in the coordinates z = L^T x / ``radius`` with S = L L^T, where V = radius^2 |z|^2:
    T'_k[i, j1..jk] = radius^(k-1) (L^T)_{ii'} T_k[i', j1'..jk'] (L^-T)_{j1'j1} ... (L^-T)_{jk'jk}."""
    lower = np.linalg.cholesky(np.asarray(S, float))
    to_z, from_z = lower.T, np.linalg.inv(lower.T)
    out = [None]
    for k, tensor in enumerate(terms[1:], start=1):
        part = np.tensordot(to_z, tensor, axes=([1], [0]))
        for axis in range(1, k + 1):
            part = np.moveaxis(np.tensordot(part, from_z, axes=([axis], [0])), -1, axis)
        out.append(part * radius ** (k - 1))
    return out


class _Program:
    """The feasibility problem of one level r of |z|^2 (z whitened): -dV/dt - eps |z|^2 + lambda (|z|^2 - r) SOS,
    lambda SOS, with dV/dt = 2 z . f_d(z)."""

    def __init__(self, terms, epsilon):
        from pydrake.solvers import MathematicalProgram
        from pydrake.symbolic import Polynomial

        self.width = terms[1].shape[0]
        self.epsilon = epsilon
        probe = MathematicalProgram()
        self.x = probe.NewIndeterminates(self.width, "z")
        field = _monomial_field(terms, self.x)
        self.norm = sum((Polynomial(v) * Polynomial(v) for v in self.x), Polynomial())
        self.Vdot = sum((2.0 * Polynomial(self.x[i]) * field[i] for i in range(self.width)), Polynomial())

    def feasible(self, level) -> bool:
        from pydrake.solvers import ClarabelSolver, MathematicalProgram
        from pydrake.symbolic import Variables

        prog = MathematicalProgram()
        prog.AddIndeterminates(self.x)
        multiplier = prog.NewSosPolynomial(Variables(self.x), MULTIPLIER_DEGREE)[0]
        prog.AddSosConstraint(-self.Vdot - self.epsilon * self.norm + multiplier * (self.norm - level))
        return bool(ClarabelSolver().Solve(prog).is_success())


def sampled_bound(terms, S, samples=20000, seed=0):
    """An upper bound of any level the SOS program can certify: the least V = x^T S x, over ``samples`` seeded
    directions d (V(d) = 1), at which the Taylor model has dV/dt >= 0 (RealAIGym's "najafi" test, solved exactly
    along each ray). Along x = s d, dV/dt = 2 s^2 (a + b s + c s^2) with a = d^T S T_1 d,
    b = d^T S T_2[d, d], c = d^T S T_3[d, d, d], so the first s > 0 with dV/dt = 0 is a root of a quadratic.

    Returns
    -------
    float or None
        None when no sampled ray turns (or the model is linear).
    """
    S = np.asarray(S, float)
    rng = np.random.default_rng(seed)
    d = rng.standard_normal((samples, S.shape[0]))
    d /= np.sqrt(np.einsum("ki,ij,kj->k", d, S, d))[:, None]
    sd = d @ S
    coefficients = [np.zeros(samples)] * 3
    patterns = {1: "ij,kj->ki", 2: "ijl,kj,kl->ki", 3: "ijlm,kj,kl,km->ki"}
    for k, tensor in enumerate(terms):
        if tensor is not None:
            coefficients[k - 1] = np.einsum("ki,ki->k", sd, np.einsum(patterns[k], tensor, *([d] * k)))
    a, b, c = coefficients
    with np.errstate(divide="ignore", invalid="ignore"):
        disc = np.sqrt(np.maximum(b * b - 4 * a * c, 0.0))
        roots = np.stack([(-b - disc) / (2 * c), (-b + disc) / (2 * c), -a / b])
    real = np.where(b * b - 4 * a * c >= 0, 1.0, np.nan)
    candidates = np.concatenate([roots[:2] * real, np.where(c == 0, roots[2:], np.nan)])
    candidates = np.where(candidates > 0, candidates, np.nan)
    if np.all(np.isnan(candidates)):
        return None
    return float(np.nanmin(candidates) ** 2)


def sos_level(S, terms, epsilon, upper, bisections=BISECTIONS):
    """The largest rho in (0, ``upper``] that the SOS program certifies for the Taylor model, by bisection.

    Parameters
    ----------
    S : ndarray (2n, 2n)
        V = x^T S x (positive definite).
    terms : list
        :func:`taylor_field`.
    epsilon : float
        The decrease asked for, -dV/dt >= epsilon |x|^2 ... in the whitened z (|z|^2 = V / upper) [1/s].
    upper : float
        The bracket's top: a level known not to be certifiable (:func:`sampled_bound`), or the largest worth
        certifying.

    Returns
    -------
    (rho, feasible_upper) : float, bool
        rho = 0.0 when not even ``upper`` 2^-bisections is certified; ``feasible_upper`` when ``upper`` itself is.
    """
    import logging

    logging.getLogger("drake").setLevel(logging.WARNING)  # Clarabel's failures are answers here, not news
    program = _Program(whitened(S, terms, math.sqrt(upper)), epsilon)
    if program.feasible(1.0):
        return float(upper), True
    low, high = 0.0, 1.0
    for _ in range(bisections):
        middle = 0.5 * (low + high)
        if program.feasible(middle):
            low = middle
        else:
            high = middle
    return float(low * upper), False
