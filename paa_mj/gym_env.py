"""The gymnast as Gymnasium environments (extra ``paa_mj[gym]``).

Registered ids (importing this module registers them; ``gym.make("paa_mj.gym_env:<id>")`` imports it by itself):

``paa_mj/GymnastKip-v1``
    The paper's task: from hanging (65), angles perturbed uniformly by up to ``init_noise`` = 0.05 rad,
    to balanced at UDD (8). 30 s episodes (``max_episode_steps`` = 3000 at the default 10 ms control period).
``paa_mj/GymnastBalance-v1``
    Stay balanced: the start is UDD plus a uniform perturbation, every angle error in
    [-0.05, 0.05] rad and every speed in [-0.05, 0.05] rad/s; 10 s episodes (``max_episode_steps`` = 1000).
``paa_mj/GymnastKip-v0``
    The first version, kept for compatibility with its old defaults: torques [N m] as actions, one
    1 ms physics step per environment step, the reward of v0 below (:class:`GymnastKipEnv`).

The v1 ids also build :class:`paa_mj.gym_vector.GymnastVectorEnv` through
``gym.make_vec(id, num_envs=N)``: N robots stepped together by one compiled call.

Any robot of the family and either goal: ``gym.make(id, robot="acrobot", goal="stretched")``. The spaces
below are the gymnast's; a chain of n links has 3n observations (cos, sin of each angle, then the speeds)
and n - 1 actions, and its rewards measure the error from its goal (``3`` below becomes n, ``6`` 2n).

Observation space
    ``Box(9,)`` float32: cos q_i, sin q_i for i = 1, 2, 3, then qd [rad/s] (unbounded); the map is
    :func:`observation`, also used by :class:`paa_mj.control.policy.SB3Policy`.
Action space
    v1: ``Box(2,)`` in [-1, 1], scaled by the torque limits: tau = clip(a T, -T, T) [N m]
    (:func:`action_to_torque`). T is the smaller of ``torque_limit`` and the model's actuator ranges
    (:func:`torque_limits_for`); ``torque_limit`` is by default 2 b1 / 1 rad for the kip (579 N m for
    Table 1, above the paper's peak torques) and 0.1 b1 / 1 rad for balance (29 N m).
    With ``normalize_actions=False`` (v0) the actions are the torques [N m] themselves, clipped at T.
Dynamics
    One environment step holds the torque over ``frame_skip`` physics steps of MuJoCo (RK4, 1 ms):
    a control period of 10 ms in v1, 1 ms in v0. The physics runs in compiled code
    (``mj_step`` called from numba, as :mod:`paa_mj.sim.engine` does), the same code for one
    environment and for the vector environment. ``physics="analytic"`` steps the robot's own equations
    of motion by the same RK4 instead (:mod:`paa_mj.sim.rk4`): the same equations, states that agree
    with MuJoCo's to rounding, at under a tenth of the cost (``paa-mj bench``).
Reward (per environment step, dimensionless)
    With x = [q1, q2 + pi, q3, d1, d2, d3] the error from UDD (angles wrapped to (-pi, pi], rad and
    rad/s), l = [pi/6, pi/6, pi/6, 0.5, 0.5, 0.5] the half-widths of region (68), u = tau / T the
    applied torques over their limits (in [-1, 1]) and 1[(68)] = 1 when the state after the step is
    inside region (68), else 0:

    - kip (v1): :math:`r = 1[(68)] - |x_{1:3}|^2 / (3 \\pi^2) - 10^{-3} |x_{4:6}|^2 - 10^{-2} \\bar{u^2}`,
      angles in rad, speeds in rad/s, the weights in 1/rad^2 and s^2/rad^2 (the angle term is 1 at the
      farthest posture, the speed term 0.1 at 10 rad/s);
    - balance (v1): :math:`r = 1[(68)] - \\frac{1}{2} \\overline{(x / l)^2} - \\frac{1}{10} \\bar{u^2}`
      (bars: means over the coordinates), so r is in [0.4, 1] inside region (68);
    - v0: :math:`r = -(|x_{1:3}|^2 / (3 \\pi^2) + 10^{-3} |x_{4:6}|^2 + 10^{-8} |\\tau|^2)`, tau in N m.

    A step that diverges gets :data:`DIVERGED_REWARD` (-100; -10 in v0).
Termination and truncation
    Terminated when the state diverges (non-finite, speeds above 1e4 rad/s, MuJoCo warnings); the
    episode then ends on the last good state. Balance also terminates when the state after a step has
    left region (68) by ``terminate_margin`` (default 0.5): :math:`\\max_i |x_i| / l_i \\ge 1 + 0.5`,
    an angle error of pi/4 rad or a speed of 0.75 rad/s. Truncated (when not terminated) after
    ``max_episode_seconds``; the registered ``max_episode_steps`` gives wrappers the same horizon (at the
    default ``frame_skip``: with another, pass ``max_episode_steps`` to ``gym.make`` as well).
Info
    ``q``, ``qd``: the raw state, angles unwrapped (controller (40) needs the unwrapped q2);
    ``time``: physics steps since reset x 1 ms [s] (the time the package's engines give controllers);
    ``diverged``; ``is_success``: the package's success (:data:`~paa_mj.control.region.SUCCESS_DEFINITION`,
    :func:`~paa_mj.control.region.succeeded`) of the episode so far, as if it ended now: no divergence,
    and the true state inside region (68) at every 1 ms physics step of the last second (the whole
    episode when shorter, the start included). At the last step of an episode it is the episode's success.

A controller of the package as a policy: :func:`controller_policy` (``policy(obs, info) -> action``).
"""
from __future__ import annotations

