"""The gymnast as a Gymnasium environment (extra ``paa_mj[gym]``): :class:`GymnastEnv`.

Registered ids (:mod:`paa_mj.envs` registers them; ``gym.make("paa_mj.envs:<id>")`` imports it by itself):

``paa_mj/GymnastKip-v1``
    The kip episode: from the task's start (hanging, (65) for the gymnast), angles perturbed uniformly by up
    to ``init_noise`` = 0.05 rad, to balanced at the task's goal (UDD (8) by default). 30 s episodes
    (``max_episode_steps`` = 3000 at the default 10 ms control period).
``paa_mj/GymnastBalance-v1``
    The balance episode: the start is the goal plus a uniform perturbation, every angle error in
    [-0.05, 0.05] rad and every speed in [-0.05, 0.05] rad/s; 10 s episodes (``max_episode_steps`` = 1000).
``paa_mj/GymnastKip-v0``
    The first version, kept for compatibility with its old defaults: torques [N m] as actions, one
    1 ms physics step per environment step, the reward of v0 (:class:`GymnastKipEnv`).

The v1 ids also build :class:`paa_mj.envs.vector.GymnastVectorEnv` through
``gym.make_vec(id, num_envs=N)``: N robots stepped together by one compiled call.

Any robot of the family and any task: ``gym.make(id, robot="acrobot", task="stretched")`` (a goal's name or a
:class:`~paa_mj.task.Task`); ``episode`` ("kip" or "balance") is the kind of episode. A chain of n links has 3n
observations and n - 1 actions (:mod:`paa_mj.envs.spaces`), and its rewards measure the error from its goal
(:mod:`paa_mj.envs.stepper`).

Dynamics
    One environment step holds the torque over ``frame_skip`` physics steps of MuJoCo (RK4, the model's
    step, 1 ms for the stored robots): a control period of 10 ms in v1, 1 ms in v0 at 1 ms. The physics runs in compiled code
    (``mj_step`` called from numba, as :mod:`paa_mj.sim.compiled.engine` does), the same code for one
    environment and for the vector environment. ``physics="analytic"`` steps the robot's own equations
    of motion by the same RK4 instead (:mod:`paa_mj.sim.analytic.rk4`; a model of another integrator is refused): the
    same equations, states that agree with MuJoCo's to rounding, at under a tenth of the cost (``paa-mj bench``).
Termination and truncation
    Terminated when the state diverges (non-finite, speeds above 1e4 rad/s, MuJoCo warnings); the
    episode then ends on the last good state. Balance also terminates when the state after a step has
    left region (68) by ``terminate_margin`` (default 0.5): :math:`\\max_i |x_i| / l_i \\ge 1 + 0.5`,
    an angle error of pi/4 rad or a speed of 0.75 rad/s. Truncated (when not terminated) after
    ``max_episode_seconds``; the registered ids wrap the environment in a ``TimeLimit`` of that horizon in
    environment steps (:func:`registered`), which wrappers read as ``env.spec.max_episode_steps``.
    ``gym.make(id, max_episode_steps=k)`` adds Gymnasium's own ``TimeLimit`` outside, which the environment
    cannot see: its task states its own horizon (``env.unwrapped.task.horizon``); give ``max_episode_seconds``
    instead (the vector environment takes ``max_episode_steps`` as its horizon).
Info
    ``q``, ``qd``: the raw state, angles unwrapped (controller (40) needs the unwrapped q2);
    ``time``: physics steps since reset x the model's time step [s] (the time the package's engines give controllers);
    ``diverged``; ``is_success``: the task's success (:attr:`~paa_mj.task.Task.success_definition`, the same
    compiled test as the engines') of the episode so far, as if it ended now: no divergence, and the true state
    inside the success region at every physics step of the last second (the whole episode when shorter,
    the start included). At the last step of an episode it is the episode's success.
Copies
    ``copy.deepcopy(env)`` and ``pickle`` give an independent environment in the same state (its physics
    rebuilt, never shared).

A controller of the package as a policy: :func:`controller_policy` (``policy(obs, info) -> action``).
"""
from __future__ import annotations

import math

import gymnasium as gym
import numpy as np
from gymnasium import spaces

