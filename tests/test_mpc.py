"""The model-predictive controller ``mpc`` (paa_mj.control.mpc): its model, its balance, its swing-up on RealAIGym's
acrobot, one law compiled and in Python, and that it reads nothing but the measured state and time."""
import numpy as np
import pytest

from paa_mj.control import mpc_estimator
from paa_mj.control import mpc_kernels as mk
from paa_mj.control.mpc import DEFAULTS, MPCController
from paa_mj.control.registry import make_controller
from paa_mj.model import chain, load_robot
from paa_mj.model.mjcf import mjcf_from_params
from paa_mj.model.params import RobotParams
from paa_mj.model.robot import robot_from_xml
from paa_mj.realaigym import study as rg
from paa_mj.realaigym import scores
from paa_mj.sim.rollout import simulate_mujoco
from paa_mj.task import Task


@pytest.fixture(scope="module")
def acrobot():
    robot = load_robot("realaigym_acrobot")
    return robot, Task.named("stretched", robot)


def passive_middle():
    """A three-link chain with its middle joint passive (motors at joints 1 and 3), as ``make-model --links 3
    --passive 2`` writes it."""
    params = RobotParams.uniform_rods([1.0, 1.0, 1.0], [1.0, 1.0, 1.0], name="passive-middle", actuated=(0, 2))
    return robot_from_xml(mjcf_from_params(params, name="passive-middle", torque_limits=100, timestep=5e-4))


def _robot(name):
    return passive_middle() if name == "passive-middle" else load_robot(name)


@pytest.mark.parametrize("name", ["realaigym_acrobot", "gymnast", "chain4", "realaigym_pendubot", "passive-middle"])
def test_the_plans_acceleration_is_the_chains(name):
    """The plan's flat (1) is :func:`~paa_mj.model.chain.acceleration_into` with the robot's drive map (B)."""
    robot = _robot(name)
    n, nu = robot.params.n_links, robot.params.n_motors
    c = MPCController(robot.analytic, Task.named("stretched", robot), np.ones(nu))
    A, b, d, arm = (np.ascontiguousarray(a) for a in mk.unpack(c.params)[:4])
    drive = chain.drive_map(n, robot.params.actuated)
    np.testing.assert_array_equal(mk.unpack(c.params)[12], drive)
    rng = np.random.default_rng(1)
    for _ in range(20):
        x, u = rng.normal(size=2 * n) * 3, rng.normal(size=nu)
        ours, theirs = np.zeros(2 * n), np.empty(n)
        mk.acceleration(c.params, x, u, ours, mk.scratch(n))
        chain.acceleration_into(A, b, d, arm, drive, x[:n].copy(), x[n:].copy(), u, theirs, np.empty(n * n + 4 * n))
        np.testing.assert_allclose(ours[n:], theirs, rtol=1e-12, atol=1e-12)


@pytest.mark.parametrize("name", ["realaigym_pendubot", "passive-middle"])
def test_its_lqr_takes_the_robots_motors(name):
    """goal_lqr's B is the robot's (n x m): K has a row per motor, and the closed loop A - B K is stable."""
    robot = _robot(name)
    task = Task.named("stretched", robot)
    c = make_controller("mpc", robot, task=task)
    A, B = robot.analytic.linearize(task.goal)
    assert c.K.shape == (robot.params.n_motors, 2 * robot.params.n_links)
    assert np.max(np.linalg.eigvals(A - B @ c.K).real) < 0


def _final_success(robot, task, X):
    return scores.final_state_success(X[-1], rg.their_goal(robot, task))


def test_it_balances_from_near_the_top(acrobot):
    robot, task = acrobot
    c = make_controller("mpc", robot, task=task)
    summary, rows = rg.performance_v2(robot, c, task, x0=np.array([0.04, -0.05, 0.1, 0.0]))
    assert summary["criteria"]["success"] and summary["criteria"]["swingup_time"] < 2.0
    # held where it started: no turn round the bar on the way (their angles: the upright is q1 = pi)
    assert abs(rows["X"][-1, 0] - np.pi) < 0.05 and abs(rows["X"][-1, 1]) < 0.05


