"""Model-predictive control on the robot's own equations of motion: iLQR over a receding horizon, then the LQR.

At a measured state y and time t the controller first estimates the state x it acts on
(:mod:`paa_mj.control.mpc_law`: a model-based observer that trusts the angles, the loop's latency scored from the
angles' second differences against the torques it commanded, and a prediction over that latency; ``estimate=0``
acts on y itself), then

1. balances by the LQR tau = -K e (e = [wrap(q - q*), qd]) while its cost-to-go e^T S e is below ``rho_in``,
   until it rises above ``rho_out`` (hysteresis; S, K the continuous Riccati solution at the goal with
   Q = diag(q_angle I, q_speed I), R = r_lqr I);
2. otherwise follows a plan of N knots of h seconds: every ``period`` seconds it solves the plan again by iLQR
   (:mod:`paa_mj.control.mpc_kernels`: RK4 knots on (1) with the robot's parameters, box-clamped DDP, a terminal
   cost s e^T S e), warm-started from the plan it keeps, shifted to t; where the state is far from where the plan
   put it (a push, a reset), or there is no plan, it also solves from an energy-pumping guess and from zero torque
   and keeps the cheapest. Between solves it applies

   .. math:: \\tau = \\bar u(t) + K_i \\left(x - \\bar x(t)\\right),

   \\bar u linear between the knots' midpoints, \\bar x linear between knots, K_i the iLQR's feedback gain.

The law reads only the measured state x = [q, qd] and the time t, and keeps its plan in its memory (the compiled
form's ``memory``, one per rollout): nothing of the run's disturbances reaches it.
"""
from __future__ import annotations

import numpy as np

from ..errors import PaaError
from ..model.dynamics import AnalyticModel
from ..task import Task
from .base import CompiledForm, Controller, kernel
from .record import controller
from . import mpc_kernels as mk
from . import mpc_law

#: Defaults for the family (see docs/controllers.md for the search behind them).
DEFAULTS = {
    "horizon": 1.0,        # s
    "knot": 0.02,          # s
    "period": 0.02,        # s between solves
    "iterations": 2,       # iLQR iterations per solve
    "cold_iterations": 15,  # iLQR iterations from a fresh guess
    "w_angle": 3.0,        # weight of (1 - cos e) per joint [1/s]
    "w_speed": 0.05,       # weight of qd^2 [s/rad^2 /s]
    "r": 0.05,             # weight of u^2
    "r_rate": 0.1,         # weight of (du/h)^2 h^2 = du^2
    "terminal": 10.0,      # scale of the terminal e^T S e
    "q_angle": 10.0, "q_speed": 1.0, "r_lqr": 1.0,   # the LQR at the goal
    "rho_in": 1.0, "rho_out": 5.0,  # hand-over levels of e^T S e
    "pump": 1.0, "pump_kp": 5.0, "pump_kd": 0.5,   # the energy-pumping guess
    "restart": 0.5,        # distance of the state from the plan's that restarts the solve
    "respin": 3.0,         # J above the goal's energy beyond which it solves afresh every 5 periods (0: never)
    "estimate": 1.0,       # 1: act on the estimator's state (paa_mj.control.mpc_law), 0: on the measurement
    "observer_angle": 0.5,  # a: share of the angles' innovation / dt added to the speeds
    "observer_speed": 0.05,  # b: share of the measured speeds' innovation
    "lag_memory": 1.0,     # s, memory of the latency's scores (0: no latency estimated)
    "lag_gate": 0.03,      # N m, the residual beyond which a step does not score the latencies
}


def goal_lqr(model: AnalyticModel, task: Task, q_angle, q_speed, r_lqr):
    """(S, K) of the LQR at the task's goal: the continuous Riccati solution of (1) linearised there with
    Q = diag(q_angle I, q_speed I), R = r_lqr I, and K = R^-1 B^T S."""
    from scipy.linalg import solve_continuous_are

    A, B = model.linearize(task.goal)
    n = model.n_links
    Q = np.diag(np.r_[np.full(n, q_angle), np.full(n, q_speed)])
    R = r_lqr * np.eye(n - 1)
    S = solve_continuous_are(A, B, Q, R)
    return S, np.linalg.solve(R, B.T @ S)


@kernel
def mpc_kernel(x, t, params, memory, tau):
    """Compiled MPC law (:func:`~paa_mj.control.mpc_law.mpc_torque`)."""
    return mpc_law.mpc_torque(params, x, t, memory, tau)


