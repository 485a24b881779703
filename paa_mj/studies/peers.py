"""paa_mj against a peer: Drake (RobotLocomotion), for the dynamics and for Spong's acrobot swing-up.

Two comparisons, run by ``paa-mj peers``; Drake is an optional extra (``pip install "paa_mj[peers]"``).
The dynamics are compared in :mod:`paa_mj.studies.peer_dynamics`; this module compares the closed loops.

**Closed loop.** Drake's ``AcrobotPlant`` with its ``AcrobotSpongController`` against paa_mj's
``spong`` (:mod:`paa_mj.control.spong`) on ``models/acrobot.xml`` in MuJoCo, from the same starts
(:data:`STARTS`, in Drake's coordinates). MuJoCo holds each torque over a step of dt (RK4 at 1 ms);
Drake's controller is continuous, so a ``ZeroOrderHold`` of period dt sits between Drake's controller
and its plant, and Drake integrates its plant between the samples with its error-controlled fifth-order
Runge-Kutta (``runge_kutta5``) at target accuracy :data:`DRAKE_ACCURACY`, steps of at most dt: what is
left of the difference is MuJoCo's RK4 error (checked: it shrinks as dt^4 when both use dt / 2).
Without the hold, Drake's continuous loop is compared with MuJoCo at several time steps; the
difference is then the hold's, O(dt). Drake's switch to its LQR is a test of the cost-to-go against
a threshold at each state, without hysteresis; where the two loops' costs straddle the threshold at the
same sample the loops split, and the tables say where (the switch split) and why (:func:`split_kind`): a
near-tie of the costs, a difference grown before, or Drake's wrapping. theta2 is wrapped to [-pi, pi) and the
cost-to-go is a quadratic form in the wrapped errors, so the set where the LQR acts (cost below the
threshold) meets the boundary theta2 = +-pi with the elbow folded back, far from the upright: two states a
hair apart on either side of it have costs orders of magnitude apart.

Per start: the largest difference of the angles [rad] and of the speeds [rad/s] over the first
:data:`WINDOW` seconds, the first time each loop's LQR acts (Drake's: the first sample whose cost-to-go,
computed with the S of Drake's own ``LinearQuadraticRegulator`` on Drake's own ``Linearize``, is below the
threshold; paa_mj's: the controller's mode), the time from which each stays within
the stretched task's balance tolerance of the upright (every angle error and speed) to the end, and
whether the outcomes (balanced at the end or not) agree.
"""
from __future__ import annotations

import math

import numpy as np

from ..errors import PaaError
from ..limits import check_seed
from ..task import STRETCHED_START_OFFSET, Task
from .drake import drake_version, require_drake, theta_from_x, x_from_theta
from .peer_dynamics import dynamics

#: Target accuracy of Drake's error-controlled integrator (``runge_kutta5``).
DRAKE_ACCURACY = 1e-12
#: The closed loops are compared over the first WINDOW seconds [s].
WINDOW = 3.0
#: Starts in Drake's coordinates (theta1, theta2, theta1dot, theta2dot) [rad, rad/s].
STARTS = {
    "drake-example": (1.2, 0.0, 0.0, 0.0),            # examples/acrobot/test/example_scenario.yaml
    "theta-1-1": (1.0, 1.0, 0.0, 0.0),
    "run-swing-up": (0.1, -0.1, 0.0, 0.02),           # examples/acrobot/run_swing_up.cc
    "paa-stretched": (STRETCHED_START_OFFSET, 0.0, 0.0, 0.0),  # the stretched task's start, in Drake's angles
    "scenario-low": (1.1, -0.1, -0.1, -0.1),          # corners of example_stochastic_scenario.yaml
    "scenario-high": (1.3, 0.1, 0.1, 0.1),
}
QUICK_STARTS = ("drake-example", "theta-1-1")
#: MuJoCo time steps [s] against Drake's continuous loop (no hold).
NO_HOLD_STEPS = (0.004, 0.002, 0.001, 0.0005)
QUICK_NO_HOLD_STEPS = (0.002, 0.001)
#: A start with the elbow straight and still has left that invariant set once abs(q2) exceeds this [rad].
ELBOW_LEFT = 1e-6


