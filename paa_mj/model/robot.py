"""A loaded robot: the MuJoCo model, its parameters read back, the analytic model and its limits.

:func:`load_robot` takes a named robot (``gymnast`` is Table 1 of the paper,
``example2`` Table 2, ``acrobot`` Drake's acrobot, ``chain4`` a four-link chain,
all in ``models/``) or a path to the MJCF file of any planar chain on the bar,
and returns a :class:`Robot`: what every controller, rollout and study of the
package is built from.
"""
from __future__ import annotations

import os
from dataclasses import dataclass, replace
from pathlib import Path

import mujoco
import numpy as np

from ..errors import PaaError
from .dynamics import AnalyticModel
from .mjcf import MODEL_DIR, mjcf_from_params
from .mjcf_read import compile_mjcf, default_gains, flatten_mjcf, params_from_model, read_text, torque_limits_from_model
from .params import RobotParams

NAMED_ROBOTS = ("gymnast", "example2", "acrobot", "chain4", "realaigym_acrobot", "realaigym_acrobot_v1",
                "realaigym_pendubot")


@dataclass(frozen=True, eq=False)
class Robot:
    """A loaded robot.

    Attributes
    ----------
    name : str
    model : mujoco.MjModel
        What MuJoCo simulates.
    params : RobotParams
        Read back from ``model``.
    analytic : AnalyticModel
        The paper's model (1)-(7) with ``params``.
    gains : dict or None
        The gains ``{"kD", "kP", "kV"}`` of controller (40) the model file stores, as read (what a controller
        takes is :func:`paa_mj.control.gains.resolve_gains`'s).
    torque_limits : ndarray (m,)
        The motors' torque limits [N m] from the model's actuator ranges (+inf: none).
    xml : str
        The MJCF text the model was compiled from (what a Dask worker rebuilds it from).
    """

    name: str
    model: mujoco.MjModel
    params: RobotParams
    analytic: AnalyticModel
    gains: dict | None
    torque_limits: np.ndarray
    xml: str

    def capped_torque_limits(self, requested=None, what="the torque limit", rollouts=None) -> np.ndarray:
        """Each motor's torque limit a run applies [N m], (m,), or one row per rollout (``rollouts``, m)
        where ``rollouts`` is given: the model's actuator ranges capped by ``requested`` (one number, one per motor,
        or with ``rollouts`` one row per rollout; None: the ranges alone). The one place the two meet; a
        ``requested`` of another shape is refused in one line naming ``what``."""
        motors = self.torque_limits.shape[0]
        shape = (motors,) if rollouts is None else (rollouts, motors)
        try:
            requested = np.asarray(np.inf if requested is None else requested, float)
        except (TypeError, ValueError):
            raise PaaError(f"{what} must be one number or one per motor ({motors}) [N m], got {requested!r}") from None
        if requested.shape not in ((), (1,), (motors,), shape):
            raise PaaError(f"{what} must be one number or one per motor ({motors}) [N m], got shape {requested.shape}")
        return np.minimum(np.broadcast_to(requested, shape), self.torque_limits)

    def with_params(self, params: RobotParams, name: str | None = None) -> "Robot":
        """The same robot with other parameters (same gains and limits), compiled from the template.

        Used for the model a controller believes in (model-error studies) and for
        families of robots (the atlas).
        """
        xml = mjcf_from_params(params, name=name or params.name)
        return replace(self, name=name or self.name, model=compile_mjcf(xml, f"parameters {params.name}"),
                       params=params, analytic=AnalyticModel.from_params(params), xml=xml)


def robot_path(robot: str | os.PathLike) -> Path:
    """Resolve a robot name (``gymnast``, ``example2``) or an MJCF path to a file path."""
    if not isinstance(robot, (str, os.PathLike)):
        raise PaaError(f"unknown robot {robot!r}: use one of {', '.join(NAMED_ROBOTS)} or a path to an MJCF .xml file")
    text = str(robot)
    if not text.strip():
        raise PaaError(f"unknown robot {text!r} (an empty name): use one of {', '.join(NAMED_ROBOTS)} or a path to an"
                       " MJCF .xml file")
    if text in NAMED_ROBOTS:
        return MODEL_DIR / f"{text}.xml"
    path = Path(text)
    if path.suffix.lower() != ".xml" and not path.exists():
        raise PaaError(f"unknown robot {text!r}: use one of {', '.join(NAMED_ROBOTS)} or a path to an MJCF .xml file")
    return path


def load_model(robot: str | os.PathLike) -> mujoco.MjModel:
    """Compile a named robot or an MJCF file, checking that it is a chain of the family (see :func:`load_robot`)."""
    return load_robot(robot).model


def load_robot(robot: str | os.PathLike) -> Robot:
    """Load a named robot or an MJCF file into a :class:`Robot`.

    Includes and asset paths resolve against the file's folder.

    Raises
    ------
    PaaError
        Unknown name, a missing, unreadable or irregular file (a FIFO, a folder),
        malformed XML, a model that is not a chain of the family, a feature the
        analytic model lacks, or parameters that are not physical; always one line.
    """
    path = robot_path(robot)
    text = read_text(path)
    xml = flatten_mjcf(text, path.resolve().parent, str(path))
    return robot_from_xml(xml, name=str(robot) if str(robot) in NAMED_ROBOTS else None, source=str(path))


def robot_from_xml(xml: str, name=None, source="<string>") -> Robot:
    """A :class:`Robot` from (flattened) MJCF text."""
    model = compile_mjcf(xml, source)
    params = params_from_model(model, source=source)
    return Robot(name=name or params.name, model=model, params=params, analytic=AnalyticModel.from_params(params),
                 gains=default_gains(model), torque_limits=torque_limits_from_model(model, source), xml=xml)


def model_from_params(params: RobotParams, name: str = "custom") -> mujoco.MjModel:
    """Compile the gymnast with the given parameters."""
    return robot_from_xml(mjcf_from_params(params, name=name), source=f"parameters {name}").model
