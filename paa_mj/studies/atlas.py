"""Which robots can kip: the theory and the simulated kip over a family of body proportions.

A family is made from a base robot of n links by scaling two of its parameters
(each one of m1..mn, l1..ln) by factors on a log-spaced grid. Scaling a length
scales that link's lc with it and its J with the square; scaling a mass scales
its J with it; damping and armature are kept. For every robot of the family:

- the theory. For the paper's gymnast shape (three links, no damping or armature)
  and its folded goal, Theorem 1's quantities: E_r (9), constraint (54) (holds,
  f_min, f_max), the range of deltabar (30), linear controllability at UDD, kD_min
  (41), eta1 (59), eta2 (60). For any other robot or goal, which Theorem 1 does not
  cover, what is defined there: E_r (the energy at the goal), kD_min of (41) from
  its definition, linear controllability at the goal, and deltabar (30) of the merged
  acrobot (Sect. 2.4); (54), (59) and (60) are not defined (NaN, False);
- gains by one rule (:func:`~paa_mj.control.gains.gain_rule`) that meets the bounds wherever they are
  finite: kD = 1.05 kD_min, kP = 1.05 max(eta1, eta2) (Theorem 1's case) or kP in the
  base robot's ratio kP / kD (elsewhere), and kV in the base robot's ratio kV / kD
  (kV = kD when the base stores no gains);
- with ``simulate``: the kip from the goal's start (65) and from N random starts in
  MuJoCo through the batch engine, each robot its own plant and controller; its outcome
  is a success (the task's), switched with no success, stuck at DUU (the gymnast's folded goal),
  never switched elsewhere (V stays above 0, ``V_final``) or diverged.

"Theorem 1 applies" means the theorem covers the robot and goal, E_r > 0, (54) holds
and UDD is linearly controllable (the gains meet the rest by construction). The
confusion table of that against the simulated kip is the atlas's finding.
"""
from __future__ import annotations

import contextlib
import math
import warnings

import numpy as np

from ..control.registry import ControllerSpec
from ..errors import PaaError
from ..provenance import text_sha256
from ..sim.compiled.retirement import SamplingWarning
from ..limits import check_memory, check_seed, check_steps
from ..model.dynamics import AnalyticModel
from ..model.params import RobotParams
from ..model.robot import Robot
from ..task import Task, as_task
from ..theory.conditions import chain_kd_min, constraint_54, eta1, eta2, frozen_acrobot_controllable, kd_min
from ..theory.merged import merged_acrobot
from ..control.closed_loop import duu_eigenvalues
from ..control.gains import gain_rule, gain_rule_words
from ..theory.linear import goal_controllability, lqr_gain, sampled_spectral_radius, theorem1_covers
from .basin import NOT_RUN_CODE, OUTCOME_NAMES, classify
from .runner import CHUNK, RolloutSet, applied_limit, map_chunks, peak_torques, run_study, task_definition
from .settings import ATLAS_MAX_GRID as MAX_GRID, ATLAS_RANGE as DEFAULT_RANGE, atlas_parameters
from .store import NOT_RUN, ChunkStore, check_arrays, runs_done, study_key

OUTCOMES = OUTCOME_NAMES
#: The outcome code of a robot whose rule gives no positive finite gains: it has no kip to run.
NO_GAINS = -2
NO_GAINS_WORDS = "not simulated: the gain rule gives no positive finite gains"
THEORY_CHUNK = 32
START_SPREAD = (np.pi, 1.0)  # random starts: angles uniform over a full turn, speeds within +-1 rad/s


def parse_vary(text, n_links=3) -> tuple[str, str]:
    """Two different parameters of an ``n_links`` chain out of m1..mn, l1..ln, or a one-line error."""
    names = [n.strip() for n in str(text).split(",")]
    allowed = atlas_parameters(n_links)
    if len(names) != 2 or names[0] == names[1] or any(n not in allowed for n in names):
        raise PaaError(f"--vary needs two different parameters out of {', '.join(allowed)} (this robot has"
                       f" {n_links} links), got {text!r}")
    return names[0], names[1]


#: The scale factors an atlas may apply: beyond them a robot is not a body of this shape (and its
#: parameters leave the range MuJoCo and the theory are checked over).
FACTOR_BOUNDS = (1e-3, 1e3)


