"""Controllers by name, and users' controllers from a file, behind one recipe.

The built-in controllers are declared beside their laws (:func:`~paa_mj.control.record.controller`; what each is
and does: ``paa-mj simulate --help``, docs/controllers.md): importing this module imports every module that
declares one (:func:`~paa_mj.control.catalog.record_modules`), and :data:`RECORDS` holds their records by name,
:data:`BUILTIN` their builders and descriptions.

A user's controller is ``path/to/file.py:ClassName``: the class is built as
``ClassName(robot)`` with the robot of :func:`paa_mj.model.load_robot` and needs
``torque(q, qd, t)`` on batches (see :mod:`paa_mj.control.base`); nothing in
the package has to change. A :class:`ControllerSpec` is the picklable recipe
that studies send to their workers, which build the controller themselves.
"""
from __future__ import annotations

import hashlib
import importlib
import importlib.util
import sys
from dataclasses import dataclass, replace
from pathlib import Path

import numpy as np

from ..errors import PaaError
from ..model.params import RobotParams
from ..task import Task, as_task
from . import record
from .base import Binding, Controller
from .catalog import record_modules
from .gains import resolve_gains
from .record import ControllerRecord


def _records() -> dict:
    """Every declared controller's record, by name, in the order of :func:`~paa_mj.control.catalog.record_modules`
    (each module imported: its declarations register)."""
    modules = record_modules()
    for module in modules:
        importlib.import_module(module)
    order = {module: k for k, module in enumerate(modules)}
    return dict(sorted(record.RECORDS.items(), key=lambda item: order.get(item[1].module, len(order))))


#: The built-in controllers' records, by name.
RECORDS = _records()
#: The built-in controllers by name: (builder, description).
BUILTIN = {name: (r.build, r.description) for name, r in RECORDS.items()}


def register(name: str, builder, description: str, **capabilities):
    """Add a built-in controller at run time: ``builder(robot, task, gains=None, check=True)`` returns it for that
    robot and :class:`~paa_mj.task.Task`; ``capabilities`` as :class:`~paa_mj.control.record.ControllerRecord`'s.
    (A controller of the package is declared in its module instead, with :func:`~paa_mj.control.record.controller`.)
    """
    RECORDS[name] = ControllerRecord(name, description, builder, getattr(builder, "__module__", ""), **capabilities)
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
        The controller's own options (:attr:`~paa_mj.control.record.ControllerRecord.options`).
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
            if self.name not in RECORDS or not RECORDS[self.name].gains:
                gain_controllers = ", ".join(name for name, r in RECORDS.items() if r.gains)
                raise PaaError(f"gains kD, kP, kV apply to the controllers {gain_controllers},"
                               f" not to {self.short_name}")
            object.__setattr__(self, "gains", _three_gains(self.gains))
        try:
            options = dict(self.options)
        except (TypeError, ValueError):
            raise PaaError(f"options must be (name, value) pairs, got {self.options!r}") from None
        known = RECORDS[self.name].options if self.name in RECORDS else ()
        unknown = sorted(set(options) - set(known))
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
            params = believed.params
            why = RECORDS[self.name].why_not(params.n_links, task.name, tuple(j + 1 for j in params.passive),
                                             params.actuation_text())
            if why is not None:
                raise PaaError(f"controller {self.name} does not apply to robot {robot.name} at the {task.name} goal:"
                               f" {why}")
            gains = None if self.gains is None else dict(zip(("kD", "kP", "kV"), self.gains))
            plant = {"plant": robot} if RECORDS[self.name].plans and self.believed is not None else {}
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
    "kV"}, any subset) override the robot's stored gains; ``options`` are the controller's own (its record's).
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
