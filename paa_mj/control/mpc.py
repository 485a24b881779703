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
   put it (a push, a reset), or there is no plan, it also solves from an energy-pumping guess, from the clamped LQR's
   rollout and, on a chain spinning with energy to spare, from a braking guess (u_j = -k_b qd_a), and keeps the
   cheapest finite plan (none finite: it brakes until the next solve); a solve from a state that turns a link more
   than ``turn`` rad per knot integrates each knot in RK4 sub-steps of at most that turn. Between solves it applies

   .. math:: \\tau = \\bar u(t) + K_i \\left(x - \\bar x(t)\\right),

   \\bar u linear between the knots' midpoints, \\bar x linear between knots, K_i the iLQR's feedback gain.

The law reads only the measured state x = [q, qd] and the time t, and keeps its plan in its memory (the compiled
form's ``memory``, one per rollout): nothing of the run's disturbances reaches it.
"""
from __future__ import annotations

import numpy as np

from ..errors import PaaError
from ..model import chain
from ..model.dynamics import AnalyticModel
from ..model.similarity import REFERENCE, similarity
from ..task import Task
from .base import CompiledForm, Controller, kernel
from .record import controller
from . import mpc_estimator as me
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
    "brake": 3.0,          # gain of the braking guess tried then, in units of pump_kd (0: none)
    "turn": 0.5,           # rad a link turns per knot at a solve's state beyond which it plans with RK4 sub-steps
    "box": 2.0,            # a motor without a range plans within box times the gravity torque it carries
    "estimate": 1.0,       # 1: act on the estimator's state (paa_mj.control.mpc_law), 0: on the measurement
    "observer_angle": 0.5,  # a: share of the angles' innovation / dt added to the speeds
    "observer_speed": 0.05,  # b: share of the measured speeds' innovation
    "lag_memory": 1.0,     # s, memory of the latency's scores (0: no latency estimated)
    "lag_gate": 0.03,      # N m, the residual beyond which a step does not score the latencies
    "observer_accel": 0.2,  # rad/s^1.5, the model's error in each joint's acceleration as white noise (its intensity)
    "noise_memory": 0.5,   # s, memory of the angles' noise statistics (0: the angles are trusted as measured)
    "climb_horizon": 0.0,  # s, the horizon of a plan started afresh far below the goal's energy (0: the horizon's)
    "climb_deficit": 0.8,  # share of the energy gap from hanging at rest to the goal beyond which a plan climbs
    "climb_w_speed": 1.0,  # factor on w_speed in a climb's plans
    "climb_r": 1.0,        # factor on r in a climb's plans
    "climb_r_rate": 1.0,   # factor on r_rate in a climb's plans
    "spread": 0.0,         # iLQR iterations a call gives a restart, spread over calls (0: a restart in one call)
    "spin_cap": 8.0,       # RK4 sub-steps per knot beyond which a spinning chain is braked, not planned for (0: never)
}

# REFERENCE: the robot the defaults were searched on; every option is stated on its scale (:func:`similarity`).

#: Changes to :data:`DEFAULTS` per actuation pattern (:func:`pattern`), stated on :data:`REFERENCE`'s scale like every
#: option and carried over by :data:`SIMILARITY` like them. "passive shoulder" (joint 1 without a motor: the acrobot,
#: the gymnast, chain4) takes DEFAULTS as they are; "driven shoulder" (a motor at joint 1, which carries the whole
#: chain: RealAIGym's pendubot) takes a shorter horizon and a climb, from ``scripts/mpc_search.py --robot
#: realaigym_pendubot`` (docs/controllers.md): a 0.5 s horizon swings it straight up (0.7 s from hanging, ~0.8 s after
#: their global test's resets), while from hanging at rest the climb's 1.5 s plans, with dearer torques (r 30: 0.05 x
#: 600) and speeds (w_speed 0.2: 0.05 x 4), swing it back first, slower (1.3 s) and cheaper (their torque cost 2.5
#: against 4.0); the LQR takes over nearer the goal (rho_in 0.3: a smaller step at the hand-over).
PATTERN_DEFAULTS = {
    "passive shoulder": {},
    "driven shoulder": {"horizon": 0.5, "rho_in": 0.3, "climb_horizon": 1.5, "climb_w_speed": 4.0, "climb_r": 600.0},
}


#: Changes for a robot with a motor without a torque range in its MJCF (the family's gymnast and chain4: nothing bounds
#: its torque but the plans' ``box``), per actuation pattern, after :data:`PATTERN_DEFAULTS`'s; from
#: ``scripts/mpc_search.py --robot chain4`` and ``--robot gymnast --goal folded`` (docs/controllers.md). A passive
#: shoulder's: plans started afresh from a reset of their global test (a chain spun to tens of rad/s with energy to
#: spare) over a shorter horizon, which swing it up sooner, while from far below the
#: goal's energy (hanging at rest) the climb keeps the longer plans, whose kip is the faster there. A driven shoulder
#: without a range is not searched: none.
NO_RANGE_DEFAULTS = {
    "passive shoulder": {"horizon": 0.7, "climb_horizon": 1.0},
    "driven shoulder": {},
}


def pattern(model: AnalyticModel) -> str:
    """The robot's actuation pattern as :data:`PATTERN_DEFAULTS` names it: "driven shoulder" where joint 1 (the
    joint at the bar, carrying the whole chain) has a motor, "passive shoulder" otherwise."""
    return "driven shoulder" if 0 in tuple(model.actuated) else "passive shoulder"


def defaults(model: AnalyticModel, torque_limit=None) -> dict:
    """:data:`DEFAULTS` with the changes of the robot's actuation pattern (:data:`PATTERN_DEFAULTS`) and, where a motor
    has no range (an infinite ``torque_limit`` [N m], one per motor), those of :data:`NO_RANGE_DEFAULTS`, on
    :data:`REFERENCE`'s scale."""
    free = torque_limit is not None and not np.all(np.isfinite(np.asarray(torque_limit, float)))
    return {**DEFAULTS, **PATTERN_DEFAULTS[pattern(model)], **(NO_RANGE_DEFAULTS[pattern(model)] if free else {})}

