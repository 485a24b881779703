"""When does the kip switch to the LQR? The region (68) along the exact closed loop, and how fragile the answer is.

The paper reports one switch time (about 13.38 s) for Table 1 from (65). This
module computes what stands behind such a number:

- :func:`switch_entries`: the visits of the exact closed loop of (40) alone
  (SciPy's DOP853, rtol 1e-10, continuous-time control) to region (68): when it
  enters, how long it stays, how deep it goes (the smallest margin), and whether
  the LQR (67) started there balances;
- :func:`switch_sensitivity`: the first switch time in MuJoCo (RK4, 1 ms) when
  (65) is perturbed by 1e-9, 1e-6 or 1e-3 rad, over many rollouts;
- :func:`candidate_reading`: where a candidate reading of the paper's switching
  code (:class:`~paa_mj.control.combined.ReadingCondition`) switches, on the exact
  solution and under several integrators.
"""
from __future__ import annotations

import numpy as np

from ..control.combined import CombinedController, ReadingCondition, RegionCondition
from ..control.region import READING_RATIOS, reading_ratios
from ..control.registry import make_controller
from ..model.robot import Robot
from ..task import Task
from ..progress import progress as progress_bar
from ..sim.analytic.engine import exact_field
from ..sim.batch import simulate_batch
from ..sim.rollout import simulate_mujoco

RESOLUTION = 1e-3


def paper_task(robot: Robot) -> Task:
    """The paper's task, every study here is of: the folded goal (UDD) from (65)."""
    return Task.named("folded", robot)


def switch_condition(name, robot):
    """The switching condition ``name``: "region", the paper's (68), or "reading", the candidate reading."""
    return RegionCondition(paper_task(robot)) if name == "region" else ReadingCondition()


def exact_swing_up(robot: Robot, t_final=40.0, rtol=1e-10):
    """The dense solution of (1) closed by (40) alone from (65), as SciPy returns it."""
    from scipy.integrate import solve_ivp

    task = paper_task(robot)
    field = exact_field(robot, make_controller("vcl-only", robot, task=task))
    return solve_ivp(field, (0.0, t_final), task.start, method="DOP853", rtol=rtol, atol=rtol, dense_output=True)


def _margin(condition, times, states):
    return np.asarray(condition.margin(states[:3].T, states[3:].T, times), dtype=float)


def _crossing(condition, dense, lo, hi, inside_at_hi):
    """Bisect the change of side between lo and hi to 1e-12 s."""
    while hi - lo > 1e-12:
        mid = 0.5 * (lo + hi)
        if (_margin(condition, mid, dense(mid)[:, None])[0] < 0) == inside_at_hi:
            hi = mid
        else:
            lo = mid
    return hi


def region_visits(solution, condition, count=5, resolution=RESOLUTION):
    """The first ``count`` visits of the dense ``solution`` to the condition's region.

    Returns a list of (t_enter, t_exit, min_margin, state at entry); the margin is
    sampled every ``resolution`` s, the crossings bisected and the depth refined
    on a 1e-5 s grid.
    """
    t_end = solution.t[-1]
    times = np.append(np.arange(0.0, t_end, resolution), t_end)  # the last partial interval too
    inside = _margin(condition, times, solution.sol(times)) < 0
    entries = np.flatnonzero(inside & ~np.concatenate([[False], inside[:-1]]))  # the first sample of each visit
    visits = []
    for i in entries[:count]:
        # a visit from the start enters at t = 0; the others between their last sample outside and first inside
        t_in = 0.0 if i == 0 else _crossing(condition, solution.sol, times[i - 1], times[i], True)
        left = np.flatnonzero(~inside[i:])
        j = i + left[0] if left.size else None  # the first sample outside after it
        t_out = t_end if j is None else _crossing(condition, solution.sol, times[j - 1], times[j], False)
        fine = np.linspace(t_in, t_out, max(3, int((t_out - t_in) / 1e-5)))
        depth = float(np.min(_margin(condition, fine, solution.sol(fine))))
        visits.append((t_in, t_out, depth, solution.sol(t_in)))
    return visits


def lqr_balances_from(robot: Robot, state, seconds=15.0, rtol=1e-10):
    """Whether the LQR (67), started at ``state``, brings the exact closed loop within the task's balance tolerance
    (1e-3) of UDD."""
    from scipy.integrate import solve_ivp

    task = paper_task(robot)
    field = exact_field(robot, make_controller("lqr", robot, task=task))
    end = solve_ivp(field, (0.0, seconds), state, method="DOP853", rtol=rtol, atol=rtol).y[:, -1]
    return bool(task.balanced(end[:3], end[3:]))


