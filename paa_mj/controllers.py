"""Controllers of the paper: energy + VCL swing-up (40), LQR balance (67), switch (68).

Each controller is a small object that maps the state to the motor torques
``tau = [tau2, tau3]`` [N m]; ``q`` and ``qd`` may carry any leading batch shape
(..., 3). :meth:`Controller.mj_control` reads ``qpos``/``qvel`` of an
``MjData`` and writes ``ctrl``, so a controller plugs into a MuJoCo loop that
holds the torque constant over each step (zero-order hold).
"""
from __future__ import annotations

import warnings

import numpy as np

from .dynamics import AnalyticModel
from .errors import PaaError
from .theory import Q_UDD, lqr_gain
from .vcl import Psi, qbar_a, psi

#: The target of the actuated VCL coordinates, q_ar = [-pi, 0] (11).
Q_AR = np.array([-np.pi, 0.0])
#: Switching region (68): |angle error| < pi/6 and |speed| < 0.5 rad/s, per joint.
SWITCH_ANGLE = np.pi / 6
SWITCH_SPEED = 0.5


class TheoryWarning(UserWarning):
    """Gains or robot outside what Theorem 1 covers; the run goes on."""


def wrap_angle(a):
    """Wrap angles to (-pi, pi]."""
    return np.pi - np.mod(np.pi - np.asarray(a, dtype=float), 2 * np.pi)


def udd_error(q, qd):
    """State error from UDD, x = [q1, q2 + pi, q3, d1, d2, d3], angles wrapped to (-pi, pi]."""
    q, qd = np.asarray(q, float), np.asarray(qd, float)
    return np.concatenate([wrap_angle(q - Q_UDD), qd], axis=-1)


class Controller:
    """Base class: a torque law with an optional symmetric torque limit [N m]."""

    torque_limit: float | None = None

    def torque(self, q, qd):
        raise NotImplementedError

    def reset(self):
        """Forget any internal state (before a new rollout)."""

    def saturate(self, tau):
        if self.torque_limit is None:
            return tau
        return np.clip(tau, -self.torque_limit, self.torque_limit)

    def mj_control(self, model, data):
        """Read ``data.qpos``/``data.qvel``, write ``data.ctrl`` (held over the next step)."""
        data.ctrl[:] = self.torque(data.qpos, data.qvel)


