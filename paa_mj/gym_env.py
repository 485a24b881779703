"""The kip as a Gymnasium environment: ``paa_mj/GymnastKip-v0`` (extra ``paa_mj[gym]``).

Observation space
    ``Box(9,)`` float32: cos q_i, sin q_i for i = 1, 2, 3, then qd [rad/s] (unbounded).
Action space
    ``Box(2,)`` float32: the shoulder and hip torques [N m] within +-``torque_limit``
    (default 2 b1 / 1 rad, above the paper's peak torques), or, with
    ``normalize_actions=True``, in [-1, 1] and scaled by ``torque_limit``.
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

import gymnasium as gym
import mujoco
import numpy as np
from gymnasium import spaces

from .model.robot import load_robot
from .model.states import X0_HANGING, udd_error
from .sim.rollout import divergence_reason

ENV_ID = "paa_mj/GymnastKip-v0"


class GymnastKipEnv(gym.Env):
    metadata = {"render_modes": ["rgb_array"], "render_fps": 30}

    def __init__(self, robot="gymnast", render_mode=None, max_episode_seconds=30.0, frame_skip=1,
                 torque_limit=None, init_noise=0.05, width=480, height=360, normalize_actions=False):
        if render_mode not in (None, "rgb_array"):
            raise ValueError(f"render_mode must be None or 'rgb_array', got {render_mode!r}")
        self.robot = load_robot(robot)
        self.model = self.robot.model.__copy__()
        self.data = mujoco.MjData(self.model)
        self.frame_skip = int(frame_skip)
        self.dt = self.model.opt.timestep * self.frame_skip
        self.max_steps = int(round(max_episode_seconds / self.dt))
        self.torque_limit = float(torque_limit if torque_limit is not None else 2 * self.robot.analytic.b1)
        self.init_noise = float(init_noise)
        self.render_mode, self.width, self.height = render_mode, width, height
        self.normalize_actions = bool(normalize_actions)
        bound = 1.0 if self.normalize_actions else self.torque_limit
        self.action_space = spaces.Box(-bound, bound, (2,), np.float32)
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
        super().reset(seed=seed)
        mujoco.mj_resetData(self.model, self.data)
        x0 = np.asarray((options or {}).get("x0", X0_HANGING), dtype=float)
        if x0.shape != (6,) or not np.all(np.isfinite(x0)):
            raise ValueError("options['x0'] must be 6 finite numbers")
        x0 = x0.copy()
        x0[:3] += self.np_random.uniform(-self.init_noise, self.init_noise, 3)
        self.data.qpos[:], self.data.qvel[:] = x0[:3], x0[3:]
        mujoco.mj_forward(self.model, self.data)
        self._steps = 0
        return self._obs(), self._info()

    def action_to_torque(self, action):
        """The torques [N m] an action asks for (scaled when actions are normalised), within the limit."""
        action = np.asarray(action, dtype=float)
        if self.normalize_actions:
            action = action * self.torque_limit
        return np.clip(action, -self.torque_limit, self.torque_limit)

    def torque_to_action(self, tau):
        """The action that asks for the torques ``tau`` [N m], as float32."""
        tau = np.clip(np.asarray(tau, dtype=float), -self.torque_limit, self.torque_limit)
        return (tau / self.torque_limit if self.normalize_actions else tau).astype(np.float32)

    def step(self, action):
        """Hold the action's torques over ``frame_skip`` physics steps; (obs, reward, terminated, truncated, info)."""
        tau = self.action_to_torque(action)
        self.data.ctrl[:] = tau
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
