"""The gains of (40) and (12), their one owner: stored, by rule, given; and checked against the theory.

- stored: the gains a robot's model file stores (``Robot.gains``, read with the model);
- by rule: :data:`FAMILY_RULE` (:func:`family_gains`) where the stored ones do not meet (41) for the goal
  (:func:`default_gains`);
- given: the user's, gain by gain over those (:func:`resolve_gains`);
- checked: errors below the singularity bound (41), warnings outside Theorem 1 (:func:`check_gains_for`).
"""
from __future__ import annotations

import math
import warnings
from dataclasses import dataclass

import numpy as np

from ..errors import PaaError
from ..model.dynamics import AnalyticModel
from ..task import Task
from ..theory.conditions import bracket_words, chain_kd_min, constraint_54, thresholds
from ..theory.linear import theorem1_covers


from ..limits import MAX_GAIN, max_gain  # noqa: F401 - the one gain limit (a robot's own scale past the paper's)


#: How far above its bound the atlas's :func:`gain_rule` puts each gain.
MARGIN = 1.05


def gain_rule(kd, e1, e2, base_gains=None):
    """The atlas's gains, which meet the bounds: kD = 1.05 kD_min (41), kP = 1.05 max(eta1 (59), eta2 (60)),
    kV = kD x (kV / kD of ``base_gains``, 1 without them).

    Where (59) and (60) are not defined (``e1`` and ``e2`` None: a robot or goal beyond Theorem 1),
    kP = kD x (kP / kD of ``base_gains``, 2 without them) instead. The atlas maps a family around a robot with
    that robot's ratios; a robot run with no gains of its own takes :data:`FAMILY_RULE`.
    """
    kD = MARGIN * kd
    ratio_v = base_gains["kV"] / base_gains["kD"] if base_gains else 1.0
    if e1 is None or e2 is None:
        kP = kD * (base_gains["kP"] / base_gains["kD"] if base_gains else 2.0)
    else:
        kP = MARGIN * max(e1, e2)
    return {"kD": kD, "kP": kP, "kV": ratio_v * kD}


def gain_rule_words(covered: bool, base_gains=None) -> str:
    """:func:`gain_rule` in words, for a family whose Theorem 1 applies (``covered``) or not."""
    kP = f"{MARGIN:g} max(eta1, eta2)" if covered else "kD x (kP/kD of the base robot)" if base_gains else "2 kD"
    kV = "kD x (kV/kD of the base robot)" if base_gains else "kD"
    return f"kD = {MARGIN:g} kD_min, kP = {kP}, kV = {kV}"


@dataclass(frozen=True)
class GainRule:
    """Gains of (40) from the robot and goal alone: kD = ``margin`` x kD_min of (41) for the goal, kP = ``p`` x kD
    and kV = ``v`` x kD (each in the units (40) gives it); where Theorem 1 covers the robot and goal, kP is at
    least ``margin`` x max(eta1 (59), eta2 (60)) as well.

    The ratios are the family's: the search behind them (:mod:`paa_mj.studies.gain_search`, ``paa-mj
    gain-search``) kips every stored robot at both goals over a grid of (margin, p, v).
    """

    margin: float
    p: float
    v: float

    def describe(self) -> str:
        return (f"kD = {self.margin:g} kD_min (41), kP = {self.p:g} kD (at least {self.margin:g} max(eta1 (59),"
                f" eta2 (60)) where Theorem 1 covers the robot and goal), kV = {self.v:g} kD")


#: The family rule (:class:`GainRule`): the search's best (docs/controllers.md), the atlas's margin.
FAMILY_RULE = GainRule(margin=MARGIN, p=2.0, v=0.5)


def singularity_bound(model: AnalyticModel, task: Task) -> float:
    """kD_min of (41) for the robot and the task's goal: Theorem 1's closed form where it covers them, its
    definition computed for the chain elsewhere (:func:`chain_singularity_bound`)."""
    if theorem1_covers(model, task):
        return thresholds(model)[0].value
    return chain_singularity_bound(model, task)