def parse_range(text) -> tuple[float, float]:
    try:
        low, high = (float(v) for v in str(text).split(":"))
    except ValueError:
        raise PaaError(f"--range must be LOW:HIGH, two positive factors, got {text!r}") from None
    return check_range((low, high), text)


def check_range(factor_range, text=None) -> tuple[float, float]:
    """``(low, high)`` with 0 < low < high within :data:`FACTOR_BOUNDS`, or a one-line error."""
    try:
        low, high = (float(v) for v in factor_range)
    except (TypeError, ValueError):
        raise PaaError(f"--range must be LOW:HIGH, two positive factors, got {factor_range!r}") from None
    shown = text if text is not None else f"{low:g}:{high:g}"
    if not (math.isfinite(low) and math.isfinite(high) and 0 < low < high):
        raise PaaError(f"--range must be LOW:HIGH with 0 < LOW < HIGH, got {shown!r}")
    if low < FACTOR_BOUNDS[0] or high > FACTOR_BOUNDS[1]:
        raise PaaError(f"--range {shown}: scale factors must lie within [{FACTOR_BOUNDS[0]:g}, {FACTOR_BOUNDS[1]:g}]"
                       " (a body scaled further is no gymnast, and its parameters leave the range this package"
                       " checks)")
    return low, high


def scale(params: RobotParams, name: str, factor: float) -> RobotParams:
    """``params`` with one mass or length scaled (a length takes its lc along and its J with the square);
    damping and armature are kept."""
    m, l, lc, J = params.m.copy(), params.l.copy(), params.lc.copy(), params.J.copy()
    i = int(name[1:]) - 1
    if name[0] == "m":
        m[i] *= factor
        J[i] *= factor
    else:
        l[i] *= factor
        lc[i] *= factor
        J[i] *= factor**2
    return RobotParams(m=m, l=l, lc=lc, J=J, g=params.g, name=params.name, damping=params.damping,
                       armature=params.armature, actuated=params.actuated)


def grid_factors(low, high, grid):
    """``grid`` log-spaced factors from low to high, with 1 itself where the grid passes within rounding."""
    factors = np.geomspace(low, high, grid)
    near_one = np.isclose(factors, 1.0, rtol=1e-9)
    factors[near_one] = 1.0
    return factors


def robot_theory(params: RobotParams, task: Task, base_gains=None, dt=1e-3) -> dict:
    """Everything the atlas says of one robot, from the theory alone.

    Besides the theory's quantities (the module's docstring): ``duu_growth``, the largest real part
    of the closed loop's eigenvalues at DUU with the rule's gains [1/s] (how fast a kip leaves DUU;
    near 0, it lingers there; Theorem 1's case only), and ``lqr_sampled_stable``, whether the LQR
    (67) balances the linearisation at the goal sampled with zero-order hold at ``dt`` (the
    simulation's step).
    """
    am = AnalyticModel.from_params(params)
    covered = theorem1_covers(am, task)
    controllable = goal_controllability(am, task).controllable
    E_r = task.goal_energy(am)
    if covered:
        kd, e1, e2 = kd_min(am).value, eta1(am).value, eta2(am).value
        c54 = constraint_54(am)
        holds, f_min, f_max = bool(c54.holds), float(c54.f_min), float(c54.f_max)
        _, db_min, db_max = frozen_acrobot_controllable(am)
        gains = gain_rule(kd, e1, e2, base_gains)
        growth = float(np.max(duu_eigenvalues(am, **gains)[0].real)) if np.all(np.isfinite(list(gains.values()))) \
            else float("nan")
    else:
        bound = chain_kd_min(am, task, progress=False)
        kd, e1, e2 = bound.value, float("nan"), float("nan")
        holds, f_min, f_max = False, float("nan"), float("nan")
        merged = merged_acrobot(am, budget_cpu_s=0.0)  # its extremes; the sign is not the atlas's to decide
        db_min, db_max = merged.minimum, merged.maximum
        gains = gain_rule(kd if bound.certified else bound.upper, None, None, base_gains)  # above a bracket's top
        growth = float("nan")
    radius = sampled_spectral_radius(am, lqr_gain(am, task), dt, task) if controllable else float("inf")
    return {"params": {"m": params.m.tolist(), "l": params.l.tolist(), "lc": params.lc.tolist(), "J": params.J.tolist()},
            "E_r": E_r, "holds_54": holds, "f_min": f_min, "f_max": f_max,
            "deltabar_min": db_min, "deltabar_max": db_max, "udd_controllable": bool(controllable),
            "kD_min": kd, "eta1": e1, "eta2": e2, "gains": gains, "duu_growth": growth,
            "lqr_sampled_stable": bool(radius < 1.0),
            "theorem1": bool(covered and E_r > 0 and holds and controllable)}


