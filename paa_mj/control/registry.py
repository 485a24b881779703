"""Controllers by name, and users' controllers from a file, behind one recipe.

Built-in names (:data:`BUILTIN`):

- ``vcl``: the paper's controller, swing-up (40) then LQR (67) when the state
  first enters region (68) (the default);
- ``vcl-only``: (40) alone (the paper's Figs. 6-8 and 12-14);
- ``vcl-roa``, ``vc-roa``: ``vcl`` and ``vc`` handing over when the LQR's cost-to-go falls below the level of its
  region of attraction (option ``switch="roa"``, :mod:`paa_mj.theory.roa`), so that both hand-overs can be
  scored side by side where controllers are named;
- ``vc``: the conventional candidate (12) then LQR (67) by (68);
- ``lqr``: (67) alone;
- ``passive``: zero torque;
- ``trajopt``: a minimum-time kip from (65) solved by direct collocation
  (:mod:`paa_mj.control.trajopt`), tracked by time-varying LQR, then (67)
  (:mod:`paa_mj.control.tvlqr`);
- ``trajopt-effort``: the same with the kip of least integral of :math:`|\\tau|^2` over
  a given duration (option ``duration``, default 3 s);
- ``spong``: Spong's acrobot swing-up with Drake's LQR switch (:mod:`paa_mj.control.spong`), for
  two-link robots and the stretched goal.

The kips plan within :data:`HEADROOM` of the torque limit (option ``limit``,
or the robot's actuator ranges; the command line defaults to the peak torques
of ``vcl`` from (65)), leaving the tracking feedback room to act.

A user's controller is ``path/to/file.py:ClassName``: the class is built as
``ClassName(robot)`` with the robot of :func:`paa_mj.model.load_robot` and needs
``torque(q, qd, t)`` on batches (see :mod:`paa_mj.control.base`); nothing in
the package has to change. A :class:`ControllerSpec` is the picklable recipe
that studies send to their workers, which build the controller themselves.
"""
from __future__ import annotations

import hashlib
import importlib.util
import sys
from dataclasses import dataclass, replace
from pathlib import Path

import numpy as np

from ..errors import PaaError
from ..model.params import RobotParams
from ..task import Task, as_task
from .base import Binding, Controller
from .catalog import DESCRIPTIONS, GAIN_CONTROLLERS, OPTIONS, PLANNERS
from .combined import CombinedController, LevelCondition, RegionCondition
from .energy import ConventionalController, EnergyVCLController
from .gains import default_gains
from .lqr import LQRController
from .passive import PassiveController
from .trajopt import INTERVALS, solve_kip
from .tvlqr import kip_controller


def resolve_gains(robot, task, kD=None, kP=None, kV=None) -> dict:
    """The gains given, the rest from the robot's stored gains where they meet (41) for ``task``'s goal, else from
    the family rule (:func:`~paa_mj.control.gains.default_gains`, which says so)."""
    given = {"kD": kD, "kP": kP, "kV": kV}
    if all(v is not None for v in given.values()):
        return robot.resolve_gains(**given)
    return robot.resolve_gains(**given, defaults=default_gains(robot.analytic, task, robot.gains, given))


def _gains(robot, task, gains):
    return resolve_gains(robot, task, **(gains or {}))


#: Fraction of the torque limit a planned kip may use (the rest is the tracking controller's).
HEADROOM = 0.9
#: Duration of a min-effort kip when none is given [s].
EFFORT_DURATION = 3.0


def _kip_bound(robot, limit):
    limits = robot.capped_torque_limits(limit, "the option limit")
    if not np.all(np.isfinite(limits)):
        raise PaaError("a planned kip needs a torque limit: give limit=(T2, T3) [N m] or a model with actuator ranges"
                       " (the command line uses the peak torques of vcl from (65))")
    return HEADROOM * limits


# Each builder takes (robot, task, gains, check, **options) and returns the controller for that robot and task.

