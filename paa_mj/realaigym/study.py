"""RealAIGym's benchmark protocols, run as their code runs them, on any robot of the family and any controller.

Three protocols of ``double_pendulum``'s acrobot leaderboards (dfki-ric-underactuated-lab, commit 1e8544e6):

- ``performance-v2`` (``leaderboard/acrobot/simulation_v2``): one run of 10 s from their start, RK4 at 2 ms,
  scored by :func:`~paa_mj.realaigym.scores.performance` (the RealAI score v2);
- ``robustness-v2`` (``robustness_v2/benchmark_controller.py`` with ``analysis/benchmark.py``): six criteria of
  21 levels: model parameters (rotor inertia I_r in [0, 1e-4] kg m^2; per link the first moment m r, the mass
  (links 2..n), the pivot inertia I = J + m r^2 at 0.75..1.25 times nominal, one at a time, the controller
  keeping the nominal model; per joint viscous damping in [-0.1, 0.1] N m s and Coulomb friction in
  [-0.2, 0.2] N m), velocity noise (sigma 0..0.5 rad/s, 10 runs a level, without a filter: their code's only
  filter is "None"), torque noise (sigma 0..1.1 N m on the motors, 10 runs a level), torque response
  (responsiveness 0.1..2), delay (0..0.04 s of the whole state) and 50 runs with random Gaussian torque
  pulses (3 per joint, widths 0.05..0.1 s, peaks 0.5..5 N m of either sign, at least 1 s apart); a run
  succeeds when its final state is within (0.35 rad, 1 rad/s) of the goal;
- ``global-v3`` (``simulation_v3``, the ICRA 2025 global policy test): 60 s with 15 resets: at a time near
  each of 15 evenly spaced times (+-1 s), a PID with gravity compensation on every joint (all joints driven,
  6 N m each) drives the chain towards a random configuration (angles uniform over a turn) for 0.2 s, the
  controller off; the score is the time up over 60 s.

The physics and disturbances are their simulator's (:mod:`paa_mj.realaigym.simulator`). Their runs draw from
NumPy's global generator unseeded; here each run draws from its own legacy generator
``RandomState([seed, criterion, level, run])`` in their order (the pulses, then 5n normals a step), and
``global-v3`` draws its reset states and times from ``RandomState(seed)`` as their wrapper does after
``np.random.seed(seed)`` (a seed of 777 stands, commented out, in their pendubot script; it is the default).

"Up" (the swing-up time of v2, the time up of v3) is their rule, the tip above 0.9 of its height at the goal,
where the goal holds the tip at its highest; at any other goal (the folded one) it is the goal's pose, every
angle within the task's switch angle of the goal (:func:`~paa_mj.realaigym.conventions.up_rows`).
"""
from __future__ import annotations

import os
from concurrent.futures import ThreadPoolExecutor

import numpy as np

from ..control.base import controller_name, reset_controller, torque_of
from ..errors import PaaError
from ..limits import check_seed
from ..model.robot import Robot
from ..model.similarity import links_ratio, similarity
from . import simulator as protocol
from ..sim.batch import check_engine
from ..sim.compiled.engine import pack
from ..sim.compiled.step import MAX_SPEED
from ..sim.verdict import diverged_words, divergence
from ..task import Task, as_task
from . import scores
from .conventions import DT, hanging, their_angles, their_goal, their_times, up_rows, up_threshold
from ..studies.settings import REALAIGYM_ENGINES as ENGINES, REALAIGYM_PROTOCOLS as PROTOCOLS
from ..studies.store import NOT_RUN, ChunkStore, per_run, runs_done, study_key

#: Their simulation settings (``sim_parameters.py`` of the three leaderboards).
T_FINAL, T_FINAL_GLOBAL = 10.0, 60.0
#: Their hardware's gear ratio (``design_C.1`` model parameters), which the rotor inertia's terms need.
GEAR_RATIO = 6.0
LEVELS = 21
REPETITIONS, PERTURBATION_RUNS = 10, 50
EPSILON = (0.35, 1.0)
RESETS, RESET_LENGTH = 15, 0.2
CHUNK = 32
#: Chunks run at once on a Warp device (a finished batch is kept chunk by chunk).
DEVICE_CHUNKS = 32