from ..model.robot import load_robot
from ..task import as_task
from .spaces import (EPISODES, FRAME_SKIP, MAX_EPISODE_STEPS, MAX_TORQUE_LIMIT, _check_options, _check_x0, _number,
                     _real_array, _whole, action_to_torque, torque_limit_for, torque_limits_for, torque_to_action)
from .stepper import PHYSICS, REWARD_BALANCE, REWARD_KIP, REWARD_V0, Robots, ended_early

_REWARD_KIND = {"kip": REWARD_KIP, "balance": REWARD_BALANCE}


def _check_names(episode, task, physics, render_mode, normalize_actions):
    """The names an environment is made with, or a ValueError naming the argument."""
    if not isinstance(episode, str) or episode not in EPISODES:
        raise ValueError(f"episode must be {' or '.join(map(repr, EPISODES))}, got {episode!r}")
    if isinstance(task, str) and task in EPISODES:
        raise ValueError(f"task={task!r} names an episode type: use episode={task!r} (task is the goal: a goal's name"
                         " or a paa_mj.task.Task)")
    if not isinstance(physics, str) or physics not in PHYSICS:
        raise ValueError(f"physics must be {' or '.join(map(repr, PHYSICS))}, got {physics!r}")
    if render_mode not in (None, "rgb_array"):
        raise ValueError(f"render_mode must be None or 'rgb_array', got {render_mode!r}")
    if not isinstance(normalize_actions, (bool, np.bool_)):
        raise ValueError(f"normalize_actions must be True or False, got {normalize_actions!r}")