def _planned_kip(robot, task, limit, objective, duration, intervals, plant):
    """The kip ``robot`` plans; a controller that believes in a model other than its ``plant``'s starts IPOPT from
    the plant's own kip (the same bounds and settings), so that a perturbed model re-plans near that plan."""
    bound = _kip_bound(robot, limit)
    start = None
    if plant is not None and plant.params != robot.params:
        start = solve_kip(plant.analytic, bound, objective, duration=duration, intervals=intervals, task=task)
    return solve_kip(robot.analytic, bound, objective, duration=duration, intervals=intervals, task=task,
                     start=start)


def build_trajopt(robot, task, gains=None, check=True, limit=None, duration=None, intervals=INTERVALS,
                  lqr_weights=None, plant=None):
    """The minimum-time kip, tracked by TVLQR, then (67)."""
    kip = _planned_kip(robot, task, limit, "min-time", duration, intervals, plant)
    return kip_controller(robot.analytic, kip, task, name="trajopt", lqr_weights=lqr_weights)


def build_trajopt_effort(robot, task, gains=None, check=True, limit=None, duration=EFFORT_DURATION,
                         intervals=INTERVALS, lqr_weights=None, plant=None):
    """The kip of least effort over ``duration`` seconds, tracked by TVLQR, then (67)."""
    kip = _planned_kip(robot, task, limit, "min-effort", duration, intervals, plant)
    return kip_controller(robot.analytic, kip, task, name="trajopt-effort", lqr_weights=lqr_weights)


#: Where a switched controller hands over to (67) (option ``switch``): region (68), or the inner estimate
#: x^T S x <= rho of the LQR's region of attraction with the robot's torque limits (:mod:`paa_mj.theory.roa`).
SWITCHES = ("region", "roa")


def _condition(robot, task, lqr_weights, switch, limit):
    if switch in (None, "region"):
        if limit is not None:
            raise PaaError("the option limit applies to the hand-over on the LQR's region of attraction (switch="
                           "\"roa\"), not to region (68)")
        return RegionCondition(task)
    if switch != "roa":
        raise PaaError(f"the option switch is one of {', '.join(SWITCHES)}, got {switch!r}")
    from ..theory.linear import lqr_weight_matrices
    from ..theory.roa import switch_level
    from .lqr import lqr_weights as weights_of

    n = robot.params.n_links
    Q, R = lqr_weight_matrices(n, *weights_of(n, lqr_weights))
    S, rho = switch_level(robot.analytic, task, Q, R, u_max=robot.capped_torque_limits(limit, "the option limit"),
                          dt=float(robot.model.opt.timestep))
    return LevelCondition(task, S, rho)


def _switched(robot, task, swing, name, lqr_weights=None, switch=None, limit=None):
    """``swing`` until region (68) of the task (or the LQR's region of attraction with the torque limits the run
    applies, ``switch="roa"``, ``limit`` capping the model's), then the LQR (67) at its goal (weights
    ``lqr_weights``)."""
    return CombinedController(swing, LQRController.for_model(robot.analytic, task, lqr_weights),
                              _condition(robot, task, lqr_weights, switch, limit), name=name)


def build_vcl(robot, task, gains=None, check=True, lqr_weights=None, switch=None, limit=None):
    """The paper's controller: (40) + (67) switched by (68) (or by the LQR's region of attraction)."""
    return _switched(robot, task, build_vcl_only(robot, task, gains, check), "vcl", lqr_weights, switch, limit)


def build_vcl_only(robot, task, gains=None, check=True):
    """Controller (40) alone, for the whole run."""
    return EnergyVCLController(robot.analytic, **_gains(robot, task, gains), check=check, task=task)


def build_vc(robot, task, gains=None, check=True, lqr_weights=None, switch=None, limit=None):
    """The conventional candidate (12) + (67) switched by (68) (or by the LQR's region of attraction)."""
    return _switched(robot, task, build_vc_only(robot, task, gains, check), "vc", lqr_weights, switch, limit)


def build_vc_only(robot, task, gains=None, check=True):
    """The conventional candidate (12) alone."""
    return ConventionalController(robot.analytic, **_gains(robot, task, gains), check=check, task=task)


def build_vcl_roa(robot, task, gains=None, check=True, lqr_weights=None, limit=None):
    """``vcl`` handing over to (67) on the LQR's region of attraction (``switch="roa"``) instead of (68)."""
    return _switched(robot, task, build_vcl_only(robot, task, gains, check), "vcl-roa", lqr_weights, "roa", limit)


