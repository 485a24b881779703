"""The controller interface: one small protocol for every controller, compiled or not.

A controller maps states to the torques tau [N m] of the robot's m motors, in the order of its driven joints
(:attr:`~paa_mj.model.params.RobotParams.actuated`; by default joints 2..n, for the gymnast [tau2, tau3]):

- ``torque(q, qd, t)`` takes a batch of states, ``q`` and ``qd`` of shape
  (..., n) [rad, rad/s] and the time ``t`` [s], and returns shape (..., m);
- ``reset()`` forgets any internal state before a new rollout;
- ``mode`` (optional) is 0 while swinging up and 1 once the balance controller
  (67) has taken over; a rollout's *switch time* is when it first becomes 1.

That is the whole contract for a user's controller (``ClassName(robot)`` with
:func:`~paa_mj.model.load_robot`'s robot, then ``torque``). A built controller is bound to
the robot and the task it was built for (:class:`Binding`): the engines refuse to run it on
another robot or to judge it against another task (:func:`check_binding`), and the built-in
controllers refuse states of the wrong width. A controller may
also offer a compiled form (:class:`CompiledForm`, a numba kernel with its
parameters); the single-rollout loop and the batch engine of :mod:`paa_mj.sim`
then run it at compiled speed, and otherwise call ``torque`` between physics
steps. Torque limits are the actuators' (the robot's and the rollout's), not
the controller's: the engine saturates whatever a controller asks for.
"""
from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np
from numba import types
from numba.experimental.function_type import WrapperAddressProtocol, _get_wrapper_address

from ..errors import PaaError
from ..jit import lazy_njit
from ..task import Task


#: Signature of a compiled controller, and of a compiled switching condition:
#: ``kernel(x, t, params, memory, tau) -> int`` with x = [q, qd] (2n) the state it sees. A controller
#: writes the m motor torques [N m] into ``tau``, may update ``memory`` and returns its mode
#: (0 swing-up, 1 balance); a condition returns 1 where it holds and touches nothing.
KERNEL_SIG = types.int64(types.float64[:], types.float64, types.float64[:], types.float64[:], types.float64[:])
KERNEL_TYPE = types.FunctionType(KERNEL_SIG)


def kernel(function):
    """Compile ``function`` as a controller or condition kernel (:data:`KERNEL_SIG`), cached on disk.

    Compiled (or loaded from the cache) on first use, not on import: a process that runs one controller does not
    load the machine code of every other (:func:`paa_mj.jit.lazy_njit`)."""
    return lazy_njit(KERNEL_SIG, cache=True)(function)


class KernelAddress(WrapperAddressProtocol):
    """A compiled kernel passed to compiled code by its machine address, looked up once.

    numba looks up the address of a kernel passed as a first-class function (:data:`KERNEL_TYPE`) at every call
    from Python, some 40 us; code that calls a compiled function with the same kernel many times over (an ODE
    right-hand side, called by SciPy at every stage) passes this instead. The kernel is kept alive with it.
    """

    _numba_type_ = KERNEL_TYPE  # numba reads the type here instead of deducing it at every call (8 us)

    def __init__(self, kernel):
        self.kernel = kernel
        self._address = _get_wrapper_address(kernel, KERNEL_SIG)

    def __wrapper_address__(self):
        return self._address

    def signature(self):
        return KERNEL_SIG


@dataclass(frozen=True, eq=False)
class CompiledForm:
    """A controller as numba sees it.

    Attributes
    ----------
    kernel : numba dispatcher of :data:`KERNEL_SIG` (see :func:`kernel`)
    params : ndarray (P,)
        Constant parameters (gains, robot constants, gain tables), float64.
    memory : ndarray (S,)
        The initial internal state, copied for each rollout.
    balance_gain : ndarray (m, 2n) or None
        The linear state feedback tau = -K x that acts in mode 1, x the error from
        the goal ((67) at UDD). The engine uses it to stop a rollout whose balance can no
        longer fail (:mod:`paa_mj.sim.compiled.retirement`); None: never stopped early.
    """

    kernel: object
    params: np.ndarray
    memory: np.ndarray = field(default_factory=lambda: np.zeros(1))
    balance_gain: np.ndarray | None = None

    def __post_init__(self):
        object.__setattr__(self, "params", np.ascontiguousarray(self.params, dtype=np.float64).reshape(-1))
        memory = np.ascontiguousarray(self.memory, dtype=np.float64).reshape(-1)
        object.__setattr__(self, "memory", memory if memory.size else np.zeros(1))


@dataclass(frozen=True, eq=False)
class SwitchedForm:
    """Two compiled controllers and the compiled condition that switches from the first to the second, for good."""

    first: CompiledForm
    second: CompiledForm
    condition: object
    condition_params: np.ndarray

    @property
    def balance_gain(self):
        return self.second.balance_gain