def drake_lqr():
    """(S, K) exactly as ``AcrobotSpongController``'s constructor computes them: Drake's ``Linearize`` of its
    ``AcrobotPlant`` at the upright (theta = (pi, 0), zero torque) and ``LinearQuadraticRegulator`` with
    Q = diag(10, 10, 1, 1), R = 1."""
    from pydrake.examples import AcrobotPlant
    from pydrake.systems.controllers import LinearQuadraticRegulator
    from pydrake.systems.primitives import Linearize

    from ..control.spong import LQR_Q, LQR_R

    plant = AcrobotPlant()
    context = plant.CreateDefaultContext()
    context.SetContinuousState([np.pi, 0.0, 0.0, 0.0])
    plant.get_input_port(0).FixValue(context, [0.0])
    linear = Linearize(plant, context)
    K, S = LinearQuadraticRegulator(linear.A(), linear.B(), LQR_Q, LQR_R)
    return S, K


def drake_cost(S, theta):
    """The cost-to-go of Drake's controller at Drake's states (..., 4): theta1 wrapped to [0, 2 pi),
    theta2 to [-pi, pi) (``math::wrap_to``), error from (pi, 0, 0, 0)."""
    theta = np.asarray(theta, float)
    span = 2 * np.pi
    e = np.stack([theta[..., 0] - span * np.floor(theta[..., 0] / span) - np.pi,
                  theta[..., 1] - span * np.floor((theta[..., 1] + np.pi) / span),
                  theta[..., 2], theta[..., 3]], -1)
    return np.einsum("...i,ij,...j->...", e, S, e)


def _wrapped_errors(theta):
    span = 2 * np.pi
    return np.array([theta[0] - span * np.floor(theta[0] / span) - np.pi,
                     theta[1] - span * np.floor((theta[1] + np.pi) / span)])


def split_kind(theta_drake, theta_paa, cost_drake, cost_paa, threshold):
    """Why the two loops' modes differ at one sample: ``"wrap of theta1"``/``"wrap of theta2"`` where the two
    states, less than 0.1 rad apart, lie on either side of a boundary of Drake's wrapping (the cost-to-go jumps
    there), ``"threshold"`` where both costs lie within 10 % of the threshold (a near-tie), else
    ``"grown difference"`` (the states had already drifted apart)."""
    theta_drake, theta_paa = np.asarray(theta_drake, float), np.asarray(theta_paa, float)
    e_drake, e_paa = _wrapped_errors(theta_drake), _wrapped_errors(theta_paa)
    close = np.max(np.abs(theta_drake[:2] - theta_paa[:2])) < 0.1
    for k in range(2):
        if close and abs(e_drake[k] - e_paa[k]) > np.pi:
            return f"wrap of theta{k + 1}"
    if max(abs(cost_drake - threshold), abs(cost_paa - threshold)) < 0.1 * threshold:
        return "threshold"
    return "grown difference"


def drake_loop(theta0, t_final, dt, hold=True, sample_dt=None, accuracy=DRAKE_ACCURACY):
    """Drake's acrobot under its Spong controller from ``theta0``: the states at multiples of ``sample_dt``
    (default ``dt``), shape (N + 1, 4), in Drake's coordinates.

    With ``hold``, a ``ZeroOrderHold`` of period ``dt`` between controller and plant: the torque of the
    state at k dt acts over [k dt, (k + 1) dt), as MuJoCo holds it. The plant is integrated by
    ``runge_kutta5`` at target accuracy ``accuracy``, steps of at most ``dt``.
    """
    from pydrake.examples import AcrobotPlant, AcrobotSpongController
    from pydrake.systems.analysis import ResetIntegratorFromFlags, Simulator
    from pydrake.systems.framework import DiagramBuilder
    from pydrake.systems.primitives import ZeroOrderHold

    builder = DiagramBuilder()
    plant = builder.AddSystem(AcrobotPlant())
    controller = builder.AddSystem(AcrobotSpongController())
    builder.Connect(plant.get_output_port(0), controller.get_input_port(0))
    if hold:
        zoh = builder.AddSystem(ZeroOrderHold(dt, 1))
        builder.Connect(controller.get_output_port(0), zoh.get_input_port(0))
        builder.Connect(zoh.get_output_port(0), plant.get_input_port(0))
    else:
        builder.Connect(controller.get_output_port(0), plant.get_input_port(0))
    diagram = builder.Build()
    simulator = Simulator(diagram)
    context = simulator.get_mutable_context()
    sample_dt = dt if sample_dt is None else sample_dt
    integrator = ResetIntegratorFromFlags(simulator, "runge_kutta5", min(dt, sample_dt))
    integrator.set_target_accuracy(accuracy)
    plant_context = diagram.GetMutableSubsystemContext(plant, context)
    plant_context.SetContinuousState(np.asarray(theta0, float))
    simulator.Initialize()
    steps = int(round(t_final / sample_dt))
    states = np.empty((steps + 1, 4))
    states[0] = theta0
    state = plant_context.get_continuous_state_vector()
    for k in range(1, steps + 1):
        simulator.AdvanceTo(k * sample_dt)
        states[k] = state.CopyToVector()
    return states