def test_it_swings_their_acrobot_up(acrobot):
    """Their performance v2 from hanging at rest: up within 2 s, held, and a RealAI score above their TVLQR's 0.504."""
    robot, task = acrobot
    c = make_controller("mpc", robot, task=task)
    summary, _ = rg.performance_v2(robot, c, task)
    criteria = summary["criteria"]
    assert criteria["success"] and criteria["swingup_time"] < 2.0
    assert criteria["score_v2"] > 0.504


def _trace(controller, robot, steps=400, dt=0.002, x0=(-np.pi + 0.3, 0.2, 0.0, 0.0)):
    """(x, t) seen and torques of the Python law along a run on the model (RK4 at dt)."""
    x = np.array(x0, float)
    seen, torques = [], []
    work = mk.scratch(robot.params.n_links)
    for k in range(steps):
        tau = controller.torque(x[:2], x[2:], k * dt)
        seen.append((x.copy(), k * dt))
        torques.append(tau.copy())
        out = np.empty(4)
        mk.step(controller.params, x, tau, dt, out, work)
        x = out
    return seen, np.array(torques)


def test_the_compiled_law_is_the_python_law(acrobot):
    robot, task = acrobot
    c = make_controller("mpc", robot, task=task)
    seen, torques = _trace(c, robot)
    form = c.compiled()
    memory, tau = form.memory.copy(), np.empty(1)
    for (x, t), expected in zip(seen, torques):
        form.kernel(x, t, form.params, memory, tau)
        assert tau[0] == expected[0]


def test_it_reads_only_the_measured_state_and_time(acrobot):
    """A run under their simulator with torque pulses and measurement noise: every (state, time) the controller was
    given, replayed into a fresh controller built again, gives the same torques bit for bit. The law's inputs are the
    kernel's (x, t, params, memory): params are the robot's, the task's and the options', the same for any run."""
    robot, task = acrobot

    class Recorder:
        """The Python law, recording what it is given (no compiled form: the protocol calls ``torque``)."""

        def __init__(self):
            self.inner = make_controller("mpc", robot, task=task)
            self.calls = []

        def reset(self):
            self.inner.reset()

        def torque(self, q, qd, t):
            tau = self.inner.torque(q, qd, t)
            self.calls.append((np.array(q), np.array(qd), float(t), tau.copy()))
            return tau

    recorder = Recorder()
    runs = rg.Runs(robot, recorder)
    T = rg.their_times(1.0)
    rng = np.random.RandomState(5)
    pulses = rg.perturbations(rng, 2, t_final=1.0)
    normals = rng.standard_normal((len(T) - 1, 10))
    runs.run(rg.plant(robot), rg.hanging(2), T, perturbation=pulses, sigma_meas=np.r_[0.0, 0.0, 0.2, 0.2],
             normals=normals)
    fresh = make_controller("mpc", robot, task=task)
    np.testing.assert_array_equal(fresh.compiled().params, recorder.inner.compiled().params)
    for q, qd, t, tau in recorder.calls:
        assert np.array_equal(fresh.torque(q, qd, t), tau)
    assert len(recorder.calls) == len(T) - 1


@pytest.mark.parametrize("name, goal", [("gymnast", "folded"), ("chain4", "stretched")])
def test_it_builds_for_the_family(name, goal):
    robot = load_robot(name)
    c = make_controller("mpc", robot, task=goal)
    n = robot.params.n_links
    tau = c.torque(np.r_[-np.pi + 0.2, np.zeros(n - 1)], np.zeros(n), 0.0)
    assert tau.shape == (n - 1,) and np.all(np.isfinite(tau))
    assert np.all(np.abs(tau) <= robot.torque_limits + 1e-12)


def test_its_record_names_every_option_it_takes():
    """The record's options (read from the module's text by the command line) are the law's :data:`DEFAULTS` and the
    run's torque limit."""
    from paa_mj.control.mpc import DEFAULTS
    from paa_mj.control.registry import RECORDS

    assert set(RECORDS["mpc"].settings) == set(DEFAULTS) | {"limit"}


def test_it_plans_within_the_runs_torque_limit(acrobot):
    """A board's or ``--torque-limit``'s limit reaches the plans' box (capped by the robot's ranges), so that it does
    not plan torques the run clips."""
    from paa_mj.control.catalog import takes_run_limit
    from paa_mj.studies.compare import _spec

    robot, task = acrobot
    assert make_controller("mpc", robot, task=task, limit=(2.0,)).limit.tolist() == [2.0]
    assert make_controller("mpc", robot, task=task, limit=(1e3,)).limit.tolist() == robot.torque_limits.tolist()
    assert takes_run_limit("mpc") and not takes_run_limit("lqr")
    assert dict(_spec("mpc", (2.0,), task).options)["limit"] == (2.0,)


