"""Many closed-loop MuJoCo rollouts at once, any controller, with per-rollout plants and disturbances.

:func:`simulate_batch` turns its arguments into a :class:`~paa_mj.sim.engine.Plan`
and runs it with :func:`~paa_mj.sim.engine.run`: compiled controllers at
compiled speed on all cores, others through ``torque`` on the whole batch.
Each rollout may have its own initial state, controller (gains, or the model the
controller believes in), plant (the model MuJoCo simulates), torque limit,
measurement and torque noise, control delay and pushes. Memory stays bounded:
per-rollout outcomes, and full trajectories only when ``record=True``. Results
equal :func:`paa_mj.sim.rollout.simulate_mujoco` for the same inputs, bit for
bit (the tests check it).
"""
from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np
from numpy.typing import ArrayLike

from ..control.region import BALANCE_TOL, succeeded
from ..control.registry import ControllerSpec
from ..errors import PaaError
from ..limits import check_memory, check_seed, check_steps, positive_finite
from ..model.params import RobotParams
from ..model.robot import Robot
from ..model.states import MAX_INITIAL_ANGLE, MAX_INITIAL_SPEED, goal_angles, goal_error, start_state
from . import engine
from .engine import (DIVERGED, F_INT_TAU2, F_SMOOTH, F_SPEED, F_WORK, I_LEFT_GOAL, I_OUTSIDE, I_REGION, I_STATUS,
                     I_STEP, I_SWITCH, RETIRED, FINISHED, S_DELAY, S_LEVEL, S_NOISE_Q, S_PUSH_END, S_TAU_NOISE,
                     STATUS_TEXT, fstate_layout, push_width, setup_layout)
from .integrators import mujoco_model_for
from .retirement import certificate_size, retirement_certificate

#: Per-rollout outcome arrays of a :class:`BatchResult`, in the order they are saved.
OUTCOMES = ("x0", "switch_time", "balanced", "final_state", "E_minus_Er_final", "V_final", "max_abs_tau", "diverged",
            "success", "t_end", "status", "t_region", "t_balanced", "int_tau2", "work", "smoothness", "max_speed")


