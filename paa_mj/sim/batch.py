"""Many closed-loop MuJoCo rollouts at once, any controller, with per-rollout plants and disturbances.

:func:`simulate_batch` turns its arguments into a :class:`~paa_mj.sim.compiled.engine.Plan`
and runs it with :func:`~paa_mj.sim.compiled.engine.run`: compiled controllers at
compiled speed on all cores, others through ``torque`` on the whole batch.
Each rollout may have its own initial state, controller (gains, or the model the
controller believes in), plant (the model MuJoCo simulates), torque limit and
:class:`Disturbances` (measurement and torque noise, control delay, pushes). Every rollout
aims at one :class:`~paa_mj.task.Task` and is judged by it. Memory stays bounded:
per-rollout outcomes, and full trajectories only when ``record=True``. Results
equal :func:`paa_mj.sim.rollout.simulate_mujoco` for the same inputs, bit for
bit (the tests check it).
"""
from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np
from numpy.typing import ArrayLike

from ..control.base import balance_gain_of, check_binding, controller_name
from ..control.registry import ControllerSpec
from ..errors import PaaError
from ..limits import check_memory, check_seed, check_steps
from ..model.params import RobotParams
from ..model.robot import Robot
from ..progress import progress as progress_bar
from ..task import B_LAST_FAR, Task, as_task, entered_times
from .compiled import engine
from .compiled.engine import DIVERGED, FINISHED, RETIRED, RUNNING, STATUS_TEXT, STOPPED, run as run_engine
from .inputs import check_initial_states, check_robot, per_rollout, sample_interval, steps_for
from .integrators import mujoco_model_for
from .compiled.records import SETTING, Run, Settings
from .compiled.retirement import certificate_size, retirement_certificate, warn_unstable_sampling

#: Per-rollout outcome arrays of a :class:`BatchResult`, in the order they are saved.
OUTCOMES = ("x0", "switch_time", "balanced", "final_state", "E_minus_Er_final", "V_final", "max_abs_tau", "diverged",
            "success", "t_end", "status", "t_region", "t_balanced", "int_tau2", "work", "smoothness", "max_speed")


@dataclass(frozen=True)
class Disturbances:
    """What disturbs rollouts, one value for all or one per rollout.

    Attributes
    ----------
    noise_std : (2,) or (N, 2), optional
        Standard deviation of Gaussian measurement noise on q [rad] and qd [rad/s].
    torque_noise : float or (N,), optional
        Standard deviation of Gaussian noise added to each applied torque [N m].
    delay_steps : int or (N,), optional
        Control delay in physics steps (zero torque until the first one arrives).
    pushes : ndarray (N, K, 2 + n), optional
        Gaussian pulses of generalized force (t_center [s], sigma [s], f_1..f_n [N m]).
    seed : int
        Seed of the noise; rollout ``rollout_ids[i]`` draws the same noise wherever it runs.
    rollout_ids : (N,) of int, optional
        The numbers that key each rollout's noise with the seed (default: 0..N-1).
    """

    noise_std: ArrayLike | None = None
    torque_noise: ArrayLike | None = None
    delay_steps: ArrayLike | None = None
    pushes: ArrayLike | None = None
    seed: int = 0
    rollout_ids: ArrayLike | None = None

    def settings(self, n, n_links, torque_limits):
        """The checked :class:`~paa_mj.sim.compiled.records.Settings` of ``n`` rollouts, torque limits (n, m) given
        (retirement left off: :func:`build_plan` adds it)."""
        noise = per_rollout(self.noise_std, n, 2, "measurement noise", 0.0)
        tau_noise = per_rollout(self.torque_noise, n, 1, "torque noise", 0.0)[:, 0]
        delays = per_rollout(self.delay_steps, n, 1, "control delay", 0.0)[:, 0]
        for name, values in (("measurement noise", noise), ("torque noise", tau_noise), ("control delay", delays)):
            if np.any(~np.isfinite(values)) or np.any(values < 0):
                raise PaaError(f"{name} must be finite and >= 0")
        if np.any(delays != np.round(delays)):
            raise PaaError("control delays must be whole numbers of steps")
        check_memory(n * (np.max(delays, initial=0) + 1) * 16.0, "delay lines", "the control delay")
        push = 2 + n_links
        pushes = np.zeros((n, 0, push)) if self.pushes is None else np.ascontiguousarray(self.pushes, dtype=float)
        if pushes.ndim != 3 or pushes.shape[0] != n or pushes.shape[2] != push or not np.all(np.isfinite(pushes)):
            forces = ", ".join(f"f{i + 1}" for i in range(n_links))
            raise PaaError(f"pushes must be a finite (N, K, {push}) array of (t_center, sigma, {forces})")
        ids = np.arange(n, dtype=np.int64) if self.rollout_ids is None else \
            np.asarray(self.rollout_ids, dtype=np.int64).reshape(-1)
        if ids.shape != (n,) or np.any(ids < 0):
            raise PaaError(f"rollout_ids must be {n} whole numbers >= 0, one per rollout, got shape {ids.shape}")
        check_seed(self.seed, "seed")
        rollouts = np.zeros(n, SETTING)
        rollouts["noise_q"], rollouts["noise_qd"] = noise[:, 0], noise[:, 1]
        rollouts["torque_noise"], rollouts["delay"], rollouts["id"] = tau_noise, delays.astype(np.int64), ids
        rollouts["push_end"] = np.max(pushes[:, :, 0] + 4 * pushes[:, :, 1], axis=1, initial=-np.inf) \
            if pushes.shape[1] else -np.inf
        return Settings(rollouts, torque_limits, np.zeros((n, certificate_size(n_links))), pushes)

    def disturbed(self, settings) -> np.ndarray:
        """Which rollouts are disturbed by noise or delay (the retirement bound does not hold for them)."""
        r = settings.rollouts
        return (r["noise_q"] > 0) | (r["noise_qd"] > 0) | (r["torque_noise"] > 0) | (r["delay"] > 0)


