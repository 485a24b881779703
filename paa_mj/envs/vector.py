"""N gymnasts stepped together: a Gymnasium vector environment on compiled stepping (extra ``paa_mj[gym]``).

``gym.make_vec("paa_mj/GymnastBalance-v1", num_envs=64)`` (or ``paa_mj/GymnastKip-v1``) builds a
:class:`GymnastVectorEnv`: the sub-environments are those of :class:`paa_mj.envs.single.GymnastEnv`, same
arguments, spaces, rewards and information, but one environment step of all of them is one compiled call
(N MjData, each with its torque set and ``frame_skip`` ``mj_step`` from numba; the actions' torques, the
observations, rewards, terminations, truncations and information are computed in the same call). The
observations, rewards, terminations and truncations equal those of N :class:`~paa_mj.envs.single.GymnastEnv`
stepped with the same actions, bit for bit (the same compiled code computes both), and so do the resets:
sub-environment i is seeded with ``seed + i`` as :class:`gymnasium.vector.SyncVectorEnv` seeds its copies.

What it saves is the Python around the physics, not the physics: at the default 10 ms control period (ten RK4
``mj_step`` of 1 ms) ``mj_step`` alone is about two thirds of a single environment's step and above 95% of
this one's, so N single environments cost about 1.5 times as much CPU per step, no more; at 1 ms, 4 to 5 times
(``paa-mj bench``: ``vector_env_speedup``, ``vector_env_speedup_bound``, ``vector_env_physics_share``).
With ``physics="analytic"`` (RK4 of the robot's own equations, :mod:`paa_mj.sim.analytic.rk4`) the physics itself is
under a tenth of MuJoCo's, and the vector environment is about 5 times cheaper a step than N single environments
on the same physics at 10 ms, 18 times cheaper than N single environments on MuJoCo's (``paa-mj bench``:
``vector_env_analytic_speedup``, ``vector_env_analytic_vs_single_mujoco``).

Autoreset (Gymnasium 1.x, ``metadata["autoreset_mode"]``):

- ``NEXT_STEP`` (default): a sub-environment whose episode ended is reset by the next ``step``, which ignores
  its action and returns its first observation with reward 0, not terminated, not truncated;
- ``SAME_STEP``: reset within the step that ended it; the last observation and information are in
  ``info["final_obs"]`` and ``info["final_info"]`` (masked by ``info["_final_obs"]``);
- ``DISABLED``: reset ended sub-environments with ``reset(options={"reset_mask": mask})``.

``info`` holds the sub-environments' ``q``, ``qd`` (N, n), ``time``, ``diverged`` and ``is_success`` (N,),
each with its mask ``_key``, as :class:`gymnasium.vector.SyncVectorEnv` would batch them. ``copy.deepcopy`` and
``pickle`` give an independent vector environment in the same state.
"""
from __future__ import annotations

import math
from concurrent.futures import ThreadPoolExecutor
from typing import NamedTuple

import numpy as np
from gymnasium.utils import seeding
from gymnasium.vector import AutoresetMode, VectorEnv
from gymnasium.vector.utils import batch_space
from numba import njit

from ..mujoco_log import mujoco_log_off
from ..sim.batch import ENGINES  # MuJoCo on the CPU (physics mujoco or analytic), or MuJoCo Warp
from ..sim.compiled.mujoco_lib import mj_step as _mj_step
from ..task import book_succeeded
from .single import GymnastEnv, perturbed
from .spaces import _check_options, _check_x0, _real_array, _whole, action_to_torque
from .stepper import _CTRL, _DATA, Robots, _float64_at, advance, ended_early

#: The most sub-environments of one vector environment.
MAX_ENVS = 1_000_000
_MODES = {mode.value: mode for mode in AutoresetMode}


