"""N copies of one robot stepped by one compiled call: the physics, observations, rewards and the task's book
of every Gymnasium environment of the package.

One environment (:class:`~paa_mj.envs.single.GymnastEnv`) holds one :class:`Robots`, the vector environment
(:class:`~paa_mj.envs.vector.GymnastVectorEnv`) N: the same code computes both, so they agree bit for bit.
With ``physics="mujoco"`` each robot is an MjData stepped by ``mj_step`` called from numba (as
:mod:`paa_mj.sim.compiled.step` does); with ``"analytic"`` its state lives in the package's own arrays and is stepped by
RK4 of the robot's equations of motion (:func:`paa_mj.sim.analytic.rk4.rk4_step`). Compiled code reads three records:

- :class:`Physics`: the robots' data (addresses), or the constants of their equations;
- :class:`Rules`: the task (:attr:`~paa_mj.task.Task.params`), the torque limits and the reward;
- :class:`Episodes`: each robot's state, physics steps, book of success (:data:`~paa_mj.task.BOOK`), last
  observation, reward and margin of region (68).

Reward (per environment step, dimensionless), with x = [wrap(q - q*), qd] the error from the task's goal,
l the half-widths of region (68), u = tau / T the applied torques over their limits and 1[(68)] = 1 when the
state after the step is inside region (68):

- kip (v1): :math:`r = 1[(68)] - |x_{1:n}|^2 / (n \\pi^2) - 10^{-3} |x_{n+1:2n}|^2 - 10^{-2} \\bar{u^2}`;
- balance (v1): :math:`r = 1[(68)] - \\frac{1}{2} \\overline{(x / l)^2} - \\frac{1}{10} \\bar{u^2}`;
- v0: :math:`r = -(|x_{1:n}|^2 / (n \\pi^2) + 10^{-3} |x_{n+1:2n}|^2 + 10^{-8} |\\tau|^2)`, tau in N m.

A step that diverges gets :data:`DIVERGED_REWARD` (-100; -10 in v0).
"""
from __future__ import annotations

import math
from typing import NamedTuple

import mujoco
import numpy as np
from numba import carray, njit, types
from numba.extending import intrinsic, register_jitable

from ..mujoco_log import mujoco_log_off
from ..sim.integrators import integrator_name
from ..sim.compiled.mujoco_lib import mj_step as _mj_step
from ..sim.analytic.rk4 import rk4_constants, rk4_step, work_size
from ..sim.compiled.step import _WARNINGS, MAX_SPEED
from ..task import (BOOK, P_SWITCH_ANGLE, P_SWITCH_SPEED, book_start, book_succeeded, book_update, state_terms,
                    switch_margin_of)
from .spaces import _observe_into, _observe_rows

#: The physics an environment can run: MuJoCo's ``mj_step`` (the default), or the chain's own equations of
#: motion integrated by the same RK4 (:func:`paa_mj.sim.analytic.rk4.rk4_step`), over ten times cheaper.
PHYSICS = ("mujoco", "analytic")
#: The reward kinds: v0's, the kip's and balance's (module docstring).
REWARD_V0, REWARD_KIP, REWARD_BALANCE = range(3)
#: The reward of a step that diverges, by reward kind.
DIVERGED_REWARD = {REWARD_V0: -10.0, REWARD_KIP: -100.0, REWARD_BALANCE: -100.0}


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


class Physics(NamedTuple):
    """The robots' physics: MjData addresses (``model`` the MjModel's), or ``model`` 0 and the constants of RK4."""

    model: int
    addresses: np.ndarray  # (N, 5) of intp: the columns _DATA.._WARN
    warn_stride: int
    constants: np.ndarray  # :func:`~paa_mj.sim.analytic.rk4.rk4_constants` (physics "analytic")
    frame_skip: int


class Rules(NamedTuple):
    """What the episodes aim at and how a step is rewarded."""

    task: np.ndarray  # the task's params
    limits: np.ndarray  # (m,) torque limits [N m], one per motor
    kind: int  # reward kind
    diverged_reward: float


