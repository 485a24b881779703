"""The engine on MuJoCo Warp (``paa_mj[gpu]``), checked on Warp's CPU device against MuJoCo's ``mj_step``.

Skipped where ``warp`` and ``mujoco_warp`` are not installed, except the refusal without them, which is checked
everywhere. Every test that runs MuJoCo Warp is marked ``slow`` (``bash scripts/test.sh -m slow``): compiling its
step for Warp's CPU device alone costs about 50 CPU-s on a fresh clone; the quick suite keeps the checks that need
no device (the refusals, the translations' coverage, the constraint rows). MuJoCo Warp computes in float32, the CPU engine in float64: what is held here is what float32
allows (measured on the CI machine, RK4 at 1 ms): one rollout of the physics alone agrees with ``mj_step`` to
about 3e-6 rad over 200 steps, the closed loop under the paper's controller to about 5e-6 (the same switches,
books and statuses), and the laws translated to Warp, run in float64, equal numba's to 1e-12. The step's bookkeeping
is paa_mj.sim.compiled.step's on both engines: the kernels call its translations and nothing else, and under every
disturbance the records agree within float32's drift.
"""
import json
import subprocess
import sys
import warnings
from pathlib import Path

import numpy as np
import pytest

from paa_mj.errors import PaaError
from paa_mj.sim.warp.device import warp_available

needs_warp = pytest.mark.skipif(not warp_available(), reason="warp and mujoco_warp not installed (paa_mj[gpu])")
DEVICE = "cpu"
ROOT = Path(__file__).resolve().parent.parent


def test_without_warp_one_line_names_the_extra():
    """With warp unimportable, --engine warp is one line on stderr naming the install, exit 2, no traceback."""
    script = ("import sys; sys.modules['warp'] = None; sys.modules['mujoco_warp'] = None\n"
              "from paa_mj.cli import main\n"
              "sys.exit(main(['basin', '--engine', 'warp', '--grid', '2', '--t-final', '0.01']))")
    # from the repository's root: the package under test, whatever the interpreter has installed
    run = subprocess.run([sys.executable, "-c", script], capture_output=True, text=True, cwd=ROOT)
    assert run.returncode == 2, run.stderr
    assert run.stderr.count("\n") == 1 and "pip install 'paa_mj[gpu]'" in run.stderr, run.stderr
    assert "Traceback" not in run.stderr


def test_device_option_needs_the_warp_engine(capsys):
    from paa_mj.cli import main

    assert main(["basin", "--device", "cpu", "--grid", "2", "--t-final", "0.01"]) == 2
    assert capsys.readouterr().err == ("paa-mj: error: --device chooses the Warp device of --engine warp; drop it or"
                                       " add --engine warp\n")


def test_unknown_engine_is_refused(gymnast):
    from paa_mj.sim import simulate_batch

    with pytest.raises(PaaError, match="engine must be one of mujoco, warp"):
        simulate_batch(gymnast, np.zeros((1, 6)), 0.01, engine="cuda")


# --- on Warp's CPU device ------------------------------------------------------------------------------------

@pytest.fixture(scope="module")
def warp_modules():
    if not warp_available():
        pytest.skip("warp and mujoco_warp not installed (paa_mj[gpu])")
    from paa_mj.sim.warp.device import load_warp

    return load_warp()


@pytest.fixture(scope="module")
def folded(gymnast):
    from paa_mj.task import Task

    return Task.named("folded", gymnast)


@pytest.mark.parametrize("name", ["gymnast", "example2", "acrobot", "chain4", "realaigym_acrobot"])
def test_every_stored_robot_makes_no_constraint_row(name):
    """The warp engine gives its worlds no room for constraint rows where ``makes_no_constraints``: true of every
    stored robot, and MuJoCo makes none for it at random states, far outside any joint range."""
    import mujoco

    from paa_mj.model import load_robot
    from paa_mj.model.mjcf_read import makes_no_constraints

    model = load_robot(name).model
    assert makes_no_constraints(model)
    data = mujoco.MjData(model)
    for x in np.random.default_rng(0).uniform(-20, 20, (20, 2 * model.nv)):
        data.qpos[:], data.qvel[:] = x[:model.nv], x[model.nv:]
        mujoco.mj_forward(model, data)
        assert data.nefc == 0 and data.ncon == 0