def switch_entries(robot: Robot, count=5, t_final=40.0, condition="region", solution=None):
    """The first ``count`` entries of the exact closed loop of (40) into the region.

    Returns a list of ``{"t_enter", "duration", "min_margin", "lqr_balances"}``; the
    margin is :math:`\\max_i(|x_i| / \\mathrm{limit}_i) - 1`, so -0.4 means the state went 40 % inside the
    region's tightest limit and a value near 0 is a graze.
    """
    solution = solution or exact_swing_up(robot, t_final)
    visits = region_visits(solution, switch_condition(condition, robot), count)
    return [{"t_enter": float(t_in), "duration": float(t_out - t_in), "min_margin": depth,
             "lqr_balances": lqr_balances_from(robot, state)} for t_in, t_out, depth, state in visits]


def _switched_controller(robot, name):
    task = paper_task(robot)
    return CombinedController(make_controller("vcl-only", robot, task=task), make_controller("lqr", robot, task=task),
                              switch_condition(name, robot), name=f"vcl ({name})")


def perturbed_starts(robot, size, n, seed=0):
    """(65) with each angle moved by a uniform random amount in [-size, size] rad."""
    x0 = np.tile(paper_task(robot).start, (n, 1))
    x0[:, :3] += np.random.default_rng([seed, int(round(-np.log10(size) * 100))]).uniform(-size, size, (n, 3))
    return x0


def switch_sensitivity(robot: Robot, sizes=(1e-9, 1e-6, 1e-3), n=200, t_final=40.0, seed=0, condition="region",
                       progress=False):
    """The first switch time in MuJoCo (the robot's integrator, RK4 at 1 ms) from perturbed copies of (65).

    Returns a list of ``{"perturbation", "n", "switched_fraction", "median", "q1", "q3", "times"}``
    (quartiles of the switch times of the rollouts that switched; ``times`` all of them, NaN for never).
    """
    rows = []
    for size in sizes:
        result = simulate_batch(robot, perturbed_starts(robot, size, n, seed), t_final, task=paper_task(robot),
                                controller=_switched_controller(robot, condition), progress=progress)
        times = result.switch_time
        switched = times[np.isfinite(times)]
        quart = np.percentile(switched, [25, 50, 75]) if switched.size else [None] * 3
        rows.append({"perturbation": size, "n": n, "switched_fraction": float(np.mean(np.isfinite(times))),
                     "median": None if quart[1] is None else float(quart[1]),
                     "q1": None if quart[0] is None else float(quart[0]),
                     "q3": None if quart[2] is None else float(quart[2]),
                     "success_fraction": float(np.mean(result.success)),
                     "times": [None if not np.isfinite(t) else float(t) for t in times]})
    return rows


INTEGRATOR_CASES = (("RK4", 1e-3), ("RK4", 5e-4), ("RK4", 1e-4), ("Euler", 1e-3), ("implicitfast", 1e-3))


def candidate_reading(robot: Robot, solution=None, t_final=40.0, cases=INTEGRATOR_CASES, sizes=(1e-9, 1e-6),
                      n=50, seed=0, progress=False):
    """Where the candidate reading of the paper's switch switches, and how fragile that is.

    Returns ``{"t_switch", "duration", "min_margin", "binding", "lqr_balances", "integrators",
    "sensitivity"}``: the exact entry, how long and how deep the exact solution stays in the
    reading's region, which limit stops it going deeper, whether the LQR balances from there,
    the switch time under MuJoCo integrators, and under perturbations of (65).
    """
    solution = solution or exact_swing_up(robot, t_final)
    visits = region_visits(solution, ReadingCondition(), 1)
    out = {"t_switch": None}
    if visits:
        t_in, t_out, depth, state = visits[0]
        mid = np.linspace(t_in, t_out, 2001)
        deepest = mid[int(np.argmin(_margin(ReadingCondition(), mid, solution.sol(mid))))]
        x = solution.sol(deepest)
        ratios = reading_ratios(x[0], x[1], x[2], x[3], x[4], x[5])
        out = {"t_switch": float(t_in), "duration": float(t_out - t_in), "min_margin": depth,
               "binding": READING_RATIOS[int(np.argmax(ratios))], "lqr_balances": lqr_balances_from(robot, state)}
    rows = []
    for integrator, dt in progress_bar(cases, desc="integrators", unit="run", enabled=progress):
        traj = simulate_mujoco(robot, _switched_controller(robot, "reading"), None, 60.0, task=paper_task(robot),
                               dt=dt, integrator=integrator, retire=True, stop_on_divergence=False)
        rows.append({"integrator": integrator, "dt": dt, "switch_time": traj.switch_time, "balanced": traj.balanced()})
    out["integrators"] = rows
    out["sensitivity"] = [{k: v for k, v in row.items() if k != "times"}
                          for row in switch_sensitivity(robot, sizes, n, 60.0, seed, "reading", progress)]
    return out
