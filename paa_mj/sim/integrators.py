"""MuJoCo's integrators by name, and a copy of a robot's model with the time step and integrator set."""
from __future__ import annotations

import mujoco

from ..errors import PaaError
from ..limits import positive_finite
from ..model.mjcf import MAX_TIMESTEP
from .integrator_names import INTEGRATOR_NAMES

INTEGRATORS = {name: getattr(mujoco.mjtIntegrator, f"mjINT_{name.upper()}") for name in INTEGRATOR_NAMES}


def integrator_name(model) -> str:
    return next(name for name, value in INTEGRATORS.items() if value == model.opt.integrator)


def mujoco_model_for(robot, dt=None, integrator=None) -> mujoco.MjModel:
    """A copy of the robot's MjModel with the time step [s] and integrator set (default: the model's)."""
    model = robot.model.__copy__()
    if dt is not None:
        dt = positive_finite("time step", dt)
        if dt > MAX_TIMESTEP:  # the bound a model file's own timestep is held to
            raise PaaError(f"time step {dt:g} s is above {MAX_TIMESTEP:g} s, where no swing of a robot of this model"
                           " is resolved")
        model.opt.timestep = dt
    if integrator is not None:
        if integrator not in INTEGRATORS:
            raise PaaError(f"unknown integrator {integrator!r}: use one of {', '.join(INTEGRATORS)}")
        model.opt.integrator = INTEGRATORS[integrator]
    return model