def plant(robot: Robot, change=None, *, global_test=False):
    """Their plant's constants for ``robot`` (no damping, friction or rotor inertia, as their protocols set), with
    one ``change`` (name, value) of the model criterion; ``global_test``: every joint driven, each passive one at
    the largest motor limit (their ``mpar_nolim``: [6, 6] for both their acrobot and their pendubot)."""
    p = robot.params
    m, l, lc, J = (np.array(a, float) for a in (p.m, p.l, p.lc, p.J))
    n = len(m)
    pivot = J + m * lc**2
    damping, coulomb, rotor = np.zeros(n), np.zeros(n), 0.0
    limit = np.zeros(n)
    limit[list(p.actuated)] = np.asarray(robot.torque_limits, float)
    if global_test:
        limit[list(p.passive)] = float(np.max(robot.torque_limits))
    if change is not None:
        name, value = change
        i = int(name.lstrip("mrIbcf")[0]) - 1 if name != "Ir" else None
        if name == "Ir":
            rotor = value
        elif name.startswith("m") and "r" in name:
            lc[i] = value / m[i]
        elif name.startswith("m"):
            m[i] = value
        elif name.startswith("I"):
            pivot[i] = value
        elif name.startswith("b"):
            damping[i] = value
        elif name.startswith("cf"):
            coulomb[i] = value
    return protocol.plant_constants(m, l, lc, pivot - m * lc**2, p.g, damping, coulomb, limit, rotor, GEAR_RATIO,
                                    p.actuated)


def model_levels(robot: Robot) -> dict:
    """Their model criterion's levels, per parameter (their ``get_par_list`` and ``linspace``; module docstring)."""
    p = robot.params
    levels = {"Ir": np.linspace(0.0, 1e-4, LEVELS)}
    scale = np.linspace(0.75, 1.25, LEVELS)
    for i in range(p.n_links):
        k = i + 1
        levels[f"m{k}r{k}"] = scale * (p.m[i] * p.lc[i])
        if i > 0:
            levels[f"m{k}"] = scale * p.m[i]
        levels[f"I{k}"] = scale * (p.J[i] + p.m[i] * p.lc[i] ** 2)
        levels[f"b{k}"] = np.linspace(-0.1, 0.1, LEVELS)
        levels[f"cf{k}"] = np.linspace(-0.2, 0.2, LEVELS)
    return levels


def perturbations(rng, n, t_final=T_FINAL, dt=DT, per_joint=3, min_gap=1.0, sigma=(0.05, 0.1), amplitude=(0.5, 5.0)):
    """Their ``get_random_gauss_perturbation_array``, n joints: (n, K) torques [N m] on t = arange(0, t_final, dt).
    Pulses that would not fit at ``min_gap`` apart (more than 2 joints) are brought closer: the gap is at most
    t_final / (pulses + 1)."""
    count = n * per_joint
    gap = min(min_gap, t_final / (count + 1))
    wiggle = (t_final - (count + 1) * gap) / count
    mu = []
    for i in range(count):
        mu.append((gap if i == 0 else mu[-1] + gap) + rng.rand() * wiggle)
    rng.shuffle(mu)
    mu = np.reshape(mu, (n, per_joint))
    widths = sigma[0] + rng.rand(n, per_joint) * (sigma[1] - sigma[0])
    span = amplitude[1] - amplitude[0]
    peaks = rng.uniform(-span, span, size=(n, per_joint))
    peaks += amplitude[0] * np.sign(peaks)
    t = np.arange(0, t_final, dt)
    return np.array([np.sum([peaks[j, i] * np.exp(-np.power(t - mu[j, i], 2.0) / (2 * widths[j, i] ** 2.0))
                             for i in range(per_joint)], axis=0) for j in range(n)])