class Counters(NamedTuple):
    """The vector environment's own episode counters and rules."""

    steps: np.ndarray  # (N,) environment steps since reset
    ended: np.ndarray  # (N,) of bool: terminated or truncated at the last step
    terminate_margin: float
    max_steps: float
    window: int  # the success window in physics steps
    timestep: float  # of the physics [s]


class StepOut(NamedTuple):
    """What a vector step returns: observations, rewards, terminations, truncations and the information."""

    obs: np.ndarray
    reward: np.ndarray
    terminated: np.ndarray
    truncated: np.ndarray
    q: np.ndarray
    qd: np.ndarray
    time: np.ndarray
    diverged: np.ndarray
    success: np.ndarray


def _step_out(n, links):
    return StepOut(np.empty((n, 3 * links), np.float32), np.empty(n), np.empty(n, bool), np.empty(n, bool),
                   np.empty((n, links)), np.empty((n, links)), np.empty(n), np.empty(n, bool), np.empty(n, bool))


@njit(nogil=True, cache=True)
def _first_bad_action(actions):
    """The first row of ``actions`` (N, n - 1) with a non-finite number, or -1."""
    for i in range(actions.shape[0]):
        for j in range(actions.shape[1]):
            if not math.isfinite(actions[i, j]):
                return i
    return -1


@njit(nogil=True, cache=True)
def _vector_torques(lo, hi, actions, normalized, restart, rules, episodes):
    """The torques of the sub-environments lo..hi-1 from their actions into ``episodes.tau`` (those of
    :func:`~paa_mj.envs.spaces.action_to_torque`: clip(a T, -T, T), the same operations); returns the rows to step
    (those not in ``restart``)."""
    limits = rules.limits
    rows = np.empty(hi - lo, np.intp)
    m = 0
    for i in range(lo, hi):
        for j in range(actions.shape[1]):
            a = np.float64(actions[i, j])
            if normalized:
                a = a * limits[j]
            if a < -limits[j]:  # np.clip(a, -T, T) of a finite a
                a = -limits[j]
            elif a > limits[j]:
                a = limits[j]
            episodes.tau[i, j] = a
        if not restart[i]:
            rows[m] = i
            m += 1
    return rows[:m]


@njit(nogil=True, cache=True)
def _vector_finish(lo, hi, restart, episodes, counters, out):
    """After the physics of a step: the step counters, terminations, truncations and the information of
    :meth:`GymnastVectorEnv._info` (time, and success as :func:`~paa_mj.task.book_succeeded` judges it) of the
    sub-environments lo..hi-1, written into ``out``. ``restart`` rows get reward 0, neither ended."""
    for i in range(lo, hi):
        if restart[i]:
            terminated, truncated, out.reward[i] = False, False, 0.0
        else:
            counters.steps[i] += 1
            terminated = ended_early(episodes, i, counters.terminate_margin)
            truncated = counters.steps[i] >= counters.max_steps and not terminated
            out.reward[i] = episodes.reward[i]
        counters.ended[i] = terminated or truncated
        out.terminated[i], out.truncated[i] = terminated, truncated
        for j in range(episodes.obs.shape[1]):
            out.obs[i, j] = episodes.obs[i, j]
        for j in range(episodes.q.shape[1]):
            out.q[i, j], out.qd[i, j] = episodes.q[i, j], episodes.qd[i, j]
        out.time[i] = episodes.phys_step[i] * counters.timestep
        out.diverged[i] = episodes.diverged[i]
        out.success[i] = book_succeeded(episodes.book[i], episodes.phys_step[i], not terminated, False,
                                        counters.window)


@njit(nogil=True, cache=True)
def _vector_step(lo, hi, actions, normalized, restart, physics, rules, episodes, counters, out):
    """One environment step of the sub-environments lo..hi-1, in one call (the actions checked finite before).

    The torques (:func:`_vector_torques`), the physics, observation and reward of
    :func:`~paa_mj.envs.stepper.advance` (the code of the single environment) for the rows not in ``restart``, then
    the counters, terminations, truncations and information (:func:`_vector_finish`), written into ``out``.
    """
    rows = _vector_torques(lo, hi, actions, normalized, restart, rules, episodes)
    advance(physics, rules, episodes, rows)
    _vector_finish(lo, hi, restart, episodes, counters, out)