NO_DISTURBANCES = Disturbances()

#: The engines of :func:`simulate_batch` (``--engine``): MuJoCo on the CPU, MuJoCo Warp on a device.
ENGINES = ("mujoco", "warp")


def check_engine(engine, device=None, engines=ENGINES):
    """``engine`` is one of ``engines`` (default :data:`ENGINES`; ``device`` goes with ``warp`` only), or a one-line
    error."""
    if engine not in engines:
        raise PaaError(f"engine must be one of {', '.join(engines)}, got {engine!r}")
    if device is not None and engine != "warp":
        raise PaaError("a Warp device is chosen for engine warp only")


@dataclass
class BatchResult:
    """Per-rollout outcomes of :func:`simulate_batch` (arrays over the batch, length N).

    Attributes
    ----------
    switch_time : first switch to the balance controller (mode 1) [s], NaN if never.
    balanced : final state within the task's balance tolerance of its goal, not diverged.
    final_state : the last good state [q, qd]; for a retired rollout, its state at retirement.
    E_minus_Er_final, V_final : E - E_r [J] and V of (34) [J^2] there (V: NaN without an energy controller).
    max_abs_tau : peak :math:`|\\tau_2|, \\dots, |\\tau_n|` [N m] (for the gymnast :math:`|\\tau_2|, |\\tau_3|`).
    diverged : stopped for a non-finite or runaway state, a non-finite torque or a MuJoCo warning.
    success : the task's success (:attr:`~paa_mj.task.Task.success_definition`; the controller's mode plays no part).
    t_end : when the rollout stopped [s] (t_final, retirement, or the last good state).
    status : engine status code (:data:`~paa_mj.sim.compiled.step.STATUS_TEXT`).
    t_region : first entry of the true state into region (68) [s], NaN if never.
    t_balanced : from when on the state stayed within the balance tolerance of the goal [s], NaN if not balanced.
    int_tau2 : integral of :math:`|\\tau|^2` dt [N^2 m^2 s]; work : integral of :math:`|\\tau \\cdot \\dot q_a|` dt [J].
    smoothness : RMS of the torque change per second [N m/s]; max_speed : peak :math:`|\\dot q_i|` [rad/s].
    task : Task
        What the rollouts aimed at and were judged by.
    """

    x0: np.ndarray
    switch_time: np.ndarray
    balanced: np.ndarray
    final_state: np.ndarray
    E_minus_Er_final: np.ndarray
    V_final: np.ndarray
    max_abs_tau: np.ndarray
    diverged: np.ndarray
    success: np.ndarray
    t_end: np.ndarray
    status: np.ndarray
    t_region: np.ndarray
    t_balanced: np.ndarray
    int_tau2: np.ndarray
    work: np.ndarray
    smoothness: np.ndarray
    max_speed: np.ndarray
    t_reached: float
    task: Task | None = None
    interrupted: bool = False
    trajectories: dict | None = None
    meta: dict = field(default_factory=dict)

    def __len__(self):
        return len(self.x0)

    def arrays(self):
        return {n: getattr(self, n) for n in OUTCOMES}