def mujoco_loop(x0, t_final, dt=None):
    """paa_mj's ``spong`` on ``models/acrobot.xml`` in MuJoCo from x0 (paa_mj's coordinates): times, states
    (N + 1, 4) and modes at every step."""
    from ..control.registry import make_controller
    from ..model.robot import load_robot
    from ..sim.rollout import simulate_mujoco

    robot = load_robot("acrobot")
    task = Task.named("stretched", robot)
    controller = make_controller("spong", robot, task=task)
    step = float(robot.model.opt.timestep) if dt is None else dt
    traj = simulate_mujoco(robot, controller, np.asarray(x0, float), t_final, task=task, dt=step, sample_dt=step,
                           stop_on_divergence=False)
    return traj.t, np.concatenate([traj.q, traj.qd], axis=1), traj.mode.astype(int), controller


def balanced_from(t, x, tol=None):
    """The time from which the acrobot's states x (K, 4) stay within ``tol`` of the stretched task's goal, the
    upright (every angle error, wrapped, and every speed; default the task's balance tolerance), to the end,
    or None."""
    task = Task.named("stretched", 2)
    tol = task.balance_tol if tol is None else tol
    distance = task.distance(x[:, :2], x[:, 2:])
    outside = np.nonzero(distance >= tol)[0]
    if outside.size == 0:
        return float(t[0])
    if outside[-1] == len(t) - 1:
        return None
    return float(t[outside[-1] + 1])


def _first(t, mask):
    hits = np.nonzero(mask)[0]
    return float(t[hits[0]]) if hits.size else None


def _crossings(t, mode, limit=6):
    changes = np.nonzero(np.diff(mode) != 0)[0] + 1
    return {"count": int(changes.size), "first_times": [float(t[i]) for i in changes[:limit]]}


def compare_start(name, theta0, t_final, dt, S_drake, threshold, no_hold_steps=(), window=WINDOW, series_dt=0.01):
    """One start: the held loops over ``t_final`` and, without the hold, the difference over ``window``
    at each MuJoCo time step of ``no_hold_steps``."""
    theta0 = np.asarray(theta0, float)
    x0 = x_from_theta(theta0)
    drake = x_from_theta(drake_loop(theta0, t_final, dt, hold=True))
    t, ours, mode_ours, controller = mujoco_loop(x0, t_final, dt)
    count = min(len(t), len(drake))
    t, ours, mode_ours, drake = t[:count], ours[:count], mode_ours[:count], drake[:count]
    cost_drake = drake_cost(S_drake, theta_from_x(drake))
    cost_ours = controller.cost_to_go(ours[:, :2], ours[:, 2:])
    mode_drake = (cost_drake < threshold).astype(int)
    diff = np.abs(drake - ours)
    early = t <= window + 1e-12
    worst = np.max(diff, axis=1)
    split = None
    differs = np.nonzero(mode_drake != mode_ours)[0]
    if differs.size:
        i = int(differs[0])
        split = {"t": float(t[i]), "mode_drake": int(mode_drake[i]), "mode_paa": int(mode_ours[i]),
                 "cost_drake": float(cost_drake[i]), "cost_paa": float(cost_ours[i]),
                 "state_difference": float(worst[i]),
                 "kind": split_kind(theta_from_x(drake[i]), theta_from_x(ours[i]), cost_drake[i], cost_ours[i],
                                    threshold)}
    balanced = {"drake": balanced_from(t, drake), "paa_mj": balanced_from(t, ours)}
    every = max(1, int(round(series_dt / dt)))
    row = {"start": name, "theta0": theta0.tolist(), "x0": x0.tolist(), "t_final": float(t[-1]), "dt": dt,
           "max_angle_difference": float(np.max(diff[early, :2])),
           "max_speed_difference": float(np.max(diff[early, 2:])),
           "max_difference_whole_run": float(np.max(worst)),
           "first_lqr": {"drake": _first(t, mode_drake == 1), "paa_mj": _first(t, mode_ours == 1)},
           "threshold_crossings": {"drake": _crossings(t, mode_drake), "paa_mj": _crossings(t, mode_ours)},
           "balanced_from": balanced,
           "balanced": {k: v is not None for k, v in balanced.items()},
           "same_outcome": (balanced["drake"] is None) == (balanced["paa_mj"] is None),
           "switch_split": split,
           "closest_cost_to_threshold": _closest(t, cost_drake, cost_ours, threshold, window),
           "series": {"t": t[::every].tolist(), "difference": worst[::every].tolist(),
                      "q_drake": drake[::every, :2].tolist(), "q_paa": ours[::every, :2].tolist()},
           "no_hold": []}
    if no_hold_steps:
        row["no_hold"] = no_hold(theta0, t_final, no_hold_steps, S_drake, threshold, window)
    return row