@njit(nogil=True, cache=True)
def physics_only(model_ptr, addresses, tau, frame_skip):
    """The physics alone of ``tau.shape[0]`` environment steps (``paa-mj bench``): the torques ``tau[k, i]`` [N m]
    held over ``frame_skip`` ``mj_step`` of the MjData at ``addresses[i]`` (a vector environment's robots),
    nothing else: no check, observation, reward or information."""
    for k in range(tau.shape[0]):
        for i in range(tau.shape[1]):
            ctrl = _float64_at(addresses[i, _CTRL])
            for j in range(tau.shape[2]):
                ctrl[j] = tau[k, i, j]
            for _ in range(frame_skip):
                _mj_step(model_ptr, addresses[i, _DATA])


class GymnastVectorEnv(VectorEnv):
    """``num_envs`` copies of :class:`~paa_mj.envs.single.GymnastEnv`, stepped by one compiled call (module docstring).

    Parameters
    ----------
    num_envs : int
        Number of sub-environments, in [1, 1000000].
    max_episode_steps : int, optional
        Truncate after this many environment steps too (``gym.make_vec`` passes the registered horizon).
    autoreset_mode : gymnasium.vector.AutoresetMode or its value ("NextStep", "SameStep", "Disabled")
    num_threads : int
        Threads that share the physics of one step, in [1, 1024] (default 1). The compiled stepping releases
        the GIL, so more threads cut the wall-clock time of a step on a machine with idle cores, not its CPU
        time; the numbers are the same with any number of threads (each sub-environment is stepped alone).
    engine : "mujoco" or "warp"
        ``warp``: every sub-environment a world of MuJoCo Warp on ``device`` (:mod:`paa_mj.envs.warp_robots`;
        float32, so its numbers agree with ``mujoco``'s to float32 rounding, not bit for bit; ``num_threads``
        does not apply).
    device : str, optional
        The Warp device of ``engine="warp"`` (``cpu``, ``cuda:0``; default ``$PAA_MJ_WARP_DEVICE`` or the first GPU).
    **kwargs
        The arguments of :class:`~paa_mj.envs.single.GymnastEnv` (``task``, ``robot``, ``frame_skip``, ...),
        checked the same way; ``render_mode`` must be None.

    Raises
    ------
    ValueError
        An argument of the wrong type or out of range, one line naming it.
    """

    def __init__(self, num_envs=64, max_episode_steps=None, autoreset_mode=AutoresetMode.NEXT_STEP, num_threads=1,
                 engine="mujoco", device=None, **kwargs):
        self._init_args = dict(num_envs=num_envs, max_episode_steps=max_episode_steps,
                               autoreset_mode=autoreset_mode, num_threads=num_threads, engine=engine, device=device,
                               **kwargs)
        if engine not in ENGINES:
            raise ValueError(f"engine must be one of {', '.join(map(repr, ENGINES))}, got {engine!r}")
        if device is not None and engine != "warp":
            raise ValueError(f"device chooses the Warp device of engine 'warp', not of {engine!r}")
        if engine == "warp" and kwargs.get("physics", "mujoco") != "mujoco":
            raise ValueError(f"engine 'warp' steps MuJoCo Warp: physics must be 'mujoco', got {kwargs['physics']!r}")
        num_envs = _whole("num_envs", num_envs, 1, MAX_ENVS)
        num_threads = _whole("num_threads", num_threads, 1, 1024)
        if engine == "mujoco":  # a Warp device checks its own memory (warp_robots)
            from ..errors import PaaError
            from ..limits import ENV_BYTES, check_memory

            try:
                check_memory(num_envs * ENV_BYTES, f"memory for {num_envs} sub-environments (about"
                             f" {ENV_BYTES / 1e3:.0f} KB each)", "num_envs")
            except PaaError as err:
                raise ValueError(str(err)) from None
        if kwargs.get("render_mode") is not None:
            raise ValueError(f"render_mode must be None for the vector environment, got {kwargs['render_mode']!r}")
        mode = autoreset_mode if isinstance(autoreset_mode, AutoresetMode) else \
            _MODES.get(autoreset_mode) if isinstance(autoreset_mode, str) else None
        if mode is None:
            raise ValueError(f"autoreset_mode must be one of {', '.join(_MODES)} (or gymnasium's AutoresetMode),"
                             f" got {autoreset_mode!r}")
        if max_episode_steps is not None:
            max_episode_steps = _whole("max_episode_steps", max_episode_steps, 1, 10**12)
        # one sub-environment checks every argument and computes what all of them share
        self.prototype = GymnastEnv(**kwargs)
        proto = self.prototype
        self.num_envs = num_envs
        self.robot, self.model, self.dt = proto.robot, proto.model, proto.dt
        self.torque_limits, self.normalize_actions = proto.torque_limits, proto.normalize_actions
        self.max_steps = min(proto.max_steps, max_episode_steps or math.inf)
        self.autoreset_mode = mode
        self.metadata = {"autoreset_mode": mode, "render_modes": []}
        self.render_mode = None
        self.single_observation_space = proto.observation_space
        self.single_action_space = proto.action_space
        self.observation_space = batch_space(proto.observation_space, num_envs)
        self.action_space = batch_space(proto.action_space, num_envs)
        # the episodes' task lasts as long as they do (a max_episode_steps below the prototype's cuts it)
        self.task = proto.task if self.max_steps == proto.max_steps else proto.task.with_(horizon=self.max_steps * self.dt)
        self.engine = engine
        if engine == "warp":
            from ..errors import PaaError
            from .warp_robots import WarpRobots

            try:
                self._robots = WarpRobots(self.model, num_envs, proto.frame_skip, proto._robots.rules.kind,
                                          self.torque_limits, self.task, device)
            except PaaError as err:
                raise ValueError(str(err)) from None
        else:
            self._robots = Robots(self.model, num_envs, proto.frame_skip, proto._robots.rules.kind,
                                  self.torque_limits, self.task, proto.physics, proto.robot.analytic)
        self._links = self.task.n_links
        self._motors = self.robot.params.n_motors
        self._rngs = [None] * num_envs
        self._counters = Counters(np.zeros(num_envs, np.int64), np.zeros(num_envs, bool), proto.terminate_margin,
                                  float(self.max_steps), self._robots.window, self.model.opt.timestep)
        self._reset_once = False
        self.num_threads = min(num_threads, num_envs)
        self._pool = None
        self._no_restart = np.zeros(num_envs, bool)

    # --- resets ---------------------------------------------------------------------------------------------

    def _seeds(self, seed):
        n = self.num_envs
        if seed is None:
            return [None] * n
        if isinstance(seed, (int, np.integer)) and not isinstance(seed, (bool, np.bool_)):
            if seed < 0:
                raise ValueError(f"seed must be an integer >= 0, got {seed!r}")
            return [int(seed) + i for i in range(n)]
        if isinstance(seed, (list, tuple)) and len(seed) == n and all(
                s is None or (isinstance(s, (int, np.integer)) and not isinstance(s, (bool, np.bool_)) and s >= 0)
                for s in seed):
            return [None if s is None else int(s) for s in seed]
        raise ValueError(f"seed must be None, an integer >= 0 or a list of {n} of them (or None), got {seed!r}")

    def _reset_one(self, i, x0, seed=None):
        if seed is not None or self._rngs[i] is None:
            self._rngs[i], _ = seeding.np_random(seed)
        proto = self.prototype
        self._robots.reset(i, perturbed(x0, self._rngs[i], proto.init_noise, proto.init_speed_noise))
        self._counters.steps[i] = 0
        self._counters.ended[i] = False

    def reset(self, *, seed=None, options=None):
        """Reset every sub-environment, or those of ``options["reset_mask"]`` (bool (N,)); ``options["x0"]``:
        a start (2n,) for all or one per sub-environment (N, 2n), perturbed as :meth:`GymnastEnv.reset` does.

        Returns the observations (N, 9) and the information of the sub-environments reset (masked).
        """
        options = _check_options(options, ("x0", "reset_mask"))
        seeds = self._seeds(seed)
        mask = np.ones(self.num_envs, bool)
        if "reset_mask" in options:
            mask = np.asarray(options["reset_mask"])
            if mask.dtype != np.bool_ or mask.shape != (self.num_envs,) or not mask.any():
                raise ValueError(f"options['reset_mask'] must be a bool array of shape ({self.num_envs},) with at"
                                 " least one True")
            if not self._reset_once and not mask.all():
                raise ValueError("the first reset resets every sub-environment: drop options['reset_mask']")
        x0 = options.get("x0")
        width = 2 * self._links
        x0 = np.broadcast_to(self.prototype.start if x0 is None else _check_x0(x0, self.num_envs, width),
                             (self.num_envs, width))
        for i in np.flatnonzero(mask):
            self._reset_one(i, x0[i], seeds[i])
        self._reset_once = True
        return self._robots.episodes.obs.copy(), self._info(mask)

    # --- steps ----------------------------------------------------------------------------------------------

    def _torques(self, actions):
        given, actions = actions, _real_array(actions)
        shape = (self.num_envs, self._motors)
        if actions is None or actions.shape != shape:
            shown = " ".join(repr(given).split())[:60] if actions is None else f"shape {actions.shape}"
            what = "two real numbers" if shape[1] == 2 else f"{shape[1]} real number{'s' * (shape[1] > 1)}"
            raise ValueError(f"actions are {what} per sub-environment, shape {shape}, got {shown}")
        if not np.all(np.isfinite(actions)):
            bad = np.flatnonzero(~np.all(np.isfinite(actions), axis=1))
            raise ValueError(f"actions must be finite; sub-environment(s) {bad[:5].tolist()} got non-finite ones")
        return action_to_torque(actions, self.torque_limits, self.normalize_actions)

    def _actions(self, actions):
        """``actions`` as a C-contiguous float64 array (N, 2) of finite numbers, else the ValueError of
        :meth:`_torques`. float32 actions (the space's) are widened exactly; one compiled step serves both."""
        if not (type(actions) is np.ndarray and actions.dtype in (np.float32, np.float64)
                and actions.shape == (self.num_envs, self._motors)):
            given, actions = actions, _real_array(actions)
            if actions is None or actions.shape != (self.num_envs, self._motors):
                self._torques(given)  # raises
        actions = np.ascontiguousarray(actions, dtype=np.float64)
        if _first_bad_action(actions) >= 0:
            self._torques(actions)  # raises, naming the rows
        return actions

    def step(self, actions):
        """One environment step of every sub-environment (autoreset as the module docstring says).

        Returns
        -------
        obs (N, 9) float32, rewards (N,) float64, terminated (N,) bool, truncated (N,) bool, info dict
        """
        if not self._reset_once:
            raise ValueError("call reset() before step()")
        mode, ended = self.autoreset_mode, self._counters.ended
        if mode == AutoresetMode.DISABLED and ended.any():
            self._actions(actions)  # a wrong action is named first, as before any other check
            raise ValueError(f"sub-environment(s) {np.flatnonzero(ended)[:5].tolist()} ended: reset them with"
                             " reset(options={'reset_mask': mask}) first (autoreset_mode Disabled)")
        actions = self._actions(actions)
        restart = self._no_restart
        if mode == AutoresetMode.NEXT_STEP and ended.any():
            restart = ended.copy()
            for i in np.flatnonzero(restart):
                self._reset_one(i, self.prototype.start)
        n = self.num_envs
        out = _step_out(n, self._links)
        self._run_step(actions, restart, out)
        obs, rewards, terminated, truncated, q, qd, time, diverged, success = out
        ones = np.ones(n, bool)
        info = {"q": q, "_q": ones, "qd": qd, "_qd": ones.copy(), "time": time, "_time": ones.copy(),
                "diverged": diverged, "_diverged": ones.copy(), "is_success": success, "_is_success": ones.copy()}
        if mode != AutoresetMode.SAME_STEP or not self._counters.ended.any():
            return obs, rewards, terminated, truncated, info
        ended = self._counters.ended.copy()
        final_obs = np.full(n, None, dtype=object)
        for i in np.flatnonzero(ended):
            final_obs[i] = obs[i].copy()
        final_info = self._info(ended)
        for i in np.flatnonzero(ended):
            self._reset_one(i, self.prototype.start)
        info = self._info() | {"final_obs": final_obs, "_final_obs": ended, "final_info": final_info,
                               "_final_info": ended}
        return self._robots.episodes.obs.copy(), rewards, terminated, truncated, info

    def _run_step(self, actions, restart, out):
        """:func:`_vector_step` of every sub-environment: one call, or contiguous chunks on ``num_threads`` threads
        (each writes rows of the shared arrays that no other thread touches)."""
        robots = self._robots
        if self.engine == "warp":  # every world in one device step, between two compiled calls on the host
            rows = _vector_torques(0, self.num_envs, actions, self.normalize_actions, restart, robots.rules,
                                   robots.episodes)
            robots.advance(rows)
            _vector_finish(0, self.num_envs, restart, robots.episodes, self._counters, out)
            return
        args = (actions, self.normalize_actions, restart, robots.physics, robots.rules, robots.episodes,
                self._counters, out)
        # a diverging step ends the episode; MuJoCo's warning must not leave MUJOCO_LOG.TXT
        with mujoco_log_off():
            if self.num_threads == 1:
                _vector_step(0, self.num_envs, *args)
                return
            if self._pool is None:
                self._pool = ThreadPoolExecutor(self.num_threads, thread_name_prefix="paa_mj-gym")
            bounds = np.linspace(0, self.num_envs, self.num_threads + 1).astype(int)
            list(self._pool.map(lambda k: _vector_step(bounds[k], bounds[k + 1], *args), range(self.num_threads)))

    def _info(self, mask=None):
        """The information of the sub-environments in ``mask`` (all by default), batched with masks."""
        robots = self._robots
        values = {"q": robots.q, "qd": robots.qd, "time": robots.time(), "diverged": robots.episodes.diverged,
                  "is_success": robots.success(self._counters.terminate_margin)}
        info = {}
        for key, value in values.items():
            if mask is None:
                info[key], info["_" + key] = value.copy(), np.ones(self.num_envs, bool)
            else:
                info[key] = np.where(mask.reshape((-1,) + (1,) * (value.ndim - 1)), value, np.zeros_like(value))
                info["_" + key] = mask.copy()
        return info

    def close_extras(self, **kwargs):
        if self._pool is not None:
            self._pool.shutdown()
            self._pool = None
        self.prototype.close()

    # --- copies: an independent vector environment in the same state, its physics rebuilt ------------------

    def __getstate__(self):
        counters = self._counters
        return {"init": self._init_args, "robots": self._robots.snapshot(), "rngs": self._rngs,
                "steps": counters.steps.copy(), "ended": counters.ended.copy(), "reset_once": self._reset_once}

    def __setstate__(self, state):
        self.__init__(**state["init"])
        self._robots.restore(state["robots"])
        self._rngs, self._reset_once = list(state["rngs"]), state["reset_once"]
        self._counters.steps[:], self._counters.ended[:] = state["steps"], state["ended"]