def build_vc_roa(robot, task, gains=None, check=True, lqr_weights=None, limit=None):
    """``vc`` handing over to (67) on the LQR's region of attraction (``switch="roa"``) instead of (68)."""
    return _switched(robot, task, build_vc_only(robot, task, gains, check), "vc-roa", lqr_weights, "roa", limit)


def build_lqr(robot, task, gains=None, check=True, lqr_weights=None):
    """The LQR (67) alone, from wherever the robot starts."""
    return LQRController.for_model(robot.analytic, task, lqr_weights)


def build_passive(robot, task, gains=None, check=True):
    """Zero torque."""
    return PassiveController().bind(robot, task)


def build_spong(robot, task, gains=None, check=True):
    """Spong's acrobot swing-up with Drake's defaults (:mod:`paa_mj.control.spong`): two links, stretched goal."""
    from .spong import SpongController

    if robot.params.n_links != 2:
        raise PaaError(f"spong is Spong's acrobot swing-up, for robots of 2 links; {robot.name} has"
                       f" {robot.params.n_links}")
    return SpongController(robot.analytic, task=task)


def build_mpc(robot, task, gains=None, check=True, **options):
    """iLQR model-predictive control with an LQR at the goal (:mod:`paa_mj.control.mpc`), within the robot's
    actuator ranges."""
    from .mpc import MPCController

    return MPCController(robot.analytic, task, robot.torque_limits, **options)


BUILTIN = {name: (builder, DESCRIPTIONS[name]) for name, builder in (
    ("vcl", build_vcl), ("vcl-only", build_vcl_only), ("vcl-roa", build_vcl_roa), ("vc", build_vc),
    ("vc-only", build_vc_only), ("vc-roa", build_vc_roa),
    ("lqr", build_lqr), ("passive", build_passive), ("trajopt", build_trajopt),
    ("trajopt-effort", build_trajopt_effort), ("spong", build_spong), ("mpc", build_mpc))}


def register(name: str, builder, description: str):
    """Add a built-in controller: ``builder(robot, task, gains=None, check=True)`` returns it for that robot and
    :class:`~paa_mj.task.Task`."""
    BUILTIN[name] = (builder, description)


def is_user_controller(spec: str) -> bool:
    return ":" in spec and spec.rsplit(":", 1)[0].endswith(".py")


def load_user_class(spec: str):
    """The class named by ``path/to/file.py:ClassName`` (one-line errors)."""
    path_text, class_name = spec.rsplit(":", 1)
    path = Path(path_text).expanduser().resolve()
    if not path.is_file():
        raise PaaError(f"controller file not found: {path_text}")
    try:
        source = path.read_bytes()
    except OSError as err:
        raise PaaError(f"cannot read controller file {path_text}: {err.strerror or err}") from None
    # Keyed by the content too: an edited file is loaded again, never served from an older import.
    module_name = "paa_mj_user_" + hashlib.sha1(str(path).encode() + b"\0" + source).hexdigest()[:16]
    module = sys.modules.get(module_name)
    if module is None:
        # no __pycache__ written beside the user's file: loading a controller leaves their folder as it was
        writes_bytecode, sys.dont_write_bytecode = sys.dont_write_bytecode, True
        try:
            loader_spec = importlib.util.spec_from_file_location(module_name, path)
            module = importlib.util.module_from_spec(loader_spec)
            sys.modules[module_name] = module
            loader_spec.loader.exec_module(module)
        except (Exception, SystemExit) as err:  # the user's file may fail in any way, sys.exit() at import included
            sys.modules.pop(module_name, None)
            raise PaaError(f"cannot load controller file {path_text}: {type(err).__name__}: {' '.join(str(err).split())}") from None
        finally:
            sys.dont_write_bytecode = writes_bytecode
    cls = getattr(module, class_name, None)
    if cls is None or not callable(cls):
        raise PaaError(f"controller file {path_text} has no class {class_name!r}")
    return cls