def no_hold(theta0, t_final, steps, S_drake, threshold, window=WINDOW):
    """Drake's continuous loop (no hold) against MuJoCo at each time step of ``steps``, over ``t_final``.

    Drake's states are sampled at the finest step, so that every MuJoCo step meets one. Per step: the
    largest differences before the first switch to the LQR (either loop; the smooth swing-up, where the
    difference is the hold's, O(dt)) and over ``window``, the first sample where the two loops' modes
    differ (their cost-to-go straddles the threshold) with both costs, and both outcomes.
    """
    theta0 = np.asarray(theta0, float)
    x0 = x_from_theta(theta0)
    fine = min(steps)
    continuous = x_from_theta(drake_loop(theta0, t_final, fine, hold=False))
    t_cont = np.arange(len(continuous)) * fine
    cost_cont = drake_cost(S_drake, theta_from_x(continuous))
    balanced_drake = balanced_from(t_cont, continuous)
    # theta2 = theta2dot = 0 is invariant under the swing-up law (y = 0, u_e = 0 keep the elbow straight) and
    # unstable (u_e pumps theta2dot while E < E_d): a start on it leaves it on round-off in the continuous
    # loop, on the O(dt^2) error of the held torque in MuJoCo's, at times that do not converge with dt
    on_manifold = theta0[1] == 0.0 and theta0[3] == 0.0
    rows = []
    for step in steps:
        t, x, mode, controller = mujoco_loop(x0, t_final, step)
        stride = int(round(step / fine))
        other = continuous[::stride]
        count = min(len(t), len(other))
        t, x, mode, other = t[:count], x[:count], mode[:count], other[:count]
        mode_drake = (cost_cont[::stride][:count] < threshold).astype(int)
        gap = np.abs(x - other)
        early = t <= window + 1e-12
        switches = [v for v in (_first(t, mode == 1), _first(t, mode_drake == 1)) if v is not None]
        before = t < (min(switches) if switches else np.inf)
        before &= early
        differs = np.nonzero(mode != mode_drake)[0]
        split = None
        if differs.size:
            i = int(differs[0])
            cost_paa = float(controller.cost_to_go(x[i, :2], x[i, 2:]))
            split = {"t": float(t[i]), "cost_drake": float(cost_cont[::stride][i]), "cost_paa": cost_paa,
                     "state_difference": float(np.max(gap[i])),
                     "kind": split_kind(theta_from_x(other[i]), theta_from_x(x[i]), cost_cont[::stride][i], cost_paa,
                                        threshold)}
        balanced = balanced_from(t, x)
        leaves = None
        if on_manifold:
            leaves = {"drake": _first(t_cont, np.abs(continuous[:, 1]) > ELBOW_LEFT),
                      "paa_mj": _first(t, np.abs(x[:, 1]) > ELBOW_LEFT)}
        rows.append({"dt": step, "elbow_leaves_zero": leaves,
                     "max_angle_difference": float(np.max(gap[early, :2])),
                     "max_speed_difference": float(np.max(gap[early, 2:])),
                     "before_first_switch": {"until": float(np.max(t[before])) if before.any() else 0.0,
                                             "max_angle_difference": float(np.max(gap[before, :2], initial=0.0)),
                                             "max_speed_difference": float(np.max(gap[before, 2:], initial=0.0))},
                     "first_lqr": {"drake": _first(t, mode_drake == 1), "paa_mj": _first(t, mode == 1)},
                     "first_mode_difference": split,
                     "balanced_from": {"drake": balanced_drake, "paa_mj": balanced},
                     "same_outcome": (balanced_drake is None) == (balanced is None)})
    return rows