@pytest.mark.parametrize("old, new", [
    ('<joint name="hips" type="hinge" axis="0 1 0"/>', '<joint name="hips" type="hinge" axis="0 1 0" range="-1 1"/>'),
    ('<joint name="hips" type="hinge" axis="0 1 0"/>',
     '<joint name="hips" type="hinge" axis="0 1 0" frictionloss="0.2"/>'),
    ('material="legs" contype="0" conaffinity="0"', 'material="legs" contype="1" conaffinity="1"'),
], ids=["joint range", "friction loss", "contacts"])
def test_a_model_that_makes_constraint_rows_is_not_constraint_free(old, new):
    """A joint range, friction loss or colliding links: MuJoCo makes rows for them, and ``makes_no_constraints``
    says so (the warp engine then keeps MuJoCo Warp's default room and solver)."""
    import mujoco

    from paa_mj.model.mjcf_read import makes_no_constraints

    from .faults_shared import _variant

    xml = _variant(old, new)
    if "contype" in new:  # colliding links with contacts on (the gymnast's file switches them off)
        xml = xml.replace('contact="disable"', 'contact="enable"')
    model = mujoco.MjModel.from_xml_string(xml)
    assert not makes_no_constraints(model)
    if "range" in new or "frictionloss" in new:
        data = mujoco.MjData(model)
        data.qpos[2] = 2.0  # past the range; friction loss makes a row at any state
        mujoco.mj_forward(model, data)
        assert data.nefc > 0


@needs_warp
@pytest.mark.slow  # MuJoCo Warp's step compiled for Warp's CPU device: 48 CPU-s on a fresh clone
def test_physics_agrees_with_mj_step_over_200_steps(gymnast, warp_modules):
    """mujoco_warp.step of 4 worlds against mj_step, RK4 at 1 ms, torques held: within 1e-5 (measured 3e-6), with
    the worlds the engines make (no room for constraint rows: the solver's work is MuJoCo's copy for nefc = 0)."""
    import mujoco

    from paa_mj.sim.warp.engine import device_worlds

    wp, mjw = warp_modules
    rng = np.random.default_rng(0)
    q0, v0, u = rng.uniform(-1, 1, (4, 3)), rng.uniform(-1, 1, (4, 3)), rng.uniform(-20, 20, (4, 2))
    with wp.ScopedDevice(DEVICE):
        m, d = device_worlds(mjw, gymnast.model, 4)
        assert d.njmax == 0  # the gymnast makes no constraint row
        d.qpos.assign(q0.astype(np.float32))
        d.qvel.assign(v0.astype(np.float32))
        d.ctrl.assign(u.astype(np.float32))
        for _ in range(200):
            mjw.step(m, d)
        qw, vw = d.qpos.numpy(), d.qvel.numpy()
    data = mujoco.MjData(gymnast.model)
    errors = []
    for i in range(4):
        mujoco.mj_resetData(gymnast.model, data)
        data.qpos[:], data.qvel[:], data.ctrl[:] = q0[i], v0[i], u[i]
        for _ in range(200):
            mujoco.mj_step(gymnast.model, data)
        errors.append(max(np.abs(data.qpos - qw[i]).max(), np.abs(data.qvel - vw[i]).max()))
    assert max(errors) < 1e-5, errors