import math
import operator

import gymnasium as gym
import mujoco
import numpy as np
from gymnasium import spaces
from numba import carray, njit, types
from numba.extending import intrinsic, register_jitable

from .control.region import SWITCH_ANGLE, SWITCH_SPEED, goal_terms, succeeded
from .model.robot import load_robot
from .model.states import GOALS, goal_angles, start_state
from .sim.engine import _WARNINGS, MAX_SPEED, _mj_step
from .sim.mujoco_log import mujoco_log_off
from .sim.rk4 import rk4_constants, rk4_step, work_size

ENV_ID = "paa_mj/GymnastKip-v0"
KIP_ID = "paa_mj/GymnastKip-v1"
BALANCE_ID = "paa_mj/GymnastBalance-v1"
#: The largest torque limit [N m]: the action space is float32.
MAX_TORQUE_LIMIT = 1e12
#: The most environment steps of one episode.
MAX_EPISODE_STEPS = 1e12
#: The tasks' defaults: episode length [s], half-widths of the initial perturbation of the angles [rad] and speeds
#: [rad/s], terminate_margin, and the torque limit in units of b1 / 1 rad [N m]. Balancing needs far less torque
#: than the kip (the LQR (67), saturated at 0.1 b1, balances every start of the task; unsaturated it peaks near
#: 0.23 b1), and the smaller limit lets a learner's first, random actions keep the robot near region (68) for
#: about ten steps instead of one.
TASKS = {"kip": dict(seconds=30.0, noise=0.05, speed_noise=0.0, margin=math.inf, torque_b1=2.0),
         "balance": dict(seconds=10.0, noise=0.05, speed_noise=0.05, margin=0.5, torque_b1=0.1)}
#: Physics steps per environment step in v1: a 10 ms control period on the 1 ms step of the models.
FRAME_SKIP = 10
#: The physics an environment can run: MuJoCo's ``mj_step`` (the default), or the chain's own equations of
#: motion integrated by the same RK4 (:func:`paa_mj.sim.rk4.rk4_step`), over ten times cheaper.
PHYSICS = ("mujoco", "analytic")
#: Registered horizons [environment steps]: the tasks' seconds at the default 10 ms period.
HORIZONS = {KIP_ID: 3000, BALANCE_ID: 1000}
#: The reward of a step that diverges, by reward kind (v0, kip, balance).
DIVERGED_REWARD = {0: -10.0, 1: -100.0, 2: -100.0}
_REWARD_KIND = {"kip": 1, "balance": 2}
OBS_SIZE = 9


# --- validation of arguments: one line that names the argument -----------------------------------------------

def _real_array(value):
    """``value`` as a float array, or None when it is not real numbers (text, complex, booleans, objects)."""
    try:
        array = np.asarray(value)
    except (TypeError, ValueError):
        return None
    if array.dtype.kind not in "fiu":
        return None
    return array.astype(float)


def _number(name, value, accept, rule, finite=True):
    """``value`` as a float for which ``accept`` holds, else a ValueError naming ``name`` and ``rule``."""
    try:
        if isinstance(value, (bool, np.bool_, str, bytes)):  # float() would read True as 1 and "2" as 2
            raise TypeError
        number = float(value)
    except (TypeError, ValueError):
        raise ValueError(f"{name} must be a number, got {value!r}") from None
    if not ((math.isfinite(number) or not finite) and not math.isnan(number) and accept(number)):
        raise ValueError(f"{name} {rule}, got {value!r}")
    return number