@dataclass
class BatchResult:
    """Per-rollout outcomes of :func:`simulate_batch` (arrays over the batch, length N).

    Attributes
    ----------
    switch_time : first switch to the balance controller (mode 1) [s], NaN if never.
    balanced : final state within :data:`~paa_mj.control.region.BALANCE_TOL` of the goal (UDD), not diverged.
    final_state : the last good state [q, qd]; for a retired rollout, its state at retirement.
    E_minus_Er_final, V_final : E - E_r [J] and V of (34) [J^2] there (V: NaN without an energy controller).
    max_abs_tau : peak :math:`|\\tau_2|, \\dots, |\\tau_n|` [N m] (for the gymnast :math:`|\\tau_2|, |\\tau_3|`).
    diverged : stopped for a non-finite or runaway state, a non-finite torque or a MuJoCo warning.
    success : :data:`~paa_mj.control.region.SUCCESS_DEFINITION`: no divergence and the true state inside region (68)
        over the last second (the one success test of every study; the controller's mode plays no part).
    t_end : when the rollout stopped [s] (t_final, retirement, or the last good state).
    status : engine status code (:data:`~paa_mj.sim.engine.STATUS_TEXT`).
    t_region : first entry of the true state into region (68) [s], NaN if never.
    t_balanced : from when on the state stayed within BALANCE_TOL of UDD [s], NaN if not balanced.
    int_tau2 : integral of :math:`|\\tau|^2` dt [N^2 m^2 s]; work : integral of :math:`|\\tau \\cdot \\dot q_a|` dt [J].
    smoothness : RMS of the torque change per second [N m/s]; max_speed : peak :math:`|\\dot q_i|` [rad/s].
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
    interrupted: bool = False
    trajectories: dict | None = None
    meta: dict = field(default_factory=dict)

    def __len__(self):
        return len(self.x0)

    def arrays(self):
        return {n: getattr(self, n) for n in OUTCOMES}


def _rows(value, n, width, name, default):
    """``value`` as an (n, width) float array: None, a scalar, one value per component (width,), one per
    rollout (n,), or (n, width). With width > 1, a vector of ``width`` values is per component."""
    if value is None:
        return np.full((n, width), default, dtype=float)
    arr = np.asarray(value, dtype=float)
    if arr.ndim == 0:
        arr = np.full((n, width), float(arr))
    elif arr.ndim == 1 and width > 1 and arr.size == width:
        arr = np.broadcast_to(arr, (n, width))
    elif arr.ndim == 1 and arr.size == n:
        arr = np.repeat(arr[:, None], width, axis=1)
    if arr.shape != (n, width):
        raise PaaError(f"{name} must have {width} value(s) per rollout, got shape {np.shape(value)} for {n} rollouts")
    if np.any(np.isnan(arr)):
        raise PaaError(f"{name} must not be NaN")
    return np.ascontiguousarray(arr)


def _state_names(n_links):
    return " ".join([f"q{i + 1}" for i in range(n_links)] + [f"d{i + 1}" for i in range(n_links)])


def _as_floats(x0, what, n_links):
    try:
        return np.asarray(x0, dtype=float)
    except (TypeError, ValueError):
        raise PaaError(f"{what} must be numbers ({_state_names(n_links)}), got {x0!r:.60}") from None


def check_initial_states(x0, n_links=3) -> np.ndarray:
    """x0 as a finite (N, 2n) array for a chain of ``n_links`` links, or a one-line error."""
    x0 = np.atleast_2d(_as_floats(x0, "initial states", n_links))
    width = 2 * n_links
    if x0.ndim != 2 or x0.shape[1] != width or len(x0) == 0:
        raise PaaError(f"initial states must be an (N, {width}) array of {_state_names(n_links)}, got shape"
                       f" {x0.shape}")
    if not np.all(np.isfinite(x0)):
        raise PaaError("initial states must be finite")
    _check_initial_magnitudes(x0)
    return x0


def check_initial_state(x0, n_links=3) -> np.ndarray:
    """One initial state as a finite (1, 2n) array for a chain of ``n_links`` links, or a one-line error."""
    x0 = _as_floats(x0, "initial state", n_links).reshape(-1)
    if x0.size != 2 * n_links:
        raise PaaError(f"initial state needs {2 * n_links} numbers ({_state_names(n_links)}), got {x0.size}")
    if not np.all(np.isfinite(x0)):
        raise PaaError(f"initial state must be finite, got {x0.tolist()}")
    _check_initial_magnitudes(x0[None])
    return x0[None]


def _check_initial_magnitudes(x0):
    n = x0.shape[1] // 2
    farthest = float(np.max(np.abs(x0[:, :n])))
    if farthest > MAX_INITIAL_ANGLE:
        raise PaaError(f"initial angle {farthest:g} rad is beyond {MAX_INITIAL_ANGLE:g} rad: give it wrapped to"
                       " (-pi, pi]")
    fastest = float(np.max(np.abs(x0[:, n:])))
    if fastest > MAX_INITIAL_SPEED:
        raise PaaError(f"initial joint speed {fastest:g} rad/s is above {MAX_INITIAL_SPEED:g} rad/s, faster than any"
                       " gymnast or robot of this model turns")


def steps_for(t_final, dt):
    """The number of steps of a run of ``t_final`` seconds at ``dt``, checked against the time budget."""
    t_final = positive_finite("final time", t_final, allow_none=False)
    if not t_final / dt < 1e15:  # past this no run could finish: say so before counting the steps
        raise PaaError(f"final time {t_final:g} s is too long: it would need about {t_final / dt:.3g} physics steps"
                       f" of {dt:g} s; lower --t-final")
    n_steps = int(round(t_final / dt))
    if n_steps < 1:
        raise PaaError(f"final time {t_final:g} s is shorter than one time step ({dt:g} s)")
    return n_steps


def sample_interval(sample_dt, dt, t_final):
    """Steps between two recorded samples: the interval must not exceed the run, and must be a whole number of
    time steps (an interval shorter than one step records every step)."""
    t_final = positive_finite("final time", t_final, allow_none=False)
    sample_dt = positive_finite("sample interval", sample_dt, allow_none=False)
    if sample_dt > t_final:
        raise PaaError(f"sample interval {sample_dt:g} s is longer than the run ({t_final:g} s): lower --sample-dt")
    steps = sample_dt / dt
    if steps < 1:  # finer than the time step: every step is recorded (the trajectory's sample_dt says so)
        return 1
    if abs(steps - round(steps)) > 1e-9 * steps:
        raise PaaError(f"sample interval {sample_dt:g} s is not a whole number of time steps (dt = {dt:g} s):"
                       " give a multiple of the time step")
    return int(round(steps))


def check_robot(robot):
    """A :class:`~paa_mj.model.robot.Robot` of :func:`~paa_mj.model.load_robot`, or a one-line error."""
    if not isinstance(robot, Robot):
        raise PaaError(f"controllers are built for a robot of load_robot(), got {type(robot).__name__}")


def controllers_for(robot: Robot, controller, n, goal="folded") -> list:
    """One controller object per rollout from a name, a spec, a controller or a list of those (names are built
    for ``goal``)."""
    items = controller if isinstance(controller, (list, tuple)) else [controller] * n
    if len(items) != n:
        raise PaaError(f"need one controller per rollout ({n}), got {len(items)}")
    built, out = {}, []
    for item in items:
        key = item if isinstance(item, (str, ControllerSpec)) else id(item)
        if key not in built:
            spec = ControllerSpec(item, goal=goal) if isinstance(item, str) else item
            built[key] = spec.build(robot) if isinstance(spec, ControllerSpec) else spec
        out.append(built[key])
    return out


def build_plan(robot: Robot, x0, t_final, controllers, dt=None, integrator=None, plants=None, torque_limit=None,
               noise_std=None, torque_noise=None, delay_steps=None, pushes=None, seed=0, rollout_ids=None, every=0,
               retire=True, goal="folded") -> engine.Plan:
    """An engine plan for these rollouts (checked; see :func:`simulate_batch`)."""
    n = len(x0)
    links = robot.params.n_links
    nu = links - 1
    s_limits, s_goal, width = setup_layout(links)
    base = mujoco_model_for(robot, dt, integrator)
    dt = float(base.opt.timestep)
    n_steps = steps_for(t_final, dt)
    check_steps(float(n) * n_steps, f"{n} rollout(s) of {t_final:g} s at dt = {dt:g} s", "--t-final or the number of rollouts, or raise --dt")
    if every:
        check_memory(n * (n_steps // every + 2) * 80.0, "recorded samples", "--t-final or raise --sample-dt")
    models, model_index, plant_robots = _plants(robot, base, plants, n)
    setup = np.zeros((n, width))
    limits = _rows(torque_limit, n, nu, "torque limit", np.inf)
    if np.any(~(limits > 0)):
        raise PaaError("torque limits must be > 0")
    setup[:, s_limits:s_limits + nu] = np.minimum(limits, robot.torque_limits)
    setup[:, s_goal:s_goal + links] = goal_angles(goal, links)
    noise = _rows(noise_std, n, 2, "measurement noise", 0.0)
    tau_noise = _rows(torque_noise, n, 1, "torque noise", 0.0)[:, 0]
    delays = _rows(delay_steps, n, 1, "control delay", 0.0)[:, 0]
    for name, values in (("measurement noise", noise), ("torque noise", tau_noise), ("control delay", delays)):
        if np.any(~np.isfinite(values)) or np.any(values < 0):
            raise PaaError(f"{name} must be finite and >= 0")
    if np.any(delays != np.round(delays)):
        raise PaaError("control delays must be whole numbers of steps")
    check_memory(n * (np.max(delays, initial=0) + 1) * 16.0, "delay lines", "the control delay")
    setup[:, S_NOISE_Q:S_NOISE_Q + 2] = noise
    setup[:, S_TAU_NOISE] = tau_noise
    setup[:, S_DELAY] = delays
    push = push_width(links)
    pushes = np.zeros((n, 0, push)) if pushes is None else np.ascontiguousarray(pushes, dtype=float)
    if pushes.ndim != 3 or pushes.shape[0] != n or pushes.shape[2] != push or not np.all(np.isfinite(pushes)):
        forces = ", ".join(f"f{i + 1}" for i in range(links))
        raise PaaError(f"pushes must be a finite (N, K, {push}) array of (t_center, sigma, {forces})")
    setup[:, S_PUSH_END] = np.max(pushes[:, :, 0] + 4 * pushes[:, :, 1], axis=1, initial=-np.inf) \
        if pushes.shape[1] else -np.inf
    cert = np.zeros((n, certificate_size(links)))
    certificates = {}
    disturbed = (noise.any(axis=1)) | (tau_noise > 0) | (delays > 0)
    for r in range(n):
        form = getattr(controllers[r], "compiled", lambda: None)() if retire else None
        gain = None if form is None else form.balance_gain
        key = (model_index[r], id(controllers[r]))
        if key not in certificates:
            certificates[key] = retirement_certificate(plant_robots[model_index[r]].analytic, gain, dt, goal)
        if not disturbed[r]:
            cert[r], setup[r, S_LEVEL] = certificates[key]
    ids = np.arange(n, dtype=np.int64) if rollout_ids is None else np.asarray(rollout_ids, dtype=np.int64).reshape(-1)
    if ids.shape != (n,) or np.any(ids < 0):
        raise PaaError(f"rollout_ids must be {n} whole numbers >= 0, one per rollout, got shape {ids.shape}")
    check_seed(seed, "seed")
    return engine.Plan(models=models, model_index=model_index, x0=np.ascontiguousarray(x0), setup=setup, cert=cert,
                       pushes=pushes, rollout_ids=ids, seed=int(seed), dt=dt, n_steps=n_steps, every=int(every),
                       retire=bool(retire), goal=goal)


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
    ist, fst, dt = outcome.istate, outcome.fstate, plan.dt
    links = plan.n_links
    f_peak, _, f_last, _ = fstate_layout(links)
    _, s_goal, _ = setup_layout(links)
    goal = plan.setup[:, s_goal:s_goal + links]
    status = ist[:, I_STATUS].copy()
    final = fst[:, f_last:f_last + 2 * links].copy()
    diverged = np.isin(status, DIVERGED)
    ended = np.isin(status, (FINISHED, RETIRED))
    distance = np.max(np.abs(goal_error(final[:, :links], final[:, links:], goal)), axis=1)
    balanced = (distance < BALANCE_TOL) & ended
    steps = ist[:, I_STEP]
    switch = np.where(ist[:, I_SWITCH] >= 0, ist[:, I_SWITCH] * dt, np.nan)
    region = np.where(ist[:, I_REGION] >= 0, ist[:, I_REGION] * dt, np.nan)
    t_balanced = np.where(balanced, (ist[:, I_OUTSIDE] + 1) * dt, np.nan)
    e_err, V = np.empty(len(final)), np.empty(len(final))
    for r, (am, ctrl) in enumerate(zip(plant_analytics, controllers)):
        q, qd = final[r, :links], final[r, links:]
        e_err[r] = am.energy(q, qd) - am.goal_energy(plan.goal)
        V[r] = _lyapunov(ctrl, am, q, qd)
    return {
        "x0": plan.x0.copy(), "switch_time": switch, "balanced": balanced, "final_state": final,
        "E_minus_Er_final": e_err, "V_final": V, "max_abs_tau": fst[:, f_peak:f_peak + links - 1].copy(), "diverged": diverged,
        "success": succeeded(status == FINISHED, status == RETIRED, ist[:, I_LEFT_GOAL], steps, dt) & ~diverged,
        "t_end": steps * dt, "status": status, "t_region": region, "t_balanced": t_balanced,
        "int_tau2": fst[:, F_INT_TAU2].copy(), "work": fst[:, F_WORK].copy(),
        "smoothness": np.sqrt(fst[:, F_SMOOTH] / np.maximum(steps, 1)), "max_speed": fst[:, F_SPEED].copy(),
    }


def _lyapunov(controller, plant, q, qd):
    """V of (34) / (12) with the controller's gains on the plant's model, NaN without an energy controller."""
    from ..control.energy import EnergyVCLController

    swing = getattr(controller, "first", controller)
    if not isinstance(swing, EnergyVCLController):
        return np.full(np.shape(q)[:-1], np.nan)
    return type(swing)(plant, swing.kD, swing.kP, swing.kV, check=False, goal=swing.goal_name).lyapunov(q, qd)


def simulate_batch(robot: Robot, x0: ArrayLike, t_final: float = 30.0, controller="vcl", dt: float | None = None,
                   integrator: str | None = None, plants: list | None = None, torque_limit: ArrayLike | None = None,
                   noise_std: ArrayLike | None = None, torque_noise: ArrayLike | None = None,
                   delay_steps: ArrayLike | None = None, pushes: ArrayLike | None = None, seed: int = 0,
                   rollout_ids: ArrayLike | None = None, record: bool = False, sample_dt: float = 0.01,
                   retire: bool = True, nthread: int | None = None, progress: bool = False,
                   goal: str = "folded") -> BatchResult:
    """Closed-loop rollouts of N initial states at once.

    Parameters
    ----------
    robot : Robot
        The nominal robot: default plant, and what controllers are built for.
    x0 : array_like (N, 2n)
        Initial states [q, qd] [rad, rad/s] ([q1, q2, q3, d1, d2, d3] for the gymnast).
    t_final : float
        Duration [s].
    controller : str, ControllerSpec, controller, or a list of those (one per rollout)
        Default ``"vcl"``, the paper's controller with the robot's stored gains.
    dt, integrator : optional
        Physics time step [s] and integrator; default: the robot model's (RK4, 1 ms).
    plants : list of RobotParams or None, optional
        Per rollout, the robot MuJoCo simulates (None: the nominal robot).
    torque_limit : float, (n - 1,), (N,) or (N, n - 1), optional
        Saturation of each torque [N m] (also capped by the model's actuator ranges).
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
    record : bool
        Keep full trajectories (t, q, qd, tau, mode every ``sample_dt``).
    retire : bool
        Stop each rollout once its balance can no longer fail (:mod:`paa_mj.sim.engine`).
    nthread : int, optional
        Threads for compiled controllers (default: all cores).
    goal : {"folded", "stretched"}
        The task: the goal the controllers named here aim at, and around which region (68), success and
        balance are judged (:mod:`paa_mj.model.states`); default the paper's folded UDD.
    """
    check_robot(robot)
    x0 = check_initial_states(x0, robot.params.n_links)
    n = len(x0)
    controllers = controllers_for(robot, controller, n, goal)
    base_dt = float(mujoco_model_for(robot, dt, integrator).opt.timestep)
    every = sample_interval(sample_dt, base_dt, t_final) if record else 0
    plan = build_plan(robot, x0, t_final, controllers, dt, integrator, plants, torque_limit, noise_std, torque_noise,
                      delay_steps, pushes, seed, rollout_ids, every, retire, goal)
    outcome = engine.run(plan, controllers, nthread=nthread, progress=progress, desc=f"{n} rollouts")
    plant_analytics = [robot.analytic if plants is None or plants[r] is None else None for r in range(n)]
    if plants is not None:
        from ..model.dynamics import AnalyticModel

        plant_analytics = [robot.analytic if p is None else AnalyticModel.from_params(p) for p in plants]
    out = outcome_arrays(plan, outcome, controllers, plant_analytics)
    completed = ~np.isin(out["status"], (engine.STOPPED, engine.RUNNING))
    trajectories = None
    if record:
        trajectories = {k: v for k, v in outcome.samples.items()}
    return BatchResult(**out, t_reached=float(np.max(out["t_end"][completed], initial=0.0)),
                       interrupted=outcome.interrupted, trajectories=trajectories,
                       meta={"robot": robot.name, "dt": plan.dt, "t_final": float(t_final), "n_steps": plan.n_steps,
                             "status_text": STATUS_TEXT, "completed": completed})


def kip_peak_torques(robot: Robot, controller="vcl", torque_limit=None, t_final: float = 30.0,
                     goal: str = "folded") -> np.ndarray:
    """Peak torques :math:`|\\tau_2|, |\\tau_3|` [N m] of a controller's kip from (65), over every step (the scale of torque limits)."""
    result = simulate_batch(robot, start_state(robot.params.n_links, goal)[None], t_final, controller=controller,
                            torque_limit=torque_limit, goal=goal,
                            retire=False)
    if result.interrupted:
        raise KeyboardInterrupt
    if result.diverged[0]:
        name = controller if isinstance(controller, str) else type(controller).__name__
        raise PaaError(f"the kip of {name} from (65) diverged at t = {result.t_end[0]:.3f} s"
                       f" ({STATUS_TEXT[int(result.status[0])]}), so its peak torques are no scale for a"
                       " torque limit (give one)")
    return result.max_abs_tau[0]