#: How each option carries over from :data:`REFERENCE` to another robot by dynamic similarity: (a, c, b) multiplies
#: it by g^a g_j^c t^b (:func:`similarity`): g = G / G_ref the ratio of the robots' gravity torque scales, g_j that of
#: motor j's (c != 0: an option per motor), t = T / T_ref that of their natural times (:func:`~paa_mj.model.similarity.robot_scales`). Times
#: scale by t; the cost is kept without unit, so that a motion that is the reference's in the units (G, T) costs what
#: the reference's does: a weight of (1 - cos e) by 1/t, of qd^2 by t, of motor j's u^2 by 1/(t g_j^2), of its
#: (du)^2/h by t/g_j^2 (h a time); the LQR's Q and R as the running cost's, so that its S, the terminal cost and the
#: hand-over levels keep their numbers; the energy-pumping guess u = k_e (E* - E) qd - k_p e - k_d qd by the robot's
#: scale: k_e by t, k_p by g, k_d by g t.
SIMILARITY = {
    "horizon": (0, 0, 1), "knot": (0, 0, 1), "period": (0, 0, 1), "iterations": (0, 0, 0),
    "cold_iterations": (0, 0, 0), "w_angle": (0, 0, -1), "w_speed": (0, 0, 1), "r": (0, -2, -1), "r_rate": (0, -2, 1),
    "terminal": (0, 0, 0), "q_angle": (0, 0, -1), "q_speed": (0, 0, 1), "r_lqr": (0, -2, -1), "rho_in": (0, 0, 0),
    "rho_out": (0, 0, 0), "pump": (0, 0, 1), "pump_kp": (1, 0, 0), "pump_kd": (1, 0, 1), "restart": (0, 0, 0),
    "respin": (1, 0, 0), "brake": (0, 0, 0), "turn": (0, 0, 0), "box": (0, 0, 0), "estimate": (0, 0, 0),
    "observer_angle": (0, 0, 0), "observer_speed": (0, 0, 0), "lag_memory": (0, 0, 1),
    "lag_gate": (1, 0, 0), "observer_accel": (0, 0, -1.5), "noise_memory": (0, 0, 1), "climb_horizon": (0, 0, 1),
    "climb_deficit": (0, 0, 0), "climb_w_speed": (0, 0, 0), "climb_r": (0, 0, 0), "climb_r_rate": (0, 0, 0),
    "spread": (0, 0, 0), "spin_cap": (0, 0, 0),
}


def scaled_options(options: dict, model: AnalyticModel) -> dict:
    """The options (stated on :data:`REFERENCE`'s scale) carried over to ``model`` by :data:`SIMILARITY`: floats, and
    arrays (one per motor) for those of the motors."""
    g, gm, t = similarity(model)
    out = {}
    for key, value in options.items():
        a, c, b = SIMILARITY[key]
        out[key] = value * g ** a * t ** b * (gm ** c if c else 1.0)
    return out