def _whole(name, value, low, high):
    """``value`` as an int in [low, high] (a float only when whole), else a ValueError."""
    if isinstance(value, (bool, np.bool_)):
        raise ValueError(f"{name} must be a whole number, got {value!r}")
    try:
        number = operator.index(value)
    except TypeError:
        number = _number(name, value, lambda v: v == int(v), "must be a whole number")
        number = int(number)
    if not low <= number <= high:
        raise ValueError(f"{name} must be in [{low}, {high}], got {value!r}")
    return number


def _check_x0(x0, rows=None, width=6):
    """``options["x0"]``: ``width`` (2n) finite numbers, or (with ``rows``) one row of them per environment too."""
    x0 = _real_array(x0)
    shapes = [(width,)] if rows is None else [(width,), (rows, width)]
    if x0 is None or x0.shape not in shapes or not np.all(np.isfinite(x0)):
        raise ValueError(f"options['x0'] must be {width} finite numbers" + ("" if rows is None
                                                                              else f" or {rows} rows of {width}"))
    return x0


def _check_options(options, known):
    if options is None:
        return {}
    # an option this environment does not know (a typo of x0) would be ignored in silence
    if not isinstance(options, dict):
        raise ValueError(f"options must be a dict (or None), got {type(options).__name__}")
    unknown = sorted(map(str, set(options) - set(known)))
    if unknown:
        raise ValueError(f"unknown reset option(s) {', '.join(unknown)}: the options are {', '.join(known)}")
    return options


# --- the maps between the package's states and torques and the learner's observations and actions -----------

def torque_limit_for(robot, task="kip", torque_limit=None):
    """The torque limit [N m] asked for: ``torque_limit``, by default 2 b1 / 1 rad (kip) or 0.1 b1 / 1 rad (balance)."""
    return float(torque_limit if torque_limit is not None else
                 TASKS[task]["torque_b1"] * robot.analytic.gravity_constants[0])


def torque_limits_for(robot, task="kip", torque_limit=None):
    """The torque limits T [N m], (n - 1,), of the environments: :func:`torque_limit_for` capped by the model's actuator
    ranges (:attr:`Robot.torque_limits <paa_mj.model.robot.Robot.torque_limits>`)."""
    return np.minimum(torque_limit_for(robot, task, torque_limit), np.asarray(robot.torque_limits, float))


def action_to_torque(action, torque_limits, normalized=True):
    """Torques tau [N m], (..., 2), of actions (..., 2): tau = clip(a T, -T, T), or clip(a, -T, T) when not normalised.

    The one definition of the action map: the environments and :class:`~paa_mj.control.policy.SB3Policy` use it.
    """
    action = np.asarray(action, dtype=float)
    if normalized:
        action = action * torque_limits
    return np.clip(action, -torque_limits, torque_limits)


def torque_to_action(tau, torque_limits, normalized=True):
    """The actions, float32 (..., 2), that ask for the torques ``tau`` [N m] (clipped at the limits T)."""
    tau = np.clip(np.asarray(tau, dtype=float), -torque_limits, torque_limits)
    return (tau / torque_limits if normalized else tau).astype(np.float32)


@register_jitable
def _observe_into(qpos, qvel, n, out):
    """[cos q1, sin q1, ..., cos qn, sin qn, qd1, ..., qdn] into ``out`` (3n)."""
    for i in range(n):
        out[2 * i], out[2 * i + 1] = math.cos(qpos[i]), math.sin(qpos[i])
        out[2 * n + i] = qvel[i]


@njit(cache=True)
def _observe_rows(q, qd, out):
    for i in range(q.shape[0]):
        _observe_into(q[i], qd[i], q.shape[1], out[i])


def observation(q, qd):
    """The observations, float32 (..., 3n), of states q, qd (..., n) [rad, rad/s]: for the gymnast (9)
    [cos q1, sin q1, cos q2, sin q2, cos q3, sin q3, qd1, qd2, qd3].

    The one definition of the observation map (the environments compute it with the same compiled code).
    """
    q, qd = np.asarray(q, dtype=float), np.asarray(qd, dtype=float)
    n = q.shape[-1]
    shape = np.broadcast_shapes(q.shape[:-1], qd.shape[:-1])
    # writable C arrays, copies where broadcast (read-only): one compiled version of the map, not one per kind
    q = np.require(np.broadcast_to(q, shape + (n,)).reshape(-1, n), requirements=("C", "W"))
    qd = np.require(np.broadcast_to(qd, shape + (n,)).reshape(-1, n), requirements=("C", "W"))
    out = np.empty((len(q), 3 * n), np.float32)
    _observe_rows(q, qd, out)
    return out.reshape(shape + (3 * n,))


# --- compiled stepping of N MjData: one call per environment step ----------------------------------------------

