"""The closed loop of (1) and an energy controller near an equilibrium: exact Jacobians and their roots.

Theorem 1 leaves two limits, the homoclinic set W_r and the down-up-up point
DUU = (-pi, -pi, 0); DUU must be unstable in closed loop for the kip to go on.
The Jacobian of the closed-loop vector field there is differentiated exactly:
the same formulas as the controllers' (:mod:`paa_mj.model.equations`,
:mod:`paa_mj.control.energy`) are evaluated on dual numbers (forward-mode
automatic differentiation: each value carries its derivatives along the six
state directions, by the chain rule of + - * / sin cos atan2), so there is no
step size to choose and no symbolic package to install.
"""
from __future__ import annotations

import numpy as np

from ..model import equations as eq
from ..model.dynamics import AnalyticModel
from ..model.states import Q_DUU
from .energy import conventional_law, energy_terms, vcl_law


class _Dual:
    """A number v + g . eps (eps^2 = 0) with the gradient ``g`` along the state's six directions: evaluated through
    a formula, ``g`` is the formula's exact gradient (forward-mode automatic differentiation)."""

    __slots__ = ("v", "g")
    _ZERO = np.zeros(6)

    def __init__(self, v, g=None):
        self.v, self.g = float(v), self._ZERO if g is None else g

    @staticmethod
    def lift(x):
        return x if isinstance(x, _Dual) else _Dual(x)

    def __add__(self, o):
        o = _Dual.lift(o)
        return _Dual(self.v + o.v, self.g + o.g)

    __radd__ = __add__

    def __sub__(self, o):
        o = _Dual.lift(o)
        return _Dual(self.v - o.v, self.g - o.g)

    def __rsub__(self, o):
        return _Dual.lift(o) - self

    def __mul__(self, o):
        o = _Dual.lift(o)
        return _Dual(self.v * o.v, self.g * o.v + self.v * o.g)

    __rmul__ = __mul__

    def __truediv__(self, o):
        o = _Dual.lift(o)
        return _Dual(self.v / o.v, (self.g * o.v - self.v * o.g) / (o.v * o.v))

    def __rtruediv__(self, o):
        return _Dual.lift(o) / self

    def __neg__(self):
        return _Dual(-self.v, -self.g)

    def __array_ufunc__(self, ufunc, method, *inputs, **kwargs):
        """NumPy's functions of the formulas (and NumPy scalars' arithmetic) on dual numbers."""
        args = [_Dual.lift(x) for x in inputs]
        if method != "__call__" or kwargs:
            return NotImplemented
        if ufunc is np.sin:
            return _Dual(np.sin(args[0].v), np.cos(args[0].v) * args[0].g)
        if ufunc is np.cos:
            return _Dual(np.cos(args[0].v), -np.sin(args[0].v) * args[0].g)
        if ufunc is np.arctan2:  # d atan2(y, x) = (x dy - y dx) / (x^2 + y^2)
            y, x = args
            return _Dual(np.arctan2(y.v, x.v), (x.v * y.g - y.v * x.g) / (x.v * x.v + y.v * y.v))
        binary = {np.add: _Dual.__add__, np.subtract: _Dual.__sub__, np.multiply: _Dual.__mul__,
                  np.true_divide: _Dual.__truediv__}
        if ufunc in binary:
            return binary[ufunc](*args)
        if ufunc is np.negative:
            return -args[0]
        return NotImplemented


def _closed_loop_field(x, c, gains, law, lambda_energy):
    """The closed loop's vector field [qd, qdd] at ``x`` (numbers or :class:`_Dual`), as six values."""
    q1, q2, q3, d1, d2, d3 = x
    kD, kP, kV = gains
    de, k22, k23, k33, u1, u2 = energy_terms(c, kD, kV, q1, q2, q3, d1, d2, d3)
    if lambda_energy is not None:  # E - E_r in Lambda replaced by a given value
        de = _Dual(lambda_energy)
    tau2, tau3 = (vcl_law if law == "vcl" else conventional_law)(c, kP, de, k22, k23, k33, u1, u2, q2, q3)
    return (d1, d2, d3, *eq.acceleration(c, q1, q2, q3, d1, d2, d3, tau2, tau3))


def closed_loop_jacobian(am: AnalyticModel, kD, kP, kV, law="vcl", state=None, lambda_energy=None) -> np.ndarray:
    """The exact 6 x 6 Jacobian of x_dot = [qd, M^-1 (B tau(x) - H - G)] at ``state`` (default DUU, at rest).

    Parameters
    ----------
    law : "vcl" for (40), "conventional" for (12)
    lambda_energy : float, optional
        Evaluate Lambda (38) with this value of E - E_r instead of the state's own
        (only Lambda; the rest of (40) is unchanged).
    """
    if law not in ("vcl", "conventional"):
        raise ValueError(f"unknown law {law!r}")
    point = np.concatenate([Q_DUU, np.zeros(3)]) if state is None else np.asarray(state, float)
    x = [_Dual(v, g) for v, g in zip(point, np.eye(6))]
    field = _closed_loop_field(x, am.constants, (float(kD), float(kP), float(kV)), law,
                               None if lambda_energy is None else float(lambda_energy))
    return np.array([_Dual.lift(f).g for f in field], dtype=float)


def sorted_eigenvalues(J):
    """Eigenvalues by decreasing real part (then decreasing imaginary part), and det(sI - J) highest power first."""
    eig = np.linalg.eigvals(J)
    eig = eig[np.lexsort((-eig.imag, -eig.real))]
    return eig, np.real(np.poly(J))


def duu_eigenvalues(am: AnalyticModel, kD, kP, kV, law="vcl", lambda_energy=None):
    """Eigenvalues and characteristic polynomial of the closed loop at DUU (:func:`closed_loop_jacobian`)."""
    return sorted_eigenvalues(closed_loop_jacobian(am, kD, kP, kV, law, lambda_energy=lambda_energy))
