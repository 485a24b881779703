"""The records the rollout engine's compiled code reads and writes, one field a name.

A run of N rollouts travels through compiled code as five named tuples, never as loose arrays at offsets:

- :class:`Run`: what all its rollouts share (time step, length, sampling, retirement, seed, the task's
  :attr:`~paa_mj.task.Task.params`);
- :class:`Settings`: each rollout's disturbances and limits, fixed for the run (a :data:`SETTING` record per
  rollout, and its torque limits, retirement certificate and pushes);
- :class:`State`: each rollout's counters and sums (a :data:`ROLLOUT` record), the task's book of success
  (:data:`~paa_mj.task.BOOK`), its peak and last torques, last good state, controller memory and delay line;
- :class:`Samples`: what is recorded every ``every`` steps;
- :class:`Physics`: one thread's MuJoCo data (addresses and views of its arrays).
"""
from __future__ import annotations

from typing import NamedTuple

import numpy as np
from numba import typeof

from ...task import BOOK

#: A rollout's counters and sums: its step, status (:data:`~paa_mj.sim.compiled.step.STATUS_TEXT`), the step of its first
#: switch to mode 1 (-1: never), samples recorded, the controller's last mode; the integrals of :math:`|\tau|^2`
#: [N^2 m^2 s] and of :math:`|\tau \cdot \dot q_a|` [J], the sum of squared torque changes per second [N^2 m^2 / s^2] and the
#: peak joint speed [rad/s].
ROLLOUT = np.dtype([("step", np.int64), ("status", np.int64), ("switch", np.int64), ("samples", np.int64),
                    ("mode", np.int64), ("effort", np.float64), ("work", np.float64), ("smooth", np.float64),
                    ("speed", np.float64)], align=True)
#: A rollout's settings: measurement noise std on q [rad] and qd [rad/s], torque noise std [N m], control delay
#: [steps], the retirement level (0: never retired), the end of its pushes [s] and the number that keys its noise.
SETTING = np.dtype([("noise_q", np.float64), ("noise_qd", np.float64), ("torque_noise", np.float64),
                    ("delay", np.int64), ("retire_level", np.float64), ("push_end", np.float64), ("id", np.int64)],
                   align=True)


class Run(NamedTuple):
    """What every rollout of a run shares."""

    dt: float
    n_steps: int
    every: int  # record a sample every this many steps (0: none)
    retire: bool
    seed: int
    task: np.ndarray  # the task's params (:attr:`paa_mj.task.Task.params`)
    joints: np.ndarray  # (m,) the joint each motor drives, 0-based, as floats (the robot's actuated joints)


class Settings(NamedTuple):
    """Each rollout's settings (N of each)."""

    rollouts: np.ndarray  # (N,) of SETTING
    limits: np.ndarray  # (N, m) torque limits [N m]
    cert: np.ndarray  # (N, 3 (2n)^2) retirement certificates (:mod:`paa_mj.sim.compiled.retirement`)
    pushes: np.ndarray  # (N, K, 2 + n): (t_center [s], sigma [s], f_1..f_n [N m])


class State(NamedTuple):
    """Each rollout's state (N of each), updated every step."""

    rollouts: np.ndarray  # (N,) of ROLLOUT
    book: np.ndarray  # (N, 3) of int64: the task's book of success
    peak: np.ndarray  # (N, m) peak |tau| [N m]
    last_tau: np.ndarray  # (N, m) the torques of the last step [N m]
    last_state: np.ndarray  # (N, 2n) the last good state [q, qd]
    memory: np.ndarray  # (N, S) the controller's memory
    delay_line: np.ndarray  # (N, D + 1, m) torques on their way [N m]


class Samples(NamedTuple):
    """The recorded samples (N rollouts, C samples each at most)."""

    t: np.ndarray  # (N, C) [s]
    q: np.ndarray  # (N, C, n) [rad]
    qd: np.ndarray  # (N, C, n) [rad/s]
    tau: np.ndarray  # (N, C, m) [N m]
    mode: np.ndarray  # (N, C) of int8


class Physics(NamedTuple):
    """One thread's MuJoCo model and data: addresses, and views of the data's arrays."""

    model: int
    data: int
    qpos: np.ndarray
    qvel: np.ndarray
    ctrl: np.ndarray
    qfrc: np.ndarray  # qfrc_applied [N m]
    warnings: np.ndarray  # MuJoCo's warning counters (a strided view)


def new_state(n_rollouts, n_links, memory_size, max_delay, n_motors=None) -> State:
    """A :class:`State` of zeros for ``n_rollouts`` rollouts (``n_motors`` motors, default n - 1)."""
    nu = n_links - 1 if n_motors is None else n_motors
    return State(np.zeros(n_rollouts, ROLLOUT), np.zeros((n_rollouts, len(BOOK)), np.int64),
                 np.zeros((n_rollouts, nu)), np.zeros((n_rollouts, nu)), np.zeros((n_rollouts, 2 * n_links)),
                 np.zeros((n_rollouts, max(1, memory_size))), np.zeros((n_rollouts, max_delay + 1, nu)))


def new_samples(n_rollouts, n_links, capacity, n_motors=None) -> Samples:
    """Room for ``capacity`` samples of each rollout (``n_motors`` torques each, default n - 1)."""
    nu = n_links - 1 if n_motors is None else n_motors
    return Samples(np.zeros((n_rollouts, capacity)), np.zeros((n_rollouts, capacity, n_links)),
                   np.zeros((n_rollouts, capacity, n_links)), np.zeros((n_rollouts, capacity, nu)),
                   np.zeros((n_rollouts, capacity), np.int8))


def physics_of(model, data) -> Physics:
    """The :class:`Physics` of an ``mujoco.MjModel`` and its ``MjData``."""
    return Physics(model._address, data._address, data.qpos, data.qvel, data.ctrl, data.qfrc_applied,
                   data.warning.number)


def _prototypes():
    """Tiny records of the layouts the engine is compiled for (C-contiguous arrays; MuJoCo's strided warnings)."""
    one, two, three = np.zeros(1), np.zeros((1, 1)), np.zeros((1, 1, 1))
    run = Run(1e-3, 1, 0, False, 0, one, one)
    settings = Settings(np.zeros(1, SETTING), two, two, three)
    state = State(np.zeros(1, ROLLOUT), np.zeros((1, len(BOOK)), np.int64), two, two, two, two, three)
    samples = Samples(two, three, three, three, np.zeros((1, 1), np.int8))
    physics = Physics(0, 0, one, one, one, one, np.zeros((2, 2), np.int32)[:, 0])
    return run, settings, state, samples, physics


#: The numba types of the records (:func:`_prototypes`), for the engine's explicit signatures.
RUN_T, SETTINGS_T, STATE_T, SAMPLES_T, PHYSICS_T = (typeof(record) for record in _prototypes())