def _pointer_at(item_type):
    """An intrinsic that reads an integer address as a pointer to ``item_type`` (numba casts none by itself)."""
    @intrinsic
    def pointer_at(typingctx, address):
        sig = types.CPointer(item_type)(types.intp)

        def codegen(context, builder, signature, args):
            return builder.inttoptr(args[0], context.get_value_type(signature.return_type))

        return sig, codegen

    return pointer_at


_float64_at = _pointer_at(types.float64)
_int32_at = _pointer_at(types.int32)


# Columns of the address table: the mjData and its qpos, qvel, ctrl and warning counters.
_DATA, _QPOS, _QVEL, _CTRL, _WARN = range(5)


@register_jitable
def _goal_terms(qpos, qvel, n, goal):
    """(inside region (68), its margin, |x_angles|^2, |qd|^2) of the state's error x from the goal, from
    :func:`~paa_mj.control.region.goal_terms`."""
    inside, angle_max, speed_max, angles, speeds = goal_terms(qpos, qvel, n, goal)
    return inside, max(angle_max / SWITCH_ANGLE, speed_max / SWITCH_SPEED) - 1.0, angles, speeds


@register_jitable
def _reward(kind, n, inside, angles, speeds, tau, limits, row):
    """The reward of a step ending with the goal terms of :func:`_goal_terms`, torques tau [N m] = u T (module
    docstring); ``tau[row]`` and ``limits`` hold the n - 1 torques and limits."""
    effort, power = 0.0, 0.0
    for j in range(n - 1):
        u = tau[row, j] / limits[j]
        effort += u * u
        power += tau[row, j] * tau[row, j]
    if kind == 0:
        return -(angles / (float(n) * math.pi ** 2) + 1e-3 * speeds + 1e-8 * power)
    alive = 1.0 if inside else 0.0
    effort = 0.5 * effort
    if kind == 1:
        return alive - angles / (float(n) * math.pi ** 2) - 1e-3 * speeds - 1e-2 * effort
    scaled = (angles / SWITCH_ANGLE ** 2 + speeds / SWITCH_SPEED ** 2) / (2.0 * n)
    return alive - 0.5 * scaled - 0.1 * effort


@njit(nogil=True, cache=True)
def _advance(model_ptr, addresses, warn_stride, constants, rows, tau, limits, frame_skip, kind, diverged_reward,
             phys_step, last_exit, diverged, q, qd, obs, reward, margin, goal):
    """One environment step of the environments ``rows``: ``tau[i]`` held over ``frame_skip`` physics steps,
    ``mj_step`` of the MjData at ``addresses[i]``, or, where ``model_ptr`` is 0 (physics "analytic"), RK4 steps of
    the robot's equations of motion (:func:`~paa_mj.sim.rk4.rk4_step` with ``constants``) on the state that
    ``addresses[i]`` points to.

    Per environment: counts the physics steps, the last one whose state was outside region (68) around the
    ``goal``, whether it diverged (then the state goes back to the last good one and the step ends), and writes
    the state, observation, reward and region margin after the step. Sized from ``q`` (N, n).
    """
    n = q.shape[1]
    good = np.empty(2 * n)
    work = np.empty(work_size(n))
    for k in range(rows.size):
        i = rows[k]
        qpos = _float64_at(addresses[i, _QPOS])
        qvel = _float64_at(addresses[i, _QVEL])
        ctrl = _float64_at(addresses[i, _CTRL])
        warn = _int32_at(addresses[i, _WARN])
        for j in range(n - 1):
            ctrl[j] = tau[i, j]
        bad = False
        for _ in range(frame_skip):
            for j in range(n):
                good[j], good[n + j] = qpos[j], qvel[j]
            if model_ptr != 0:
                _mj_step(model_ptr, addresses[i, _DATA])
            else:
                rk4_step(constants, carray(qpos, (n,)), carray(qvel, (n,)), carray(ctrl, (n - 1,)), work)
            for j in range(n):
                if not (math.isfinite(qpos[j]) and math.isfinite(qvel[j])) or abs(qvel[j]) > MAX_SPEED:
                    bad = True
            for w in _WARNINGS:
                if warn[w * warn_stride] > 0:
                    bad = True
            if bad:
                for j in range(n):
                    qpos[j], qvel[j] = good[j], good[n + j]
                break
            phys_step[i] += 1
            if not _goal_terms(qpos, qvel, n, goal)[0]:
                last_exit[i] = phys_step[i]
        diverged[i] = bad
        for j in range(n):
            q[i, j], qd[i, j] = qpos[j], qvel[j]
        _observe_into(qpos, qvel, n, obs[i])
        inside, margin[i], angles, speeds = _goal_terms(qpos, qvel, n, goal)
        if bad:
            reward[i] = diverged_reward
        else:
            reward[i] = _reward(kind, n, inside, angles, speeds, tau, limits, i)