def _closest(t, cost_drake, cost_paa, threshold, window):
    """Where, within ``window``, the two costs come nearest the threshold (relative), when both are near it."""
    early = t <= window + 1e-12
    margin = np.maximum(np.abs(cost_drake[early] - threshold), np.abs(cost_paa[early] - threshold)) / threshold
    if not margin.size:
        return None
    i = int(np.argmin(margin))
    return {"t": float(t[i]), "relative_margin": float(margin[i])}


def integration_check(theta0, t_final, dt):
    """The held loops at ``dt`` and at ``dt / 2`` over ``t_final``: the largest state difference of each.
    If what is left is MuJoCo's RK4 error, halving the step divides it by 16 or more (dt^4)."""
    out = {}
    for step in (dt, dt / 2):
        drake = x_from_theta(drake_loop(theta0, t_final, step, hold=True))
        _, ours, _, _ = mujoco_loop(x_from_theta(theta0), t_final, step)
        count = min(len(drake), len(ours))
        out[f"{step:g}"] = float(np.max(np.abs(drake[:count] - ours[:count])))
    return out


def closed_loop(t_final=30.0, quick=False, progress=False, window=WINDOW):
    """Every start of :data:`STARTS` (the quick ones with ``quick``): rows of :func:`compare_start`."""
    from ..control.registry import make_controller
    from ..control.spong import THRESHOLD
    from ..model.robot import load_robot
    from ..progress import stage

    robot = load_robot("acrobot")
    dt = float(robot.model.opt.timestep)
    S_drake, K_drake = drake_lqr()
    ours = make_controller("spong", robot, task="stretched")
    lqr = {"S_relative_difference": float(np.max(np.abs(S_drake - ours.S)) / np.max(np.abs(S_drake))),
           "K_relative_difference": float(np.max(np.abs(K_drake - ours.K)) / np.max(np.abs(K_drake))),
           "K_drake": np.asarray(K_drake).reshape(-1).tolist(), "K_paa_mj": ours.K.reshape(-1).tolist()}
    names = QUICK_STARTS if quick else tuple(STARTS)
    steps = QUICK_NO_HOLD_STEPS if quick else NO_HOLD_STEPS
    window = min(window, t_final)
    rows = []
    for name in names:
        stage(f"peers: closed loop from {name} {STARTS[name]} (Drake with ZeroOrderHold, MuJoCo; then without"
              " the hold)", progress)
        rows.append(compare_start(name, STARTS[name], t_final, dt, S_drake, THRESHOLD, steps, window))
    stage("peers: integration check (both loops at dt and dt / 2)", progress)
    check = integration_check(STARTS[names[0]], window, dt)
    return {"dt": dt, "window": window, "t_final": t_final, "threshold": THRESHOLD, "lqr": lqr,
            "integration_check": {"start": names[0], "max_difference": check}, "starts": rows}


def peers(t_final=30.0, samples=200, seed=0, quick=False, progress=False):
    """Everything ``paa-mj peers`` reports: the dynamics rows and the closed loops."""
    require_drake()
    from .. import __version__

    if not (math.isfinite(t_final) and t_final > 0):
        raise PaaError(f"t_final must be a positive number of seconds, got {t_final}")
    seed = check_seed(seed, "--seed")
    task = Task.named("stretched", 2)
    described = {**task.describe(), "success_definition": "balanced: from some time on to the end, every angle"
                 f" error (wrapped) and every speed below the task's balance tolerance ({task.balance_tol:g}) of the"
                 " upright; Drake's and paa_mj's runs judged alike (balanced_from)"}
    return {"paa_mj": __version__, "drake": drake_version(), **described,
            "settings": {"samples": samples, "seed": seed, "quick": quick, "drake_integrator":
                         f"runge_kutta5, target accuracy {DRAKE_ACCURACY:g}, steps of at most dt",
                         "mujoco_integrator": "RK4 (models/acrobot.xml)",
                         "map": "theta1 = q1 + pi, theta2 = q2, thetadot = qd, u = tau2",
                         "relative_difference": "max abs(a - b) of a sample / max(1, max abs(b)), worst sample"},
            "dynamics": dynamics(samples, seed, quick, progress),
            "closed_loop": closed_loop(t_final, quick, progress)}