class _Law:
    """The Python law of ``mpc`` under their simulator (no compiled form: its memory stays readable)."""

    def __init__(self, robot, task, **options):
        self.inner = make_controller("mpc", robot, task=task, **options)

    def reset(self):
        self.inner.reset()

    def torque(self, q, qd, t):
        return self.inner.torque(q, qd, t)

    def estimator(self):
        memory = self.inner._memory[1][0]
        return mpc_estimator.estimator_views(self.inner.params, memory, 2, 1)


def test_the_estimator_finds_the_loops_latency_and_holds_the_top(acrobot):
    """Their delay of 20 ms (the state measured 10 of their 2 ms steps late): the latency scored from the angles'
    second differences is those 10 calls, and the swing-up is held (their final-state success)."""
    robot, task = acrobot
    law = _Law(robot, task)
    T = rg.their_times(4.0)
    X, _ = rg.Runs(robot, law).run(rg.plant(robot), rg.hanging(2), T, delay=0.02)
    head = law.estimator()[0]
    assert int(head[mpc_estimator.E_LAG]) == int(0.02 / rg.DT)
    assert _final_success(robot, task, X)
    off = _Law(robot, task, estimate=0.0)
    X, _ = rg.Runs(robot, off).run(rg.plant(robot), rg.hanging(2), T, delay=0.02)
    assert not _final_success(robot, task, X)  # the same law on the measurement alone loses it


def test_the_estimator_filters_their_velocity_noise(acrobot):
    """Their velocity noise at its largest level (0.5 rad/s on each speed, every step) over their 10 s: with the
    estimator the top is held; the speeds it acts on are within a tenth of the noise of the true ones at the end."""
    robot, task = acrobot
    law = _Law(robot, task)
    T = rg.their_times(rg.T_FINAL)
    rng = np.random.RandomState(3)
    normals = rng.standard_normal((len(T) - 1, 10))
    X, _ = rg.Runs(robot, law).run(rg.plant(robot), rg.hanging(2), T, sigma_meas=np.r_[0.0, 0.0, 0.5, 0.5],
                                   normals=normals)
    assert _final_success(robot, task, X)
    xhat = law.estimator()[1]
    assert np.max(np.abs(xhat[2:] - X[-2, 2:])) < 0.05


def test_it_balances_a_chain_with_a_passive_middle_joint():
    """``make-model --links 3 --passive 2``'s chain (motors at joints 1 and 3) brought back upright from 0.1 rad and
    0.2 rad/s off the top on MuJoCo within 3 s, within its motors' 100 N m (with the acrobot's weights unscaled it
    was 0.66 rad/s off after 2 s)."""
    robot = passive_middle()
    task = Task.named("stretched", robot)
    c = make_controller("mpc", robot, task=task)
    x0 = np.r_[task.goal + np.array([0.1, -0.1, 0.05]), 0.2, 0.0, -0.2]
    run = simulate_mujoco(robot, c, x0=x0, t_final=3.0, task=task)
    error = np.r_[np.angle(np.exp(1j * (run.q[-1] - task.goal))), run.qd[-1]]
    assert np.max(np.abs(error)) < 0.03 and np.max(np.abs(run.tau)) <= 100 + 1e-9


def test_its_options_carry_over_by_similarity(acrobot):
    """Every option states how it scales (:data:`~paa_mj.control.mpc.SIMILARITY`); the defaults' own robot and
    RealAIGym's pendubot (the same links) keep them exactly, while a motor is weighed by the gravity torque it carries
    (the pendubot's shoulder carries the whole chain: 2.44 times the acrobot's elbow); on the 53 kg gymnast the
    torque weights fall by about 130^2."""
    from paa_mj.control.mpc import SIMILARITY, scaled_options, similarity

    assert set(SIMILARITY) == set(DEFAULTS)
    robot, _ = acrobot
    assert scaled_options(DEFAULTS, robot.analytic) == DEFAULTS
    g, gm, t = similarity(load_robot("realaigym_pendubot").analytic)
    assert (g, t) == (1.0, 1.0) and gm[0] == pytest.approx(2.4367, abs=1e-4)
    gymnast = load_robot("gymnast")
    g, gm, t = similarity(gymnast.analytic)
    scaled = scaled_options(DEFAULTS, gymnast.analytic)
    np.testing.assert_allclose(scaled["r"], DEFAULTS["r"] / (t * gm ** 2))
    assert 120 < g < 140 and 0.9 < t < 1.1 and scaled["rho_in"] == DEFAULTS["rho_in"]