class _Robots:
    """N copies of one robot's state and their episode counters, stepped by :func:`_advance`.

    :class:`GymnastEnv` holds one, :class:`~paa_mj.gym_vector.GymnastVectorEnv` N: the same code computes
    their observations and rewards, so that they agree bit for bit. With ``physics="mujoco"`` each robot is an
    MjData stepped by ``mj_step``; with ``"analytic"`` the state lives in :attr:`q`, :attr:`qd` and is stepped by
    RK4 of the robot's equations of motion (``analytic``, its :class:`~paa_mj.model.dynamics.AnalyticModel`).
    """

    def __init__(self, model, n, frame_skip, kind, torque_limits, goal, physics="mujoco", analytic=None):
        self.model, self.frame_skip, self.kind, self.physics = model, frame_skip, kind, physics
        self.torque_limits = np.ascontiguousarray(torque_limits, dtype=float)
        self.goal = np.ascontiguousarray(goal, dtype=float)
        links = self.goal.size
        self.phys_step = np.zeros(n, np.int64)
        self.last_exit = np.full(n, -1, np.int64)
        self.diverged = np.zeros(n, bool)
        self.q, self.qd = np.zeros((n, links)), np.zeros((n, links))
        self.obs = np.zeros((n, 3 * links), np.float32)
        self.reward, self.margin = np.zeros(n), np.zeros(n)
        self.tau = np.zeros((n, links - 1))
        if physics == "mujoco":
            self.datas = [mujoco.MjData(model) for _ in range(n)]
            # MuJoCo keeps each array of an mjData where it was allocated: the addresses hold while the data lives
            self.addresses = np.array([[d._address, d.qpos.ctypes.data, d.qvel.ctypes.data, d.ctrl.ctypes.data,
                                        d.warning.number.ctypes.data] for d in self.datas], dtype=np.intp)
            self.warn_stride = self.datas[0].warning.number.strides[0] // 4
            self.model_address = model._address
            self.constants = np.zeros(1)
        else:
            # the same table over the package's own arrays: the state is q, qd, the torques tau, no warnings
            self.datas = None
            self._no_warnings = np.zeros((n, int(_WARNINGS.max()) + 1), np.int32)
            self.addresses = np.array([[0, self.q[i:].ctypes.data, self.qd[i:].ctypes.data, self.tau[i:].ctypes.data,
                                        self._no_warnings[i:].ctypes.data] for i in range(n)], dtype=np.intp)
            self.warn_stride = 1
            self.model_address = 0
            self.constants = rk4_constants(analytic, model.opt.timestep)

    def reset(self, i, x0):
        """Environment ``i`` to the state ``x0`` (2n,), at rest in time."""
        links = self.goal.size
        if self.physics == "mujoco":
            data = self.datas[i]
            mujoco.mj_resetData(self.model, data)
            data.qpos[:], data.qvel[:] = x0[:links], x0[links:]
            with mujoco_log_off():
                mujoco.mj_forward(self.model, data)
            self.q[i], self.qd[i] = data.qpos, data.qvel
        else:
            self.q[i], self.qd[i] = x0[:links], x0[links:]
            self.tau[i] = 0.0
        self.phys_step[i], self.diverged[i] = 0, False
        inside, self.margin[i], _, _ = _goal_terms(self.q[i], self.qd[i], links, self.goal)
        self.last_exit[i] = -1 if inside else 0
        _observe_rows(self.q[i:i + 1], self.qd[i:i + 1], self.obs[i:i + 1])

    def step(self, rows, tau, log=True):
        """One environment step of ``rows`` (int array) with the torques ``tau`` (len(rows), 2) [N m].

        ``log=False``: the caller has turned MuJoCo's log off (threads stepping parts of the rows)."""
        self.tau[rows] = tau
        args = (self.model_address, self.addresses, self.warn_stride, self.constants, rows, self.tau,
                self.torque_limits,
                self.frame_skip, self.kind, DIVERGED_REWARD[self.kind], self.phys_step, self.last_exit,
                self.diverged, self.q, self.qd, self.obs, self.reward, self.margin, self.goal)
        if not log:
            _advance(*args)
            return
        with mujoco_log_off():  # a diverging step ends the episode; MuJoCo's warning must not leave MUJOCO_LOG.TXT
            _advance(*args)

    def time(self):
        """Simulated time since reset [s], as the engines give it to controllers (steps x time step)."""
        return self.phys_step * self.model.opt.timestep

    def success(self):
        """:func:`~paa_mj.control.region.succeeded` of every episode so far, as if it ended now."""
        return succeeded(~self.diverged, np.zeros(len(self.q), bool), self.last_exit, self.phys_step,
                         self.model.opt.timestep)


