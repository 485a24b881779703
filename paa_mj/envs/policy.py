"""Policies and controllers, both ways: a controller of the package as a policy of the environments
(:func:`controller_policy`), and a trained policy as a controller that every command runs (:class:`SB3Policy`).

:class:`SB3Policy` maps the controller interface ``torque(q, qd, t)`` (batches (..., n) [rad, rad/s]
to torques (..., n - 1) [N m]; (..., 3) and (..., 2) for the gymnast) to ``model.predict(obs, deterministic=True)`` of a Stable-Baselines3 model
trained on the environments of :mod:`paa_mj.envs`, through their own maps: the observations are
:func:`~paa_mj.envs.spaces.observation` of the state the controller sees and the torques are
:func:`~paa_mj.envs.spaces.action_to_torque` of the actions. As in the environment, an action is held over
``frame_skip`` physics steps (the 10 ms control period of the v1 environments).

A user's file configures it and the commands take it as ``FILE.py:Class``::

    # mine.py
    from pathlib import Path
    from paa_mj.envs.policy import SB3Policy

    class Balance(SB3Policy):
        path = Path(__file__).with_name("ppo_balance.zip")   # what model.save() wrote
        algorithm = "PPO"

    # paa-mj simulate --controller mine.py:Balance --x0 0 -3.1 0 0 0 0 --t-final 10 --out run

Stable-Baselines3 (and torch) are needed only to load a model file: ``pip install "paa_mj[rl]"``.
A subclass may instead override :meth:`SB3Policy.load_model` to return any object with
``predict(obs, deterministic=True) -> (actions, state)``.
"""
from __future__ import annotations

import math
from pathlib import Path

import numpy as np

from ..errors import PaaError
from .spaces import FRAME_SKIP

#: How to install what a Stable-Baselines3 model needs.
RL_INSTALL = 'pip install "paa_mj[rl]"'


def require_sb3():
    """The ``stable_baselines3`` module, or a one-line :class:`PaaError` saying how to install it."""
    try:
        import stable_baselines3
    except ImportError:
        raise PaaError(f"stable-baselines3 is not installed (it brings torch): {RL_INSTALL}") from None
    return stable_baselines3


def controller_policy(controller, env):
    """A policy ``policy(obs, info) -> action`` from a controller of the package (a name, or a controller built for
    the environment's robot and task).

    The controller reads the unwrapped state and the time in ``info`` and its torques become actions of
    ``env`` (normalised when the environment's actions are). Call ``policy.reset()`` with ``env.reset()``.
    """
    from ..control.base import check_binding, reset_controller, torque_of
    from ..control.registry import make_controller

    env = getattr(env, "unwrapped", env)
    if isinstance(controller, str):
        controller = make_controller(controller, env.robot, task=env.task)
    check_binding(controller, env.robot, env.task)

    def policy(obs, info):
        return env.torque_to_action(torque_of(controller, info["q"][None], info["qd"][None], info["time"])[0])

    policy.reset = lambda: reset_controller(controller)
    policy.controller = controller
    return policy


def _gym_maps():
    try:
        from . import spaces
    except ImportError:  # gymnasium missing: the maps live with the environments
        raise PaaError(f"a trained policy needs the Gymnasium environments' maps (gymnasium): {RL_INSTALL}") from None
    return spaces