def test_its_defaults_follow_the_actuation_pattern(acrobot):
    """A passive shoulder (their acrobot, the gymnast) takes :data:`DEFAULTS` as they are; a driven one (their
    pendubot, the chain with a passive middle joint) takes its pattern's changes (a shorter horizon), and an option
    given still wins over both."""
    from paa_mj.control.mpc import PATTERN_DEFAULTS, pattern

    robot, task = acrobot
    assert MPCController(robot.analytic, task, robot.torque_limits).options == DEFAULTS
    assert pattern(load_robot("gymnast").analytic) == "passive shoulder"
    assert pattern(passive_middle().analytic) == "driven shoulder"
    pendubot = load_robot("realaigym_pendubot")
    goal = Task.named("stretched", pendubot)
    options = MPCController(pendubot.analytic, goal, pendubot.torque_limits).options
    assert options == {**DEFAULTS, **PATTERN_DEFAULTS["driven shoulder"]} and options["horizon"] < DEFAULTS["horizon"]
    assert MPCController(pendubot.analytic, goal, pendubot.torque_limits, horizon=1.0).options["horizon"] == 1.0


def test_the_header_slots_are_distinct():
    """Every named slot of the parameter vector's header (mpc_kernels', mpc_law's and mpc_estimator's) is its own: a
    merge once put the motor count and the estimator's lag gate in one slot."""
    from paa_mj.control import mpc_law

    slots = {name: getattr(module, name) for module in (mk, mpc_law, mpc_estimator) for name in dir(module)
             if name.startswith("H_") and isinstance(getattr(module, name), int)}
    assert len(set(slots.values())) == len(slots) and max(slots.values()) < mk.HEADER


@pytest.mark.parametrize("name, goal, within", [("gymnast", "folded", 5.0), ("chain4", "stretched", 5.0),
                                                ("realaigym_pendubot", "stretched", 2.0)])
def test_one_set_of_defaults_swings_the_family_up(name, goal, within):
    """Their performance v2 from hanging at rest with the defaults carried over by similarity: the 53 kg gymnast's
    kip to the folded goal and chain4's to the stretched one up within 5 s and held (the paper's vcl: 18 s on the
    gymnast), RealAIGym's pendubot (its pattern's defaults) within 2 s."""
    robot = load_robot(name)
    task = Task.named(goal, robot)
    summary, _ = rg.performance_v2(robot, make_controller("mpc", robot, task=task), task)
    assert summary["criteria"]["success"] and summary["criteria"]["swingup_time"] < within


def test_its_torque_stays_finite_on_a_chain_spun_past_its_plans():
    """chain4 spun to 200 rad/s at its last joint (their global test's resets leave it so): the plans' RK4 knots run
    away there, and the law still returns a finite torque within the motors' box at every call."""
    robot = load_robot("chain4")
    c = make_controller("mpc", robot, task="stretched")
    qd = np.array([-2.0, -11.5, 32.0, 142.0])
    q = np.array([8.7, 7.7, -14.3, 2.0])
    for k in range(10):
        t = 34.16 + 0.002 * k
        tau = c.torque(q + qd * 0.002 * k, qd * (1 + 0.05 * k), t)
        assert np.all(np.isfinite(tau)) and np.all(np.abs(tau) <= c.limit + 1e-9)