def _device_evaluate(wp, form, x, n_links, t=0.0):
    """The packed compiled ``form`` translated to Warp (float64) and run at the states ``x`` (N, 2n) and the time
    ``t`` on the CPU device: (torques, modes)."""
    from paa_mj.sim.compiled.engine import pack
    from paa_mj.sim.compiled.step import call_controller
    from paa_mj.sim.warp.translate import device_function

    p = pack(form)
    f64, size = wp.float64, 2 * n_links
    triple = [device_function(wp, k, real=f64, state_size=size) for k in (p.first, p.second, p.condition)]
    law = device_function(wp, call_controller, bind=dict(zip(("first", "second", "condition"), triple)), real=f64,
                          state_size=size)

    @wp.kernel(module="unique", enable_backward=False)
    def evaluate_all(xs: wp.array2d(dtype=wp.float64), t: wp.float64, params: wp.array(dtype=wp.float64),
                     memory: wp.array2d(dtype=wp.float64), tau: wp.array2d(dtype=wp.float64),
                     mode: wp.array(dtype=wp.int32)):
        r = wp.tid()
        mode[r] = law(xs[r], t, params, memory[r], tau[r])

    with wp.ScopedDevice(DEVICE):
        tau = wp.zeros((len(x), n_links - 1), dtype=wp.float64)
        mode = wp.zeros(len(x), dtype=wp.int32)
        wp.launch(evaluate_all, dim=len(x), inputs=[wp.array(x, dtype=wp.float64), float(t),
                                                    wp.array(p.params, dtype=wp.float64),
                                                    wp.array(np.tile(p.memory, (len(x), 1)), dtype=wp.float64),
                                                    tau, mode])
        return tau.numpy(), mode.numpy()


def _states_around(task, n_links, seed=1):
    """64 states around the task's goal, the first 8 inside (68) (the balance law acts)."""
    rng = np.random.default_rng(seed)
    goal = np.r_[task.goal, np.zeros(n_links)]
    x = goal + rng.uniform(-1.0, 1.0, (64, 2 * n_links)) * np.r_[np.full(n_links, 1.5), np.full(n_links, 2.0)]
    x[:8] = goal + rng.uniform(-0.05, 0.05, (8, 2 * n_links))
    return x


@needs_warp
@pytest.mark.slow  # runs MuJoCo Warp on Warp's CPU device (its kernels compiled on first use)
def test_translated_laws_equal_numba_in_float64(gymnast, folded, warp_modules):
    """(40), (12), (67) and the switch (68), translated from the source numba compiles (paa_mj.sim.warp.translate) and
    run by Warp in float64: the same torques and modes as the compiled forms, to rounding."""
    from paa_mj.control import make_controller
    from paa_mj.sim.compiled.engine import evaluate

    wp, _ = warp_modules
    x = _states_around(folded, 3)
    for name in ("vcl", "vc", "lqr"):
        form = make_controller(name, gymnast, task=folded).compiled()
        expected, modes = evaluate(form, x[:, :3], x[:, 3:])
        got, got_modes = _device_evaluate(wp, form, x, 3)
        np.testing.assert_array_equal(got_modes, modes, err_msg=name)
        np.testing.assert_allclose(got, expected, rtol=1e-12, atol=1e-9, err_msg=name)


@needs_warp
@pytest.mark.slow  # runs MuJoCo Warp on Warp's CPU device (its kernels compiled on first use)
@pytest.mark.parametrize("robot_name, goal, name", [("chain4", "folded", "vcl"), ("gymnast", "stretched", "vc"),
                                                    ("acrobot", "folded", "vcl"), ("acrobot", "stretched", "spong"),
                                                    ("realaigym_pendubot", "stretched", "fantoni")])