class Episodes(NamedTuple):
    """Each robot's state and episode counters."""

    phys_step: np.ndarray  # (N,) physics steps since reset
    book: np.ndarray  # (N, 3) the task's book of success
    diverged: np.ndarray  # (N,) of bool
    q: np.ndarray  # (N, n) [rad]
    qd: np.ndarray  # (N, n) [rad/s]
    tau: np.ndarray  # (N, m) [N m], the torques of the step (one per motor)
    obs: np.ndarray  # (N, 3n) of float32
    reward: np.ndarray  # (N,)
    margin: np.ndarray  # (N,) of region (68): negative inside


@register_jitable
def _reward(rules, n, inside, angles, speeds, tau, row):
    """The reward of a step ending with the terms of :func:`~paa_mj.task.state_terms`, torques tau [N m] = u T
    (module docstring); ``tau[row]`` and ``rules.limits`` hold the m torques and limits."""
    effort, power = 0.0, 0.0
    for j in range(tau.shape[1]):
        u = tau[row, j] / rules.limits[j]
        effort += u * u
        power += tau[row, j] * tau[row, j]
    if rules.kind == REWARD_V0:
        return -(angles / (float(n) * math.pi ** 2) + 1e-3 * speeds + 1e-8 * power)
    alive = 1.0 if inside else 0.0
    effort = 0.5 * effort
    if rules.kind == REWARD_KIP:
        return alive - angles / (float(n) * math.pi ** 2) - 1e-3 * speeds - 1e-2 * effort
    # (x / l)^2 averaged over the 2n coordinates, l the half-widths of region (68)
    scaled = (angles / rules.task[P_SWITCH_ANGLE] ** 2 + speeds / rules.task[P_SWITCH_SPEED] ** 2) / (2.0 * n)
    return alive - 0.5 * scaled - 0.1 * effort


@register_jitable
def _physics_step(physics, i, qpos, qvel, ctrl, n, m, work):
    """One physics step of robot ``i`` (n joints, m motors): ``mj_step``, or RK4 of its equations (``physics.model``
    0)."""
    if physics.model != 0:
        _mj_step(physics.model, physics.addresses[i, _DATA])
    else:
        rk4_step(physics.constants, carray(qpos, (n,)), carray(qvel, (n,)), carray(ctrl, (m,)), work)


@njit(nogil=True, cache=True)
def advance(physics, rules, episodes, rows):
    """One environment step of the robots ``rows``: ``episodes.tau[i]`` held over ``frame_skip`` physics steps.

    Per robot: counts the physics steps, keeps the task's book of success on the true state after each, whether
    it diverged (then the state goes back to the last good one and the step ends), and writes the state,
    observation, reward and region margin after the step. Sized from ``episodes.q`` (N, n).
    """
    n, m = episodes.q.shape[1], episodes.tau.shape[1]
    good = np.empty(2 * n)
    work = np.empty(work_size(n))
    for k in range(rows.size):
        i = rows[k]
        qpos = _float64_at(physics.addresses[i, _QPOS])
        qvel = _float64_at(physics.addresses[i, _QVEL])
        ctrl = _float64_at(physics.addresses[i, _CTRL])
        warn = _int32_at(physics.addresses[i, _WARN])
        for j in range(m):
            ctrl[j] = episodes.tau[i, j]
        bad = False
        for _ in range(physics.frame_skip):
            for j in range(n):
                good[j], good[n + j] = qpos[j], qvel[j]
            _physics_step(physics, i, qpos, qvel, ctrl, n, m, work)
            for j in range(n):
                if not (math.isfinite(qpos[j]) and math.isfinite(qvel[j])) or abs(qvel[j]) > MAX_SPEED:
                    bad = True
            for w in _WARNINGS:
                if warn[w * physics.warn_stride] > 0:
                    bad = True
            if bad:
                for j in range(n):
                    qpos[j], qvel[j] = good[j], good[n + j]
                break
            episodes.phys_step[i] += 1
            book_update(rules.task, carray(qpos, (n,)), carray(qvel, (n,)), episodes.phys_step[i], episodes.book[i])
        _finish(rules, episodes, i, carray(qpos, (n,)), carray(qvel, (n,)), bad)


