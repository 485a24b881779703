"""Time-varying LQR tracking of a stored trajectory, and the optimised kip as a controller.

Along a reference (x_ref(t), u_ref(t)) of duration T, (1) linearised gives
A(t), B(t) (exact derivatives of :mod:`paa_mj.model.equations` by CasADi). The
Riccati differential equation

.. math::

    -\\dot S = A^\\top S + S A - S B R^{-1} B^\\top S + Q, \\qquad S(T) = S_{UDD}

is integrated backwards from T to 0 with SciPy (S_UDD the solution of the
algebraic Riccati equation of (67) at UDD, so the hand-over is seamless), and

.. math::

    \\tau = u_{ref}(t) - K(t) \\left(x - x_{ref}(t)\\right), \\qquad K = R^{-1} B^\\top S,

with the angle error wrapped to (-pi, pi]. References and gains are tabled
every ``table_dt`` seconds and interpolated linearly; the compiled kernel reads
the same table. After T the LQR (67) takes over (:func:`kip_controller`).
"""
from __future__ import annotations

import numpy as np
from numba import types
from numba.extending import register_jitable

from ..errors import PaaError
from ..jit import lazy_njit
from ..model.dynamics import AnalyticModel
from ..model.states import wrap
from ..task import Task
from ..theory.linear import LQR_Q, LQR_R, LQR_WEIGHT, goal_linearization, lqr_weight_matrices
from .base import CompiledForm, Controller, kernel
from .combined import CombinedController, TimeCondition, time_condition
from .lqr import LQRController, lqr_kernel
from ..model.equations import casadi_module
from .record import controller
from .trajopt import BUDGET_CPU_S, INTERVALS, Kip, dynamics_function, solve_kip

#: Table step of the tracking controller [s] (the physics step of the named robots).
TABLE_DT = 1e-3
_HEADER = 2  # params = [n, dt, x_ref (n x nx), u_ref (n x nu), K (n x nu x nx)], nx = 2 links, nu = links - 1


@register_jitable
def tvlqr_torque(params, t, x, tau):
    """tau = u_ref(t) - K(t) (x - x_ref(t)) into ``tau`` from the table in ``params`` (linear interpolation,
    clamped), angles of the error wrapped. Compiled on one state, or in NumPy on a batch laid out along the last
    axis (x of shape (nx, ...), tau (nu, ...)), the same sums in the same order."""
    n = int(params[0])
    dt = params[1]
    nx, nu = x.shape[0], tau.shape[0]
    s = t / dt
    i = int(min(max(np.floor(s), 0.0), float(n) - 2.0))
    w = min(max(s - float(i), 0.0), 1.0)
    xr, ur, kr = _HEADER, _HEADER + nx * n, _HEADER + (nx + nu) * n
    for row in range(nu):
        u = (1.0 - w) * params[ur + nu * i + row] + w * params[ur + nu * (i + 1) + row]
        for j in range(nx):  # the error of state j, again for each row: no list, so that a Warp device runs it too
            ref = (1.0 - w) * params[xr + nx * i + j] + w * params[xr + nx * (i + 1) + j]
            error = wrap(x[j] - ref) if j < nx // 2 else x[j] - ref
            gain = (1.0 - w) * params[kr + nu * nx * i + nx * row + j] \
                + w * params[kr + nu * nx * (i + 1) + nx * row + j]
            u = u - gain * error
        tau[row] = u


@kernel
def tvlqr_kernel(x, t, params, memory, tau):
    """Compiled tracking (mode 0: following the stored trajectory)."""
    tvlqr_torque(params, t, x, tau)
    return 0


_MATRICES = types.float64[:, :, ::1]


@lazy_njit(types.float64[::1](types.float64, types.float64[::1], types.float64, _MATRICES, _MATRICES,
                         types.float64[:, ::1], types.float64[:, ::1]), cache=True)
def riccati_field(t, s_flat, step, A_all, B_all, R_inv, Q):
    """dS/dt = -(A^T S + S A - S B R^-1 B^T S + Q) at time t [s], symmetrised, S flattened (nx * nx).

    A(t), B(t) are interpolated linearly in the tables ``A_all`` (N, nx, nx) and ``B_all`` (N, nx, nu), whose
    entries are ``step`` seconds apart (held at the ends).
    """
    n_table, nx = A_all.shape[0], A_all.shape[1]
    s = min(max(t / step, 0.0), n_table - 1.000001)
    i = int(s)
    w = s - i
    j = min(i + 1, n_table - 1)
    A = (1.0 - w) * A_all[i] + w * A_all[j]
    B = (1.0 - w) * B_all[i] + w * B_all[j]
    S = s_flat.reshape((nx, nx))
    dS = -(np.ascontiguousarray(A.T) @ S + S @ A - S @ B @ R_inv @ np.ascontiguousarray(B.T) @ S + Q)
    out = np.empty(nx * nx)
    for r in range(nx):
        for c in range(nx):
            out[r * nx + c] = 0.5 * (dS[r, c] + dS[c, r])
    return out