def test_the_chain_s_law_on_the_device_equals_numba(robot_name, goal, name, warp_modules):
    """(40) and (12) on any chain and goal, and Spong's law (their scratch in the controller's memory, viewed as
    matrices on the device): the same torques and modes as numba's, to rounding, and finite (the law ran, not a
    NaN for a NaN); both modes among the states."""
    from paa_mj.control import make_controller
    from paa_mj.model import load_robot
    from paa_mj.sim.compiled.engine import evaluate
    from paa_mj.task import Task

    wp, _ = warp_modules
    robot = load_robot(robot_name)
    task, n = Task.named(goal, robot.analytic), robot.analytic.n_links
    x = _states_around(task, n)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")  # the family rule's gains where the stored ones are below (41)
        form = make_controller(name, robot, task=task).compiled()
    expected, modes = evaluate(form, x[:, :n], x[:, n:])
    assert np.isfinite(expected).all() and 0 < np.sum(modes) < len(x)
    got, got_modes = _device_evaluate(wp, form, x, n)
    np.testing.assert_array_equal(got_modes, modes)
    np.testing.assert_allclose(got, expected, rtol=1e-12, atol=1e-9)


@needs_warp
@pytest.mark.slow  # runs MuJoCo Warp on Warp's CPU device (its kernels compiled on first use)
def test_the_tracking_law_on_the_device_equals_numba(gymnast, folded, warp_modules):
    """trajopt's TVLQR (a table of references and gains, interpolated in time, its angles' errors wrapped): the
    device's torques equal numba's to rounding at times on a sample, between samples and past the table's end."""
    from paa_mj.control.base import CompiledForm
    from paa_mj.control.tvlqr import tvlqr_kernel
    from paa_mj.sim.compiled.engine import evaluate

    wp, _ = warp_modules
    rng = np.random.default_rng(4)
    samples, dt = 7, 0.05
    table = np.concatenate([[samples, dt], rng.normal(size=samples * 6) * 3.0, rng.normal(size=samples * 2) * 50.0,
                            rng.normal(size=samples * 2 * 6) * 100.0])
    form = CompiledForm(tvlqr_kernel, table)
    x = _states_around(folded, 3)
    for t in (0.0, 0.1, 0.1234, 0.2999, 5.0):
        expected, _ = evaluate(form, x[:, :3], x[:, 3:], t=t)
        got, _ = _device_evaluate(wp, form, x, 3, t=t)
        np.testing.assert_allclose(got, expected, rtol=1e-12, atol=1e-9, err_msg=str(t))


def _grid_around_goal(task, n_links=3):
    """16 starts around the task's goal: some inside (68) (the LQR balances, one exactly at the goal retires at
    once), the others swinging under (40)."""
    goal = np.r_[task.goal, np.zeros(n_links)]
    Q1, D1 = np.meshgrid([-0.6, -0.25, 0.0, 0.35], [-1.2, -0.4, 0.0, 0.8], indexing="ij")
    x0 = np.tile(goal, (16, 1))
    x0[:, 0] += Q1.ravel()
    x0[:, n_links] += D1.ravel()
    return x0


@needs_warp
@pytest.mark.slow  # runs MuJoCo Warp on Warp's CPU device (its kernels compiled on first use)
def test_small_basin_has_the_outcomes_of_the_mujoco_engine(gymnast, folded, warp_modules):
    """A 4 x 4 basin around the goal, 1.5 s of RK4 at 5 ms (300 steps) under vcl: the same outcome, switch step,
    status and end step in every cell as the MuJoCo engine, final states within float32's drift (1e-5 relative and
    absolute; measured at most 2.4e-5 rad/s at 5.4 rad/s, 4e-6 relative)."""
    from paa_mj.sim import simulate_batch
    from paa_mj.studies.basin import SUCCESS, classify

    x0 = _grid_around_goal(folded)
    common = dict(task=folded, dt=0.005)
    cpu = simulate_batch(gymnast, x0, 1.5, **common)
    dev = simulate_batch(gymnast, x0, 1.5, engine="warp", device=DEVICE, **common)
    outcome = classify(cpu, folded)
    assert 0 < np.sum(outcome == SUCCESS) < len(x0), outcome  # mixed: the comparison means something
    assert np.any(cpu.status == 2)  # one retired (the start at the goal)
    np.testing.assert_array_equal(classify(dev, folded), outcome)
    np.testing.assert_array_equal(dev.status, cpu.status)
    np.testing.assert_array_equal(dev.success, cpu.success)
    np.testing.assert_array_equal(dev.switch_time, cpu.switch_time)
    np.testing.assert_array_equal(dev.t_end, cpu.t_end)
    np.testing.assert_array_equal(dev.t_region, cpu.t_region)
    np.testing.assert_allclose(dev.final_state, cpu.final_state, rtol=1e-5, atol=1e-5)
    np.testing.assert_allclose(dev.max_abs_tau, cpu.max_abs_tau, rtol=1e-4)
    np.testing.assert_allclose(dev.int_tau2, cpu.int_tau2, rtol=1e-4)
    assert dev.meta["engine"] == "warp" and dev.meta["device"] == DEVICE