def controllers_for(robot: Robot, controller, n, task: Task, progress: bool = False) -> list:
    """One controller object per rollout from a name, a spec, a controller or a list of those (names, and specs
    without a task, are built for ``task``), each distinct one built once (``progress``: counted on stderr, as
    building one may plan a kip)."""
    items = controller if isinstance(controller, (list, tuple)) else [controller] * n
    if len(items) != n:
        raise PaaError(f"need one controller per rollout ({n}), got {len(items)}")
    # each distinct object keyed once: a million rollouts of one spec hash its task once, not a million times
    first = {}
    for item in items:
        first.setdefault(id(item), item)
    key_of = {i: item if isinstance(item, (str, ControllerSpec)) else i for i, item in first.items()}
    distinct = {}
    for i, key in key_of.items():
        distinct.setdefault(key, first[i])  # each key's first item, in the order of first use
    built = {}
    for key in progress_bar(list(distinct), desc="building the controllers", unit="controller",
                            enabled=progress and len(distinct) > 1):
        spec = ControllerSpec(distinct[key], task=task) if isinstance(distinct[key], str) else distinct[key]
        if isinstance(spec, ControllerSpec) and spec.task is None:
            spec = spec.for_task(task)
        built[key] = spec.build(robot) if isinstance(spec, ControllerSpec) else spec
    built_of = {i: built[key] for i, key in key_of.items()}
    return [built_of[id(item)] for item in items]