# ~16 CPU-s (two 5 s runs of the law called from Python, which compiles the estimator's views again for its
# layouts); its quick forms: test_the_estimator_filters_their_velocity_noise and the board rows' robustness runs
@pytest.mark.slow
def test_the_estimator_holds_the_top_under_noise_on_the_angles_too():
    """Gaussian noise of 0.01 rad on each angle and 0.01 rad/s on each speed at every 1 ms step (compare's and
    robustness' ``noise``), RealAIGym's acrobot from hanging for 5 s on MuJoCo: the angles' noise the estimator finds
    from the measurements alone is within a fifth of 0.01, the swing-up is held within 0.1 rad over the last half
    second, and the plan is solved afresh (a cold restart: three iLQR solves of ``cold_iterations``) a few times, not
    at every period as when the angles' innovation over 1 ms drove the speeds (5 rad/s of noise on them)."""
    from paa_mj.control import mpc_law
    from paa_mj.sim.batch import Disturbances

    robot = load_robot("realaigym_acrobot")
    task = Task.named("stretched", robot)

    class Counting:
        """The Python law (no compiled form: its memory stays readable), counting the cold restarts."""

        name = "mpc"

        def __init__(self, **options):
            self.inner = make_controller("mpc", robot, task=task, **options)
            self.cold, self.last, self.memory = 0, None, None

        def reset(self):
            self.inner.reset()

        def compiled(self):
            return None

        def torque(self, q, qd, t):
            tau = self.inner.torque(q, qd, t)
            self.memory = self.inner._memory[1][0].copy()
            if self.memory[mpc_law.M_COLD] != self.last:
                self.cold, self.last = self.cold + 1, self.memory[mpc_law.M_COLD]
            return tau

        def __getattr__(self, name):
            return getattr(self.inner, name)

    def run(**options):
        law = Counting(**options)
        traj = simulate_mujoco(robot, law, t_final=5.0, task=task,
                               disturbances=Disturbances(noise_std=[0.01, 0.01], seed=1))
        error = np.max(np.abs(np.angle(np.exp(1j * (traj.q[-50:] - task.goal)))))
        return law, error

    law, error = run()
    head, _, _, _, _, _, stats = mpc_estimator.estimator_views(law.inner.params, law.memory, 2, 1)
    sigma = [np.sqrt(mpc_estimator.angle_variance(law.inner.params, 1e-3, head, stats, i)) for i in range(2)]
    np.testing.assert_allclose(sigma, 0.01, rtol=0.2)
    assert error < 0.1 and law.cold <= 10
    trusting, error = run(noise_memory=0.0)  # the angles trusted as measured: today's filter before the noise's
    assert trusting.cold > 100 and error > 1.0


# 22 CPU-s: replan called from Python compiles the solver again for Python's array layouts; its quick form is
# test_its_torque_stays_finite_on_a_chain_spun_past_its_plans (the same spun chain4, through the compiled law)
@pytest.mark.slow
def test_a_plan_that_runs_away_is_never_kept():
    """chain4 spun to 142 rad/s at its last joint: planned on single 16 ms RK4 knots its rollouts run away, and no such
    plan is kept (the law brakes until the next solve); planned with the RK4 sub-steps of a fast state (the default
    ``turn``) a finite plan is found."""
    from paa_mj.control import mpc_law

    robot = load_robot("chain4")
    x = np.array([8.7, 7.7, -14.3, 2.0, -2.0, -11.5, 32.0, 142.0])
    costs = {}
    for turn in (0.0, DEFAULTS["turn"]):
        c = make_controller("mpc", robot, task="stretched", turn=turn)
        memory = c.memory0.copy()
        mpc_law.replan(c.params, mk.unpack(c.params), x, 0.0, memory)
        X = mpc_law.plan_views(c.params, memory)[2]
        costs[turn] = memory[mk.M_COST]
        kept = memory[mk.M_VALID] == 1.0
        assert kept == np.isfinite(costs[turn]) and kept != (memory[mpc_law.M_BRAKE] == 1.0)
        assert not kept or np.all(np.isfinite(X))
    assert np.isfinite(costs[DEFAULTS["turn"]])


def test_the_braking_guess_takes_energy_out_of_a_spin():
    """The braking guess u_j = -k_b qd_a (clamped) rolled out from RealAIGym's acrobot spinning: every motor's power
    is at most zero, and the chain ends the horizon with less energy than it started."""
    from paa_mj.control import mpc_law

    robot = load_robot("realaigym_acrobot")
    c = make_controller("mpc", robot, task="stretched")
    p, model = c.params, mk.unpack(c.params)
    knots = int(p[mk.H_KNOTS])
    U, X = np.empty((knots, 1)), np.empty((knots + 1, 4))
    x0 = np.array([2.0, -1.0, 8.0, 40.0])
    mpc_law.pump_guess(p, model, x0, U, X, 0.0, 0.0, p[mpc_law.H_BRAKE] * p[mk.H_PUMP_KD])
    assert np.all(U[:, 0] * X[:-1, 3] <= 0.0)
    assert mk.energy(model, X[-1]) < mk.energy(model, x0) - 1.0