@needs_warp
@pytest.mark.slow  # runs MuJoCo Warp on Warp's CPU device (its kernels compiled on first use)
@pytest.mark.slow  # runs MuJoCo Warp on Warp's CPU device
def test_a_chain_s_basin_has_the_outcomes_of_the_mujoco_engine(warp_modules):
    """The 4-link chain under (40) on any chain (the chain's law, not the paper's closed forms) and its LQR, 0.3 s at
    its 1 ms: every outcome, status, switch and end of the MuJoCo engine (success, lost, never and a switch from
    (40) at 0.186 s among them), final states within float32's drift (measured at most 1.7e-5)."""
    from paa_mj.model import load_robot
    from paa_mj.sim import simulate_batch
    from paa_mj.studies.basin import LOST, NEVER, SUCCESS, classify
    from paa_mj.task import Task

    chain = load_robot("chain4")
    task = Task.named("folded", chain.analytic)
    x0 = _grid_around_goal(task, 4)
    cpu = simulate_batch(chain, x0, 0.3, task=task)
    dev = simulate_batch(chain, x0, 0.3, task=task, engine="warp", device=DEVICE)
    outcome = classify(cpu, task)
    assert {SUCCESS, LOST, NEVER} <= set(outcome.tolist()) and np.any(cpu.switch_time > 0)
    np.testing.assert_array_equal(classify(dev, task), outcome)
    np.testing.assert_array_equal(dev.status, cpu.status)
    np.testing.assert_array_equal(dev.switch_time, cpu.switch_time)
    np.testing.assert_array_equal(dev.t_end, cpu.t_end)
    np.testing.assert_allclose(dev.final_state, cpu.final_state, rtol=1e-5, atol=5e-5)


def test_each_rollout_gets_its_own_controller_s_parameters(gymnast, folded):
    """Rollouts of two controllers of one law (other gains), interleaved: each row of the device's parameters and
    memory is its own controller's packed form."""
    from paa_mj.control import make_controller
    from paa_mj.sim.batch import build_plan
    from paa_mj.sim.compiled.engine import pack
    from paa_mj.sim.warp.engine import device_controllers

    a = make_controller("vcl", gymnast, task=folded)
    b = make_controller("vcl", gymnast, task=folded, gains={"kD": 2 * gymnast.gains["kD"]})
    controllers = [a, b, b, a, b]
    plan = build_plan(gymnast, folded, np.tile(np.r_[folded.goal, np.zeros(3)], (5, 1)), 0.01, controllers)
    _, params, memory = device_controllers(plan, controllers)
    for row, controller in enumerate(controllers):
        packed = pack(controller.compiled())
        np.testing.assert_array_equal(params[row, :packed.params.size], packed.params)
        np.testing.assert_array_equal(memory[row, :packed.memory.size], packed.memory)
    assert not np.array_equal(params[0], params[1])