class EnergyVCLController(Controller):
    """Energy + virtual-composite-link swing-up controller (40).

    With e = qbar_a - q_ar (13), (11) and qd_a = [d2, d3],

        Lambda = (E - E_r) I2 + kD B^T M^-1 B                                 (38)
        tau    = Lambda^-1 (kD B^T M^-1 (H + G) - kV qd_a - kP Psi^T e)          (40)

    which makes V = 1/2 (E - E_r)^2 + 1/2 kD qd_a^T qd_a + 1/2 kP e^T e decrease as
    dV/dt = -kV qd_a^T qd_a (36). The angle q2 in e is *not* wrapped: V is defined
    on the unwrapped coordinate, as in the paper.

    Parameters
    ----------
    model : AnalyticModel
        The robot, normally read back from the MuJoCo model.
    kD, kP, kV : float
        Gains of (40) [kD: J kg m^2, kP: J^2/rad^2, kV: J^2 s/rad^2].
    torque_limit : float, optional
        Symmetric saturation of each torque [N m].
    check : bool
        Validate the gains against the theory (:func:`check_gains`).
    """

    def __init__(self, model: AnalyticModel, kD, kP, kV, torque_limit=None, check=True):
        self.model = model
        self.kD, self.kP, self.kV = float(kD), float(kP), float(kV)
        self.torque_limit = torque_limit
        if check:
            check_gains(model, self.kD, self.kP, self.kV)

    def vcl_error(self, q):
        """e = qbar_a - q_ar, shape (..., 2) [rad]."""
        q = np.asarray(q, float)
        return qbar_a(self.model.b2, self.model.b3, q[..., 1], q[..., 2]) - Q_AR

    def energy_error(self, q, qd):
        """E - E_r [J]."""
        return self.model.energy(q, qd) - self.model.E_r

    def lyapunov(self, q, qd):
        """V of (34) [J^2]."""
        q, qd = np.asarray(q, float), np.asarray(qd, float)
        e = self.vcl_error(q)
        qd_a = qd[..., 1:]
        return (0.5 * self.energy_error(q, qd) ** 2 + 0.5 * self.kD * np.sum(qd_a**2, -1)
                + 0.5 * self.kP * np.sum(e**2, -1))

    def torque(self, q, qd):
        q, qd = np.asarray(q, float), np.asarray(qd, float)
        am = self.model
        M_inv = np.linalg.inv(am.mass_matrix(q))
        lam = self.energy_error(q, qd)[..., None, None] * np.eye(2) + self.kD * M_inv[..., 1:, 1:]
        M_inv_bias = np.einsum("...ij,...j->...i", M_inv[..., 1:, :], am.bias(q, qd))
        e = self.vcl_error(q)
        p = psi(am.b2, am.b3, q[..., 2])
        psi_t_e = np.stack([e[..., 0], p * e[..., 0] + e[..., 1]], -1)
        rhs = self.kD * M_inv_bias - self.kV * qd[..., 1:] - self.kP * psi_t_e
        return self.saturate(np.linalg.solve(lam, rhs[..., None])[..., 0])

    def lyapunov_rate(self, q, qd, tau=None):
        """dV/dt along (1) with torque ``tau`` (default: this controller's), from the chain rule.

        dV/dt = (E - E_r) qd_a^T tau + kD qd_a^T qdd_a + kP e^T Psi qd_a; with tau of
        (40) it equals -kV qd_a^T qd_a (36).
        """
        q, qd = np.asarray(q, float), np.asarray(qd, float)
        tau = self.torque(q, qd) if tau is None else np.asarray(tau, float)
        qdd = self.model.acceleration(q, qd, tau)
        qd_a = qd[..., 1:]
        e = self.vcl_error(q)
        e_rate = np.einsum("...ij,...j->...i", Psi(self.model.b2, self.model.b3, q[..., 2]), qd_a)
        return (self.energy_error(q, qd) * np.sum(qd_a * tau, -1)
                + self.kD * np.sum(qd_a * qdd[..., 1:], -1) + self.kP * np.sum(e * e_rate, -1))


class LQRController(Controller):
    """LQR balance controller (67): tau = -K x, x = [q1, q2 + pi, q3, d1, d2, d3] wrapped.

    Parameters
    ----------
    K : array_like, shape (2, 6)
        State-feedback gain, normally :func:`paa_mj.theory.lqr_gain` (Q = 1e4 I6, R = I2).
    """

    def __init__(self, K, torque_limit=None):
        self.K = np.asarray(K, float)
        if self.K.shape != (2, 6):
            raise PaaError(f"LQR gain must be 2 x 6, got {self.K.shape}")
        self.torque_limit = torque_limit

    @classmethod
    def for_model(cls, model: AnalyticModel, torque_limit=None):
        return cls(lqr_gain(model), torque_limit=torque_limit)

    def torque(self, q, qd):
        return self.saturate(-udd_error(q, qd) @ self.K.T)


def in_switch_region(q, qd):
    """Region (68): every |x_i| < pi/6 and |x_{i+3}| < 0.5 with x = :func:`udd_error`."""
    x = udd_error(q, qd)
    return np.all(np.abs(x[..., :3]) < SWITCH_ANGLE, -1) & np.all(np.abs(x[..., 3:]) < SWITCH_SPEED, -1)


def switch_margin(q, qd):
    """A continuous function that is negative exactly inside region (68) (an ODE event)."""
    x = udd_error(q, qd)
    return np.max(np.concatenate([np.abs(x[..., :3]) / SWITCH_ANGLE, np.abs(x[..., 3:]) / SWITCH_SPEED], -1), -1) - 1