class Runs:
    """One controller, run again and again under their simulator: compiled when it has a compiled form; with
    ``engine="warp"``, many runs at once on a Warp ``device`` (:mod:`paa_mj.realaigym.simulator_warp`). Starts are in
    paa_mj's angles, the states of a run in theirs (:func:`~paa_mj.realaigym.conventions.their_angles`), as their simulator keeps them."""

    def __init__(self, robot: Robot, controller, engine="cpu", device=None):
        self.robot, self.controller, self.n = robot, controller, robot.params.n_links
        form = controller.compiled() if hasattr(controller, "compiled") else None
        self.packed = None if form is None else pack(form)
        check_engine(engine, device, ENGINES)
        self.engine, self.device = engine, device
        if engine == "warp":
            from ..sim.warp.engine import device_law

            device_law(self.packed, controller_name(controller), "--engine cpu")  # refused before any run

    def disturbances(self, delay=0.0, sigma_meas=None, responsiveness=1.0, sigma_u=None, normals=None,
                     perturbation=None, reset=None):
        """One run's disturbances as the simulator takes them: the delay in steps, the measurement's and the
        motor's sigmas, the responsiveness, the normals (N, 5n), the pulses (n, K) and the reset record (None:
        none of that kind)."""
        n = self.n
        return (int(delay / DT) + 1, np.zeros(2 * n) if sigma_meas is None else np.asarray(sigma_meas, float),
                float(responsiveness), np.zeros(n) if sigma_u is None else np.asarray(sigma_u, float), normals,
                None if perturbation is None else np.ascontiguousarray(perturbation), reset)

    def run(self, P, x0, T, **disturbances):
        """States X (K, 2n) (their angles) and applied torques U (K - 1, n) of one run from ``x0`` (paa_mj's angles)
        on the plant ``P`` over the times T (K,); ``disturbances``: :meth:`disturbances`'s keywords."""
        return self.run_many([(P, x0, disturbances)], T)[0]

    def run_many(self, runs, T, advanced=None):
        """(X, U) of each run of ``runs`` ((P, x0, disturbances) each, as :meth:`run` takes them), all over the
        times T; ``advanced(steps)`` is told of the steps run as they go. Ctrl-C raises KeyboardInterrupt."""
        if not runs:  # every chunk of a study kept already
            return []
        T = np.ascontiguousarray(T, float)
        steps = len(T) - 1
        runs = [(P, their_angles(np.reshape(x0, (1, -1)))[0], d) for P, x0, d in runs]
        if self.engine == "warp":
            return self._run_on_device(runs, T, advanced)
        if self.packed is None:  # a Python controller: one run at a time (it may keep state between calls)
            return [self._told(self._run_one(P, x0, T, *self.disturbances(**d)), advanced, steps) for P, x0, d in runs]
        # compiled rollouts release the GIL: a thread per core, each run on its own arrays, so the same results
        pool = ThreadPoolExecutor(max(1, min(os.cpu_count() or 1, len(runs))))
        try:
            futures = [pool.submit(self._run_one, P, x0, T, *self.disturbances(**d)) for P, x0, d in runs]
            return [self._told(future.result(), advanced, steps) for future in futures]
        finally:  # Ctrl-C: the runs not started are dropped, the running ones end within their few seconds
            pool.shutdown(wait=True, cancel_futures=True)

    @staticmethod
    def _told(result, advanced, steps):
        if advanced is not None:
            advanced(steps)
        return result

    def _run_one(self, P, x0, T, delay_steps, sigma_meas, responsiveness, sigma_u, normals, perturbation, reset):
        n, steps = self.n, len(T) - 1
        X, U = np.full((steps + 1, 2 * n), np.nan), np.full((steps, n), np.nan)
        X[0] = x0
        args = (P, X, U, T, DT, delay_steps, sigma_meas, responsiveness, sigma_u,
                np.zeros((steps, 5 * n)) if normals is None else normals,
                np.zeros((n, 0)) if perturbation is None else perturbation, np.zeros(0) if reset is None else reset)
        if self.packed is not None:
            k = self.packed
            done = protocol.rollout_compiled(k.first, k.second, k.condition, k.params, k.memory.copy(), *args)
        else:
            done = self._run_python(*args)
        return X[:done + 1], U[:done]

    def _run_on_device(self, runs, T, advanced):
        from . import simulator_warp as protocol_warp

        batch = protocol_warp.Rollouts(self.n, T, DT)
        for P, x0, disturbances in runs:
            batch.add(P, x0, *self.disturbances(**disturbances))
        X, U, done, interrupted = protocol_warp.run(batch, self.packed, controller_name(self.controller),
                                                    device=self.device, advanced=advanced)
        if interrupted:
            raise KeyboardInterrupt
        return [(X[r, :d + 1], U[r, :d]) for r, d in enumerate(done)]

    def _run_python(self, P, X, U, T, dt, delay_steps, sigma_meas, responsiveness, sigma_u, normals, perturbation,
                    reset):
        """:func:`~paa_mj.realaigym.simulator.rollout_compiled`'s loop with the controller called from Python."""
        n = self.n
        reset_controller(self.controller)
        A, (work, mass, force) = protocol.inertia_constants(P, n), protocol.scratch(n)
        x_meas, seen, u = np.empty(2 * n), np.empty(2 * n), np.zeros(n)
        resetting, pulses = reset.size > 0, perturbation.shape[1]
        for k in range(U.shape[0]):
            if protocol.measure_or_reset_compiled(A, P, X, k, T, delay_steps, sigma_meas, normals[k], reset, resetting,
                                                  x_meas, seen, u, work):
                tau = torque_of(self.controller, seen[:n], seen[n:], float(T[k]), motors=self.robot.params.n_motors)
                protocol.command(P, u, np.asarray(tau, float))
            if not protocol.advance_compiled(A, P, X, U, k, T, dt, u, responsiveness, sigma_u, normals[k],
                                             perturbation, pulses, work, mass, force):
                return k + 1
        return U.shape[0]