@needs_warp
@pytest.mark.slow  # runs MuJoCo Warp on Warp's CPU device (its kernels compiled on first use)
def test_worlds_beyond_the_device_s_free_memory_are_refused_in_one_line(gymnast, folded, warp_modules, monkeypatch):
    """Before any allocation, the worlds' bytes (MuJoCo Warp's data of a world, measured, and the engine's rows)
    against the device's free memory: one line that names the need, the room and --chunk."""
    from paa_mj.sim import simulate_batch

    wp, _ = warp_modules
    monkeypatch.setattr(type(wp.get_device(DEVICE)), "free_memory", property(lambda self: 10_000))
    with pytest.raises(PaaError, match=r"would need .* of cpu memory for 4 worlds .*free memory can give .*--chunk"):
        simulate_batch(gymnast, np.zeros((4, 6)), 0.01, task=folded, engine="warp", device=DEVICE)


@needs_warp
@pytest.mark.slow  # runs MuJoCo Warp on Warp's CPU device (its kernels compiled on first use)
def test_packing_the_running_worlds_changes_no_result(gymnast, folded, warp_modules, monkeypatch):
    """The worlds still running are packed into fewer as others stop: every record of every rollout is the same,
    bit for bit, as without packing (each world's step reads its own rows only)."""
    from paa_mj.sim import simulate_batch
    from paa_mj.sim.warp import engine as warp_engine

    x0 = _grid_around_goal(folded)
    common = dict(task=folded, dt=0.005, engine="warp", device=DEVICE)
    monkeypatch.setattr(warp_engine, "SEGMENT", 8)
    monkeypatch.setattr(warp_engine, "PACK_MIN", 10**9)
    whole = simulate_batch(gymnast, x0, 1.5, **common)
    packs = []
    take = warp_engine._Worlds.take
    monkeypatch.setattr(warp_engine._Worlds, "take", lambda self, keep: packs.append(len(keep)) or take(self, keep))
    monkeypatch.setattr(warp_engine, "PACK_MIN", 2)
    monkeypatch.setattr(warp_engine, "PACK_WHEN", 0.99)
    packed = simulate_batch(gymnast, x0, 1.5, **common)
    assert packs and packs[0] < len(x0), packs  # packed at least once, while worlds still ran
    for field in ("status", "success", "switch_time", "t_end", "t_region", "final_state", "max_abs_tau", "int_tau2",
                  "work", "smoothness", "max_speed"):
        np.testing.assert_array_equal(getattr(packed, field), getattr(whole, field), err_msg=field)


@needs_warp
@pytest.mark.slow  # runs MuJoCo Warp on Warp's CPU device (its kernels compiled on first use)
def test_step_kernels_call_only_the_translations_of_step(warp_modules):
    """The bookkeeping of a step is written once: the Warp engine's kernels call, as Warp functions, exactly the
    translations of paa_mj.sim.compiled.step's (the law's switch, measure_into, command_into, account, verdict, apply_pushes,
    add_effort_work, state_status) and no function of their own, so that the engines cannot drift apart."""
    from paa_mj.control.energy import vcl_kernel
    from paa_mj.control.lqr import lqr_kernel
    from paa_mj.control.region import region_condition
    from paa_mj.sim.compiled import step
    from paa_mj.sim.warp import engine as warp_engine
    from paa_mj.sim.warp.translate import device_function

    wp, _ = warp_modules
    triple = (vcl_kernel, lqr_kernel, region_condition)
    control, after = warp_engine._kernels(wp, triple, 3)

    def translated(fn, bind=None):
        return device_function(wp, fn, bind=bind, real=wp.float64, state_size=6)

    law = translated(step.call_controller, dict(zip(("first", "second", "condition"), map(translated, triple))))
    expected_control = {law} | {translated(fn) for fn in (step.measure_into, step.command_into, step.account,
                                                          step.verdict, step.apply_pushes)}
    expected_after = {translated(step.add_effort_work), translated(step.state_status)}
    for kernel, expected in ((control, expected_control), (after, expected_after)):
        # by key (the translated function's module and name): Warp hands back the kernel it already built for the
        # same code, so a kernel made for another chain length may hold that length's translations, the same code
        called = {cell.cell_contents.key for cell in kernel.func.__closure__ or ()
                  if isinstance(cell.cell_contents, type(law))}
        assert called == {f.key for f in expected}, kernel.key