class GymnastEnv(gym.Env):
    """The gymnast as a Gymnasium environment, tasks ``kip`` and ``balance`` (module docstring).

    Parameters
    ----------
    task : "kip" or "balance"
        From hanging (65) to balanced at UDD, or staying balanced from near UDD.
    robot : str or path
        A named robot or an MJCF file, as :func:`~paa_mj.model.load_robot` takes.
    render_mode : None or "rgb_array"
    max_episode_seconds : float, optional
        Simulated time before truncation [s], positive and at least one environment step;
        default 30 s (kip), 10 s (balance).
    frame_skip : int
        Physics steps (1 ms) per environment step, in [1, 1000000]; default 10 (a 10 ms control period).
    torque_limit : float, optional
        Saturation of both torques [N m], positive and at most 1e12; the model's actuator ranges
        also apply (the smaller wins). Default 2 b1 / 1 rad (kip, above the paper's peak torques) or
        0.1 b1 / 1 rad (balance), b1 of (9) [J]: 579 or 29 N m for Table 1.
    init_noise : float, optional
        Half-width of the uniform perturbation of the initial angles at reset [rad], finite and >= 0;
        default 0.05.
    init_speed_noise : float, optional
        Half-width of the uniform perturbation of the initial speeds [rad/s], finite and >= 0;
        default 0 (kip), 0.05 (balance).
    terminate_margin : float, optional
        Terminate when :math:`\\max_i |x_i| / l_i - 1` (:func:`~paa_mj.control.region.switch_margin`) reaches it
        after a step, >= 0; ``math.inf``: never. Default inf (kip), 0.5 (balance).
    normalize_actions : bool
        Actions in [-1, 1] scaled by the torque limits (default), or torques [N m].
    width, height : int
        Size of the rendered frames [pixels], in [16, 4096].
    goal : "folded" or "stretched"
        The goal of the tasks (the paper's folded UDD by default); any robot of the family is welcome: the
        observations are then 3n numbers and the actions n - 1.
    physics : "mujoco" or "analytic"
        ``mj_step`` of the robot's MuJoCo model (default), or the classic RK4 of the robot's own equations of
        motion (:func:`paa_mj.sim.rk4.rk4_step`, the same time step, the torque held over it): the same
        equations as MuJoCo's (``paa-mj check``: 1e-13), over ten times cheaper a step, agreeing with MuJoCo's
        steps to rounding (about 1e-13 over a second of motion), not bit for bit; rounding grows where the
        motion is chaotic (a swing-up), so episodes of the two agree closely while they balance and
        statistically, not state for state, over a long kip.

    Raises
    ------
    ValueError
        An argument of the wrong type or out of range (NaN, inf, negative), one line naming it.
    paa_mj.errors.PaaError
        A robot that cannot be loaded.
    """

    metadata = {"render_modes": ["rgb_array"], "render_fps": 30}
    _legacy = False

    def __init__(self, task="kip", robot="gymnast", render_mode=None, max_episode_seconds=None, frame_skip=FRAME_SKIP,
                 torque_limit=None, init_noise=None, init_speed_noise=None, terminate_margin=None,
                 normalize_actions=True, width=480, height=360, goal="folded", physics="mujoco"):
        if not isinstance(task, str) or task not in TASKS:
            raise ValueError(f"task must be {' or '.join(map(repr, TASKS))}, got {task!r}")
        if not isinstance(goal, str) or goal not in GOALS:
            raise ValueError(f"goal must be {' or '.join(map(repr, GOALS))}, got {goal!r}")
        if not isinstance(physics, str) or physics not in PHYSICS:
            raise ValueError(f"physics must be {' or '.join(map(repr, PHYSICS))}, got {physics!r}")
        if render_mode not in (None, "rgb_array"):
            raise ValueError(f"render_mode must be None or 'rgb_array', got {render_mode!r}")
        if not isinstance(normalize_actions, (bool, np.bool_)):
            raise ValueError(f"normalize_actions must be True or False, got {normalize_actions!r}")
        seconds, noise, speed_noise, margin = (TASKS[task][k] for k in ("seconds", "noise", "speed_noise", "margin"))
        # checked before the robot is loaded: a wrong argument is named before any slower failure
        frame_skip = _whole("frame_skip", frame_skip, 1, 1_000_000)
        if max_episode_seconds is not None:
            seconds = _number("max_episode_seconds", max_episode_seconds, lambda v: v > 0,
                              "must be a positive finite number [s]")
        if torque_limit is not None:
            # a negative limit would turn np.clip(a, -T, T) into T for every action: every torque inverted; one
            # beyond float32 would make the action space's bounds infinite
            torque_limit = _number("torque_limit", torque_limit, lambda v: 0 < v <= MAX_TORQUE_LIMIT,
                                   f"must be a positive finite number [N m] up to {MAX_TORQUE_LIMIT:g}")
        if init_noise is not None:
            noise = _number("init_noise", init_noise, lambda v: v >= 0, "must be a finite number >= 0 [rad]")
        if init_speed_noise is not None:
            speed_noise = _number("init_speed_noise", init_speed_noise, lambda v: v >= 0,
                                  "must be a finite number >= 0 [rad/s]")
        if terminate_margin is not None:
            margin = _number("terminate_margin", terminate_margin, lambda v: v >= 0,
                             "must be a number >= 0 (math.inf: never terminate outside region (68))", finite=False)
        width, height = _whole("width", width, 16, 4096), _whole("height", height, 16, 4096)
        self.task, self.goal, self.physics = task, goal, physics
        self.robot = load_robot(robot)
        links = self.robot.params.n_links
        self.model = self.robot.model.__copy__()
        self.frame_skip = frame_skip
        self.dt = self.model.opt.timestep * self.frame_skip
        steps = seconds / self.dt
        shown = max_episode_seconds if max_episode_seconds is not None else seconds
        if not steps <= MAX_EPISODE_STEPS:
            raise ValueError(f"max_episode_seconds {shown!r} is too long: {steps:.3g} environment steps"
                             f" of {self.dt:g} s, more than {MAX_EPISODE_STEPS:g}")
        self.max_steps = int(round(steps))
        if self.max_steps < 1:
            raise ValueError(f"max_episode_seconds {shown!r} is shorter than one environment step ({self.dt:g} s)")
        self.torque_limit = torque_limit_for(self.robot, task, torque_limit)
        #: The torque limits applied [N m], (n - 1,): ``torque_limit`` capped by the model's actuator ranges.
        self.torque_limits = torque_limits_for(self.robot, task, torque_limit)
        self.init_noise, self.init_speed_noise, self.terminate_margin = noise, speed_noise, margin
        self.render_mode, self.width, self.height = render_mode, width, height
        self.normalize_actions = bool(normalize_actions)
        bound = np.ones(links - 1) if self.normalize_actions else self.torque_limits
        self.action_space = spaces.Box(-bound.astype(np.float32), bound.astype(np.float32), (links - 1,), np.float32)
        high = np.array([1.0] * (2 * links) + [np.inf] * links, np.float32)
        self.observation_space = spaces.Box(-high, high, dtype=np.float32)
        self._robots = _Robots(self.model, 1, frame_skip, 0 if self._legacy else _REWARD_KIND[task],
                               self.torque_limits, goal_angles(goal, links), physics, self.robot.analytic)
        #: The MuJoCo state of the robot (physics "mujoco"; None with "analytic", whose state is in ``info``).
        self.data = self._robots.datas[0] if physics == "mujoco" else None
        self._rows = np.zeros(1, np.intp)
        self._renderer = None
        self._steps = 0

    @property
    def start(self):
        """The state the episodes start from before the perturbation: (65) for the kip (the task's start,
        :func:`~paa_mj.model.states.start_state`), the goal at rest (UDD) for balance."""
        links = self.robot.params.n_links
        return start_state(links, self.goal) if self.task == "kip" else \
            np.concatenate([goal_angles(self.goal, links), np.zeros(links)])

    def _info(self):
        r = self._robots
        return {"q": r.q[0].copy(), "qd": r.qd[0].copy(), "time": float(r.time()[0]),
                "diverged": bool(r.diverged[0]), "is_success": bool(r.success()[0])}

    def reset(self, *, seed=None, options=None):
        """Back to :attr:`start` (or ``options["x0"]``), angles and speeds perturbed uniformly by up to
        ``init_noise`` [rad] and ``init_speed_noise`` [rad/s]."""
        x0 = _check_options(options, ("x0",)).get("x0")
        x0 = self.start if x0 is None else _check_x0(x0, width=2 * self.robot.params.n_links)
        super().reset(seed=seed)
        self._robots.reset(0, perturbed(x0, self.np_random, self.init_noise, self.init_speed_noise))
        self._steps = 0
        return self._robots.obs[0].copy(), self._info()

    def action_to_torque(self, action):
        """The torques [N m] an action asks for (scaled when actions are normalised), within the limits.

        Raises
        ------
        ValueError
            An action that is not two finite real numbers: one number would be given to both motors and a
            NaN or infinite one would be clipped or end the episode as a divergence, in silence.
        """
        given, action = action, _real_array(action)
        motors = self.robot.params.n_links - 1
        if action is None or action.shape != (motors,):
            shown = " ".join(repr(given).split())
            what = "two real numbers [tau2, tau3]" if motors == 2 else f"{motors} real number{'s' * (motors > 1)}"
            raise ValueError(f"an action is {what}, shape ({motors},), got "
                             + (f"{shown[:60]}" if action is None else f"shape {action.shape}"))
        if not np.all(np.isfinite(action)):
            raise ValueError(f"an action must be finite, got {action.tolist()}")
        return action_to_torque(action, self.torque_limits, self.normalize_actions)

    def torque_to_action(self, tau):
        """The action that asks for the torques ``tau`` [N m], as float32."""
        return torque_to_action(tau, self.torque_limits, self.normalize_actions)

    def step(self, action):
        """Hold the action's torques over ``frame_skip`` physics steps; (obs, reward, terminated, truncated, info)."""
        tau = self.action_to_torque(action)
        r = self._robots
        r.step(self._rows, tau[None])
        self._steps += 1
        terminated = bool(r.diverged[0] or r.margin[0] >= self.terminate_margin)
        truncated = self._steps >= self.max_steps and not terminated
        return r.obs[0].copy(), float(r.reward[0]), terminated, truncated, self._info()

    def render(self):
        if self.render_mode != "rgb_array":
            return None
        if self._renderer is None:
            from .outputs.gl import select_backend
            from .outputs.video import GymnastRenderer

            select_backend("auto")
            self._renderer = GymnastRenderer(self.robot, self.width, self.height)
        return self._renderer.render(self._robots.q[0].copy())

    def close(self):
        if self._renderer is not None:
            self._renderer.close()
            self._renderer = None