class SB3Policy:
    """A Stable-Baselines3 model as a controller (module docstring); configure it by subclassing.

    Attributes
    ----------
    path : str or Path
        The model file (``model.save(path)``); relative paths are from the working folder.
    algorithm : str
        The class of ``stable_baselines3`` that saved it ("PPO", "SAC", "TD3", ...).
    episode : str
        The environment's episode type, "balance" (``paa_mj/GymnastBalance-v1``) or "kip": its default torque
        limit.
    torque_limit : float or None
        As the environment's ``torque_limit`` [N m] (None: the episode type's default).
    normalize_actions : bool
        As the environment's: actions in [-1, 1] scaled by the torque limits.
    frame_skip : int
        Physics steps an action is held, as the environment's (10: 10 ms on the 1 ms models).
    deterministic : bool
        Passed to ``predict``.

    Parameters
    ----------
    robot : paa_mj.model.robot.Robot
        The robot, as every command builds a user's controller (``Class(robot)``).
    model : object, optional
        A model with ``predict(obs, deterministic=True)``; default :meth:`load_model`.
    """

    name = "sb3-policy"
    path = None
    algorithm = "PPO"
    episode = "balance"
    torque_limit = None
    normalize_actions = True
    frame_skip = FRAME_SKIP
    deterministic = True
    mode = 0

    def __init__(self, robot, model=None):
        maps = _gym_maps()
        if self.episode not in maps.EPISODES:
            raise PaaError(f"{type(self).__name__}.episode must be one of {', '.join(maps.EPISODES)}, got"
                           f" {self.episode!r}")
        self._observation, self._action_to_torque = maps.observation, maps.action_to_torque
        #: The torque limits T [N m], (n - 1,), as the environment computes them.
        self.torque_limits = maps.torque_limits_for(robot, self.episode, self.torque_limit)
        self.robot = robot
        self.period = self.frame_skip * robot.model.opt.timestep
        self.model = self.load_model() if model is None else model
        if not callable(getattr(self.model, "predict", None)):
            raise PaaError(f"{type(self).__name__}: the model has no method predict(obs, deterministic=True)")
        self._check_spaces(self.model)
        self.reset()

    def load_model(self):
        """The Stable-Baselines3 model of :attr:`path` (one-line errors: no SB3, no file, unknown algorithm)."""
        sb3 = require_sb3()
        if self.path is None:
            raise PaaError(f"{type(self).__name__}.path is not set: name the model file that model.save() wrote")
        cls = getattr(sb3, str(self.algorithm), None)
        if cls is None or not hasattr(cls, "load"):
            raise PaaError(f"{type(self).__name__}.algorithm {self.algorithm!r} is no algorithm of stable_baselines3")
        path = Path(self.path).expanduser()
        # as Stable-Baselines3 reads it: the path, else the path with ".zip" appended (not a suffix replaced)
        if not path.is_file() and not Path(f"{path}.zip").is_file():
            raise PaaError(f"policy file not found: {self.path}")
        try:
            model = cls.load(str(path), device="cpu")
        except Exception as err:  # not a model file, another algorithm's, an incompatible version...
            raise PaaError(f"cannot load policy file {self.path} as {self.algorithm}: {type(err).__name__}:"
                           f" {' '.join(str(err).split())[:300]}") from None
        return model

    def _check_spaces(self, model):
        """A one-line error when the model's spaces are not those of the v1 environments of this robot
        (3n observations, one action per motor) that this adapter feeds it."""
        name = type(self).__name__
        links = self.robot.params.n_links
        obs_space, action_space = getattr(model, "observation_space", None), getattr(model, "action_space", None)
        if obs_space is not None and getattr(obs_space, "shape", None) != (3 * links,):
            raise PaaError(f"{name}: the model observes {getattr(obs_space, 'shape', obs_space)}, not the"
                           f" {3 * links} observations of the environments of robot {self.robot.name} ({links} links)")
        if action_space is None:
            return
        motors = self.robot.params.n_motors
        if getattr(action_space, "shape", None) != (motors,):
            raise PaaError(f"{name}: the model acts in {getattr(action_space, 'shape', action_space)}, not the"
                           f" {motors} torques of the environments of robot {self.robot.name} ({links} links,"
                           f" {motors} motor{'s' * (motors > 1)})")
        if self.normalize_actions and not (np.all(np.asarray(action_space.high) == 1)
                                           and np.all(np.asarray(action_space.low) == -1)):
            raise PaaError(f"{name}: the model's actions are not in [-1, 1] (a model of paa_mj/GymnastKip-v0, torques"
                           " as actions?): set normalize_actions = False")

    def reset(self):
        """Forget the held torques (before a new rollout)."""
        self._held, self._period_index = None, None

    def actions(self, q, qd):
        """The model's actions (..., n - 1) at states q, qd (..., n), through the environment's observation map."""
        obs = self._observation(q, qd)
        motors = np.shape(q)[-1] - 1
        flat = obs.reshape(-1, obs.shape[-1])
        actions, _ = self.model.predict(flat, deterministic=self.deterministic)
        actions = np.asarray(actions, dtype=float)
        if actions.shape != (len(flat), motors):
            raise PaaError(f"{type(self).__name__}: predict returned actions of shape {actions.shape} for"
                           f" {len(flat)} observations; it must return ({len(flat)}, {motors})")
        return actions.reshape(obs.shape[:-1] + (motors,))

    def torque(self, q, qd, t=0.0):
        """Torques [N m], (..., n - 1): the actions of the state at the start of each control period, held over it."""
        q, qd = np.asarray(q, dtype=float), np.asarray(qd, dtype=float)
        # the period index by floor with a margin: t = k dt arrives a rounding below k dt now and then
        index = math.floor(float(t) / self.period + 1e-6)
        if self._held is None or index != self._period_index or self._held.shape[:-1] != q.shape[:-1]:
            self._held = self._action_to_torque(self.actions(q, qd), self.torque_limits, self.normalize_actions)
            self._period_index = index
        return self._held.copy()

    def describe(self) -> dict:
        return {"controller": type(self).__name__, "policy": None if self.path is None else str(self.path),
                "algorithm": self.algorithm, "frame_skip": self.frame_skip}