def test_a_motor_without_a_range_plans_within_box_times_its_gravity_torque(acrobot):
    """chain4's motors have no range: each plans within ``box`` times the gravity torque it carries (sum_{k >= j} b_k,
    the links beyond it held level); RealAIGym's acrobot keeps its 6 N m whatever ``box`` is (its motor has a
    range), so that its plans, and its scores, do not move with it."""
    robot = load_robot("chain4")
    carried = np.cumsum(robot.analytic.gravity_constants[::-1])[::-1][list(robot.analytic.actuated)]
    for box in (1.0, DEFAULTS["box"], 4.0):
        c = make_controller("mpc", robot, task="stretched", box=box)
        np.testing.assert_allclose(c.limit, box * carried)
        assert c.params[mk.offsets(4, 3)[1]:mk.offsets(4, 3)[1] + 3].tolist() == c.limit.tolist()
    acro, task = acrobot
    for box in (1.0, 4.0):
        assert make_controller("mpc", acro, task=task, box=box).limit.tolist() == [6.0]


def test_motors_without_a_range_plan_afresh_over_a_shorter_horizon_and_climb_from_hanging(acrobot):
    """chain4's and the gymnast's motors have no range: they take NO_RANGE_DEFAULTS (a shorter horizon, the longer
    one as the climb's), so that a plan started afresh from a spun chain near the goal's energy (a reset of their global
    test) has the shorter horizon's knots, and one from hanging at rest the climb's; a motor with a range (their
    acrobot's, or chain4 under a finite limit) keeps the pattern's defaults."""
    from paa_mj.control import mpc_law
    from paa_mj.control.mpc import NO_RANGE_DEFAULTS

    changes = NO_RANGE_DEFAULTS["passive shoulder"]
    assert changes["horizon"] < changes["climb_horizon"] == DEFAULTS["horizon"]
    for name, goal in (("chain4", "stretched"), ("gymnast", "folded")):
        robot = load_robot(name)
        c = make_controller("mpc", robot, task=goal)
        assert c.options == {**DEFAULTS, **changes}
        knots = round(changes["horizon"] / DEFAULTS["knot"]), round(changes["climb_horizon"] / DEFAULTS["knot"])
        assert (c.params[mk.H_KNOTS], c.params[mk.H_CLIMB_KNOTS]) == knots
        n = robot.params.n_links
        hanging, spun = np.zeros(2 * n), np.zeros(2 * n)
        hanging[0] = -np.pi
        spun[:n] = c.task.goal
        spun[n:] = 3.0  # every joint turning at 3 rad/s at the goal's pose: above the goal's energy
        for x, expected in ((hanging, knots[1]), (spun, knots[0])):
            c.reset()
            c.law(x[:n], x[n:], 0.0)
            assert c._memory[1][0][mpc_law.M_KNOTS] == expected
    chain4 = load_robot("chain4")
    capped = MPCController(chain4.analytic, Task.named("stretched", chain4), [600.0, 200.0, 40.0])
    robot, task = acrobot
    assert capped.options == DEFAULTS == MPCController(robot.analytic, task, robot.torque_limits).options


@pytest.mark.slow  # one global v3 run of chain4 (~20 CPU-s); quick form: the test above (its plans' horizons)
def test_chain4_is_up_more_than_40_s_of_their_global_test():
    """chain4 at the stretched goal, their global v3 on their seed: up more than 40 s of 60 (the horizon 1.0 s of the
    pattern's defaults: 39.47 s)."""
    robot = load_robot("chain4")
    task = Task.named("stretched", robot)
    summary, _ = rg.global_v3(robot, make_controller("mpc", robot, task=task), task, seed=777)
    assert summary["diverged"] is None and summary["time_up"] > 40.0