class GymnastEnv(gym.Env):
    """The gymnast as a Gymnasium environment, episodes ``kip`` and ``balance`` (module docstring).

    Parameters
    ----------
    episode : "kip" or "balance"
        From the task's start (hanging (65)) to balanced at its goal, or staying balanced from near the goal.
    robot : str or path
        A named robot or an MJCF file, as :func:`~paa_mj.model.load_robot` takes.
    task : Task or str, optional
        The goal and how success is judged: a :class:`~paa_mj.task.Task` of this robot or a goal's name
        ("folded", the paper's UDD by default, or "stretched"). Any robot of the family is welcome: the
        observations are then 3n numbers and the actions n - 1.
    render_mode : None or "rgb_array"
    max_episode_seconds : float, optional
        Simulated time before truncation [s], positive and at least one environment step;
        default 30 s (kip), 10 s (balance).
    frame_skip : int
        Physics steps (1 ms) per environment step, in [1, 1000000]; default 10 (a 10 ms control period).
    torque_limit : float, optional
        Saturation of every torque [N m], positive and at most 1e12; the model's actuator ranges
        also apply (the smaller wins). Default 2 b1 / 1 rad (kip, above the paper's peak torques) or
        0.1 b1 / 1 rad (balance), b1 of (4) [J]: 579 or 29 N m for Table 1.
    init_noise : float, optional
        Half-width of the uniform perturbation of the initial angles at reset [rad], finite and >= 0;
        default 0.05.
    init_speed_noise : float, optional
        Half-width of the uniform perturbation of the initial speeds [rad/s], finite and >= 0;
        default 0 (kip), 0.05 (balance).
    terminate_margin : float, optional
        Terminate when the margin of region (68), :math:`\\max_i |x_i| / l_i - 1`, reaches it after a step,
        >= 0; ``math.inf``: never. Default inf (kip), 0.5 (balance).
    normalize_actions : bool
        Actions in [-1, 1] scaled by the torque limits (default), or torques [N m].
    width, height : int
        Size of the rendered frames [pixels], in [16, 4096].
    physics : "mujoco" or "analytic"
        ``mj_step`` of the robot's MuJoCo model (default), or the classic RK4 of the robot's own equations of
        motion (:func:`paa_mj.sim.analytic.rk4.rk4_step`, the same time step, the torque held over it): the same
        equations as MuJoCo's (``paa-mj check``), over ten times cheaper a step, agreeing with MuJoCo's
        steps to rounding, not bit for bit; rounding grows where the motion is chaotic (a swing-up), so
        episodes of the two agree closely while they balance and statistically, not state for state, over a
        long kip.

    Attributes
    ----------
    task : Task
        The task with this environment's start and horizon: what an episode aims at and how it is judged.

    Raises
    ------
    ValueError
        An argument of the wrong type or out of range (NaN, inf, negative), one line naming it.
    paa_mj.errors.PaaError
        A robot that cannot be loaded, or a task of another robot.
    """

    metadata = {"render_modes": ["rgb_array"], "render_fps": 30}
    _legacy = False

    def __init__(self, episode="kip", robot="gymnast", task=None, render_mode=None, max_episode_seconds=None,
                 frame_skip=FRAME_SKIP, torque_limit=None, init_noise=None, init_speed_noise=None,
                 terminate_margin=None, normalize_actions=True, width=480, height=360, physics="mujoco"):
        self._init_args = dict(episode=episode, robot=robot, task=task, render_mode=render_mode,
                               max_episode_seconds=max_episode_seconds, frame_skip=frame_skip,
                               torque_limit=torque_limit, init_noise=init_noise, init_speed_noise=init_speed_noise,
                               terminate_margin=terminate_margin, normalize_actions=normalize_actions, width=width,
                               height=height, physics=physics)
        _check_names(episode, task, physics, render_mode, normalize_actions)
        seconds, noise, speed_noise, margin = (EPISODES[episode][k] for k in ("seconds", "noise", "speed_noise",
                                                                               "margin"))
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
        self.episode, self.physics = episode, physics
        self.robot = load_robot(robot)
        self._setup_time(frame_skip, seconds, max_episode_seconds)
        links = self.robot.params.n_links
        base = as_task(task, self.robot)
        start = base.start if episode == "kip" else np.concatenate([base.goal, np.zeros(links)])
        self.task = base.with_(start=start, horizon=self.max_steps * self.dt)
        self.torque_limit = torque_limit_for(self.robot, episode, torque_limit)
        #: The torque limits applied [N m], (m,): ``torque_limit`` capped by the model's actuator ranges.
        self.torque_limits = torque_limits_for(self.robot, episode, torque_limit)
        self.init_noise, self.init_speed_noise, self.terminate_margin = noise, speed_noise, margin
        self.render_mode, self.width, self.height = render_mode, width, height
        self.normalize_actions = bool(normalize_actions)
        motors = self.robot.params.n_motors
        bound = np.ones(motors) if self.normalize_actions else self.torque_limits
        self.action_space = spaces.Box(-bound.astype(np.float32), bound.astype(np.float32), (motors,), np.float32)
        high = np.array([1.0] * (2 * links) + [np.inf] * links, np.float32)
        self.observation_space = spaces.Box(-high, high, dtype=np.float32)
        self._robots = Robots(self.model, 1, frame_skip, REWARD_V0 if self._legacy else _REWARD_KIND[episode],
                              self.torque_limits, self.task, physics, self.robot.analytic)
        #: The MuJoCo state of the robot (physics "mujoco"; None with "analytic", whose state is in ``info``).
        self.data = self._robots.datas[0] if physics == "mujoco" else None
        self._rows = np.zeros(1, np.intp)
        self._renderer = None
        self._steps = 0

    def _setup_time(self, frame_skip, seconds, asked):
        """The control period and the episode's length in environment steps."""
        self.model = self.robot.model.__copy__()
        self.frame_skip = frame_skip
        self.dt = self.model.opt.timestep * self.frame_skip
        steps = seconds / self.dt
        shown = asked if asked is not None else seconds
        if not steps <= MAX_EPISODE_STEPS:
            raise ValueError(f"max_episode_seconds {shown!r} is too long: {steps:.3g} environment steps"
                             f" of {self.dt:g} s, more than {MAX_EPISODE_STEPS:g}")
        self.max_steps = int(round(steps))
        if self.max_steps < 1:
            raise ValueError(f"max_episode_seconds {shown!r} is shorter than one environment step ({self.dt:g} s)")

    @property
    def goal(self) -> str:
        """The name of the task's goal."""
        return self.task.name

    @property
    def start(self):
        """The state the episodes start from before the perturbation: the task's start for the kip ((65) for the
        gymnast), the goal at rest for balance."""
        return np.array(self.task.start)

    def _info(self):
        r = self._robots
        return {"q": r.q[0].copy(), "qd": r.qd[0].copy(), "time": float(r.time()[0]),
                "diverged": bool(r.episodes.diverged[0]), "is_success": bool(r.success(self.terminate_margin)[0])}

    def reset(self, *, seed=None, options=None):
        """Back to :attr:`start` (or ``options["x0"]``), angles and speeds perturbed uniformly by up to
        ``init_noise`` [rad] and ``init_speed_noise`` [rad/s]."""
        x0 = _check_options(options, ("x0",)).get("x0")
        x0 = self.start if x0 is None else _check_x0(x0, width=2 * self.robot.params.n_links)
        super().reset(seed=seed)
        self._robots.reset(0, perturbed(x0, self.np_random, self.init_noise, self.init_speed_noise))
        self._steps = 0
        return self._robots.episodes.obs[0].copy(), self._info()

    def action_to_torque(self, action):
        """The torques [N m] an action asks for (scaled when actions are normalised), within the limits.

        Raises
        ------
        ValueError
            An action that is not m finite real numbers (one per motor): one number would be given to every motor and a
            NaN or infinite one would be clipped or end the episode as a divergence, in silence.
        """
        given, action = action, _real_array(action)
        motors = self.robot.params.n_motors
        if action is None or action.shape != (motors,):
            shown = " ".join(repr(given).split())
            what = "two real numbers [tau2, tau3]" if motors == 2 and self.robot.params.is_paper_shape else f"{motors} real number{'s' * (motors > 1)}"
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
        e = r.episodes
        terminated = bool(ended_early(e, 0, self.terminate_margin))
        truncated = self._steps >= self.max_steps and not terminated
        return e.obs[0].copy(), float(e.reward[0]), terminated, truncated, self._info()

    def render(self):
        if self.render_mode != "rgb_array":
            return None
        if self._renderer is None:
            from ..view.gl import select_backend
            from ..view.renderer import GymnastRenderer

            select_backend("auto")
            self._renderer = GymnastRenderer(self.robot, self.width, self.height)
        return self._renderer.render(self._robots.q[0].copy())

    def close(self):
        if self._renderer is not None:
            self._renderer.close()
            self._renderer = None

    # --- copies: an independent environment in the same state, its physics rebuilt ------------------------

    def __getstate__(self):
        return {"init": self._init_args, "robots": self._robots.snapshot(), "steps": self._steps,
                "np_random": self._np_random, "np_random_seed": getattr(self, "_np_random_seed", None),
                "spec": self.spec}

    def __setstate__(self, state):
        self.__init__(**state["init"])
        self._robots.restore(state["robots"])
        self._steps = state["steps"]
        self._np_random, self._np_random_seed, self.spec = state["np_random"], state["np_random_seed"], state["spec"]


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
    step, 30 s episodes and the v0 reward (:mod:`paa_mj.envs.stepper`). Parameters as :class:`GymnastEnv`'s
    (no ``episode``, ``task`` or ``physics``: the folded task on MuJoCo).
    """

    _legacy = True

    def __init__(self, robot="gymnast", render_mode=None, max_episode_seconds=30.0, frame_skip=1,
                 torque_limit=None, init_noise=0.05, width=480, height=360, normalize_actions=False,
                 init_speed_noise=0.0, terminate_margin=math.inf):
        args = dict(robot=robot, render_mode=render_mode, max_episode_seconds=max_episode_seconds,
                    frame_skip=frame_skip, torque_limit=torque_limit, init_noise=init_noise, width=width,
                    height=height, normalize_actions=normalize_actions, init_speed_noise=init_speed_noise,
                    terminate_margin=terminate_margin)
        super().__init__("kip", **args)
        self._init_args = args


def registered(**kwargs) -> gym.Wrapper:
    """The entry point of the registered v1 ids: a :class:`GymnastEnv` in a ``TimeLimit`` of its own horizon in
    environment steps (``max_episode_seconds`` over its control period), so that the horizon wrappers read
    (``env.spec.max_episode_steps``) is the one it truncates at, whatever the robot's time step and ``frame_skip``."""
    env = GymnastEnv(**kwargs)
    return gym.wrappers.TimeLimit(env, env.max_steps)