def balance_gain_of(controller):
    """The gain K of the controller's balance tau = -K x (its compiled form's, (67) for the built-in ones), or None
    for a controller without a compiled form or a balance."""
    compiled = getattr(controller, "compiled", None)
    form = compiled() if callable(compiled) else None
    return None if form is None else form.balance_gain


@dataclass(frozen=True)
class Binding:
    """What a built controller is for: a robot (its links and a digest of its parameters) and a task.

    Attributes
    ----------
    robot : str
        The robot's name, for messages.
    n_links : int
    digest : str or None
        :attr:`~paa_mj.model.dynamics.AnalyticModel.digest` of the robot's parameters; None: any robot of
        ``n_links`` links (a gain given as it is).
    task : Task
    controller : str or None
        The name the user gave the controller (``vcl``, ``mine.py:Balance``), for messages.
    n_motors : int or None
        The motors its torques are for (None: n - 1, joints 2..n).
    """

    robot: str
    n_links: int
    digest: str | None
    task: Task
    controller: str | None = None
    n_motors: int | None = None

    @classmethod
    def of(cls, robot, task: Task, controller: str | None = None) -> "Binding":
        """The binding to a :class:`~paa_mj.model.robot.Robot` or an AnalyticModel, and ``task``."""
        model = getattr(robot, "analytic", robot)
        name = getattr(robot, "name", None) or model.params.name
        return cls(str(name), model.n_links, model.digest, task, controller, model.n_motors)

    def robot_text(self) -> str:
        parts = f"{self.n_links} links" + (f", parameters {self.digest}" if self.digest else "")
        return f"robot {self.robot} ({parts})"


def controller_name(controller) -> str:
    """The name a controller is known by in messages: the one the user gave it (its :class:`Binding`'s), else its
    ``name``, else its class."""
    binding = getattr(controller, "binding", None)
    if isinstance(binding, Binding) and binding.controller:
        return binding.controller
    name = getattr(controller, "name", None)
    return name if isinstance(name, str) and name else type(controller).__name__


def check_binding(controller, robot, task: Task | None):
    """Refuse, in one line naming both, a controller built for another robot or task than the run's.

    ``robot`` is the :class:`~paa_mj.model.robot.Robot` the run simulates (its nominal model: the plants of a
    model-error study vary on purpose), ``task`` the run's (None: the robot alone is checked). A controller without
    a :class:`Binding` (a user's object) is not checked here; its torques' shape is (:func:`torque_of`).
    """
    binding = getattr(controller, "binding", None)
    if not isinstance(binding, Binding):
        return
    model = getattr(robot, "analytic", robot)
    ours = Binding(str(getattr(robot, "name", None) or model.params.name), model.n_links, model.digest, task)
    name = controller_name(controller)
    if (binding.n_links != ours.n_links or (binding.digest is not None and binding.digest != ours.digest)
            or (binding.n_motors is not None and binding.n_motors != model.n_motors)):
        raise PaaError(f"controller {name} was built for {binding.robot_text()}, not for {ours.robot_text()}"
                       " that runs it: build it for this robot")
    if task is not None and binding.task.aim() != task.aim():
        raise PaaError(f"controller {name} was built for the {binding.task.name} task, not for the {task.name} task"
                       " this run is judged by: build it for this task")


class Controller:
    """Base class of the built-in controllers (users' controllers need not inherit from it).

    Subclasses set ``name`` and implement :meth:`law`; :meth:`torque` checks the width of the states against
    the controller's :attr:`binding` first. A stateless controller needs nothing else. ``mode`` is 0 unless
    the controller switches. A controller that holds each torque over a period (sampled data, as a policy held
    over an environment step) states it as ``period`` [s], and the analytic engine, which integrates laws continuous
    in time, refuses it.
    """

    name = "controller"
    mode = 0
    #: The robot and task it was built for (:class:`Binding`).
    binding: Binding | None = None

    def torque(self, q, qd, t=0.0):
        """Torques (..., m) [N m] at states q, qd (..., n) [rad, rad/s] and time t [s]."""
        q, qd = np.asarray(q, float), np.asarray(qd, float)
        links = self.binding.n_links if self.binding is not None else None
        if links is not None and (q.shape[-1:] != (links,) or qd.shape[-1:] != (links,)):
            raise PaaError(f"controller {self.name} was built for a {links}-link robot and got states of"
                           f" {q.shape[-1] if q.ndim else 0} angles and {qd.shape[-1] if qd.ndim else 0} speeds")
        return self.law(q, qd, t)

    def law(self, q, qd, t):
        """The torques at states of the right width (:meth:`torque`)."""
        raise NotImplementedError

    def reset(self):
        """Forget any internal state (before a new rollout)."""

    def compiled(self) -> CompiledForm | SwitchedForm | None:
        """The compiled form, or None (then rollouts call :meth:`torque`)."""
        return None

    def describe(self) -> dict:
        """What a trajectory's metadata records about this controller."""
        return {"controller": self.name}

    def bind(self, robot, task: Task):
        """Record the robot and task this controller is built for (:class:`Binding`); returns it."""
        self.binding = Binding.of(robot, task)
        return self