_NUMBERS = ("E_r", "f_min", "f_max", "deltabar_min", "deltabar_max", "kD_min", "eta1", "eta2", "duu_growth")
_FLAGS = ("holds_54", "udd_controllable", "lqr_sampled_stable", "theorem1")


def _theory_task(shared, payload):
    base_gains, dt, task = shared
    rows = [robot_theory(RobotParams(m=p[0], l=p[1], lc=p[2], J=p[3], g=p[4], damping=p[5], armature=p[6]), task,
                         base_gains, dt) for p in payload]
    out = {key: np.array([row[key] for row in rows], float) for key in _NUMBERS}
    out.update({key: np.array([row[key] for row in rows], bool) for key in _FLAGS})
    out["gains"] = np.array([[row["gains"][k] for k in ("kD", "kP", "kV")] for row in rows])
    return out


def atlas(robot: Robot, vary=("l1", "m1"), factor_range=DEFAULT_RANGE, grid=32, simulate=False, starts=4,
          t_final=None, seed=0, *, task: Task | str | None = None, scheduler="inline", out_dir=None, fresh=False,
          progress=False, chunk=None, torque_limit=None):
    """The atlas of a family of robots; returns (summary, arrays).

    The family is ordered with the first parameter's factor as the slow index.
    ``chunk``: robots per chunk of the theory and kips per chunk of the simulation
    (default :data:`THEORY_CHUNK` and :data:`~paa_mj.studies.runner.CHUNK`);
    ``torque_limit`` [N m] saturates every simulated kip; ``task`` (a Task or a goal's name, default the folded
    task) is what the theory, the controllers and success are taken at, and ``t_final`` defaults to its horizon.
    """
    task = as_task(task, robot)
    t_final = task.horizon if t_final is None else t_final
    if not (isinstance(grid, (int, np.integer)) and 2 <= grid <= MAX_GRID):
        raise PaaError(f"--grid must be an integer in [2, {MAX_GRID}], got {grid}")
    seed = check_seed(seed, "--seed")
    vary = parse_vary(",".join(map(str, vary)) if isinstance(vary, (tuple, list)) else vary, robot.params.n_links)
    factor_range = check_range(factor_range)
    if not (isinstance(starts, (int, np.integer)) and 0 <= starts <= 10_000):
        raise PaaError(f"--starts must be an integer in [0, 10000], got {starts}")
    from ..theory.linear import require_passive_first

    require_passive_first(robot.analytic, "the atlas (Theorem 1 and the kip of (40) over body proportions)", robot.name)
    n = grid * grid
    check_memory(n * 4000.0, "the atlas", "--grid")
    if simulate and scheduler in ("inline", "local"):
        check_steps(n * (starts + 1) * t_final / float(robot.model.opt.timestep),
                    f"{n * (starts + 1)} kips of {t_final:g} s", "--grid, --starts or --t-final",
                    links=robot.params.n_links, runs=n * (starts + 1))
    f1, f2 = grid_factors(*factor_range, grid), grid_factors(*factor_range, grid)
    try:
        family = [scale(scale(robot.params, vary[0], a), vary[1], b) for a in f1 for b in f2]
    except PaaError as err:  # a robot at the edge of the plausible parameters: said before any work, with the remedy
        raise PaaError(f"the atlas's factors {factor_range[0]:g} to {factor_range[1]:g} on {', '.join(vary)} make a"
                       f" robot of the family non-physical: {str(err).removeprefix('non-physical parameters: ')};"
                       " narrow --range") from None
    key = {"study": "atlas", "robot": robot.xml, "vary": list(vary), "range": list(factor_range), "grid": grid,
           **task_definition(task)}
    theory_chunk = chunk or THEORY_CHUNK
    payloads = [[(p.m, p.l, p.lc, p.J, p.g, p.damping, p.armature) for p in family[i:i + theory_chunk]]
                for i in range(0, n, theory_chunk)]
    covered = theorem1_covers(robot.analytic, task)
    store = ChunkStore(out_dir, study_key({**key, "part": "theory", "chunk": theory_chunk}), fresh,
                       study="atlas-theory")
    finished, interrupted = map_chunks(_theory_task, payloads, scheduler=scheduler, store=store, progress=progress,
                                       desc=f"theory of {n} robots", fits=_theory_fits,
                                       shared=(robot.gains, float(robot.model.opt.timestep), task))
    arrays = {"factors_1": f1, "factors_2": f2}
    for name in _NUMBERS + _FLAGS + ("gains",):
        parts = [finished[i][name] if i in finished else
                 np.full((len(payloads[i]),) + ((3,) if name == "gains" else ()), np.nan if name not in _FLAGS else False)
                 for i in range(len(payloads))]
        arrays[name] = np.concatenate(parts)
    arrays["theory_done"] = np.concatenate([np.full(len(payloads[i]), i in finished) for i in range(len(payloads))])
    summary = {"robot": robot.name, "robot_sha256": text_sha256(robot.xml), "vary": list(vary),
               "factors": [f1.tolist(), f2.tolist()],
               "range": list(factor_range), "grid": grid, "links": robot.params.n_links, **task.describe(),
               "theorem1_covers": covered,
               "gain_rule": gain_rule_words(covered, robot.gains),
               "interrupted": interrupted, "simulated": bool(simulate)}
    if simulate and not interrupted:
        outcome, reached, success_starts, V_final, interrupted, peak = _simulate(
            robot, family, arrays, starts, t_final, seed, scheduler, out_dir, fresh, progress, key, chunk or CHUNK,
            torque_limit, task)
        arrays["outcome"], arrays["reached_68"], arrays["success_starts"] = outcome, reached, success_starts
        arrays["V_final"] = V_final
        summary["interrupted"] = interrupted
        summary["starts"], summary["t_final"] = starts, t_final
        summary["torque_limit"] = applied_limit(robot, torque_limit)
        summary["max_abs_tau"] = peak
        summary["success"] = float(np.mean(arrays["outcome"][arrays["outcome"] >= 0] == 0)) \
            if np.any(arrays["outcome"] >= 0) else None
    # a robot is run when its theory is, and (with --simulate) its kips unless it has none; a robot not run is absent
    # from "robots" and counted here
    robot_done = arrays["theory_done"] & (arrays["outcome"] != NOT_RUN_CODE if "outcome" in arrays
                                          else not simulate)
    summary.update(runs_done(robot_done))
    summary["robots"] = _robot_rows(family, arrays, f1, f2)
    summary["counts"] = _counts(arrays, simulate and "outcome" in arrays, covered)
    summary["findings"] = _findings(summary, arrays)
    return summary, arrays