def _saved_rows(T, X, U):
    """Their saved CSV's rows: (t_k, x_k, u_k), k < K - 1 (``save_trajectory`` cuts to the shortest column)."""
    return T[:len(U)], X[:len(U)], U


def robot_norms(robot: Robot) -> dict:
    """Their v2 normalisations carried to ``robot`` by dynamic similarity (:func:`~paa_mj.realaigym.scores.
    scaled_norms`): theirs on their acrobot."""
    model = robot.analytic
    return scores.scaled_norms(*similarity(model), links_ratio(model))


def performance_v2(robot: Robot, controller, task: Task, x0=None, engine="cpu", device=None) -> dict:
    """Their simulation_v2 run and scores (module docstring); ``engine``, ``device``: :class:`Runs`'s."""
    runs = Runs(robot, controller, engine, device)
    T = their_times(T_FINAL)
    X, U = runs.run(plant(robot), hanging(runs.n) if x0 is None else x0, T)
    rows = _saved_rows(T[:len(X)], X, U)
    with np.errstate(all="ignore"):  # a diverged run's costs: said once, as every command says it (below)
        result = scores.performance(*rows, up_rows(robot, task, X[:len(U)]), T_FINAL, robot_norms(robot))
    summary = {"criteria": result, "score": result["score_v2"], "score_robot_scaled": result["score_v2_scaled"],
               "steps": len(U),
               "diverged": _diverged(T[:len(X)], X, U, runs.n),
               **scores.no_action(X, U, robot.analytic.gravity_constants)}
    return summary, dict(zip("TXU", rows))


def _diverged(T, X, U, n):
    """How a run of their simulator diverged, in every command's words (:func:`~paa_mj.sim.verdict.divergence`:
    their simulator runs on past a non-finite torque or a runaway), or None."""
    found = divergence(T, X, U, n)
    return None if found is None else diverged_words(*found)