def perturbed(x0, rng, init_noise, init_speed_noise):
    """``x0`` with the angles and (when ``init_speed_noise`` > 0) the speeds perturbed uniformly."""
    x0 = np.array(x0, dtype=float)
    n = x0.size // 2
    x0[:n] += rng.uniform(-init_noise, init_noise, n)
    if init_speed_noise > 0:  # no draw otherwise: the episodes of v0 start as they always did
        x0[n:] += rng.uniform(-init_speed_noise, init_speed_noise, n)
    return x0


class GymnastKipEnv(GymnastEnv):
    """``paa_mj/GymnastKip-v0``: the kip with the first version's defaults, kept for compatibility.

    Torques [N m] as actions (``normalize_actions=False``), one 1 ms physics step per environment
    step, 30 s episodes and the v0 reward of the module docstring. Parameters as :class:`GymnastEnv`'s
    (no ``task``).
    """

    _legacy = True

    def __init__(self, robot="gymnast", render_mode=None, max_episode_seconds=30.0, frame_skip=1,
                 torque_limit=None, init_noise=0.05, width=480, height=360, normalize_actions=False,
                 init_speed_noise=0.0, terminate_margin=math.inf):
        super().__init__("kip", robot, render_mode, max_episode_seconds, frame_skip, torque_limit, init_noise,
                         init_speed_noise, terminate_margin, normalize_actions, width, height)