def build_plan(robot: Robot, task: Task, x0, t_final, controllers, *, dt=None, integrator=None, plants=None,
               torque_limit=None, disturbances=NO_DISTURBANCES, every=0, retire=True) -> engine.Plan:
    """An engine plan for these rollouts (checked; see :func:`simulate_batch`): every controller is checked against
    the robot and task first (:func:`~paa_mj.control.base.check_binding`)."""
    for controller in {id(c): c for c in controllers}.values():
        check_binding(controller, robot, task)
    n = len(x0)
    links = robot.params.n_links
    base = mujoco_model_for(robot, dt, integrator)
    dt = float(base.opt.timestep)
    n_steps = steps_for(t_final, dt)
    check_steps(float(n) * n_steps, f"{n} rollout(s) of {t_final:g} s at dt = {dt:g} s",
                "the final time (--t-final) or the number of rollouts, or raise the time step (--dt)", links=links,
                runs=n)
    if every:
        check_memory(n * (n_steps // every + 2) * 80.0, "recorded samples", "--t-final or raise --sample-dt")
    models, model_index, plant_robots = _plants(robot, base, plants, n)
    groups = _groups(model_index, controllers)  # each gain held on its own plant
    warn_unstable_sampling([(plant_robots[plant].analytic, controllers[rows[0]]) for (plant, _), rows in groups.items()],
                           dt, task, robot.name)
    limits = per_rollout(torque_limit, n, robot.params.n_motors, "torque limit", np.inf)
    if np.any(~(limits > 0)):
        raise PaaError("torque limits must be > 0")
    if not isinstance(disturbances, Disturbances):
        raise PaaError(f"disturbances must be a Disturbances (or None), got {type(disturbances).__name__}")
    settings = disturbances.settings(n, links, robot.capped_torque_limits(limits, rollouts=n))
    disturbed = disturbances.disturbed(settings)
    # one certificate per distinct (plant, controller): a study's million rollouts share a handful
    for (plant, _), rows in groups.items():
        gain = balance_gain_of(controllers[rows[0]]) if retire else None
        certificate, level = retirement_certificate(plant_robots[plant].analytic, gain, dt, task)
        rows = rows[~disturbed[rows]]
        settings.cert[rows], settings.rollouts["retire_level"][rows] = certificate, level
    run = Run(dt, n_steps, int(every), bool(retire), int(disturbances.seed), task.params,
              np.asarray(robot.params.actuated, float))
    return engine.Plan(robot=robot, task=task, models=models, model_index=model_index, x0=x0, settings=settings,
                       run=run)


def _groups(plant_index, controllers) -> dict:
    """The rollouts (indices) of each distinct (plant index, controller object), in the order of first use."""
    groups = {}
    for r, key in enumerate(zip(np.asarray(plant_index).tolist(), map(id, controllers))):
        groups.setdefault(key, []).append(r)
    return {key: np.asarray(rows, np.int64) for key, rows in groups.items()}


def _plants(robot, base, plants, n):
    """Distinct plant models (time step and integrator of ``base``), which one each rollout uses, their robots."""
    if plants is None:
        return [base], np.zeros(n, np.int64), [robot]
    if len(plants) != n:
        raise PaaError(f"plants needs one entry per rollout ({n}), got {len(plants)}")
    models, robots, index, seen = [], [], np.empty(n, np.int64), {}
    for r, params in enumerate(plants):
        if params is not None and not isinstance(params, RobotParams):
            raise PaaError(f"plants must hold RobotParams (or None for the nominal robot), got {type(params).__name__}"
                           f" at {r}")
        key = None if params is None else params.key()
        if key not in seen:
            plant = robot if params is None else robot.with_params(params)
            model = base if params is None else plant.model.__copy__()
            model.opt.timestep, model.opt.integrator = base.opt.timestep, base.opt.integrator
            seen[key] = len(models)
            models.append(model)
            robots.append(plant)
        index[r] = seen[key]
    return models, index, robots


def outcome_arrays(plan: engine.Plan, outcome: engine.Outcome, controllers, plant_analytics) -> dict:
    """The per-rollout outcomes (:data:`OUTCOMES`) of an engine run."""
    state, dt, task = outcome.state, plan.dt, plan.task
    links = plan.n_links
    rollouts = state.rollouts
    status = rollouts["status"].copy()
    final = state.last_state.copy()
    diverged = np.isin(status, DIVERGED)
    ended = np.isin(status, (FINISHED, RETIRED))
    balanced = task.balanced(final[:, :links], final[:, links:]) & ended
    steps = rollouts["step"].copy()
    switch = np.where(rollouts["switch"] >= 0, rollouts["switch"] * dt, np.nan)
    region = entered_times(state.book, dt)
    t_balanced = np.where(balanced, (state.book[:, B_LAST_FAR] + 1) * dt, np.nan)
    e_err, V = np.empty(len(final)), np.empty(len(final))
    for rows in _groups(plan.model_index, controllers).values():
        am = plant_analytics[rows[0]]
        q, qd = final[rows, :links], final[rows, links:]
        e_err[rows] = am.energy(q, qd) - task.goal_energy(am)
        V[rows] = _lyapunov(controllers[rows[0]], am, q, qd)
    return {
        "x0": plan.x0.copy(), "switch_time": switch, "balanced": balanced, "final_state": final,
        "E_minus_Er_final": e_err, "V_final": V, "max_abs_tau": state.peak.copy(), "diverged": diverged,
        "success": task.succeeded(state.book, np.where(status == RETIRED, plan.n_steps, steps), status == FINISHED,
                                  status == RETIRED, dt) & ~diverged,
        "t_end": steps * dt, "status": status, "t_region": region, "t_balanced": t_balanced,
        "int_tau2": rollouts["effort"].copy(), "work": rollouts["work"].copy(),
        "smoothness": np.sqrt(rollouts["smooth"] / np.maximum(steps, 1)), "max_speed": rollouts["speed"].copy(),
    }


def _lyapunov(controller, plant, q, qd):
    """V of (34) / (12) with the controller's gains on the plant's model, NaN without an energy controller."""
    from ..control.energy import EnergyVCLController

    swing = getattr(controller, "first", controller)
    if not isinstance(swing, EnergyVCLController):
        return np.full(np.shape(q)[:-1], np.nan)
    return type(swing)(plant, swing.kD, swing.kP, swing.kV, check=False, task=swing.task).lyapunov(q, qd)


def simulate_batch(robot: Robot, x0: ArrayLike, t_final: float | None = None, *, task: Task | str | None = None,
                   controller="vcl", dt: float | None = None, integrator: str | None = None,
                   plants: list | None = None, torque_limit: ArrayLike | None = None,
                   disturbances: Disturbances | None = None, record: bool = False, sample_dt: float = 0.01,
                   retire: bool = True, nthread: int | None = None, progress: bool = False, engine: str = "mujoco",
                   device: str | None = None, partial: bool = False) -> BatchResult:
    """Closed-loop rollouts of N initial states at once.

    Parameters
    ----------
    robot : Robot
        The nominal robot: default plant, and what controllers are built for.
    x0 : array_like (N, 2n)
        Initial states [q, qd] [rad, rad/s] ([q1, q2, q3, d1, d2, d3] for the gymnast).
    t_final : float, optional
        Duration [s]; default the task's horizon.
    task : Task or str, optional
        What the rollouts aim at and are judged by (:mod:`paa_mj.task`): controllers named here are built for it,
        a controller built for another is refused; default the paper's folded task.
    controller : str, ControllerSpec, controller, or a list of those (one per rollout)
        Default ``"vcl"``, the paper's controller with the robot's stored gains.
    dt, integrator : optional
        Physics time step [s] and integrator; default: the robot model's (RK4, 1 ms).
    plants : list of RobotParams or None, optional
        Per rollout, the robot MuJoCo simulates (None: the nominal robot).
    torque_limit : float, (m,), (N,) or (N, m), optional
        Saturation of each torque [N m] (also capped by the model's actuator ranges).
    disturbances : Disturbances, optional
        Noise, delay and pushes, and the seed of the noise (default: none).
    record : bool
        Keep full trajectories (t, q, qd, tau, mode every ``sample_dt``).
    retire : bool
        Stop each rollout once its balance can no longer fail (:mod:`paa_mj.sim.compiled.retirement`).
    nthread : int, optional
        Threads for compiled controllers (default: all cores).
    engine : "mujoco" or "warp"
        ``mujoco``: MuJoCo's ``mj_step`` and the compiled controllers on the CPU's cores (:mod:`paa_mj.sim.compiled.engine`);
        ``warp``: every rollout a world of MuJoCo Warp, the controller on the device too
        (:mod:`paa_mj.sim.warp.engine`, ``pip install "paa_mj[gpu]"``; float32, what it runs is listed there).
    device : str, optional
        The Warp device of ``engine="warp"`` (``cpu``, ``cuda:0``; default ``$PAA_MJ_WARP_DEVICE`` or the first GPU).
    partial : bool
        After Ctrl-C or SIGTERM, return what finished with ``interrupted`` set (a study that keeps it and resumes);
        by default the interruption is raised again (``KeyboardInterrupt``), so that no caller can take a batch cut
        short for a whole one.
    """
    check_engine(engine, device)
    check_robot(robot)
    task = as_task(task, robot)
    t_final = task.horizon if t_final is None else t_final
    x0 = check_initial_states(x0, robot.params.n_links)
    n = len(x0)
    controllers = controllers_for(robot, controller, n, task, progress)
    base_dt = float(mujoco_model_for(robot, dt, integrator).opt.timestep)
    every = sample_interval(sample_dt, base_dt, t_final) if record else 0
    plan = build_plan(robot, task, x0, t_final, controllers, dt=dt, integrator=integrator, plants=plants,
                      torque_limit=torque_limit, disturbances=disturbances or NO_DISTURBANCES, every=every,
                      retire=retire)
    if engine == "warp":
        from .warp import engine as warp_engine

        outcome = warp_engine.run(plan, controllers, device=device, progress=progress, desc=f"{n} rollouts")
    else:
        outcome = run_engine(plan, controllers, nthread=nthread, progress=progress, desc=f"{n} rollouts")
    if outcome.interrupted and not partial:
        raise KeyboardInterrupt
    plant_analytics = [robot.analytic if plants is None or plants[r] is None else None for r in range(n)]
    if plants is not None:
        from ..model.dynamics import AnalyticModel

        plant_analytics = [robot.analytic if p is None else AnalyticModel.from_params(p) for p in plants]
    out = outcome_arrays(plan, outcome, controllers, plant_analytics)
    completed = ~np.isin(out["status"], (STOPPED, RUNNING))
    trajectories = None
    if record:
        trajectories = {k: v for k, v in outcome.samples.items()}
    return BatchResult(**out, t_reached=float(np.max(out["t_end"][completed], initial=0.0)), task=task,
                       interrupted=outcome.interrupted, trajectories=trajectories,
                       meta={"robot": robot.name, "dt": plan.dt, "t_final": float(t_final), "n_steps": plan.n_steps,
                             "status_text": STATUS_TEXT, "completed": completed, "engine": engine,
                             **({"device": outcome.meta["device"]} if "device" in outcome.meta else {})})


def kip_peak_torques(robot: Robot, controller, task: Task, torque_limit=None, t_final: float | None = None) \
        -> np.ndarray:
    """Peak torques :math:`|\\tau_2|, \\dots, |\\tau_n|` [N m] of a controller's run from the task's start ((65)
    for the gymnast's kip), over every step: the scale of torque limits and torque noise."""
    result = simulate_batch(robot, task.start[None], t_final, task=task, controller=controller,
                            torque_limit=torque_limit, retire=False)
    if result.diverged[0]:
        name = controller if isinstance(controller, str) else getattr(controller, "short_name", None) or \
            controller_name(controller)
        raise PaaError(f"the run of {name} from the {task.name} task's start diverged at t = {result.t_end[0]:.3f} s"
                       f" ({STATUS_TEXT[int(result.status[0])]}), so its peak torques are no scale for a"
                       " torque limit (give one)")
    return result.max_abs_tau[0]