def _user_call(controller, what, call, *args):
    """``call(*args)``, with any failure of a user's controller turned into one line that says where."""
    try:
        return call(*args)
    except (PaaError, KeyboardInterrupt):
        raise
    except (Exception, SystemExit) as err:  # a user's controller may fail in any way, exit included
        detail = " ".join(str(err).split())
        raise PaaError(f"controller {controller_name(controller)}.{what} failed: {type(err).__name__}"
                       + (f": {detail}" if detail else "")) from None


def torque_of(controller, q, qd, t, copy=True, motors=None):
    """``controller.torque(q, qd, t)`` as a float array of shape (..., m), or a one-line error: m = ``motors``, else
    the motors of the robot the controller is bound to, else n - 1 (joints 2..n).

    The controller gets copies of ``q`` and ``qd``: the engines pass views of their own state (the
    integrator's, the measured state), which a controller that writes into its inputs would
    otherwise move. The result is a copy too, so that a controller reusing its output buffer cannot
    change a torque already applied. ``copy=False`` leaves both to the caller (the engine, every
    step: it passes float copies of its own and reads the torques before the controller runs again).

    Raises
    ------
    PaaError
        The controller failed, or returned the wrong shape or numbers that are not real
        (complex, boolean, text, objects).
    """
    if copy:
        q, qd = np.array(q, dtype=float), np.array(qd, dtype=float)
    shape = q.shape
    if motors is None:
        binding = getattr(controller, "binding", None)
        motors = binding.n_motors if isinstance(binding, Binding) and binding.n_motors is not None else shape[-1] - 1
    expected = shape[:-1] + (motors,)
    raw = _user_call(controller, "torque", controller.torque, q, qd, t)
    if type(raw) is np.ndarray and raw.dtype == np.float64 and raw.shape == expected:
        return raw.copy() if copy else raw  # the common case, checked at once (this runs every step of a rollout)
    raw = _user_call(controller, "torque", np.asarray, raw)
    name = controller_name(controller)
    if raw.dtype.kind not in "fiu":
        # np.asarray(.., float) would drop an imaginary part (a warning at most) and read booleans as 0 and 1
        raise PaaError(f"controller {name}.torque returned {raw.dtype} torques; it must return real numbers"
                       " (float) [N m]")
    tau = np.array(raw, dtype=float)
    if tau.shape != expected:
        motors = ("[tau2, tau3]" if shape[-1] == 3 and motors == 2 else
                  f"{motors} motor torque{'s' if motors > 1 else ''}")
        raise PaaError(f"controller {name}.torque returned shape {tau.shape} for states of"
                       f" shape {shape}; it must return {expected} ({motors} per state)")
    return tau


def mode_of(controller, shape=(), plain=False):
    """The controller's mode as an int array of ``shape`` (0 when it has none), or a one-line error.

    With ``plain``, a mode that is a plain 0 or 1 comes back as that int, the mode of every state (the
    engine asks every step, and an array costs more than the rest of the check).
    """
    mode = _user_call(controller, "mode", getattr, controller, "mode", 0)
    if type(mode) is int and (mode == 0 or mode == 1):  # the common case, at once (every step of a rollout)
        return mode if plain else np.full(shape, mode, np.int8)
    mode = _user_call(controller, "mode", np.asarray, mode)
    if mode.dtype.kind not in "biu" or not (mode.shape == () or mode.shape == shape):
        raise PaaError(f"controller {controller_name(controller)}.mode must be an integer or one integer per state"
                       f" (shape {shape}), got {mode.dtype} of shape {mode.shape}")
    if np.any((mode != 0) & (mode != 1)):
        bad = mode[(mode != 0) & (mode != 1)].reshape(-1)[0]
        raise PaaError(f"controller {controller_name(controller)}.mode must be 0 (swing-up) or 1 (balance), got {bad}")
    return np.broadcast_to(mode, shape).astype(np.int8) if mode.shape != shape else mode.astype(np.int8)


def reset_controller(controller):
    """Call ``reset()`` when the controller has one (a user's may not), or a one-line error."""
    reset = getattr(controller, "reset", None)
    if callable(reset):
        _user_call(controller, "reset", reset)