def family_gains(model: AnalyticModel, task: Task, rule: GainRule = FAMILY_RULE) -> dict:
    """The gains ``rule`` gives the robot for the task's goal: {"kD", "kP", "kV"}."""
    kD = rule.margin * singularity_bound(model, task)
    kP = rule.p * kD
    if theorem1_covers(model, task):
        _, e1, e2 = thresholds(model)
        if np.isfinite(e1.value) and np.isfinite(e2.value):
            kP = max(kP, rule.margin * max(e1.value, e2.value))
    return {"kD": kD, "kP": kP, "kV": rule.v * kD}


def apart(value: float, bound: float) -> tuple[str, str]:
    """``value`` and ``bound`` written with 6 significant digits, or as many more as tell them apart (a gain just
    below its bound must not read as equal to it)."""
    for digits in range(6, 18):
        texts = f"{value:.{digits}g}", f"{bound:.{digits}g}"
        if texts[0] != texts[1] or value == bound:
            return texts
    return texts


def gains_text(gains: dict) -> str:
    """``--kD X --kP Y --kV Z``: gains as the command line takes them (those of the three that ``gains`` has)."""
    return " ".join(f"--{k} {gains[k]:.6g}" for k in ("kD", "kP", "kV") if k in gains)


def gains_origin(model: AnalyticModel, task: Task, stored: dict | None, gains: dict, noted: bool = False) -> str:
    """Where a run's ``gains`` come from, in words: the family rule's for the task's goal, the robot's stored gains
    (they may be both: :command:`make-model` stores the rule's gains for the folded goal), the command's, or gain
    by gain where they mix (a kD given, kP and kV of the rule). The rule is described unless ``noted``: a run that
    took the rule's gains in place of the stored ones said so, rule and all, in its :class:`GainsNote`."""
    keys = ("kD", "kP", "kV")

    def same(other, which=keys):
        return bool(other) and all(k in other and math.isclose(gains[k], other[k], rel_tol=1e-9) for k in which)

    rule_gains = family_gains(model, task)
    rule = f"the family rule's for the {task.name} goal"
    stored_words = "the model's stored gains" if same(stored) else ""
    if same(rule_gains):
        if stored_words or not noted:
            rule = f"{rule}: {FAMILY_RULE.describe()}"
        return f"{stored_words}, {rule}" if stored_words else rule
    if stored_words:
        return stored_words
    from_rule = [k for k in keys if same(rule_gains, (k,))]
    from_stored = [k for k in keys if k not in from_rule and same(stored, (k,))]
    given = [k for k in keys if k not in from_rule + from_stored]
    parts = [f"{', '.join(given)} as given"]
    parts += [f"{', '.join(from_rule)} {rule}"] if from_rule else []
    parts += [f"{', '.join(from_stored)} the model's stored ones"] if from_stored else []
    return "; ".join(parts)


class GainsNote(UserWarning):
    """The run uses the family rule's gains instead of gains the robot stores (or it stores none)."""


_NOTED: set = set()


def default_gains(model: AnalyticModel, task: Task, stored: dict | None, given: dict | None = None) -> dict:
    """The gains a controller takes when none are given: the robot's stored gains where their kD is above the
    bound (41) of the task's goal, else the family rule's (:func:`family_gains`), said once per robot and goal by
    a :class:`GainsNote` naming those of them the run takes (not the ``given`` ones; nothing where a given kD is
    not above the bound, which the run's check refuses with the rule's gains in its message)."""
    bound = singularity_bound(model, task)
    if stored and all(k in stored for k in ("kD", "kP", "kV")) and stored["kD"] > bound:
        return dict(stored)
    gains = family_gains(model, task)
    given = {k: v for k, v in (given or {}).items() if v is not None}
    taken = {k: v for k, v in gains.items() if k not in given}
    key = (model.key(), task.name, bool(stored), tuple(taken))
    refused = "kD" in given and given["kD"] <= bound  # the run's check refuses it, naming the rule's gains
    if taken and not refused and key not in _NOTED:
        _NOTED.add(key)
        why = ("its stored kD = {} is not above kD_min = {} of (41) for the {} goal".format(
            *apart(stored["kD"], bound), task.name) if stored and "kD" in stored else "it stores no gains")
        warnings.warn(f"{'gains' if len(taken) == 3 else ', '.join(taken)} of the family rule"
                      f" ({FAMILY_RULE.describe()}): {gains_text(taken)}, since {why}", GainsNote, stacklevel=2)
    return gains