@register_jitable
def _finish(rules, episodes, i, qpos, qvel, bad):
    """State, observation, margin and reward of robot ``i`` after its step."""
    n = qpos.size
    episodes.diverged[i] = bad
    for j in range(n):
        episodes.q[i, j], episodes.qd[i, j] = qpos[j], qvel[j]
    _observe_into(qpos, qvel, n, episodes.obs[i])
    inside, _, angle_max, speed_max, angles, speeds = state_terms(rules.task, qpos, qvel)
    episodes.margin[i] = switch_margin_of(rules.task, angle_max, speed_max)
    if bad:
        episodes.reward[i] = rules.diverged_reward
    else:
        episodes.reward[i] = _reward(rules, n, inside, angles, speeds, episodes.tau, i)


@njit(cache=True)
def finish_rows(rules, episodes, rows, bad):
    """:func:`_finish` of each robot in ``rows`` (int64) after a step computed elsewhere (MuJoCo Warp's worlds),
    ``bad`` (int32, one per robot) nonzero where its state left the finite world."""
    for k in range(rows.size):
        i = rows[k]
        _finish(rules, episodes, i, episodes.q[i], episodes.qd[i], bad[i] != 0)


@njit(cache=True)
def start_episode(rules, episodes, i):
    """Robot ``i`` at the start of an episode (its state set): a fresh book, its observation and margin."""
    book_start(episodes.book[i])
    book_update(rules.task, episodes.q[i], episodes.qd[i], 0, episodes.book[i])
    _, _, angle_max, speed_max, _, _ = state_terms(rules.task, episodes.q[i], episodes.qd[i])
    episodes.margin[i] = switch_margin_of(rules.task, angle_max, speed_max)


@register_jitable
def ended_early(episodes, i, terminate_margin):
    """Whether robot ``i``'s episode is over before its horizon: diverged, or left region (68) by
    ``terminate_margin``."""
    return episodes.diverged[i] or episodes.margin[i] >= terminate_margin


@njit(cache=True)
def success_now(episodes, window, terminate_margin, out):
    """Each robot's success (:func:`~paa_mj.task.book_succeeded`) as if its episode ended now: an episode
    :func:`ended_early` did not finish, and is no success, as a run cut short is none for the engines."""
    for i in range(out.size):
        finished = not ended_early(episodes, i, terminate_margin)
        out[i] = book_succeeded(episodes.book[i], episodes.phys_step[i], finished, False, window)


class EpisodeRecords:
    """What every set of robots of the vector environment shares: the episodes' records (``episodes``, ``rules``)
    and the start of an episode once a robot's state is set."""

    @property
    def q(self):
        return self.episodes.q

    @property
    def qd(self):
        return self.episodes.qd

    def _new_episodes(self, model, n, kind, torque_limits, task):
        """``rules``, ``episodes`` (n robots, all zero, no book) and the success window of ``task``."""
        links = task.n_links
        self.rules = Rules(task.params, np.ascontiguousarray(torque_limits, dtype=float), int(kind),
                           DIVERGED_REWARD[kind])
        self.episodes = Episodes(np.zeros(n, np.int64), np.full((n, len(BOOK)), -1, np.int64), np.zeros(n, bool),
                                 np.zeros((n, links)), np.zeros((n, links)), np.zeros((n, self.rules.limits.size)),
                                 np.zeros((n, 3 * links), np.float32), np.zeros(n), np.zeros(n))
        self.window = task.window_steps(model.opt.timestep)

    def _begin(self, i):
        """Robot ``i``'s episode from its state (set): step 0, a fresh book, its margin and observation."""
        e = self.episodes
        e.phys_step[i], e.diverged[i] = 0, False
        start_episode(self.rules, e, i)
        _observe_rows(e.q[i:i + 1], e.qd[i:i + 1], e.obs[i:i + 1])

    def restore(self, snapshot: dict):
        """The episodes' records back to a snapshot's, in place."""
        for name, value in self.episodes._asdict().items():
            value[...] = snapshot[name]

    def time(self):
        """Simulated time since reset [s], as the engines give it to controllers (steps x time step)."""
        return self.episodes.phys_step * self.model.opt.timestep

    def success(self, terminate_margin):
        """Each episode's success so far, as if it ended now (:func:`success_now`)."""
        out = np.empty(len(self.episodes.q), bool)
        success_now(self.episodes, self.window, float(terminate_margin), out)
        return out