def global_v3(robot: Robot, controller, task: Task, x0=None, seed=777, engine="cpu", device=None) -> dict:
    """Their simulation_v3 run (the global policy test) and its score (module docstring); ``engine``, ``device``:
    :class:`Runs`'s."""
    runs = Runs(robot, controller, engine, device)
    n = runs.n
    rng = np.random.RandomState(seed)
    targets = rng.uniform(0.0, 2 * np.pi, (10 * RESETS + 1, 2 * n)) - np.pi
    average = T_FINAL_GLOBAL / (RESETS + 1.0)
    times = np.linspace(average, T_FINAL_GLOBAL - average, RESETS) + 2.0 * (rng.rand(RESETS) - 0.5)
    T = their_times(T_FINAL_GLOBAL)
    record = protocol.reset_record(times, targets[:RESETS + 1, :n], RESET_LENGTH)
    X, U = runs.run(plant(robot, global_test=True), hanging(n) if x0 is None else x0, T, reset=record)
    Tr, Xr, _ = _saved_rows(T[:len(X)], X, U)
    up = up_rows(robot, task, X[:len(U)])
    time_up = scores.uptime(Tr, up)
    summary = {"time_up": time_up, "score": time_up / T_FINAL_GLOBAL, "reset_times": times.tolist(),
               "steps": len(U), "diverged": _diverged(T[:len(X)], X, U, n),
               **scores.no_action(X, U, robot.analytic.gravity_constants)}
    return summary, {"T": Tr, "X": Xr, "U": U, "height": scores.tip_height(Xr, robot.params.l), "up": up,
                     "threshold": up_threshold(robot, task)}


def robustness_cases(robot: Robot):
    """Every run of robustness v2, in their order: (criterion, parameter, level index, repetition, value)."""
    cases = []
    for name, values in model_levels(robot).items():
        cases += [("model", name, i, 0, float(v)) for i, v in enumerate(values)]
    for criterion, values, reps in (("measurement_noise", np.linspace(0.0, 0.5, LEVELS), REPETITIONS),
                                    ("u_noise", np.linspace(0.0, 1.1, LEVELS), REPETITIONS),
                                    ("u_responsiveness", np.linspace(0.1, 2.0, LEVELS), 1),
                                    ("delay", np.linspace(0.0, 0.04, LEVELS), 1)):
        cases += [(criterion, criterion, i, r, float(v)) for i, v in enumerate(values) for r in range(reps)]
    cases += [("perturbation", "perturbation", 0, r, 0.0) for r in range(PERTURBATION_RUNS)]
    return cases


def _case_inputs(runs, robot, nominal, case, T, seed):
    """The plant and the disturbances (:meth:`Runs.disturbances`'s keywords) of one run of robustness v2 (``case`` of
    :func:`robustness_cases`); ``nominal``: the robot's plant."""
    criterion, name, level, rep, value = case
    n = runs.n
    code = scores.ROBUSTNESS_CRITERIA.index(criterion)
    rng = np.random.RandomState([seed, code, level, rep])
    motors = (protocol.limits(nominal, n) != 0.0).astype(float)
    if criterion == "model":
        return plant(robot, (name, value)), {}
    if criterion == "perturbation":
        return nominal, {"perturbation": perturbations(rng, n)}
    if criterion == "u_responsiveness":
        return nominal, {"responsiveness": value}
    if criterion == "delay":
        return nominal, {"delay": value}
    normals = rng.standard_normal((len(T) - 1, 5 * n))
    if criterion == "measurement_noise":
        return nominal, {"sigma_meas": np.r_[np.zeros(n), np.full(n, value)], "normals": normals}
    return nominal, {"sigma_u": value * motors, "normals": normals}