def _theory_fits(payload, result):
    rows = len(payload)
    shapes = {**{name: (rows,) for name in _NUMBERS + _FLAGS}, "gains": (rows, 3)}
    return check_arrays(result, shapes)


def _simulate(robot, family, arrays, starts, t_final, seed, scheduler, out_dir, fresh, progress, key, chunk,
              torque_limit, task):
    rng = np.random.default_rng(seed)
    links = robot.params.n_links
    first = task.start
    x0, specs, plants, owner = [], [], [], []
    for r, params in enumerate(family):
        gains = tuple(arrays["gains"][r])
        if not np.all(np.isfinite(gains)) or min(gains) <= 0:
            continue
        spec = ControllerSpec("vcl", gains, params, check=False, task=task)
        starts_r = [first] + [np.concatenate([rng.uniform(-START_SPREAD[0], START_SPREAD[0], links),
                                              rng.uniform(-START_SPREAD[1], START_SPREAD[1], links)])
                              for _ in range(starts)]
        for state in starts_r:
            x0.append(state)
            specs.append(spec)
            plants.append(params)
            owner.append(r)
    owner = np.array(owner, int)
    outcome = np.full(len(family), NO_GAINS, np.int8)  # robots without a kip keep it; the others are set below
    reached = np.zeros(len(family), bool)
    success_starts = np.full(len(family), np.nan)
    V_final = np.full(len(family), np.nan)
    if not x0:
        return outcome, reached, success_starts, V_final, False, None
    rollouts = RolloutSet(np.array(x0), specs, task, plants=plants, torque_limit=torque_limit)
    store = ChunkStore(out_dir, study_key({**key, "part": "kips", "starts": starts, "t_final": t_final, "seed": seed,
                                           "chunk": chunk, **rollouts.definition()}), fresh, study="atlas-kips")
    with _sampling_warnings_summed(len(family)):
        result = run_study(robot, rollouts, t_final, seed=seed, scheduler=scheduler, store=store, progress=progress,
                           desc="atlas kips", chunk=chunk)
    done = result.meta["completed"]
    codes = classify(result, task)
    for r in np.unique(owner):
        rows = np.flatnonzero(owner == r)
        kip = rows[0]
        if not done[rows].all():  # a robot is run when its kip and its random starts are
            outcome[r] = NOT_RUN_CODE
            continue
        outcome[r] = codes[kip]
        reached[r] = bool(np.isfinite(result.switch_time[kip]))
        V_final[r] = result.V_final[kip]
        if len(rows) > 1:
            success_starts[r] = float(np.mean(result.success[rows[1:]]))
    return outcome, reached, success_starts, V_final, result.interrupted, peak_torques(result.max_abs_tau, done)