@pytest.mark.slow  # replan called from Python compiles the solver again (~20 CPU-s); quick form: the pendubot board's
# performance run (tests/test_realaigym_board_rows.py), whose swing-up is the climb's
def test_a_climb_is_planned_from_far_below_the_goals_energy():
    """With a climb horizon, a plan started afresh from hanging at rest (far below the goal's energy) is solved over
    the climb's knots with the climb's weights: the plan a controller of that horizon and those weights makes (to
    rounding: 300 x 0.1 is not 30 in floating point);
    the solves that follow it keep its knots; from near the goal's energy a plan takes the horizon's knots."""
    from paa_mj.control import mpc_law

    robot = load_robot("realaigym_pendubot")
    task = Task.named("stretched", robot)
    base = {"horizon": 0.5, "w_speed": 0.2, "r": 300.0, "r_rate": 0.3}
    c = MPCController(robot.analytic, task, robot.torque_limits, **base, climb_horizon=1.0, climb_w_speed=0.5,
                      climb_r=0.1, climb_r_rate=2.0)
    long = MPCController(robot.analytic, task, robot.torque_limits, horizon=1.0, w_speed=0.1, r=30.0, r_rate=0.6,
                         climb_horizon=0.0)
    hanging = np.array([np.pi, 0.0, 0.0, 0.0])
    memory, reference = c.memory0.copy(), long.memory0.copy()
    mpc_law.replan(c.params, mk.unpack(c.params), hanging, 0.0, memory)
    mpc_law.replan(long.params, mk.unpack(long.params), hanging, 0.0, reference)
    U = mpc_law.plan_views(c.params, memory)[3]
    assert memory[mpc_law.M_KNOTS] == U.shape[0] == 50
    np.testing.assert_allclose(U, mpc_law.plan_views(long.params, reference)[3], rtol=1e-6, atol=1e-9)
    X = mpc_law.plan_views(c.params, memory)[2]
    mpc_law.replan(c.params, mk.unpack(c.params), X[1], 0.02, memory)  # on the plan: no fresh start
    assert memory[mpc_law.M_KNOTS] == 50
    near = c.memory0.copy()
    mpc_law.replan(c.params, mk.unpack(c.params), np.array([0.3, -0.2, 0.0, 0.0]), 0.0, near)
    assert near[mpc_law.M_KNOTS] == 25 == mpc_law.plan_views(c.params, near)[3].shape[0]


def test_without_a_climb_the_memory_is_as_before(acrobot):
    """No climb horizon (the passive shoulder's defaults): the memory keeps room for the horizon's knots only."""
    from paa_mj.control import mpc_law

    robot, task = acrobot
    c = MPCController(robot.analytic, task, robot.torque_limits)
    knots = int(c.params[mk.H_KNOTS])
    assert c.params[mk.H_CLIMB_KNOTS] == 0 and c.memory0.size == mpc_law.memory_size(2, 1, knots)


def test_a_climb_as_long_as_the_horizon_is_refused(acrobot):
    """A kept plan is told to be a climb by its length: a climb horizon equal to the horizon is refused in one line
    (it would run with the balance's weights and say nothing)."""
    from paa_mj.errors import PaaError

    robot, task = acrobot
    with pytest.raises(PaaError, match="climb_horizon must differ from its horizon"):
        MPCController(robot.analytic, task, robot.torque_limits, horizon=0.5, climb_horizon=0.5)
    MPCController(robot.analytic, task, robot.torque_limits, horizon=0.5, climb_horizon=0.0)


def test_the_analytic_engine_refuses_it_in_one_line(acrobot):
    """Its calls are tied to time steps (a plan solved every period, kept between calls): an adaptive ODE solver,
    which calls a law at trial times back and forth, would integrate a law it never runs (it did: the gymnast stayed
    hanging), so the analytic engine refuses it and names why."""
    from paa_mj.errors import PaaError
    from paa_mj.sim.analytic.engine import simulate_analytic

    robot, task = acrobot
    with pytest.raises(PaaError, match="mpc solves its plan every 20 ms and keeps it between calls"):
        simulate_analytic(robot, make_controller("mpc", robot, task=task), t_final=0.1, task=task)


