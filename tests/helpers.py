"""Test-only helpers: replaying torque sequences, running the CLI."""
import subprocess
import sys

import mujoco
import numpy as np
from scipy.integrate import solve_ivp

from paa_mj.sim.integrators import mujoco_model_for


def replay_torques_mujoco(robot, x0, torques, dt=None, integrator=None):
    """Feed a fixed torque sequence (one per step, zero-order hold) to MuJoCo; states after each step."""
    model = mujoco_model_for(robot, dt, integrator)
    data = mujoco.MjData(model)
    data.qpos[:], data.qvel[:] = x0[:3], x0[3:]
    out = np.empty((len(torques), 6))
    for i, tau in enumerate(torques):
        data.ctrl[:] = tau
        mujoco.mj_step(model, data)
        out[i, :3], out[i, 3:] = data.qpos, data.qvel
    return out


def replay_torques_analytic(robot, x0, torques, dt, rtol=1e-12, atol=1e-12):
    """Integrate (1) exactly (to rtol) with the same zero-order-hold torque sequence."""
    am = robot.analytic
    x = np.asarray(x0, float)
    out = np.empty((len(torques), 6))
    for i, tau in enumerate(torques):
        sol = solve_ivp(lambda _t, s: am.state_derivative(s, tau),
                        (0.0, dt), x, method="DOP853", rtol=rtol, atol=atol)
        x = sol.y[:, -1]
        out[i] = x
    return out


def cli(*args, cwd=None, env=None, timeout=300):
    """``paa-mj ARGS`` in a fresh process."""
    return subprocess.run([sys.executable, "-m", "paa_mj.cli", *map(str, args)], capture_output=True, text=True,
                          cwd=cwd, env=env, timeout=timeout)


class Uncompiled:
    """A controller seen only through ``torque`` (how a user's Python controller runs)."""

    def __init__(self, controller):
        self.controller = controller

    @property
    def mode(self):
        return self.controller.mode

    def torque(self, q, qd, t):
        return self.controller.torque(q, qd, t)

    def reset(self):
        self.controller.reset()