def robustness_v2(robot: Robot, controller, task: Task, x0=None, seed=777, *, out_dir=None, fresh=False,
                  progress=True, key_definition=None, engine="cpu", device=None) -> dict:
    """Their robustness_v2 benchmark (module docstring): each run's final state and success, each level's success,
    the six scores and the overall one. Finished chunks are kept in ``out_dir`` (resumable); ``engine``, ``device``:
    :class:`Runs`'s (a Warp device runs :data:`DEVICE_CHUNKS` chunks at once)."""
    from ..progress import progress as bar

    runs = Runs(robot, controller, engine, device)
    n = runs.n
    x0 = hanging(n) if x0 is None else np.asarray(x0, float)
    T = their_times(T_FINAL)
    cases = robustness_cases(robot)
    nominal = plant(robot)
    # a device's rounding is not the CPU's nor another device's: its runs are kept apart (the CPU's key is as it was
    # before the engine)
    on_device = {} if engine == "cpu" else {"engine": engine, "device": device_of(engine, device)}
    key = study_key({"study": "realaigym-robustness-v2", "x0": x0, "seed": seed, "states": "their angles",
                     **(key_definition or {}), **on_device})
    store = ChunkStore(out_dir, key, fresh, "realaigym")
    final, steps = np.full((len(cases), 2 * n), np.nan), np.zeros(len(cases), int)
    chunks = range(0, len(cases), CHUNK)
    per_batch = 1 if runs.engine == "cpu" else DEVICE_CHUNKS
    interrupted = False
    with bar(total=len(cases), desc="robustness-v2 runs", unit="run", enabled=progress) as shown:
        try:
            for first in range(0, len(chunks), per_batch):
                batch = range(first, min(first + per_batch, len(chunks)))
                kept = {index: store.load(index) for index in batch}
                todo = [index for index in batch if kept[index] is None]
                inputs = [_case_inputs(runs, robot, nominal, case, T, seed) for index in todo
                          for case in cases[chunks[index]:chunks[index] + CHUNK]]
                results = iter(runs.run_many([(P, x0, d) for P, d in inputs], T,
                                             advanced=lambda s: shown.update(s / (len(T) - 1))))
                for index in batch:
                    part = slice(chunks[index], chunks[index] + CHUNK)
                    if kept[index] is None:
                        rows = [next(results) for _ in cases[part]]
                        kept[index] = {"final": np.array([X[-1] for X, _ in rows]),
                                       "steps": np.array([len(X) - 1 for X, _ in rows])}
                        store.save(index, kept[index])
                    else:
                        shown.update(len(kept[index]["steps"]))
                    final[part], steps[part] = kept[index]["final"], kept[index]["steps"]
        except KeyboardInterrupt:
            interrupted = True
    return _robustness_summary(robot, task, cases, final, steps, len(T) - 1, interrupted), {}


