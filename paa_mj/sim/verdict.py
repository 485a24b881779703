"""What became of a run, in words, from the run's own records: one place for every command.

``simulate``'s outcome line, ``compare``'s reason for a failed kip, ``basin``'s "stuck at DUU" and
``realaigym``'s divergence are all said here, so that one run reads the same whichever command ran it:

- a diverged run (:func:`diverged_words`): when, and why (a non-finite torque, a non-finite state, joint speeds
  above :data:`~paa_mj.sim.compiled.step.MAX_SPEED`), found in any simulator's records by :func:`divergence`;
- how it ended where it did not succeed (:func:`ending_words`): at rest at DUU (stuck: the other limit of Theorem
  1 for the gymnast's folded goal), at rest elsewhere (an equilibrium of the closed loop), or spinning: no
  longer run changes any of them, so none is told to try a longer ``--t-final``;
- whether the controller hands over to the balance (67) at all (:func:`outcome_words`'s ``hands_over``): a
  controller without a switch (the LQR alone, a user's) is not told of a switch it never had.
"""
from __future__ import annotations

import numpy as np

from ..model.states import Q_DUU, wrap_angle
from .compiled.step import MAX_SPEED, NONFINITE_STATE, NONFINITE_TORQUE, RUNAWAY, STATUS_TEXT

#: A final state within this distance of DUU (each coordinate, rad and rad/s) is "stuck at DUU" (``basin``'s too).
DUU_TOL = 0.05
#: Joint speeds all below this at the end [rad/s]: the run is at rest there.
REST_SPEED = DUU_TOL
#: A joint faster than this at the end [rad/s] (four turns a second): the run is spinning, not settling.
SPIN_SPEED = 8 * np.pi


def diverged_words(t: float, why: str) -> str:
    """A diverged run, the same words in every command: ``diverged at t = T s: WHY``."""
    return f"diverged at t = {t:.4f} s: {why}"


def divergence(T, X, U, n_links: int):
    """The first sign of divergence in a run's records, as ``(t, why)``, or None.

    ``T`` (K,) times [s], ``X`` (K, 2n) states (angles, then speeds [rad/s]) and ``U`` (K - 1, m) the torques
    applied over each step: the first non-finite torque, non-finite state or joint speed above
    :data:`~paa_mj.sim.compiled.step.MAX_SPEED`, with the time it was recorded at (the engines' own tests, for a simulator
    that does not stop on them).
    """
    T, X, U = np.asarray(T, float), np.asarray(X, float), np.asarray(U, float)
    candidates = []
    bad_u = np.flatnonzero(~np.all(np.isfinite(U.reshape(len(U), -1)), axis=1))
    if bad_u.size:
        candidates.append((int(bad_u[0]), STATUS_TEXT[NONFINITE_TORQUE]))
    bad_x = np.flatnonzero(~np.all(np.isfinite(X.reshape(len(X), -1)), axis=1))
    if bad_x.size:
        candidates.append((int(bad_x[0]), STATUS_TEXT[NONFINITE_STATE]))
    with np.errstate(invalid="ignore"):
        fast = np.flatnonzero(np.max(np.abs(X[:, n_links:]), axis=1, initial=0.0) > MAX_SPEED)
    if fast.size:
        candidates.append((int(fast[0]), STATUS_TEXT[RUNAWAY]))
    if not candidates:
        return None
    k, why = min(candidates)
    return float(T[min(k, len(T) - 1)]), why


def near_duu(final_states, task) -> np.ndarray:
    """Which final states (N, 2n) lie within :data:`DUU_TOL` of DUU, for the gymnast's folded goal (where DUU is the
    other limit of Theorem 1); all False for any other robot or goal."""
    final = np.nan_to_num(np.atleast_2d(np.asarray(final_states, float)), nan=1e9)
    if not (task.n_links == 3 and task.name == "folded"):
        return np.zeros(len(final), bool)
    return np.max(np.abs(np.concatenate([wrap_angle(final[:, :3] - Q_DUU), final[:, 3:]], axis=1)), axis=1) < DUU_TOL


def ending_words(final_state, task, recent_speeds=None) -> tuple[str, bool]:
    """How a run that did not succeed ended, and whether a longer run could change it: ``("", True)`` where it is
    still moving about; stuck at DUU (its final state), at rest elsewhere, or spinning: not.

    ``recent_speeds`` (K,): the largest joint speed [rad/s] at each state recorded over the run's last second. At
    rest and spinning are judged over all of them (a swing's turning point is not rest), and not at all without
    them (a batch that keeps its final state only).
    """
    final = np.asarray(final_state, float)
    if final.size == 0 or not np.all(np.isfinite(final)):
        return "", True
    n = len(final) // 2
    if near_duu(final, task)[0]:
        return "stuck at DUU (at rest there, the other limit of Theorem 1)", False
    speeds = None if recent_speeds is None else np.asarray(recent_speeds, float)
    if speeds is None or speeds.size == 0 or not np.all(np.isfinite(speeds)):
        return "", True
    if np.max(speeds) < REST_SPEED:
        angles = " ".join(f"{a:.3g}" for a in wrap_angle(final[:n]))
        return (f"at rest at q = ({angles}) rad over its last second, not the goal: an equilibrium of the closed"
                " loop"), False
    if np.min(speeds) > SPIN_SPEED:
        return f"spinning at {float(np.max(np.abs(final[n:]))):.3g} rad/s at the end (above {SPIN_SPEED:.3g}" \
               " rad/s over its last second)", False
    return "", True