class MPCController(Controller):
    """iLQR model-predictive control with an LQR at the goal (module docstring), for any chain and goal.

    Parameters
    ----------
    model : AnalyticModel
        The model the plans are made on (the robot's own).
    task : Task
        The goal q*.
    torque_limit : array_like (n - 1,)
        The box of the plans [N m] (the robot's actuator ranges); an infinite one is replaced by the gravity torque
        the motor carries at worst, sum_{k >= j} b_k (the links beyond it held level).
    **options
        Any of :data:`DEFAULTS`.
    """

    name = "mpc"

    def __init__(self, model: AnalyticModel, task: Task, torque_limit, **options):
        unknown = sorted(set(options) - set(DEFAULTS))
        if unknown:
            raise PaaError(f"mpc has no option(s) {', '.join(unknown)}; its options: {', '.join(DEFAULTS)}")
        o = {**DEFAULTS, **{k: float(v) for k, v in options.items()}}
        n = model.n_links
        limit = np.array(np.broadcast_to(np.asarray(torque_limit, float), (n - 1,)))
        if np.any(np.isnan(limit)) or np.any(limit <= 0):
            raise PaaError(f"mpc plans within positive torque limits, got {limit.tolist()}")
        # a motor without a range gets the gravity torque it carries at worst, sum_{k >= j} b_k (the links beyond it
        # held level): the plans need a box
        carried = np.cumsum(model.gravity_constants[::-1])[::-1][1:]
        limit = np.where(np.isfinite(limit), limit, carried)
        knots = int(round(o["horizon"] / o["knot"]))
        if knots < 2 or o["period"] <= 0 or o["iterations"] < 1:
            raise PaaError("mpc needs a horizon of at least two knots, a positive period and at least one iteration")
        self.model, self.task, self.options, self.limit = model, task, o, limit
        self.S, self.K = goal_lqr(model, task, o["q_angle"], o["q_speed"], o["r_lqr"])
        p = model.params
        header = np.zeros(mk.HEADER)
        header[[mk.H_N, mk.H_KNOTS, mk.H_STEP, mk.H_PERIOD, mk.H_ITERS, mk.H_RHO_IN, mk.H_RHO_OUT, mk.H_TERM,
                mk.H_PUMP, mk.H_RESTART, mk.H_ITERS_COLD, mk.H_PUMP_KP, mk.H_PUMP_KD, mk.H_E_GOAL]] = [
            n, knots, o["knot"], o["period"], o["iterations"], o["rho_in"], o["rho_out"], o["terminal"], o["pump"],
            o["restart"], o["cold_iterations"], o["pump_kp"], o["pump_kd"], task.goal_energy(model)]
        header[[mpc_law.H_ESTIMATE, mpc_law.H_OBS_ANGLE, mpc_law.H_OBS_SPEED, mpc_law.H_LAG_MEMORY,
                mpc_law.H_LAG_GATE]] = [o["estimate"], o["observer_angle"], o["observer_speed"], o["lag_memory"],
                                        o["lag_gate"]]
        header[mpc_law.H_RESPIN] = o["respin"]
        self.params = np.concatenate([
            header, task.goal, limit, model.inertia_constants.reshape(-1), model.gravity_constants,
            np.broadcast_to(p.damping, (n,)), np.broadcast_to(p.armature, (n,)), np.full(n, o["w_angle"]),
            np.full(n, o["w_speed"]), np.full(n - 1, o["r"]), np.full(n - 1, o["r_rate"]), self.S.reshape(-1),
            self.K.reshape(-1)]).astype(float)
        assert self.params.size == mk.offsets(n)[-1]
        self.memory0 = np.zeros(mpc_law.memory_size(n, n - 1, knots))
        self._memory = {}
        self.mode = np.int8(0)
        self.bind(model, task)

    def reset(self):
        self._memory = {}
        self.mode = np.int8(0)

    def law(self, q, qd, t):
        q, qd = np.broadcast_arrays(np.asarray(q, float), np.asarray(qd, float))
        batch = q.shape[:-1]
        x = np.ascontiguousarray(np.concatenate([q, qd], axis=-1).reshape(-1, q.shape[-1] * 2))
        memory = self._memory.get(x.shape[0])
        if memory is None:
            memory = self._memory[x.shape[0]] = np.tile(self.memory0, (x.shape[0], 1))
        tau = np.empty((x.shape[0], q.shape[-1] - 1))
        mode = np.empty(x.shape[0], np.int8)
        for r in range(x.shape[0]):
            mode[r] = mpc_law.mpc_torque(self.params, x[r], float(t), memory[r], tau[r])
        self.mode = mode.reshape(batch) if batch else mode[0]
        return tau.reshape(batch + (q.shape[-1] - 1,))

    def compiled(self) -> CompiledForm:
        return CompiledForm(mpc_kernel, self.params, memory=self.memory0, balance_gain=None)

    def describe(self) -> dict:
        return {"controller": self.name, **self.options}


@controller("mpc", "iLQR model-predictive control on the robot's own model over a receding horizon, then an LQR at"
            " the goal", hands_over=True, kernels=(mpc_kernel,),
            settings=("horizon", "knot", "period", "iterations", "cold_iterations", "w_angle", "w_speed",
                      "r", "r_rate", "terminal", "q_angle", "q_speed", "r_lqr", "rho_in", "rho_out", "pump", "pump_kp",
                      "pump_kd", "restart", "respin", "estimate", "observer_angle", "observer_speed", "lag_memory",
                      "lag_gate"),
            checked=(("realaigym_acrobot", "stretched"), ("acrobot", "stretched")))
def build_mpc(robot, task, gains=None, check=True, **options):
    """iLQR model-predictive control with an LQR at the goal (module docstring), within the robot's actuator
    ranges."""
    return MPCController(robot.analytic, task, robot.torque_limits, **options)