def goal_lqr(model: AnalyticModel, task: Task, q_angle, q_speed, r_lqr):
    """(S, K) of the LQR at the task's goal: the continuous Riccati solution of (1) linearised there (B of the
    robot's m motors, :attr:`~paa_mj.model.dynamics.AnalyticModel.actuated`) with Q = diag(q_angle I, q_speed I),
    R = diag(r_lqr) (m, m; one weight, or one per motor), and K = R^-1 B^T S (m, 2n)."""
    from scipy.linalg import solve_continuous_are

    A, B = model.linearize(task.goal)
    n = model.n_links
    Q = np.diag(np.r_[np.full(n, q_angle), np.full(n, q_speed)])
    R = np.diag(np.broadcast_to(np.asarray(r_lqr, float), (model.n_motors,)))
    S = solve_continuous_are(A, B, Q, R)
    return S, np.linalg.solve(R, B.T @ S)


def climb_energy(model: AnalyticModel, task: Task, deficit) -> float:
    """E* - deficit (E* - E_rest) [J]: the energy below which a plan started afresh climbs
    (:func:`~paa_mj.control.mpc_law.climb_knots`), E* the goal's, E_rest = -sum_k b_k the chain's least (hanging at
    rest)."""
    goal = task.goal_energy(model)
    return goal - deficit * (goal + float(np.sum(np.abs(model.gravity_constants))))


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
    torque_limit : array_like (m,)
        The box of the plans [N m] (the robot's actuator ranges, one per motor); an infinite one is replaced by
        ``box`` (an option) times the gravity torque the motor carries at worst, sum_{k >= a} b_k for the motor on
        joint a (the links beyond it held level).
    **options
        Any of :data:`DEFAULTS`, stated on :data:`REFERENCE`'s scale (the defaults' robot) and carried over to this
        one by dynamic similarity (:data:`SIMILARITY`; :attr:`scaled` the values used); those not given take
        :func:`defaults` (the robot's actuation pattern's, and its motors' ranges').
    """

    name = "mpc"

    def __init__(self, model: AnalyticModel, task: Task, torque_limit, **options):
        unknown = sorted(set(options) - set(DEFAULTS))
        if unknown:
            raise PaaError(f"mpc has no option(s) {', '.join(unknown)}; its options: {', '.join(DEFAULTS)}")
        given = {**defaults(model, torque_limit), **{k: float(v) for k, v in options.items()}}
        o = scaled_options(given, model)
        n, nu = model.n_links, model.n_motors
        joints = list(model.actuated)
        limit = np.array(np.broadcast_to(np.asarray(torque_limit, float), (nu,)))
        if np.any(np.isnan(limit)) or np.any(limit <= 0):
            raise PaaError(f"mpc plans within positive torque limits, got {limit.tolist()}")
        # a motor without a range gets ``box`` times the gravity torque it carries at worst, sum_{k >= j} b_k (the
        # links beyond it held level): the plans need a box
        carried = np.cumsum(model.gravity_constants[::-1])[::-1][joints]
        limit = np.where(np.isfinite(limit), limit, o["box"] * carried)
        knots = int(round(o["horizon"] / o["knot"]))
        climb = int(round(o["climb_horizon"] / o["knot"]))
        if knots < 2 or o["period"] <= 0 or o["iterations"] < 1 or climb == 1 or climb < 0:
            raise PaaError("mpc needs a horizon of at least two knots (a climb_horizon of none or at least two), a "
                           "positive period and at least one iteration")
        if climb == knots:
            # a kept plan tells a climb from a balance by its length (mpc_law.replan): equal lengths would drop the
            # climb's weights without a word
            raise PaaError(f"mpc's climb_horizon must differ from its horizon ({o['horizon']:g} s, {knots} knots) or be "
                           "0 (no climb): a climb is told apart from a balance by its length")
        self.model, self.task, self.options, self.scaled, self.limit = model, task, given, o, limit
        self.S, self.K = goal_lqr(model, task, o["q_angle"], o["q_speed"], o["r_lqr"])
        p = model.params
        header = np.zeros(mk.HEADER)
        header[[mk.H_N, mk.H_KNOTS, mk.H_STEP, mk.H_PERIOD, mk.H_ITERS, mk.H_RHO_IN, mk.H_RHO_OUT, mk.H_TERM,
                mk.H_PUMP, mk.H_RESTART, mk.H_ITERS_COLD, mk.H_PUMP_KP, mk.H_PUMP_KD, mk.H_E_GOAL]] = [
            n, knots, o["knot"], o["period"], o["iterations"], o["rho_in"], o["rho_out"], o["terminal"], o["pump"],
            o["restart"], o["cold_iterations"], o["pump_kp"], o["pump_kd"], task.goal_energy(model)]
        header[mk.H_NU] = nu
        header[[me.H_ESTIMATE, me.H_OBS_ANGLE, me.H_OBS_SPEED, me.H_LAG_MEMORY, me.H_LAG_GATE]] = [
            o["estimate"], o["observer_angle"], o["observer_speed"], o["lag_memory"], o["lag_gate"]]
        header[[mpc_law.H_RESPIN, mpc_law.H_BRAKE, mpc_law.H_FAST]] = [o["respin"], o["brake"], o["turn"]]
        header[[mpc_law.H_SPREAD, mpc_law.H_SPIN_CAP]] = [round(o["spread"]), o["spin_cap"]]
        header[[me.H_OBS_ACCEL, me.H_NOISE_MEMORY]] = [o["observer_accel"], o["noise_memory"]]
        header[[mk.H_CLIMB_KNOTS, mpc_law.H_CLIMB_ENERGY, mpc_law.H_CLIMB_SPEED, mpc_law.H_CLIMB_R,
                mpc_law.H_CLIMB_RATE]] = [climb, climb_energy(model, task, o["climb_deficit"]), o["climb_w_speed"],
                                          o["climb_r"], o["climb_r_rate"]]
        self.params = np.concatenate([
            header, task.goal, limit, model.inertia_constants.reshape(-1), model.gravity_constants,
            np.broadcast_to(p.damping, (n,)), np.broadcast_to(p.armature, (n,)), chain.drive_map(n, joints),
            np.full(n, o["w_angle"]), np.full(n, o["w_speed"]), np.full(nu, o["r"]), np.full(nu, o["r_rate"]),
            self.S.reshape(-1), self.K.reshape(-1), self._regularisation_unit()]).astype(float)
        assert self.params.size == mk.offsets(n, nu)[-1]
        self.memory0 = np.zeros(mpc_law.memory_size(n, nu, max(knots, climb)))
        self._memory = {}
        self.mode = np.int8(0)
        # what a continuous-time integrator cannot honour (the analytic engine refuses it with this phrase)
        self.sampled_data = f"solves its plan every {o['period'] * 1e3:g} ms and keeps it between calls"
        self.bind(model, task)

    def _regularisation_unit(self):
        """iLQR's regularisation of Quu, per motor, in the unit of that motor's torque weights (1 / (t g_j^2))."""
        g, gm, t = similarity(self.model)
        return 1.0 / (t * gm * gm)

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
        nu = self.model.n_motors
        tau = np.empty((x.shape[0], nu))
        mode = np.empty(x.shape[0], np.int8)
        for r in range(x.shape[0]):  # the kernel itself: the law compiled once, for the engines' array layouts
            mode[r] = mpc_kernel(x[r], float(t), self.params, memory[r], tau[r])
        self.mode = mode.reshape(batch) if batch else mode[0]
        return tau.reshape(batch + (nu,))

    def compiled(self) -> CompiledForm:
        return CompiledForm(mpc_kernel, self.params, memory=self.memory0, balance_gain=None)

    def describe(self) -> dict:
        g, gm, t = similarity(self.model)
        carried = {} if g == t == 1.0 and np.all(gm == 1.0) else {
            "similarity": {"reference": REFERENCE, "g": g, "g_motors": gm.tolist(), "t": t}}
        return {"controller": self.name, **self.options, **carried}


@controller("mpc", "iLQR model-predictive control on the robot's own model over a receding horizon, then an LQR at"
            " the goal", hands_over=True, compare=True, kernels=(mpc_kernel,),
            settings=("horizon", "knot", "period", "iterations", "cold_iterations", "w_angle", "w_speed",
                      "r", "r_rate", "terminal", "q_angle", "q_speed", "r_lqr", "rho_in", "rho_out", "pump", "pump_kp",
                      "pump_kd", "restart", "respin", "brake", "turn", "box", "estimate", "observer_angle",
                      "observer_speed", "lag_memory", "lag_gate", "observer_accel", "noise_memory", "climb_horizon",
                      "climb_deficit", "climb_w_speed", "climb_r", "climb_r_rate", "spread", "spin_cap", "limit"),
            passive=None,
            checked=(("realaigym_acrobot", "stretched"), ("acrobot", "stretched"), ("realaigym_pendubot", "stretched")))
def build_mpc(robot, task, gains=None, check=True, limit=None, **options):
    """iLQR model-predictive control with an LQR at the goal (module docstring), planned within the robot's actuator
    ranges, capped by the run's torque limits ``limit`` [N m] where given (a board's or ``--torque-limit``)."""
    box = robot.torque_limits if limit is None else robot.capped_torque_limits(limit, "the option limit")
    return MPCController(robot.analytic, task, box, **options)
