"""A built-in controller's record, declared once beside its law (as dm_control's suite declares its tasks).

A law's module declares each controller it builds by putting :func:`controller` on its builder::

    @controller("lqr", "LQR (67) alone", lqr=True, kernels=(lqr_kernel,), device=True)
    def build_lqr(robot, task, gains=None, check=True, lqr_weights=None):
        return LQRController.for_model(robot.analytic, task, lqr_weights)

and nothing else in the package names it: the names and capabilities the command line shows
(:mod:`~paa_mj.control.catalog`, read from the modules' text without importing them), the builders by name
(:mod:`~paa_mj.control.registry`), the laws the Warp engine runs, what ``paa-mj compile`` compiles, compare's
default leaderboard and the tests' enrolment are all derived from these records. A module of
``paa_mj/control/`` that declares one is found by :func:`~paa_mj.control.catalog.record_modules`.

This module is plain Python (no NumPy, numba or MuJoCo): the laws' modules register into it on import.
"""
from __future__ import annotations

from dataclasses import dataclass

#: The goals a controller may declare (:class:`~paa_mj.task.Task`'s names).
GOALS = ("folded", "stretched")


@dataclass(frozen=True)
class ControllerRecord:
    """What a built-in controller is and can do.

    Attributes
    ----------
    name, description : str
        Its name (``--controller NAME``) and one line on what it is.
    build : callable or str
        ``build(robot, task, gains=None, check=True, **options)``: the controller for that robot and
        :class:`~paa_mj.task.Task` (its name where read from the text, :mod:`~paa_mj.control.catalog`).
    module : str
        The module that declares it.
    gains : bool
        It takes the gains kD, kP, kV of (40) / (12).
    plans : bool
        It plans a kip (options ``limit``, ``duration``, ``intervals``; a believed model other than the plant's
        is planned from the plant's kip, the builder's ``plant``).
    lqr : bool
        It balances by the LQR (67) (option ``lqr_weights = (q, r)``: Q = q I, R = r I).
    switches : bool
        It switches from a swing-up to (67), with the option ``switch``: ``"region"`` ((68), the default) or
        ``"roa"`` (the LQR's region of attraction).
    roa : bool
        It always hands over on the LQR's region of attraction, whose level takes the run's torque limits (option
        ``limit``).
    kernels : tuple
        The compiled kernels of its compiled form (empty: no compiled law, the engines call ``torque``).
    device : bool
        Every one of its kernels has a device form (:mod:`paa_mj.sim.warp.translate`): ``--engine warp`` runs it.
    links : int or None
        The number of links of the chains it applies to (None: any chain).
    passive : tuple of int or None
        The passive joints (1-based) of the chains it applies to (default ``(1,)``: the paper's family, joint 1
        passive and every other driven; None: any actuation).
    hands_over : bool
        It swings up, then hands over to a balance: a run of it has a switch to speak of.
    goals : tuple of str
        The goals it applies to.
    settings : tuple of str
        Options of its own, by name, beside those its capabilities bring (:attr:`options`).
    compare : bool
        It is on compare's default leaderboard (``paa-mj compare``).
    checked : tuple of (robot, goal) or None
        The stored robots and goals the enrolled tests run it on (None: every stored robot and goal it applies to);
        a costly one names fewer (a planner: each plan is an optimisation; a hand-over on the region of attraction:
        each level is a search).
    check_options : tuple of (name, value)
        The options the enrolled tests build it with (a planner's torque limit and a coarse grid, say).
    """

    name: str
    description: str
    build: object
    module: str = ""
    gains: bool = False
    plans: bool = False
    lqr: bool = False
    switches: bool = False
    roa: bool = False
    kernels: tuple = ()
    device: bool = False
    links: int | None = None
    passive: tuple | None = (1,)
    hands_over: bool = False
    goals: tuple = GOALS
    settings: tuple = ()
    compare: bool = False
    checked: tuple | None = None
    check_options: tuple = ()

    @property
    def compiled(self) -> bool:
        """It has a compiled law (the engines run it in numba)."""
        return bool(self.kernels)

    @property
    def options(self) -> tuple:
        """The options it takes, by name (``limit`` for a planner's torque bound or the ROA's level)."""
        names = (("limit", "duration", "intervals", "budget") if self.plans else ()) + (("lqr_weights",) if self.lqr else ()) \
            + (("switch",) if self.switches else ()) + (("limit",) if self.switches or self.roa else ()) \
            + tuple(self.settings)
        return tuple(dict.fromkeys(names))

    def hands_over_on_roa(self, switch=None) -> bool:
        """Whether it hands over on the LQR's region of attraction with the option ``switch``."""
        return self.roa or (self.switches and switch == "roa")

    def why_not(self, n_links: int, goal: str, passive: tuple = (1,), actuation: str = "") -> str | None:
        """Why it does not apply to a chain of ``n_links`` whose passive joints are ``passive`` (1-based; the chain's
        actuation in words, ``actuation``) at ``goal``, in words; None where it applies."""
        if self.links is not None and self.links != n_links:
            return f"it is for chains of {self.links} links, this one has {n_links}"
        if self.passive is not None and tuple(self.passive) != tuple(passive):
            joints = ", ".join(map(str, self.passive))
            return (f"it needs joint{'s' if len(self.passive) > 1 else ''} {joints} alone passive, this one has"
                    f" {actuation or 'passive joints ' + ', '.join(map(str, passive))}")
        if goal not in self.goals:
            return f"it aims at the {' or '.join(self.goals)} goal (--goal {self.goals[0]}), not the {goal} one"
        return None

    def applies_to(self, n_links: int, goal: str, passive: tuple = (1,)) -> bool:
        """Whether it applies to a chain of ``n_links`` whose passive joints are ``passive`` (1-based) at ``goal``."""
        return self.why_not(n_links, goal, passive) is None


#: The records declared so far, by name, in the order their modules were imported.
RECORDS: dict = {}

#: The capabilities :func:`controller` takes (the fields of :class:`ControllerRecord` a module declares).
CAPABILITIES = ("gains", "plans", "lqr", "switches", "roa", "kernels", "device", "links", "passive", "hands_over",
                "goals", "settings", "compare", "checked", "check_options")


def controller(name: str, description: str, **capabilities):
    """Declare the built-in controller ``name`` that the decorated function builds (:class:`ControllerRecord`).

    Its arguments are literals (and, for ``kernels``, names of the module's kernels): the command line reads them
    from the module's text without importing it (:mod:`~paa_mj.control.catalog`).
    """
    unknown = sorted(set(capabilities) - set(CAPABILITIES))
    if unknown:
        raise TypeError(f"controller {name}: unknown capabilities {', '.join(unknown)}")

    def declare(build):
        known = RECORDS.get(name)
        if known is not None and (known.module, known.build.__qualname__) != (build.__module__, build.__qualname__):
            raise ValueError(f"controller {name!r} is declared twice: in {known.module} and {build.__module__}")
        RECORDS[name] = ControllerRecord(name, description, build, build.__module__, **capabilities)
        return build

    return declare