def riccati_gains(am: AnalyticModel, times, x_ref, u_ref, task: Task, Q=None, R=None):
    """K(t) at ``times`` (n, nu, nx) of the LQR along the reference, S(T) from (67)'s Riccati equation at the task's
    goal (UDD for the gymnast); Q, R default to the paper's weights sized for the robot."""
    from scipy.integrate import solve_ivp
    from scipy.linalg import solve_continuous_are

    ca = casadi_module()
    f = dynamics_function(am)
    nx, nu = 2 * am.n_links, am.n_motors
    Q, R = lqr_weight_matrices(am.n_links, Q, R, nu)
    x, u = ca.SX.sym("x", nx), ca.SX.sym("u", nu)
    jac = ca.Function("AB", [x, u], [ca.jacobian(f(x, u), x), ca.jacobian(f(x, u), u)])
    pairs = [jac(x_ref[i], u_ref[i]) for i in range(len(times))]
    A_all = np.array([np.array(a) for a, _ in pairs], dtype=float)
    B_all = np.array([np.array(b) for _, b in pairs], dtype=float)
    A_goal, B_goal = goal_linearization(am, task)
    S_end = solve_continuous_are(A_goal, B_goal, Q, R)
    R_inv = np.ascontiguousarray(np.linalg.inv(R), dtype=float)
    Q = np.ascontiguousarray(Q, dtype=float)
    step = float(times[1] - times[0])

    def rhs(t, s_flat):
        return riccati_field(float(t), np.ascontiguousarray(s_flat, dtype=float), step, A_all, B_all, R_inv, Q)

    sol = solve_ivp(rhs, (times[-1], times[0]), S_end.reshape(-1), method="LSODA", rtol=1e-8, atol=1e-6,
                    dense_output=True)
    if not sol.success:
        raise PaaError(f"the Riccati equation of the tracking controller failed: {sol.message}")
    S = sol.sol(times).T.reshape(-1, nx, nx)
    return np.einsum("ij,njk,nkl->nil", R_inv, B_all.transpose(0, 2, 1), S)


