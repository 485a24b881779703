"""N robots as N worlds of MuJoCo Warp: the physics of :class:`~paa_mj.envs.vector.GymnastVectorEnv` with
``engine="warp"`` (``pip install "paa_mj[gpu]"``).

:class:`WarpRobots` keeps the interface and the records of :class:`~paa_mj.envs.stepper.Robots` (its
``episodes``, ``rules``, resets, snapshots), and the host's arrays stay what the environment reads: an
environment step sends the states, torques and books of the robots to the device, runs ``frame_skip`` physics
steps of every world there, each followed by a kernel that keeps the task's book of success
(:func:`~paa_mj.task.book_update`, translated from the same source: :mod:`paa_mj.sim.warp.translate`) and stops a
robot whose state is not finite or runs away (back at its last good state), then reads the states and books back
and computes the observations, rewards and margins on the host with the compiled code of the CPU physics
(:func:`~paa_mj.envs.stepper.finish_rows`). MuJoCo Warp computes in float32: the observations agree with the
``mujoco`` physics to float32 rounding over a few steps, not bit for bit.
"""
from __future__ import annotations

import numpy as np

from ..sim.compiled.step import MAX_SPEED
from ..sim.warp.device import device_name, load_warp
from ..sim.warp.engine import device_worlds, world_bytes
from ..task import BOOK, book_update
from .stepper import EpisodeRecords, finish_rows

_KERNELS = {}


def _kernels(wp, n_links):
    key = (id(wp), n_links)
    if key in _KERNELS:
        return _KERNELS[key]
    from ..sim.warp.translate import device_function

    book = device_function(wp, book_update, state_size=2 * n_links)

    @wp.kernel(module="unique", enable_backward=False)
    def keep(qpos: wp.array2d(dtype=wp.float32), qvel: wp.array2d(dtype=wp.float32),
             good: wp.array2d(dtype=wp.float32)):
        """Each world's state before a physics step (its last good state)."""
        r = wp.tid()
        n = qpos.shape[1]
        for i in range(n):
            good[r, i] = qpos[r, i]
            good[r, n + i] = qvel[r, i]

    @wp.kernel(module="unique", enable_backward=False)
    def check(qpos: wp.array2d(dtype=wp.float32), qvel: wp.array2d(dtype=wp.float32),
              good: wp.array2d(dtype=wp.float32), active: wp.array(dtype=wp.int32), bad: wp.array(dtype=wp.int32),
              steps: wp.array(dtype=wp.int32), books: wp.array2d(dtype=wp.int32), task: wp.array(dtype=wp.float32)):
        """After a physics step: a robot not stepped (or stopped) goes back; a bad state stops it; else its book."""
        r = wp.tid()
        n = qpos.shape[1]
        if active[r] != 0:
            for i in range(n):
                if not (wp.isfinite(qpos[r, i]) and wp.isfinite(qvel[r, i])) or wp.abs(qvel[r, i]) > wp.float32(
                        MAX_SPEED):
                    bad[r] = 1
            if bad[r] != 0:
                active[r] = 0
        if active[r] == 0:
            for i in range(n):
                qpos[r, i] = good[r, i]
                qvel[r, i] = good[r, n + i]
            return
        steps[r] = steps[r] + 1
        book(task, qpos[r], qvel[r], steps[r], books[r])

    _KERNELS[key] = (keep, check)
    return keep, check


class WarpRobots(EpisodeRecords):
    """N copies of one robot on MuJoCo Warp, with the interface of :class:`~paa_mj.envs.stepper.Robots`."""

    physics_name = "warp"
    datas = None

    def __init__(self, model, n, frame_skip, kind, torque_limits, task, device=None):
        self.wp, self.mjw = load_warp()
        wp = self.wp
        self.device = device_name(wp, device)
        self.model, self.task, self.frame_skip = model, task, int(frame_skip)
        links = task.n_links
        from ..limits import check_memory

        # the worlds, as every engine sizes them before allocating: refused in one line where they would not fit
        check_memory(1.5 * n * (world_bytes(wp, self.mjw, model, self.device) + 8 * (8 * links + 32)),
                     f"{self.device} memory for {n} sub-environments", "num_envs",
                     budget=wp.get_device(self.device).free_memory, where="the device's free memory")
        self._new_episodes(model, n, kind, torque_limits, task)
        with wp.ScopedDevice(self.device):
            self._keep, self._check = _kernels(wp, links)
            self._model, self._data = device_worlds(self.mjw, model, n)
            self._good = wp.zeros((n, 2 * links), dtype=wp.float32)
            self._active = wp.zeros(n, dtype=wp.int32)
            self._bad = wp.zeros(n, dtype=wp.int32)
            self._steps = wp.zeros(n, dtype=wp.int32)
            self._books = wp.zeros((n, len(BOOK)), dtype=wp.int32)
            self._task = wp.array(np.asarray(task.params, np.float32), dtype=wp.float32)

    def reset(self, i, x0):
        """Robot ``i`` to the state ``x0`` (2n,), at rest in time (sent to the device with the next step)."""
        links = self.task.n_links
        e = self.episodes
        # the device holds float32: the state starts where the device will have it
        e.q[i] = np.float32(x0[:links])
        e.qd[i] = np.float32(x0[links:])
        e.tau[i] = 0.0
        self._begin(i)

    def advance(self, rows):
        """One environment step of ``rows`` (int array): ``episodes.tau`` held over ``frame_skip`` physics steps of
        every world, the others held where they are (module docstring)."""
        wp, mjw, e = self.wp, self.mjw, self.episodes
        n = len(e.q)
        active = np.zeros(n, np.int32)
        active[rows] = 1
        with wp.ScopedDevice(self.device):
            d = self._data
            d.qpos.assign(e.q.astype(np.float32))
            d.qvel.assign(e.qd.astype(np.float32))
            d.ctrl.assign(e.tau.astype(np.float32))
            self._active.assign(active)
            self._bad.zero_()
            self._steps.assign(e.phys_step.astype(np.int32))
            self._books.assign(e.book.astype(np.int32))
            for _ in range(self.frame_skip):
                wp.launch(self._keep, dim=n, inputs=[d.qpos, d.qvel, self._good])
                mjw.step(self._model, d)
                wp.launch(self._check, dim=n, inputs=[d.qpos, d.qvel, self._good, self._active, self._bad,
                                                      self._steps, self._books, self._task])
            e.q[:] = d.qpos.numpy()
            e.qd[:] = d.qvel.numpy()
            e.phys_step[:] = self._steps.numpy()
            e.book[:] = self._books.numpy()
            bad = self._bad.numpy()
        finish_rows(self.rules, e, np.ascontiguousarray(rows, dtype=np.int64), bad)

    def step(self, rows, tau, log=True):
        """One environment step of ``rows`` with the torques ``tau`` (len(rows), n - 1) [N m]."""
        self.episodes.tau[rows] = tau
        self.advance(np.asarray(rows))

    def snapshot(self) -> dict:
        """The robots' state (the host's arrays hold all of it between steps)."""
        return {name: np.array(value) for name, value in self.episodes._asdict().items()}