def given_gains(robot_name: str, base: dict | None, kD=None, kP=None, kV=None) -> dict:
    """The gains given, each checked to be a number, the rest from ``base`` (the robot's stored gains, or those of
    :func:`default_gains`); a gain neither given nor in ``base`` is refused in one line naming the robot."""
    given = {"kD": kD, "kP": kP, "kV": kV}
    base = base or {}
    missing = [k for k, v in given.items() if v is None and k not in base]
    if missing:
        raise PaaError(f"robot {robot_name} stores no default gains: give {', '.join('--' + k for k in missing)}")
    resolved = {}
    for k, v in given.items():
        value = base[k] if v is None else v
        if isinstance(value, (bool, np.bool_, str, bytes)):  # float() would read True as 1 and "5" as 5
            raise PaaError(f"gain {k} must be a number, got {value!r}")
        try:
            resolved[k] = float(value)
        except (TypeError, ValueError):
            raise PaaError(f"gain {k} must be a number, got {value!r}") from None
    return resolved


def resolve_gains(robot, task: Task | None = None, kD=None, kP=None, kV=None) -> dict:
    """The gains a controller of (40) / (12) takes on ``robot`` (a :class:`~paa_mj.model.robot.Robot`) for
    ``task``: those given, the rest from the robot's stored gains (its model file's) where they meet (41) for the
    task's goal, else from the family rule (:func:`default_gains`, which says so). Without a ``task``: the given
    and the stored gains alone."""
    given = {"kD": kD, "kP": kP, "kV": kV}
    if task is None or all(v is not None for v in given.values()):
        return given_gains(robot.name, robot.gains, **given)
    return given_gains(robot.name, default_gains(robot.analytic, task, robot.gains, given), **given)


class TheoryWarning(UserWarning):
    """Gains or robot outside what Theorem 1 covers; the run goes on."""


def check_gain_range(kD, kP, kV, model: AnalyticModel | None = None):
    """Gains of (40) (or (12)) that the theory and the law can be evaluated with, or a one-line error.

    Each finite, positive (V weighs the speeds by kD/2 and the posture error by
    kP/2; dV/dt = -kV ``|qd_a|^2`` (36)) and at most :func:`~paa_mj.limits.max_gain` of the robot ``model`` (1e8
    times the paper's gains, or a million times the robot's own gain scale where that is more). The paper's
    bounds (41), (59), (60) are :func:`check_gains`'s.
    """
    p = None if model is None else model.params
    ceiling = max_gain() if p is None else max_gain(p.m, p.l, p.g)
    for name, value in (("kD", kD), ("kP", kP), ("kV", kV)):
        if not np.isfinite(value):
            raise PaaError(f"gain {name} = {value} is not finite")
        if value <= 0:
            raise PaaError(f"gain {name} = {value:g} must be > 0")
        if value > ceiling:
            why = ("1e8 times the paper's gains" if ceiling == MAX_GAIN else
                   "a million times this robot's gain scale (sum m)^2 (sum l)^3 g")
            raise PaaError(f"gain {name} = {value:g} is above {ceiling:g}, {why}")


def check_runnable_gains(model: AnalyticModel, stored: dict | None = None):
    """The gains a robot's runs would take, checked as every run checks them, or a one-line error: ``stored`` (the
    gains its file keeps) and the family rule's for each goal (what a run takes where the stored kD is not above
    kD_min (41) for the goal). ``make-model`` calls it, so that no command refuses the robot it writes."""
    if stored is not None:
        check_gain_range(**stored, model=model)
    for goal in ("folded", "stretched"):
        gains = family_gains(model, Task.named(goal, model))
        try:
            check_gain_range(**gains, model=model)
        except PaaError as err:
            raise PaaError(f"the family rule's gains for the {goal} goal are out of range ({err}): no command"
                           " could run this robot; change its masses or lengths") from None


