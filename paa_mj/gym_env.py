"""The kip as a Gymnasium environment: ``paa_mj/GymnastKip-v0`` (extra ``paa_mj[gym]``).

Observation space
    ``Box(9,)`` float32: cos q_i, sin q_i for i = 1, 2, 3, then qd [rad/s] (unbounded).
Action space
    ``Box(2,)`` float32: the shoulder and hip torques [N m] within the torque limits, the
    smaller of ``torque_limit`` (default 2 b1 / 1 rad, above the paper's peak torques) and the
    model's actuator ranges (:attr:`Robot.torque_limits <paa_mj.model.robot.Robot.torque_limits>`),
    or, with ``normalize_actions=True``, in [-1, 1] and scaled by those limits.
Dynamics
    One environment step is ``frame_skip`` physics steps with the torque held
    (default one RK4 step of 1 ms, as the paper's controller runs).
Reward
    Minus the squared distance to UDD: :math:`-(|x_{angles}|^2 / (3 \\pi^2) + 10^{-3} |\\dot q|^2 + 10^{-8} |\\tau|^2)`,
    x the error from UDD with the angles wrapped; 0 at UDD, -10 when the simulation diverges.
Termination and truncation
    Terminated when the state diverges (non-finite, runaway speeds, MuJoCo warnings);
    truncated after ``max_episode_seconds``.
Info
    The raw, unwrapped ``q`` and ``qd`` and the ``time``: controller (40) needs the unwrapped q2.

A controller of the package as a policy: :func:`controller_policy` (``policy(obs, info) -> action``).
Importing this module registers the environment; ``gym.make("paa_mj.gym_env:paa_mj/GymnastKip-v0")``
imports it by itself.
"""
from __future__ import annotations

import math
import operator

import gymnasium as gym
import mujoco
import numpy as np
from gymnasium import spaces

from .model.robot import load_robot
from .model.states import X0_HANGING, udd_error
from .sim.mujoco_log import mujoco_log_off
from .sim.rollout import divergence_reason

ENV_ID = "paa_mj/GymnastKip-v0"
#: The largest torque limit [N m]: the action space is float32.
MAX_TORQUE_LIMIT = 1e12
#: The most environment steps of one episode.
MAX_EPISODE_STEPS = 1e12


def _real_array(value):
    """``value`` as a float array, or None when it is not real numbers (text, complex, booleans, objects)."""
    try:
        array = np.asarray(value)
    except (TypeError, ValueError):
        return None
    if array.dtype.kind not in "fiu":
        return None
    return array.astype(float)


def _number(name, value, accept, rule):
    """``value`` as a float for which ``accept`` holds, else a ValueError naming ``name`` and ``rule``."""
    try:
        if isinstance(value, (bool, np.bool_, str, bytes)):  # float() would read True as 1 and "2" as 2
            raise TypeError
        number = float(value)
    except (TypeError, ValueError):
        raise ValueError(f"{name} must be a number, got {value!r}") from None
    if not (math.isfinite(number) and accept(number)):
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