@dataclass(frozen=True)
class ControllerSpec:
    """A recipe for a controller: picklable, hashable, built on the robot that runs it.

    Attributes
    ----------
    name : str
        A built-in name or ``path/to/file.py:ClassName``.
    gains : tuple (kD, kP, kV) or None
        For the gain controllers; None: the robot's stored gains.
    believed : RobotParams or None
        The model the controller believes in (model error when it differs from
        the plant); None: the plant's own.
    check : bool
        Check the gains against the theory when building.
    options : tuple of (name, value)
        The controller's own options (:data:`~paa_mj.control.catalog.OPTIONS`).
    task : Task or None
        The task it is built for (None: the folded task of the robot it is built on); a user's class gets it as
        ``task=`` when its constructor takes it (or its goal's name as ``goal=``).
    """

    name: str = "vcl"
    gains: tuple | None = None
    believed: RobotParams | None = None
    check: bool = True
    options: tuple = ()
    task: Task | None = None

    def __post_init__(self):
        if not isinstance(self.name, str):
            raise PaaError(f"a controller is named by a string (one of {', '.join(BUILTIN)} or"
                           f" path/to/file.py:ClassName), got {self.name!r}")
        if self.task is not None and not isinstance(self.task, Task):
            raise PaaError(f"the controller {self.name}'s task must be a paa_mj.task.Task (or None), got"
                           f" {type(self.task).__name__}")
        if not isinstance(self.check, (bool, np.bool_)):
            raise PaaError(f"check must be True or False, got {self.check!r}")
        if self.believed is not None and not isinstance(self.believed, RobotParams):
            raise PaaError(f"believed must be the RobotParams the controller believes in (or None), got"
                           f" {type(self.believed).__name__}")
        if is_user_controller(self.name):
            path, cls = self.name.rsplit(":", 1)
            object.__setattr__(self, "name", f"{Path(path).expanduser().resolve()}:{cls}")
        elif self.name not in BUILTIN:
            raise PaaError(f"unknown controller {self.name!r}: use one of {', '.join(BUILTIN)} or"
                           " path/to/file.py:ClassName")
        if self.gains is not None:
            if self.name not in GAIN_CONTROLLERS:
                raise PaaError(f"gains kD, kP, kV apply to the controllers {', '.join(GAIN_CONTROLLERS)},"
                               f" not to {self.short_name}")
            object.__setattr__(self, "gains", _three_gains(self.gains))
        try:
            options = dict(self.options)
        except (TypeError, ValueError):
            raise PaaError(f"options must be (name, value) pairs, got {self.options!r}") from None
        unknown = sorted(set(options) - set(OPTIONS.get(self.name, ())))
        if unknown:
            raise PaaError(f"option(s) {', '.join(unknown)} do not apply to the controller {self.short_name}")
        object.__setattr__(self, "options", tuple(sorted((k, _hashable(v)) for k, v in options.items())))

    @property
    def short_name(self) -> str:
        return Path(self.name.rsplit(":", 1)[0]).name + ":" + self.name.rsplit(":", 1)[1] \
            if is_user_controller(self.name) else self.name

    def source_digest(self) -> str | None:
        """A digest of a user controller's file (None for a built-in one): studies are keyed by it, so that
        chunks computed by an older version of the file are never reused."""
        if not is_user_controller(self.name):
            return None
        path = Path(self.name.rsplit(":", 1)[0])
        try:
            return hashlib.sha256(path.read_bytes()).hexdigest()
        except OSError as err:
            raise PaaError(f"cannot read controller file {path}: {err.strerror or err}") from None

    def for_task(self, task: Task) -> "ControllerSpec":
        """The same recipe for ``task``."""
        return replace(self, task=task)

    def build(self, robot) -> Controller:
        """The controller for ``robot`` (the plant) and :attr:`task`, bound to both (:class:`Binding`); it believes
        in ``believed`` when given."""
        from ..model.robot import Robot

        if not isinstance(robot, Robot):
            raise PaaError(f"controllers are built for a robot of load_robot(), got {type(robot).__name__}")
        task = as_task(self.task, robot)
        believed = robot if self.believed is None else robot.with_params(self.believed)
        if is_user_controller(self.name):
            controller = self._build_user(believed, task)
            if isinstance(getattr(controller, "binding", None), Binding):
                return controller  # bound already (a built-in the user's class made): the run checks that binding
        else:
            gains = None if self.gains is None else dict(zip(("kD", "kP", "kV"), self.gains))
            plant = {"plant": robot} if self.name in PLANNERS and self.believed is not None else {}
            controller = BUILTIN[self.name][0](believed, task, gains=gains, check=self.check, **dict(self.options),
                                               **plant)
        _bind(controller, robot, task, self.short_name)  # to the plant: believing another model is on purpose
        return controller

    def _build_user(self, robot, task):
        cls = load_user_class(self.name)
        accepted = _keywords(cls)
        given = {"task": task} if "task" in accepted else {"goal": task.name} if "goal" in accepted else {}
        try:
            controller = cls(_private_copy(robot), **given)
        except (PaaError, KeyboardInterrupt):
            raise
        except (Exception, SystemExit) as err:  # sys.exit() in __init__ must not end the command as a success
            raise PaaError(f"controller {self.short_name}(robot) failed: {type(err).__name__}:"
                           f" {' '.join(str(err).split())}") from None
        if not callable(getattr(controller, "torque", None)):
            raise PaaError(f"controller {self.short_name} has no method torque(q, qd, t)")
        return controller