def _remedies(remedies) -> str:
    """"; try a, b or c" (nothing without a remedy)."""
    if not remedies:
        return ""
    return "; try " + (", ".join(remedies[:-1]) + " or " if len(remedies) > 1 else "") + remedies[-1]


def outcome_words(*, status: str, success: bool, task, t_final: float, switch_time, t_region, hands_over: bool,
                  final_state, recent_speeds=None, balanced: bool = False, saturated: str = "", unstable: str = "", gains: bool = False,
                  engine: str = "mujoco", region: bool = False, remedies: bool = True, idle: bool = False) -> str:
    """What became of one run, in one sentence, and what to try where it did not succeed: every command's words.

    Parameters
    ----------
    status : str
        The run's status: "ok", "diverged at t = ...: why" (:func:`diverged_words`), "interrupted at ...".
    success : bool
        The task's success, judged by the engine.
    switch_time, t_region : float or None
        The first switch to the balance (67) and the first entry into region (68) [s], None if never.
    hands_over : bool
        The controller swings up and hands over to (67) (vcl, vc...); False for one that has no switch (the LQR
        alone from the start, passive, a user's controller).
    final_state : array_like (2n,)
        The last state recorded.
    recent_speeds : array_like (K,), optional
        The largest joint speed at each state recorded over the last second (:func:`ending_words`).
    saturated, unstable : str
        The torque limits reached, and a balance unstable when sampled at the run's step (its remedy replaces the
        generic ones).
    gains, engine, region : bool, str, bool
        A gain controller (other gains may help), the engine (a smaller --dt helps MuJoCo only; "protocol": a
        benchmark's fixed step), and a hand-over on region (68) (--switch roa may help).
    remedies : bool
        Say what to try (a command's outcome line), or only what happened (a leaderboard's column).
    idle : bool
        The controller exerted no torque over the run (every torque recorded is zero): the chain keeps its energy,
        less its damping, so a longer run cannot take it to a goal it has not reached.
    """
    goal = task.name
    _try = _remedies if remedies else (lambda _: "")
    if hands_over and switch_time is not None:
        switched = f" after switching to (67) at t = {switch_time:.4f} s"
    elif switch_time is not None and switch_time == 0.0:
        switched = " under the balance (67) from the start"
    else:
        switched = ""
    if status.startswith("diverged"):
        law = STATUS_TEXT[NONFINITE_TORQUE] in status  # the law's own doing: no time step mends it
        fixes = ["gains with a larger margin over kD_min (41) (paa-mj theory shows the family rule's)"] * gains \
            + ["a smaller --dt"] * (engine not in ("analytic", "protocol") and not law) + ["--switch roa"] * (region and not law) \
            + ["a controller whose torque is finite at every state"] * (law and not gains)
        return f"{status}{switched}{saturated}" + (unstable * remedies or _try(fixes))
    if status.startswith("interrupted"):  # what it had done by then: no verdict on the whole run
        where = f"at the {goal} goal" if balanced else f"not at the {goal} goal"
        return (f"{status}, before the end of its {t_final:g} s, {where}{switched}{saturated}; run it whole for its"
                " outcome")
    if success:
        return f"reached the {goal} goal and held it (the task's success){switched}{saturated}"
    ending, longer_helps = ending_words(final_state, task, recent_speeds)
    ending = f", {ending}" if ending else ""
    other_gains = ["other gains (paa-mj gain-search compares rules of gains)"] * gains
    elsewhere = ["another start (--x0)"] if "at rest" in ending or "stuck" in ending else []
    longer = ["a controller that exerts torque (this one exerted none)"] if idle else \
        ["a longer --t-final"] * longer_helps
    entered = (f"never entered region (68) in {t_final:g} s" if t_region is None else
               f"entered region (68) at t = {t_region:.4f} s")
    if hands_over and switch_time is None:
        if t_region is None:
            return f"{entered}{ending}{saturated}" + _try(longer + other_gains + elsewhere)
        return f"{entered} but never handed over to (67){ending}{saturated}"
    if hands_over:
        return f"not balanced at the {goal} goal at the end{switched}{ending}{saturated}" + (
            unstable * remedies or _try(["--switch roa (a certified hand-over)"] * region + longer + elsewhere))
    # a controller without a hand-over: where it went, not a switch it never had
    if switched and t_region is None:  # the balance alone, started outside its region: a longer run keeps it out
        longer = ["a start inside its region of attraction (paa-mj roa)", "a swing-up controller"]
    return f"not at the {goal} goal at the end{switched} ({entered}){ending}{saturated}" + (
        unstable * remedies or _try(longer + other_gains + elsewhere))