class SwitchingController(Controller):
    """Swing-up (40) until the state first enters region (68), then LQR (67) for good.

    The switch is one-way. ``mode`` is 0 during swing-up and 1 once balancing;
    with a batch of states each element switches on its own.

    Parameters
    ----------
    swing_up : EnergyVCLController
    balance : LQRController
    enabled : bool
        False keeps controller (40) for the whole run (the paper's Figs. 6-8, 12-14).
    """

    SWING_UP, BALANCE = 0, 1

    def __init__(self, swing_up: EnergyVCLController, balance: LQRController, enabled=True):
        self.swing_up, self.balance, self.enabled = swing_up, balance, enabled
        self.mode = np.int8(self.SWING_UP)

    @classmethod
    def for_model(cls, model: AnalyticModel, kD, kP, kV, torque_limit=None, enabled=True, check=True):
        return cls(EnergyVCLController(model, kD, kP, kV, torque_limit=torque_limit, check=check),
                   LQRController.for_model(model, torque_limit=torque_limit), enabled=enabled)

    @property
    def torque_limit(self):
        return self.swing_up.torque_limit

    def reset(self):
        self.mode = np.int8(self.SWING_UP)

    def update_mode(self, q, qd):
        """Apply the switching rule (68) and return the mode(s)."""
        if self.enabled:
            self.mode = np.where(in_switch_region(q, qd), self.BALANCE, self.mode).astype(np.int8)
        return self.mode

    def torque(self, q, qd):
        mode = self.update_mode(q, qd)
        if np.all(mode == self.BALANCE):
            return self.balance.torque(q, qd)
        if np.all(mode == self.SWING_UP):
            return self.swing_up.torque(q, qd)
        return np.where(mode[..., None] == self.BALANCE, self.balance.torque(q, qd), self.swing_up.torque(q, qd))


def check_gains(model: AnalyticModel, kD, kP, kV, stacklevel=3):
    """Validate gains against the theory.

    Raises
    ------
    PaaError
        kD <= kD_min of (41) (the controller can hit a singular Lambda), or kV <= 0.

    Warns
    -----
    TheoryWarning
        kP <= eta1 (59) or eta2 (60), E_r <= 0, or constraint (54) fails: Theorem 1
        no longer guarantees convergence to W_r or DUU, but the run may go on.
    """
    from .theory import constraint_54, thresholds

    for name, value in (("kD", kD), ("kP", kP), ("kV", kV)):
        if not np.isfinite(value):
            raise PaaError(f"gain {name} = {value} is not finite")
    if kV <= 0:
        raise PaaError(f"gain kV = {kV:g} must be > 0 (dV/dt = -kV |qd_a|^2 (36))")
    kd, e1, e2 = thresholds(model)
    if kD <= kd.value:
        raise PaaError(f"gain kD = {kD:g} is not above kD_min = {kd.value:.6g} of (41): controller (40) can become singular")
    messages = []
    if model.E_r <= 0:
        messages.append(f"E_r = {model.E_r:.6g} J <= 0: the method of the paper does not apply (9)")
    if kP <= e1.value:
        messages.append(f"kP = {kP:g} is not above eta1 = {e1.value:.6g} of (59): Theorem 1 no longer guarantees convergence")
    if kP <= e2.value:
        messages.append(f"kP = {kP:g} is not above eta2 = {e2.value:.6g} of (60): Theorem 1 no longer guarantees convergence")
    c54 = constraint_54(model)
    if not c54.holds:
        messages.append(f"constraint (54) fails (f(z) = 1 near z = {c54.z_closest:.4g}): Theorem 1 does not apply, the swing-up may stall")
    for message in messages:
        warnings.warn(message, TheoryWarning, stacklevel=stacklevel)
    return messages
