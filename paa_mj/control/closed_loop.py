"""The closed loop of (1) and an energy controller near an equilibrium: exact Jacobians and their roots.

Theorem 1 leaves two limits, the homoclinic set W_r and the down-up-up point
DUU = (-pi, -pi, 0); DUU must be unstable in closed loop for the kip to go on.
The Jacobian of the closed-loop vector field there is differentiated exactly:
the same formulas as the controllers' (:mod:`paa_mj.model.equations`,
:mod:`paa_mj.control.energy`) are evaluated on CasADi symbols and differentiated
by automatic differentiation, so there is no step size to choose.
"""
from __future__ import annotations

import functools

import numpy as np

from ..model import equations as eq
from ..model.dynamics import AnalyticModel
from ..model.states import Q_DUU
from .energy import conventional_law, energy_terms, vcl_law


@functools.lru_cache(maxsize=None)
def _jacobian_function(law):
    """J(x, c, gains, override, value): the closed loop's Jacobian with the robot and gains as parameters.

    Built and differentiated once per law; ``override`` = 1 replaces E - E_r in Lambda by ``value``.
    """
    ca = eq.casadi_module()
    x, c, gains = ca.SX.sym("x", 6), ca.SX.sym("c", len(eq.CONSTANTS)), ca.SX.sym("gains", 3)
    override, value = ca.SX.sym("override"), ca.SX.sym("value")
    q1, q2, q3, d1, d2, d3 = (x[i] for i in range(6))
    kD, kP, kV = gains[0], gains[1], gains[2]
    de, k22, k23, k33, u1, u2 = energy_terms(c, kD, kV, q1, q2, q3, d1, d2, d3)
    de = ca.if_else(override > 0.5, value, de)
    tau2, tau3 = (vcl_law if law == "vcl" else conventional_law)(c, kP, de, k22, k23, k33, u1, u2, q2, q3)
    qdd = eq.acceleration(c, q1, q2, q3, d1, d2, d3, tau2, tau3)
    field = ca.vertcat(d1, d2, d3, *qdd)
    return ca.Function("J", [x, c, gains, override, value], [ca.jacobian(field, x)])


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
    J = _jacobian_function(law)(point, am.constants, [kD, kP, kV], 0.0 if lambda_energy is None else 1.0,
                                0.0 if lambda_energy is None else float(lambda_energy))
    return np.array(J, dtype=float)


def sorted_eigenvalues(J):
    """Eigenvalues by decreasing real part (then decreasing imaginary part), and det(sI - J) highest power first."""
    eig = np.linalg.eigvals(J)
    eig = eig[np.lexsort((-eig.imag, -eig.real))]
    return eig, np.real(np.poly(J))


def duu_eigenvalues(am: AnalyticModel, kD, kP, kV, law="vcl", lambda_energy=None):
    """Eigenvalues and characteristic polynomial of the closed loop at DUU (:func:`closed_loop_jacobian`)."""
    return sorted_eigenvalues(closed_loop_jacobian(am, kD, kP, kV, law, lambda_energy=lambda_energy))
