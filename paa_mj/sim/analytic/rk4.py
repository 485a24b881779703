"""MuJoCo's RK4 step on the package's own equations of motion: the physics ``"analytic"`` of the Gymnasium
environments (:class:`paa_mj.envs.single.GymnastEnv`, :class:`paa_mj.envs.vector.GymnastVectorEnv`).

One step over dt [s] with the motors' torques tau held, x = [q, qd], f(x) = [qd, qdd(q, qd, tau)] of (1):
k1 = f(x), k2 = f(x + dt/2 k1), k3 = f(x + dt/2 k2), k4 = f(x + dt k3), x += dt/6 (k1 + 2 k2 + 2 k3 + k4),
the classic method MuJoCo's ``RK4`` integrator applies to its own model. The accelerations are the paper's
closed form (1)-(7) for the gymnast's shape (:func:`paa_mj.model.equations.acceleration`) and the chain's
(:func:`paa_mj.model.chain.acceleration_into`, damping and armature included) for every other robot: the same
equations as MuJoCo's (``paa-mj check``), so a step agrees with ``mj_step`` to rounding, not bit for bit.
"""
from __future__ import annotations

import numpy as np
from numba.extending import register_jitable

from ...model import chain
from ...model import equations as eq

#: Layout of the constants: the paper's c (9) or the chain's A (n x n), b, damping, armature, the motor of each joint
#: (:func:`paa_mj.model.chain.drive_map`), then the time step
#: [s], 1.0 for the paper's closed form (else 0.0) and the number of links, counted from the end. The robot's
#: constants come first so that the closed form reads them in place (no view is made in the step).
_DT, _PAPER, _LINKS = -3, -2, -1


@register_jitable
def work_size(n):
    """The scratch numbers :func:`rk4_step` needs for n links."""
    return 5 * n + chain.ACCELERATION_WORK[0] * n * n + chain.ACCELERATION_WORK[1] * n


def rk4_constants(analytic, dt) -> np.ndarray:
    """The constants :func:`rk4_step` takes for an :class:`~paa_mj.model.dynamics.AnalyticModel` and a step dt [s]:
    the model's own (:meth:`~paa_mj.model.dynamics.AnalyticModel.kernel_constants`), then the tail."""
    constants, closed_form = analytic.kernel_constants()
    return np.concatenate([constants, [float(dt), 1.0 if closed_form else 0.0, float(analytic.n_links)]])


@register_jitable
def acceleration_into(constants, q, qd, tau, out, work):
    """qdd(q, qd, tau) of (1) into ``out`` (n) [rad/s^2], by the closed form or the chain's (module docstring);
    ``work``: scratch space (:func:`work_size`)."""
    n = q.size
    if constants[_PAPER] == 1.0:
        out[0], out[1], out[2] = eq.acceleration(constants, q[0], q[1], q[2], qd[0], qd[1], qd[2], tau[0], tau[1])
        return
    A = constants[:n * n].reshape((n, n))
    chain.acceleration_into(A, constants[n * n:n * n + n], constants[n * n + n:n * n + 2 * n],
                            constants[n * n + 2 * n:n * n + 3 * n], constants[n * n + 3 * n:n * n + 4 * n], q, qd,
                            tau, out, work)


@register_jitable
def rk4_step(constants, q, qd, tau, work):
    """One RK4 step (module docstring) of ``q``, ``qd`` (n) in place, ``tau`` (m) [N m] held; ``work`` is scratch
    space of at least :func:`work_size` numbers (allocated once by the caller: the step allocates nothing).

    ``work`` holds the stage's q, qd, qdd and the weighted sums of qd and qdd (n each), addressed by offset: the
    closed form's step makes no array view, which halves its cost.
    """
    n = q.size
    dt = constants[_DT]
    paper = constants[_PAPER] == 1.0
    QD, QDD, SUM_QD, SUM_QDD = n, 2 * n, 3 * n, 4 * n
    for i in range(n):
        work[i], work[QD + i], work[SUM_QD + i], work[SUM_QDD + i] = q[i], qd[i], 0.0, 0.0
    for stage in range(4):
        if paper:
            work[QDD], work[QDD + 1], work[QDD + 2] = eq.acceleration(
                constants, work[0], work[1], work[2], work[QD], work[QD + 1], work[QD + 2], tau[0], tau[1])
        else:
            acceleration_into(constants, work[:n], work[QD:QDD], tau, work[QDD:SUM_QD], work[5 * n:])
        weight = 1.0 if stage == 0 or stage == 3 else 2.0
        h = 0.5 * dt if stage < 2 else (dt if stage == 2 else 0.0)
        for i in range(n):
            work[SUM_QD + i] += weight * work[QD + i]
            work[SUM_QDD + i] += weight * work[QDD + i]
            work[i] = q[i] + h * work[QD + i]
            work[QD + i] = qd[i] + h * work[QDD + i]
    for i in range(n):
        q[i] += dt / 6.0 * work[SUM_QD + i]
        qd[i] += dt / 6.0 * work[SUM_QDD + i]