@contextlib.contextmanager
def _sampling_warnings_summed(robots):
    """One :class:`~paa_mj.sim.compiled.retirement.SamplingWarning` for the family instead of one per robot (each scaled robot
    carries its base robot's name, and a 16 x 16 atlas would say it 256 times); other warnings pass through."""
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always", SamplingWarning)
        yield
    sampling = [w for w in caught if issubclass(w.category, SamplingWarning)]
    for w in caught:
        if not issubclass(w.category, SamplingWarning):
            warnings.warn_explicit(w.message, w.category, w.filename, w.lineno)
    if sampling:
        warnings.warn(f"the balance LQR (67) is unstable when sampled at the model's time step on {len(sampling)} of"
                      f" the {robots} robots of this atlas, whose runs cannot balance (the first:"
                      f" {sampling[0].message.detail})", SamplingWarning, stacklevel=3)


def _robot_rows(family, arrays, f1, f2):
    rows = []
    grid2 = len(f2)
    for r, params in enumerate(family):
        if not arrays["theory_done"][r]:
            continue
        row = {"factors": [float(f1[r // grid2]), float(f2[r % grid2])],
               "params": {"m": params.m.tolist(), "l": params.l.tolist(), "lc": params.lc.tolist(),
                          "J": params.J.tolist()}}
        for name in _NUMBERS:
            value = float(arrays[name][r])
            row[name] = value if math.isfinite(value) else None
        for name in _FLAGS:
            row[name] = bool(arrays[name][r])
        row["gains"] = dict(zip(("kD", "kP", "kV"), arrays["gains"][r].tolist()))
        if "outcome" in arrays:
            code = int(arrays["outcome"][r])
            row["outcome"] = NOT_RUN if code == NOT_RUN_CODE else NO_GAINS_WORDS if code == NO_GAINS else OUTCOMES[code]
            row["swing_up_reaches_68"] = None if code < 0 else bool(arrays["reached_68"][r])
            v_final = float(arrays["V_final"][r])
            row["V_final"] = v_final if math.isfinite(v_final) else None
            value = float(arrays["success_starts"][r])
            row["success_from_random_starts"] = value if math.isfinite(value) else None
        rows.append(row)
    return rows


def _counts(arrays, simulated, covered=True):
    done = arrays["theory_done"]
    counts = {"robots": int(done.sum()), "E_r > 0": int(np.sum((arrays["E_r"] > 0) & done))}
    if covered:
        counts.update({"(54) holds": int(np.sum(arrays["holds_54"] & done)),
                       "UDD controllable": int(np.sum(arrays["udd_controllable"] & done))})
    else:
        counts["goal controllable"] = int(np.sum(arrays["udd_controllable"] & done))
    counts["Theorem 1 applies"] = int(np.sum(arrays["theorem1"] & done))
    if simulated:
        ran = arrays["outcome"] >= 0
        kip = arrays["reached_68"] & ran
        theorem = arrays["theorem1"]
        counts.update({name: int(np.sum(arrays["outcome"] == code)) for code, name in enumerate(OUTCOMES)})
        counts["confusion"] = {
            "theorem applies, swing-up reaches (68)": int(np.sum(theorem & kip)),
            "theorem applies, swing-up does not": int(np.sum(theorem & ~kip & ran)),
            "theorem does not apply, swing-up reaches (68)": int(np.sum(~theorem & kip)),
            "theorem does not apply, swing-up does not": int(np.sum(~theorem & ~kip & ran)),
        }
    return counts


def _findings(summary, arrays):
    """What the map shows, in sentences."""
    counts = summary["counts"]
    lines = [] if not summary["interrupted"] else [
        f"INCOMPLETE (interrupted): what follows covers only the {counts['robots']} robots finished so far"
        + (" and only their finished kips" if summary["simulated"] else "") + "; run the same command to finish."]
    if summary["theorem1_covers"]:
        lines += [f"{counts['Theorem 1 applies']} of {counts['robots']} robots meet Theorem 1's conditions on the"
                  f" robot (E_r > 0 on {counts['E_r > 0']}, (54) on {counts['(54) holds']}, UDD controllable on"
                  f" {counts['UDD controllable']})."]
    else:
        why = f"{summary['links']} links" if summary["links"] != 3 else "damping or armature"
        lines += [f"Theorem 1 does not cover this family ({why if summary['goal'] == 'folded' else 'the stretched goal'}"
                  f"; it is proved for the paper's 3-link gymnast without damping and its folded goal): the map shows"
                  f" what is defined. Of {counts['robots']} robots, E_r > 0 on {counts['E_r > 0']} and the"
                  f" {summary['goal']} goal is linearly controllable on {counts['goal controllable']}; kD_min (41) is"
                  " computed from its definition and deltabar (30) for the merged acrobot; (54), (59), (60) are not"
                  " defined here."]
    if "confusion" in counts and not summary["theorem1_covers"]:
        kip = arrays["reached_68"] & (arrays["outcome"] >= 0)
        ran = int(np.sum(arrays["outcome"] >= 0))
        lines.append(f"The swing-up (40) from the start reaches region (68) around the {summary['goal']} goal on"
                     f" {int(kip.sum())} of {ran} robots and succeeds there (the task's success) on {counts['success']}.")
    elif "confusion" in counts:
        c = counts["confusion"]
        lines.append(f"The swing-up (40) from (65) reaches region (68) on {c['theorem applies, swing-up reaches (68)']}"
                     f" of the robots where Theorem 1 applies and not on {c['theorem applies, swing-up does not']};"
                     f" where it does not apply, it reaches (68) on {c['theorem does not apply, swing-up reaches (68)']}"
                     f" and not on {c['theorem does not apply, swing-up does not']}.")
        if c["theorem does not apply, swing-up reaches (68)"]:
            lines.append("Constraint (54) (with E_r > 0) is sufficient for the guarantee, not necessary for a kip: some"
                         " robots outside the theorem still swing up from (65).")
        inside = arrays["theorem1"] & (arrays["outcome"] >= 0) & ~arrays["reached_68"]
        if inside.any():
            stuck = int(np.sum(inside & (arrays["outcome"] == OUTCOMES.index("never switched, stuck at DUU"))))
            lines.append(f"Of the {int(inside.sum())} robots inside the theorem whose swing-up did not reach (68) within"
                         f" {summary['t_final']:g} s, {stuck} sat at DUU: Theorem 1 allows DUU as a limit and only"
                         " promises it is unstable; there its growth rate is as small as"
                         f" {np.nanmin(arrays['duu_growth'][inside]):.2g} /s.")
    if "confusion" in counts:
        lost = (arrays["outcome"] == OUTCOMES.index("switched, no success")) | \
            (arrays["reached_68"] & (arrays["outcome"] == OUTCOMES.index("diverged")))
        if lost.any():
            unstable = int(np.sum(lost & ~arrays["lqr_sampled_stable"]))
            lines.append(f"{int(lost.sum())} robots reached (68) and then lost the balance; on {unstable} of them the"
                         " LQR (67) with the paper's weights is unstable when sampled at the simulation's step"
                         + (", on the others it is stable, so they entered (68) outside the basin of (67) or had"
                            " not settled by the end." if unstable < int(lost.sum()) else "."))
    return lines