@needs_warp
@pytest.mark.slow  # runs MuJoCo Warp on Warp's CPU device (its kernels compiled on first use)
def test_disturbances_draw_the_same_noise_as_the_cpu_engine(gymnast, folded, warp_modules):
    """Measurement and torque noise (the same counter-based draws), delay and pushes, 0.2 s at 1 ms (RK4): the same
    steps, statuses, switches, modes and books, states within 2e-5, and the sums kept by the step's shared
    bookkeeping (peak torques, effort, work, smoothness, peak speed; measured within 5e-5 relative) within float32's
    drift."""
    from paa_mj.sim import Disturbances
    from paa_mj.sim.batch import build_plan, controllers_for
    from paa_mj.sim.compiled import engine
    from paa_mj.sim.warp import engine as warp_engine

    x0 = _grid_around_goal(folded)[::2]
    n = len(x0)
    pushes = np.zeros((n, 1, 5))
    pushes[::2, 0] = [0.05, 0.02, 30.0, 0.0, 0.0]
    disturbances = Disturbances(noise_std=np.tile([0.01, 0.02], (n, 1)), torque_noise=np.r_[0.0, 1.0] .repeat(n // 2),
                                delay_steps=np.arange(n) % 3, pushes=pushes, seed=4)
    controllers = controllers_for(gymnast, "vcl", n, folded)
    plan = build_plan(gymnast, folded, x0, 0.2, controllers, disturbances=disturbances)
    cpu = engine.run(plan, controllers).state
    dev = warp_engine.run(plan, controllers, device=DEVICE).state
    for field in ("step", "status", "switch", "mode"):
        np.testing.assert_array_equal(dev.rollouts[field], cpu.rollouts[field], err_msg=field)
    np.testing.assert_array_equal(dev.book, cpu.book)
    np.testing.assert_allclose(dev.last_state, cpu.last_state, rtol=0, atol=2e-5)
    assert np.any(cpu.rollouts["switch"] >= 0) and np.any(cpu.rollouts["switch"] < 0)  # both modes were met
    np.testing.assert_allclose(dev.peak, cpu.peak, rtol=2e-4)
    np.testing.assert_allclose(dev.last_tau, cpu.last_tau, rtol=0, atol=5e-3)
    for field in ("effort", "work", "smooth", "speed"):
        np.testing.assert_allclose(dev.rollouts[field], cpu.rollouts[field], rtol=2e-4, err_msg=field)


@needs_warp
@pytest.mark.slow  # runs MuJoCo Warp on Warp's CPU device (its kernels compiled on first use)
def test_basin_command_on_the_warp_engine(tmp_path, warp_modules):
    """``paa-mj basin --engine warp --device cpu``: the summary of the MuJoCo engine's run, and says its engine."""
    def basin(*extra):
        run = subprocess.run([sys.executable, "-m", "paa_mj.cli", "basin", "--grid", "2", "--t-final", "0.05",
                              "--scheduler", "inline", "--json", *extra], capture_output=True, text=True,
                             cwd=ROOT)
        assert run.returncode == 0, run.stderr
        return json.loads(run.stdout)

    cpu, dev = basin(), basin("--engine", "warp", "--device", DEVICE)
    assert dev.pop("engine") == "warp"
    assert dev["outcomes"] == cpu["outcomes"] and dev["success"] == cpu["success"]
    np.testing.assert_allclose(dev.pop("max_abs_tau"), cpu.pop("max_abs_tau"), rtol=1e-4)
    assert dev == cpu


@needs_warp
@pytest.mark.slow  # runs MuJoCo Warp on Warp's CPU device (its kernels compiled on first use)
def test_refusals_on_the_warp_engine(gymnast, folded, warp_modules):
    from paa_mj.sim import simulate_batch

    class Mine:
        def __init__(self, robot):
            pass

        def torque(self, q, qd, t):
            return np.zeros(q.shape[:-1] + (2,))

    x0 = np.r_[folded.goal, np.zeros(3)][None]
    with pytest.raises(PaaError, match=r"controller Mine has no law on the device .* use --engine cpu"):
        simulate_batch(gymnast, x0, 0.01, controller=Mine(gymnast), engine="warp", device=DEVICE)
    with pytest.raises(PaaError, match="records no trajectories"):
        simulate_batch(gymnast, x0, 0.01, record=True, engine="warp", device=DEVICE)
    with pytest.raises(PaaError, match="no Warp device 'cuda:7'"):
        simulate_batch(gymnast, x0, 0.01, engine="warp", device="cuda:7")


def test_every_built_in_controller_with_a_compiled_law_has_a_device_law_but_mpc():
    """The commands' help says the warp engine runs every built-in controller whose record declares a device law,
    every one but mpc (its iLQR is not translated): the list of device laws is theirs, derived from their records
    (each law's agreement with numba is tested above, each record's kernels translate:
    tests/test_registered_controllers.py)."""
    from paa_mj.control.registry import RECORDS
    from paa_mj.sim.warp.engine import DEVICE_LAWS, _device_laws

    compiled = {name for name, record in RECORDS.items() if record.compiled}
    assert sorted(DEVICE_LAWS) == sorted(compiled - {"mpc"}) and "mpc" in compiled
    assert set(_device_laws()) >= {k for name in DEVICE_LAWS for k in RECORDS[name].kernels}


def test_translation_refuses_what_it_does_not_cover():
    pytest.importorskip("warp")
    from paa_mj.sim.warp.translate import TranslationError, device_function
    from paa_mj.sim.warp.device import load_warp

    def uses_try(x):
        try:
            return x
        except ValueError:
            return x

    wp, _ = load_warp(mujoco=False)  # the translation needs Warp alone
    with pytest.raises(TranslationError, match=r"cannot translate .*uses_try \(line \d+\) to Warp: try"):
        device_function(wp, uses_try)


@needs_warp
@pytest.mark.slow  # runs MuJoCo Warp on Warp's CPU device (its kernels compiled on first use)
def test_vector_env_on_warp_agrees_with_mujoco(warp_modules):
    """GymnastVectorEnv(engine="warp"): the observations, rewards and information of the MuJoCo physics to float32
    rounding over 5 steps of 10 ms (50 physics steps), the same terminations; a copy steps as the original."""
    import copy

    pytest.importorskip("gymnasium")
    from paa_mj.envs.vector import GymnastVectorEnv

    kw = dict(num_envs=3, episode="balance")
    cpu, dev = GymnastVectorEnv(**kw), GymnastVectorEnv(engine="warp", device=DEVICE, **kw)
    obs_cpu, _ = cpu.reset(seed=3)
    obs_dev, _ = dev.reset(seed=3)
    np.testing.assert_allclose(obs_dev, obs_cpu, atol=1e-6)
    rng = np.random.default_rng(0)
    for _ in range(5):
        action = rng.uniform(-0.3, 0.3, (3, 2)).astype(np.float32)
        a, b = cpu.step(action), dev.step(action)
        np.testing.assert_allclose(b[0], a[0], atol=2e-5)
        np.testing.assert_allclose(b[1], a[1], atol=2e-5)
        np.testing.assert_array_equal(b[2], a[2])
        np.testing.assert_array_equal(b[4]["time"], a[4]["time"])
        np.testing.assert_allclose(b[4]["q"], a[4]["q"], atol=2e-5)
    twin = copy.deepcopy(dev)
    np.testing.assert_array_equal(twin.step(action)[0], dev.step(action)[0])
    with pytest.raises(ValueError, match="engine 'warp' steps MuJoCo Warp: physics must be 'mujoco'"):
        GymnastVectorEnv(engine="warp", physics="analytic", **kw)
    with pytest.raises(ValueError, match="engine must be one of"):
        GymnastVectorEnv(engine="jax", **kw)