@pytest.mark.parametrize("hold", [0.01, 0.02, 0.05])
def test_a_loop_slower_than_half_a_knot_gets_the_knots_torque(acrobot, hold):
    """Called once every half knot or slower (a 10 ms Gymnasium step, --dt 0.02), the ramp from the applied torque to
    the plan's cannot show: called once a period it held the torque it started with (zero) for ever. From its third
    call on (two intervals seen) such a loop gets the plan's knot torque, held as the plan was solved; a fast loop
    (1 ms) keeps the ramp."""
    from paa_mj.control import mpc_law

    robot, task = acrobot
    c = MPCController(robot.analytic, task, robot.torque_limits)
    x = np.array(task.start, float)
    taus = [float(np.ravel(c.torque(x[:2], x[2:], k * hold))[0]) for k in range(3)]
    memory = c._memory[1][0]
    assert memory[mk.M_T0] == 2 * hold  # the third call solved again: at the plan's start, where x is the plan's
    assert taus[2] != 0.0 and taus[2] == pytest.approx(mpc_law.plan_views(c.params, memory)[3][0, 0], abs=1e-12)
    fast = MPCController(robot.analytic, task, robot.torque_limits)
    ramp = [float(np.ravel(fast.torque(x[:2], x[2:], k * 0.001))[0]) for k in range(4)]
    assert 0.0 < abs(ramp[1]) < abs(ramp[2]) < abs(ramp[3])  # from the applied torque (zero) towards the plan's


def _restart_after_first_plan(c, x_far, calls=200):
    """The compiled law of ``c`` from hanging at t = 0 (its first plan), then at ``x_far`` from the next solve's time
    on, call after call every 2 ms until no restart is in progress: the memory, and the calls the restart took."""
    from paa_mj.control import mpc_law

    form = c.compiled()
    memory, tau = form.memory.copy(), np.empty(1)
    form.kernel(np.array([-np.pi, 0.0, 0.0, 0.0]), 0.0, form.params, memory, tau)
    assert memory[mk.M_SOLVES] == 1.0
    for k in range(calls):
        form.kernel(x_far.copy(), 0.02 + 0.002 * k, form.params, memory, tau)
        assert np.all(np.isfinite(tau))
        if mpc_law.restart_views(form.params, memory)[0][mpc_law.R_STAGE] == 0.0:
            return memory, k + 1
    raise AssertionError("the restart never ended")


def test_a_restart_spread_over_calls_makes_the_plan_of_one_call(acrobot):
    """With ``spread`` 2 a restart (the state far from the plan) after the first plan takes many calls of at most 2
    iLQR iterations each (iLQR resumed, mpc_kernels.ilqr_steps), and ends with the plan that one call makes."""
    from paa_mj.control import mpc_law

    robot, task = acrobot
    x_far = np.array([2.0, -1.0, 3.0, 5.0])
    plans = {}
    for spread in (0, 2):
        c = MPCController(robot.analytic, task, robot.torque_limits, estimate=0.0, spread=spread)
        memory, calls = _restart_after_first_plan(c, x_far)
        assert memory[mk.M_SOLVES] == 2.0 and memory[mk.M_VALID] == 1.0
        assert (calls == 1) == (spread == 0) and (spread == 0 or calls >= DEFAULTS["cold_iterations"] / spread)
        plans[spread] = mpc_law.plan_views(c.params, memory)[3].copy(), memory[mk.M_COST], memory[mk.M_T0]
    np.testing.assert_allclose(plans[2][0], plans[0][0], rtol=1e-9, atol=1e-9)
    assert plans[2][1:] == pytest.approx(plans[0][1:], rel=1e-9)


def test_a_chain_spun_past_spin_cap_is_braked_not_planned_for(acrobot):
    """Their acrobot's elbow at 300 rad/s (12 sub-steps a knot, past ``spin_cap`` 8): the law brakes (each motor's
    power at most zero) without a solve; with no cap it solves."""
    from paa_mj.control import mpc_law

    robot, task = acrobot
    x = np.array([0.5, 1.0, 10.0, 300.0])
    for cap, solves in ((DEFAULTS["spin_cap"], 0.0), (0.0, 1.0)):
        form = MPCController(robot.analytic, task, robot.torque_limits, spin_cap=cap).compiled()
        memory, tau = form.memory.copy(), np.empty(1)
        form.kernel(x.copy(), 0.0, form.params, memory, tau)
        assert memory[mk.M_SOLVES] == solves and np.isfinite(tau[0])
        assert solves or (memory[mpc_law.M_BRAKE] == 1.0 and tau[0] * x[3] < 0.0)