def check_gains(model: AnalyticModel, kD, kP, kV, stacklevel=3, task: Task | None = None):
    """Validate gains of (40) (or (12)) against the theory for ``model``.

    Raises
    ------
    PaaError
        A gain that is not finite or above :data:`MAX_GAIN`, kV <= 0, kP <= 0, or kD <= kD_min of (41) (the
        controller can hit a singular Lambda (38)); the message names the bound
        and its value.

    Warns
    -----
    TheoryWarning
        kP <= eta1 (59) or eta2 (60), E_r <= 0, or constraint (54) fails: Theorem 1
        no longer guarantees convergence to W_r or DUU, but the run may go on.

    Returns
    -------
    list of str
        The warnings given.
    """
    check_gain_range(kD, kP, kV, model)
    kd, e1, e2 = thresholds(model)
    if kD <= kd.value:
        shown, bound = apart(kD, kd.value)
        raise PaaError(f"gain kD = {shown} is not above kD_min = {bound} of (41): controller (40) can become"
                       " singular; the family rule's gains would do:"
                       f" {gains_text(family_gains(model, Task.named('folded', model) if task is None else task))}")
    messages = []
    if model.E_r <= 0:
        messages.append(f"E_r = {model.E_r:.6g} J <= 0: the method of the paper does not apply (9)")
    for name, eta in (("eta1", e1), ("eta2", e2)):
        if kP <= eta.value:
            shown, bound = apart(kP, eta.value)
            messages.append(f"kP = {shown} is not above {name} = {bound} of ({59 if name == 'eta1' else 60}): Theorem 1"
                            " no longer guarantees convergence")
    c54 = constraint_54(model)
    if not c54.holds:
        messages.append(f"constraint (54) fails (f(z) = 1 near z = {c54.z_closest:.4g}): Theorem 1 does not apply, the swing-up may stall")
    for message in messages:
        warnings.warn(message, TheoryWarning, stacklevel=stacklevel)
    return messages


def chain_singularity_bound(model: AnalyticModel, task: Task) -> float:
    """kD_min of (41) from its definition for any chain and the task's goal
    (:func:`~paa_mj.theory.conditions.chain_kd_min`, cached per robot and goal): its value, or where the search
    could only bracket it, its certified upper bound."""
    kd = chain_kd_min(model, task)
    return kd.value if kd.certified else kd.upper


def check_chain_gains(model: AnalyticModel, kD, kP, kV, task: Task):
    """Gains of (40) (or (12)) on a chain or goal beyond the paper, or a one-line error.

    Each in range (:func:`check_gain_range`), and kD above the singularity bound (41) computed from its
    definition for this robot and goal: below it Lambda (38) can become singular. Where the search could only
    bracket the bound (long chains), kD must be above the bracket's certified upper end. Theorem 1's other
    bounds, (59) and (60), are proved for the paper's gymnast and goal only and are not checked here.
    """
    check_gain_range(kD, kP, kV, model)
    kd = chain_kd_min(model, task)
    where = f"its definition, computed for this {model.n_links}-link robot and the {task.name} goal"
    would_do = f"the family rule's gains would do: {gains_text(family_gains(model, task))}"
    if kD <= kd.value:
        shown, bound = apart(kD, kd.value)
        raise PaaError(f"gain kD = {shown} is not above kD_min = {bound} of (41) ({where}): controller (40)"
                       f" can become singular; {would_do}")
    if not kd.certified and kD <= kd.upper:
        raise PaaError(f"gain kD = {kD:g} is not certified singularity-free: {bracket_words(kd)} ({where}); {would_do}")


def check_gains_for(model: AnalyticModel, kD, kP, kV, task: Task, stacklevel=3):
    """:func:`check_gains` (Theorem 1's bounds) where Theorem 1 covers the robot and task, :func:`check_chain_gains`
    (the singularity bound (41) by its definition) for every other robot or goal."""
    if theorem1_covers(model, task):
        return check_gains(model, kD, kP, kV, stacklevel=stacklevel + 1, task=task)
    check_chain_gains(model, kD, kP, kV, task)
    return []