def controller_policy(controller, env: GymnastEnv):
    """A policy ``policy(obs, info) -> action`` from a controller of the package (name or object).

    The controller reads the unwrapped state and the time in ``info`` and its torques become actions of
    ``env`` (normalised when the environment's actions are). Call ``policy.reset()`` with ``env.reset()``.
    """
    from .control.base import reset_controller, torque_of
    from .control.registry import make_controller

    env = getattr(env, "unwrapped", env)
    if isinstance(controller, str):
        controller = make_controller(controller, env.robot, goal=env.goal)

    def policy(obs, info):
        return env.torque_to_action(torque_of(controller, info["q"][None], info["qd"][None], info["time"])[0])

    policy.reset = lambda: reset_controller(controller)
    policy.controller = controller
    return policy


def register():
    """Register the environments of the module docstring with Gymnasium (done on import of this module)."""
    if ENV_ID not in gym.registry:
        gym.register(id=ENV_ID, entry_point="paa_mj.gym_env:GymnastKipEnv")
    for env_id, task in ((KIP_ID, "kip"), (BALANCE_ID, "balance")):
        if env_id not in gym.registry:
            gym.register(id=env_id, entry_point="paa_mj.gym_env:GymnastEnv",
                         vector_entry_point="paa_mj.gym_vector:GymnastVectorEnv", kwargs={"task": task},
                         max_episode_steps=HORIZONS[env_id])


register()