class Robots(EpisodeRecords):
    """N copies of one robot's state and their episode counters, stepped by :func:`advance` (module docstring)."""

    def __init__(self, model, n, frame_skip, kind, torque_limits, task, physics="mujoco", analytic=None):
        if physics != "mujoco" and integrator_name(model) != "RK4":
            raise ValueError(f"physics 'analytic' steps RK4, and this model's integrator is"
                             f" {integrator_name(model)}: use physics 'mujoco' (or the model with integrator RK4)")
        self.model, self.physics_name, self.task = model, physics, task
        self._new_episodes(model, n, kind, torque_limits, task)
        if physics == "mujoco":
            self.datas = [mujoco.MjData(model) for _ in range(n)]
            # MuJoCo keeps each array of an mjData where it was allocated: the addresses hold while the data lives
            addresses = np.array([[d._address, d.qpos.ctypes.data, d.qvel.ctypes.data, d.ctrl.ctypes.data,
                                   d.warning.number.ctypes.data] for d in self.datas], dtype=np.intp)
            self.physics = Physics(model._address, addresses, self.datas[0].warning.number.strides[0] // 4,
                                   np.zeros(1), int(frame_skip))
        else:
            # the same table over the package's own arrays: the state is q, qd, the torques tau, no warnings
            self.datas = None
            e = self.episodes
            self._no_warnings = np.zeros((n, int(_WARNINGS.max()) + 1), np.int32)
            addresses = np.array([[0, e.q[i:].ctypes.data, e.qd[i:].ctypes.data, e.tau[i:].ctypes.data,
                                   self._no_warnings[i:].ctypes.data] for i in range(n)], dtype=np.intp)
            self.physics = Physics(0, addresses, 1, rk4_constants(analytic, model.opt.timestep), int(frame_skip))

    def reset(self, i, x0):
        """Robot ``i`` to the state ``x0`` (2n,), at rest in time."""
        links = self.task.n_links
        e = self.episodes
        if self.physics_name == "mujoco":
            data = self.datas[i]
            mujoco.mj_resetData(self.model, data)
            data.qpos[:], data.qvel[:] = x0[:links], x0[links:]
            with mujoco_log_off():
                mujoco.mj_forward(self.model, data)
            e.q[i], e.qd[i] = data.qpos, data.qvel
        else:
            e.q[i], e.qd[i] = x0[:links], x0[links:]
            e.tau[i] = 0.0
        self._begin(i)

    def step(self, rows, tau, log=True):
        """One environment step of ``rows`` (int array) with the torques ``tau`` (len(rows), m) [N m].

        ``log=False``: the caller has turned MuJoCo's log off (threads stepping parts of the rows)."""
        self.episodes.tau[rows] = tau
        if not log:
            advance(self.physics, self.rules, self.episodes, rows)
            return
        with mujoco_log_off():  # a diverging step ends the episode; MuJoCo's warning must not leave MUJOCO_LOG.TXT
            advance(self.physics, self.rules, self.episodes, rows)

    def snapshot(self) -> dict:
        """Everything that makes the robots' state, as plain arrays (MuJoCo's full integration state included):
        what a copy of an environment is rebuilt from (:meth:`restore`)."""
        out = {name: np.array(value) for name, value in self.episodes._asdict().items()}
        if self.datas is not None:
            spec = mujoco.mjtState.mjSTATE_INTEGRATION
            size = mujoco.mj_stateSize(self.model, spec)
            states = np.empty((len(self.datas), size))
            for state, data in zip(states, self.datas):
                mujoco.mj_getState(self.model, data, state, spec)
            out["mujoco"] = states
        return out

    def restore(self, snapshot: dict):
        """Back to a :meth:`snapshot` of robots of the same robot and number, in place (the compiled step holds the
        addresses of these arrays and of this physics)."""
        super().restore(snapshot)
        if self.datas is not None:
            for state, data in zip(snapshot["mujoco"], self.datas):
                mujoco.mj_setState(self.model, data, state, mujoco.mjtState.mjSTATE_INTEGRATION)