def _robustness_summary(robot, task, cases, final, steps, n_steps, interrupted):
    """Per criterion and parameter: the levels' values, every run's success and the level's success as their score
    counts it; the six scores and the overall one once every run has finished. A run not run (an interrupted study)
    is null, never false (:func:`~paa_mj.studies.store.per_run`), and so is a level any of whose runs was not run."""
    goal = their_goal(robot, task)  # the final states are in their angles
    finished = steps > 0
    success = per_run([bool(s == n_steps and scores.final_state_success(x, goal, EPSILON))
                       for x, s in zip(final, steps)], finished)
    criteria = {c: {} for c in scores.ROBUSTNESS_CRITERIA}
    for i, (criterion, name, level, rep, value) in enumerate(cases):
        entry = criteria[criterion].setdefault(name, {"values": [], "runs": []})
        if criterion == "perturbation":
            level = rep  # their 50 runs are 50 levels of one run each
        if level == len(entry["runs"]):
            entry["values"].append(value if criterion != "perturbation" else rep)
            entry["runs"].append([])
        entry["runs"][level].append(success[i])
    for criterion, entries in criteria.items():
        for entry in entries.values():
            repeated = criterion in ("measurement_noise", "u_noise")
            entry["success"] = [NOT_RUN if NOT_RUN in runs else
                                bool(scores.level_successes([runs] if repeated else [runs[0]], repeated)[0])
                                for runs in entry["runs"]]
    with np.errstate(invalid="ignore"):
        runaway = ~np.all(np.isfinite(final), axis=1) | (np.max(np.abs(final[:, final.shape[1] // 2:]), axis=1,
                                                                   initial=0.0) > MAX_SPEED)
    result = {"criteria": criteria, **runs_done(finished), "interrupted": interrupted,
              "diverged_runs": int(np.sum(finished & runaway))}
    if finished.all():
        per_criterion = {c: [e["success"] for e in criteria[c].values()] for c in scores.ROBUSTNESS_CRITERIA}
        result["scores"] = scores.robustness_score(per_criterion)
        result["score"] = result["scores"]["overall"]
    return result


def run_protocol(protocol_name: str, robot: Robot, spec, task, x0=None, seed=777, *, out_dir=None, fresh=False,
                 progress=True, engine="cpu", device=None):
    """One protocol (``PROTOCOLS``) for the controller that ``spec`` (a
    :class:`~paa_mj.control.registry.ControllerSpec`) builds, on ``engine`` (:data:`ENGINES`; ``device``: the Warp
    device of ``warp``): the summary and the arrays its files need."""
    if protocol_name not in PROTOCOLS:
        raise PaaError(f"--protocol must be one of {', '.join(PROTOCOLS)}, not {protocol_name!r}")
    check_engine(engine, device, ENGINES)  # before the controller is built
    seed = check_seed(seed, "--seed")  # their legacy generator's range, every seed's (limits.SEED_LIMIT)
    task = as_task(task, robot)
    controller = spec.for_task(task).build(robot)
    n = robot.params.n_links
    x0 = hanging(n) if x0 is None else np.asarray(x0, float)
    if protocol_name in ("performance-v2", "global-v3"):
        try:
            result, arrays = (performance_v2(robot, controller, task, x0, engine, device)
                              if protocol_name == "performance-v2" else
                              global_v3(robot, controller, task, x0, seed, engine, device))
        except KeyboardInterrupt:  # its one run not run, said as every study says a run it did not finish
            result, arrays = {"interrupted": True, **runs_done([False])}, {}
    else:
        definition = {"robot": robot.xml, "controller": spec.short_name, "source": spec.source_digest(),
                      "recipe": repr(spec), "goal": task.name}
        result, arrays = robustness_v2(robot, controller, task, x0, seed, out_dir=out_dir, fresh=fresh,
                                       progress=progress, key_definition=definition, engine=engine, device=device)
    summary = {"protocol": protocol_name, "robot": robot.name, "controller": spec.short_name,
               **task.describe(), **protocol_success(protocol_name, robot, task, result),
               "x0": x0.tolist(), "seed": seed if protocol_name != "performance-v2" else None,
               "their_code": "dfki-ric-underactuated-lab/double_pendulum 1e8544e6", "engine": engine,
               "device": device_of(engine, device), "result": result,
               "interrupted": bool(result.get("interrupted", False)),
               "runs": int(result.get("runs", 1)), "not_run": int(result.get("not_run", 0)),
               "completed_fraction": float(result.get("completed_fraction", 1.0))}
    return summary, arrays


def protocol_success(protocol_name, robot, task, result) -> dict:
    """A protocol's ``success`` and ``success_definition``: their rule, not the task's region (68) and window (the
    summary's ``task`` states the goal their rules measure against)."""
    threshold = up_threshold(robot, task)
    up = (f"the tip above 0.9 of its height at the goal ({threshold:.4g} m)" if threshold is not None else
          "every angle within the task's switch angle of the goal")
    if protocol_name == "performance-v2":
        return {"success": result["criteria"]["success"] if "criteria" in result else NOT_RUN,
                "success_definition": f"their swing-up: {up} from some time before the end of the {T_FINAL:g} s to"
                                      " the end (the score is 0 without it)"}
    if protocol_name == "robustness-v2":
        done = [r for entries in result["criteria"].values() for e in entries.values() for level in e["runs"]
                for r in level if r is not NOT_RUN]
        return {"success": float(np.mean(done)) if done else None,
                "success_definition": f"the share of the runs run whose final state, at {T_FINAL:g} s, has every"
                                      f" angle within {EPSILON[0]:g} rad and every speed within {EPSILON[1]:g} rad/s"
                                      " of the goal (their check_goal_success); a noise level succeeds when more"
                                      " than half its runs do"}
    return {"success": None, "success_definition": f"none: the score is the time up over {T_FINAL_GLOBAL:g} s, up"
                                                   f" meaning {up}"}


def device_of(engine, device):
    """The device a run of ``engine`` ran on: ``cpu`` for the CPU engine, else the Warp device's name."""
    if engine == "cpu":
        return "cpu"
    from ..sim.warp.device import device_name, load_warp

    return device_name(load_warp(mujoco=False)[0], device)


def board(robot: Robot, specs: dict, task, seed=777, progress=False) -> list[dict]:
    """Every protocol for each controller of ``specs`` (label -> ControllerSpec) from hanging: per controller, the
    performance criteria and score v2, the six robustness scores and the overall one, the global test's time up."""
    rows = []
    for label, spec in specs.items():
        row = {"controller": label}
        for name in PROTOCOLS:
            summary, _ = run_protocol(name, robot, spec, task, seed=seed, progress=progress)
            row[name] = summary["result"]
        rows.append(row)
    return rows