class TVLQRController(Controller):
    """Feedforward u_ref plus time-varying LQR feedback along a solved :class:`~paa_mj.control.trajopt.Kip`.

    Parameters
    ----------
    model : AnalyticModel
        The robot the tracking gains are computed for.
    kip : Kip
    table_dt : float
        Step of the reference and gain table [s].
    task : Task
        The task whose goal the kip ends at (the Riccati equation's end condition is its LQR's).
    """

    name = "tvlqr"

    def __init__(self, model: AnalyticModel, kip: Kip, task: Task, table_dt=TABLE_DT):
        self.model, self.kip = model, kip
        n = int(np.ceil(kip.duration / table_dt)) + 1
        self.times = np.arange(n) * table_dt
        self.params = _cached_table(model, kip, self.times, table_dt, task)
        self.bind(model, task)

    @property
    def duration(self):
        return self.kip.duration

    def reference(self, t):
        """(x_ref, u_ref) at time t as the controller tables them."""
        x, u = self.kip.sample(np.atleast_1d(t), self.model)
        return x[0], u[0]

    def law(self, q, qd, t):
        x = np.concatenate(np.broadcast_arrays(q, qd), axis=-1)
        tau = np.empty(x.shape[:-1] + (x.shape[-1] // 2 - 1,))
        tvlqr_torque(self.params, float(t), np.moveaxis(x, -1, 0), np.moveaxis(tau, -1, 0))
        return tau

    def compiled(self) -> CompiledForm:
        return CompiledForm(tvlqr_kernel, self.params)

    def describe(self) -> dict:
        return {"controller": self.name, "plan": self.kip.plan()}


def _cached_table(model, kip, times, table_dt, task: Task):
    """The controller's table [n, dt, x_ref, u_ref, K], from the trajectory cache when it is there."""
    from ..io import write_npz
    from ..provenance import cache_key
    from .trajopt import cache_dir

    nx, nu = 2 * model.n_links, model.n_motors
    weights = (LQR_Q.tolist(), LQR_R.tolist()) if nx == 6 else (LQR_WEIGHT, nx, nu)
    digest = cache_key(kind="tvlqr", model=model.key(), table_dt=table_dt, weights=weights, goal=task.name,
                       x=kip.x, u=kip.u, x_mid=kip.x_mid, u_mid=kip.u_mid)
    path = cache_dir() / f"tvlqr-{digest}.npz"
    if path.is_file():
        try:
            with np.load(path, allow_pickle=False) as z:
                kept = np.array(z["params"], dtype=float)
        except Exception:  # a damaged entry is computed again
            kept = None
        n = len(times)
        if kept is not None and kept.shape == (2 + n * (nx + nu + nu * nx),) and kept[0] == n and kept[1] == table_dt \
                and np.all(np.isfinite(kept)):
            return kept  # else: not this table (damaged, or written by other code), computed again
    x_ref, u_ref = kip.sample(times, model)
    K = riccati_gains(model, times, x_ref, u_ref, task)
    params = np.concatenate([[len(times), table_dt], x_ref.reshape(-1), u_ref.reshape(-1), K.reshape(-1)])
    try:
        write_npz(path, params=params)
    except PaaError:
        pass
    return params


def kip_controller(model: AnalyticModel, kip: Kip, task: Task, name="trajopt", lqr_weights=None) \
        -> CombinedController:
    """Track ``kip`` by TVLQR, then balance by the LQR (67) at the task's goal once it has ended (t >= T);
    ``lqr_weights`` (q, r) weigh that LQR (default the paper's)."""
    tracking = TVLQRController(model, kip, task)
    return CombinedController(tracking, LQRController.for_model(model, task, lqr_weights), TimeCondition(kip.duration),
                              name=name)


# The planned kips, tracked: ``trajopt`` and ``trajopt-effort``. Each builder takes (robot, task, gains, check,
# **options) and, where the controller believes in a model other than the plant's, the ``plant``.

#: Fraction of the torque limit a planned kip may use (the rest is the tracking controller's).
HEADROOM = 0.9
#: Duration of a min-effort kip when none is given [s].
EFFORT_DURATION = 3.0


def _kip_bound(robot, limit):
    limits = robot.capped_torque_limits(limit, "the option limit")
    if not np.all(np.isfinite(limits)):
        raise PaaError("a planned kip needs a torque limit: give limit=(T2, T3) [N m] or a model with actuator ranges"
                       " (the command line uses the peak torques of vcl from (65))")
    return HEADROOM * limits


def _planned_kip(robot, task, limit, objective, duration, intervals, plant, budget):
    """The kip ``robot`` plans within :data:`HEADROOM` of the torque limit (option ``limit``, or the robot's
    actuator ranges); a controller that believes in a model other than its ``plant``'s starts IPOPT from the
    plant's own kip (the same bounds and settings), so that a perturbed model re-plans near that plan."""
    bound = _kip_bound(robot, limit)
    start = None
    if plant is not None and plant.params != robot.params:
        start = solve_kip(plant.analytic, bound, objective, duration=duration, intervals=intervals, task=task,
                          budget_cpu_s=budget)
    return solve_kip(robot.analytic, bound, objective, duration=duration, intervals=intervals, task=task,
                     start=start, budget_cpu_s=budget)


@controller("trajopt", "minimum-time kip by collocation, tracked by TVLQR, then (67)", plans=True, lqr=True,
            passive=None, compare=True, device=True, kernels=(tvlqr_kernel, lqr_kernel, time_condition),
            checked=(("gymnast", "folded"),), check_options=(("limit", (470.0, 217.0)), ("intervals", 16)))
def build_trajopt(robot, task, gains=None, check=True, limit=None, duration=None, intervals=INTERVALS,
                  lqr_weights=None, plant=None, budget=BUDGET_CPU_S):
    """The minimum-time kip, tracked by TVLQR, then (67); IPOPT's CPU-seconds at most ``budget``."""
    kip = _planned_kip(robot, task, limit, "min-time", duration, intervals, plant, budget)
    return kip_controller(robot.analytic, kip, task, name="trajopt", lqr_weights=lqr_weights)


@controller("trajopt-effort", "least-effort kip over a duration, tracked by TVLQR, then (67)", plans=True,
            lqr=True, passive=None, compare=True, device=True, kernels=(tvlqr_kernel, lqr_kernel, time_condition),
            checked=(("gymnast", "folded"),), check_options=(("limit", (470.0, 217.0)), ("intervals", 16)))
def build_trajopt_effort(robot, task, gains=None, check=True, limit=None, duration=EFFORT_DURATION,
                         intervals=INTERVALS, lqr_weights=None, plant=None, budget=BUDGET_CPU_S):
    """The kip of least effort over ``duration`` seconds, tracked by TVLQR, then (67); IPOPT's CPU-seconds at most
    ``budget``."""
    kip = _planned_kip(robot, task, limit, "min-effort", duration, intervals, plant, budget)
    return kip_controller(robot.analytic, kip, task, name="trajopt-effort", lqr_weights=lqr_weights)