def _bind(controller, robot, task, name):
    """Record on ``controller`` the robot and task it is built for and the name it was asked by, where it takes
    attributes (a user's object with ``__slots__`` may not: it is then not checked against the run)."""
    try:
        controller.binding = Binding.of(robot, task, name)
    except AttributeError:
        pass


def _keywords(cls) -> set:
    import inspect

    try:
        return set(inspect.signature(cls).parameters)
    except (TypeError, ValueError):
        return set()


def _three_gains(gains) -> tuple:
    """``gains`` as (kD, kP, kV) floats, or a one-line error (a fourth value must not be dropped in silence)."""
    try:
        values = tuple(gains)
    except TypeError:
        raise PaaError(f"gains must be three numbers (kD, kP, kV), got {gains!r}") from None
    if len(values) != 3 or any(isinstance(v, (bool, np.bool_, str, bytes)) for v in values):
        raise PaaError(f"gains must be three numbers (kD, kP, kV), got {gains!r}")
    try:
        return tuple(float(v) for v in values)
    except (TypeError, ValueError):
        raise PaaError(f"gains must be three numbers (kD, kP, kV), got {gains!r}") from None


def _private_copy(robot):
    """A copy of ``robot`` for a user's controller: what its ``__init__`` changes in the robot it is given (the
    MjModel's gravity or time step, the torque limits, the parameters) must not change the robot simulated."""
    import copy
    from dataclasses import replace

    return replace(robot, model=robot.model.__copy__(), params=copy.deepcopy(robot.params),
                   analytic=copy.deepcopy(robot.analytic), gains=copy.deepcopy(robot.gains),
                   torque_limits=np.array(robot.torque_limits, float))


def _hashable(value):
    return tuple(float(v) for v in np.ravel(value)) if np.ndim(value) else value


def make_controller(name: str, robot, *, task: Task | str | None = None, gains: dict | None = None,
                    check: bool = True, **options) -> Controller:
    """The controller ``name`` (built-in or ``file.py:ClassName``) for ``robot`` and ``task``, bound to both.

    ``task``: a :class:`~paa_mj.task.Task`, a goal's name, or None for the folded task. ``gains`` ({"kD", "kP",
    "kV"}, any subset) override the robot's stored gains; ``options`` are the controller's own (:data:`OPTIONS`).
    """
    from ..model.robot import Robot

    if not isinstance(robot, Robot):
        raise PaaError(f"controllers are built for a robot of load_robot(), got {type(robot).__name__}")
    values = None
    if gains:
        if not isinstance(gains, dict) or set(gains) - {"kD", "kP", "kV"}:
            raise PaaError(f"gains must be a dict with some of kD, kP, kV, got {gains!r}")
        values = tuple(resolve_gains(robot, as_task(task, robot), **gains).values())
    return ControllerSpec(name, values, check=check, options=tuple(options.items()),
                          task=as_task(task, robot)).build(robot)