class GymnastKipEnv(gym.Env):
    metadata = {"render_modes": ["rgb_array"], "render_fps": 30}

    """The kip as a Gymnasium environment (module docstring).

    Parameters
    ----------
    robot : str or path
        A named robot or an MJCF file, as :func:`~paa_mj.model.load_robot` takes.
    render_mode : None or "rgb_array"
    max_episode_seconds : float
        Simulated time before truncation [s], positive and at least one environment step.
    frame_skip : int
        Physics steps per environment step, in [1, 1000000].
    torque_limit : float, optional
        Saturation of both torques [N m], positive and finite; the model's actuator ranges
        also apply (the smaller wins). Default 2 b1 / 1 rad.
    init_noise : float
        Largest perturbation of the initial angles at reset [rad], finite and >= 0.
    width, height : int
        Size of the rendered frames [pixels], in [16, 4096].
    normalize_actions : bool

    Raises
    ------
    ValueError
        An argument of the wrong type or out of range (NaN, inf, negative), one line naming it.
    paa_mj.errors.PaaError
        A robot that cannot be loaded.
    """

    def __init__(self, robot="gymnast", render_mode=None, max_episode_seconds=30.0, frame_skip=1,
                 torque_limit=None, init_noise=0.05, width=480, height=360, normalize_actions=False):
        if render_mode not in (None, "rgb_array"):
            raise ValueError(f"render_mode must be None or 'rgb_array', got {render_mode!r}")
        if not isinstance(normalize_actions, (bool, np.bool_)):
            raise ValueError(f"normalize_actions must be True or False, got {normalize_actions!r}")
        # checked before the robot is loaded: a wrong argument is named before any slower failure
        frame_skip = _whole("frame_skip", frame_skip, 1, 1_000_000)
        seconds = _number("max_episode_seconds", max_episode_seconds, lambda v: v > 0, "must be a positive finite"
                          " number [s]")
        if torque_limit is not None:
            # a negative limit would turn np.clip(a, -T, T) into T for every action: every torque inverted; one
            # beyond float32 would make the action space's bounds infinite
            torque_limit = _number("torque_limit", torque_limit, lambda v: 0 < v <= MAX_TORQUE_LIMIT,
                                   f"must be a positive finite number [N m] up to {MAX_TORQUE_LIMIT:g}")
        init_noise = _number("init_noise", init_noise, lambda v: v >= 0, "must be a finite number >= 0 [rad]")
        width, height = _whole("width", width, 16, 4096), _whole("height", height, 16, 4096)
        self.robot = load_robot(robot)
        self.model = self.robot.model.__copy__()
        self.data = mujoco.MjData(self.model)
        self.frame_skip = frame_skip
        self.dt = self.model.opt.timestep * self.frame_skip
        steps = seconds / self.dt
        if not steps <= MAX_EPISODE_STEPS:
            raise ValueError(f"max_episode_seconds {max_episode_seconds!r} is too long: {steps:.3g} environment steps"
                             f" of {self.dt:g} s, more than {MAX_EPISODE_STEPS:g}")
        self.max_steps = int(round(steps))
        if self.max_steps < 1:
            raise ValueError(f"max_episode_seconds {max_episode_seconds!r} is shorter than one environment step"
                             f" ({self.dt:g} s)")
        self.torque_limit = float(torque_limit if torque_limit is not None else 2 * self.robot.analytic.b1)
        #: The torque limits applied [N m], (2,): ``torque_limit`` capped by the model's actuator ranges.
        self.torque_limits = np.minimum(self.torque_limit, self.robot.torque_limits)
        self.init_noise = init_noise
        self.render_mode, self.width, self.height = render_mode, width, height
        self.normalize_actions = bool(normalize_actions)
        bound = np.ones(2) if self.normalize_actions else self.torque_limits
        self.action_space = spaces.Box(-bound.astype(np.float32), bound.astype(np.float32), (2,), np.float32)
        high = np.array([1, 1, 1, 1, 1, 1, np.inf, np.inf, np.inf], np.float32)
        self.observation_space = spaces.Box(-high, high, dtype=np.float32)
        self._renderer = None
        self._steps = 0

    def _obs(self):
        q, qd = self.data.qpos, self.data.qvel
        return np.concatenate([np.stack([np.cos(q), np.sin(q)], -1).ravel(), qd]).astype(np.float32)

    def _info(self):
        return {"q": self.data.qpos.copy(), "qd": self.data.qvel.copy(), "time": float(self.data.time)}

    def reset(self, *, seed=None, options=None):
        """Back to (65) (or ``options["x0"]``) with the angles perturbed by up to ``init_noise`` [rad]."""
        if options is not None:
            # an option this environment does not know (a typo of x0) would be ignored in silence
            if not isinstance(options, dict):
                raise ValueError(f"options must be a dict (or None), got {type(options).__name__}")
            unknown = sorted(map(str, set(options) - {"x0"}))
            if unknown:
                raise ValueError(f"unknown reset option(s) {', '.join(unknown)}: the only option is x0")
        x0 = _real_array((options or {}).get("x0", X0_HANGING))
        if x0 is None or x0.shape != (6,) or not np.all(np.isfinite(x0)):
            raise ValueError("options['x0'] must be 6 finite numbers")
        super().reset(seed=seed)
        mujoco.mj_resetData(self.model, self.data)
        x0 = x0.copy()
        x0[:3] += self.np_random.uniform(-self.init_noise, self.init_noise, 3)
        self.data.qpos[:], self.data.qvel[:] = x0[:3], x0[3:]
        with mujoco_log_off():
            mujoco.mj_forward(self.model, self.data)
        self._steps = 0
        return self._obs(), self._info()

    def action_to_torque(self, action):
        """The torques [N m] an action asks for (scaled when actions are normalised), within the limits.

        Raises
        ------
        ValueError
            An action that is not two finite real numbers: one number would be given to both motors and a
            NaN or infinite one would be clipped or end the episode as a divergence, in silence.
        """
        given, action = action, _real_array(action)
        if action is None or action.shape != (2,):
            shown = " ".join(repr(given).split())
            raise ValueError("an action is two real numbers [tau2, tau3], shape (2,), got "
                             + (f"{shown[:60]}" if action is None else f"shape {action.shape}"))
        if not np.all(np.isfinite(action)):
            raise ValueError(f"an action must be finite, got {action.tolist()}")
        if self.normalize_actions:
            action = action * self.torque_limits
        return np.clip(action, -self.torque_limits, self.torque_limits)

    def torque_to_action(self, tau):
        """The action that asks for the torques ``tau`` [N m], as float32."""
        tau = np.clip(np.asarray(tau, dtype=float), -self.torque_limits, self.torque_limits)
        return (tau / self.torque_limits if self.normalize_actions else tau).astype(np.float32)

    def step(self, action):
        """Hold the action's torques over ``frame_skip`` physics steps; (obs, reward, terminated, truncated, info)."""
        tau = self.action_to_torque(action)
        self.data.ctrl[:] = tau
        with mujoco_log_off():  # a diverging step ends the episode; MuJoCo's warning must not leave MUJOCO_LOG.TXT
            for _ in range(self.frame_skip):
                mujoco.mj_step(self.model, self.data)
        self._steps += 1
        diverged = divergence_reason(self.data) is not None
        if diverged:
            return np.zeros(9, np.float32), -10.0, True, False, self._info() | {"diverged": True}
        x = udd_error(self.data.qpos, self.data.qvel)
        reward = -(float(x[:3] @ x[:3]) / (3 * np.pi**2) + 1e-3 * float(x[3:] @ x[3:]) + 1e-8 * float(tau @ tau))
        truncated = self._steps >= self.max_steps
        return self._obs(), reward, False, truncated, self._info()

    def render(self):
        if self.render_mode != "rgb_array":
            return None
        if self._renderer is None:
            from .outputs.gl import select_backend
            from .outputs.video import GymnastRenderer

            select_backend("auto")
            self._renderer = GymnastRenderer(self.robot, self.width, self.height)
        return self._renderer.render(self.data.qpos.copy())

    def close(self):
        if self._renderer is not None:
            self._renderer.close()
            self._renderer = None


def controller_policy(controller, env: GymnastKipEnv):
    """A policy ``policy(obs, info) -> action`` from a controller of the package (name or object).

    The controller reads the unwrapped state in ``info`` and its torques become actions of ``env``
    (normalised when the environment's actions are). Call ``policy.reset()`` with ``env.reset()``.
    """
    from .control.base import reset_controller, torque_of
    from .control.registry import make_controller

    env = getattr(env, "unwrapped", env)
    if isinstance(controller, str):
        controller = make_controller(controller, env.robot)

    def policy(obs, info):
        return env.torque_to_action(torque_of(controller, info["q"][None], info["qd"][None], info["time"])[0])

    policy.reset = lambda: reset_controller(controller)
    policy.controller = controller
    return policy


def register():
    """Register ``paa_mj/GymnastKip-v0`` with Gymnasium (done on import of this module)."""
    if ENV_ID not in gym.registry:
        gym.register(id=ENV_ID, entry_point="paa_mj.gym_env:GymnastKipEnv")


register()
