"""``paa-mj bench``: costs measured in one process, reported as ratios of things measured together.

* bare: ``mj_step`` alone from a Python loop (RK4, 1 ms, the Table 1 robot unless ``--robot`` names another), one thread;
* single: a closed-loop MuJoCo rollout of the compiled ``vcl`` (controller + step + recording), per step;
* python: the same with the controller called through ``torque`` from Python every step;
* batch: :func:`paa_mj.sim.batch.simulate_batch` of random states, all cores, no early stop, per state-step;
* mujoco.batch: the batch's work (its plan, ``mujoco_batch_seconds`` long) through the engine and through MuJoCo's
  batch API (:mod:`paa_mj.sim.compiled.mujoco_batch`), measured in turns: ``mujoco_batch_vs_engine_ratio`` (time of
  ``mujoco.batch`` / time of the engine, all cores, wall clock), ``mujoco_batch_vs_engine_ratio_1thread`` (the same
  on one thread, CPU time) and ``mujoco_batch_agreement`` (whether the two outcomes are identical bit for bit, the
  largest difference of their final states, whether every rollout's outcome is the same);
* basin: the 16 x 16 (q1, q2) basin of Table 1 over 30 s through the batch engine (rollouts retire on
  their own), its time divided by 256 x 30000 bare steps (``basin_effective_ratio``);
* analytic: the ``solve_ivp`` reference of the 30 s Table 1 run against the MuJoCo rollout;
* vector env (with Gymnasium installed): CPU time per environment step of
  :class:`~paa_mj.envs.vector.GymnastVectorEnv` of 64 robots against 64 :class:`~paa_mj.envs.single.GymnastEnv`
  stepped one after the other with the same actions (``vector_env_speedup``: single / vector), against
  them in Gymnasium's ``SyncVectorEnv`` (``vector_env_speedup_vs_sync``), and the ``mj_step`` calls alone of
  the same steps: ``vector_env_physics_share`` (physics / vector) and ``vector_env_speedup_bound``
  (single / physics, the most any vector environment on MuJoCo's ``mj_step`` can reach), at the default
  10 ms control period (10 RK4 steps, mostly physics) and at 1 ms (``..._frame_skip_1``, mostly Python);
  the same with ``physics="analytic"`` (RK4 of the robot's own equations, :mod:`paa_mj.sim.analytic.rk4`):
  ``vector_env_analytic_speedup`` (single / vector, both analytic) and
  ``vector_env_analytic_vs_single_mujoco`` (single environments on MuJoCo, the default, / the analytic vector);
* mpc: with RealAIGym's row, the ``mpc`` controller's CPU time per control call along their global v3 test, one
  core (:func:`paa_mj.realaigym.bench.mpc_call_cost`: ``mpc_call_median_us``, ``mpc_call_p99_us``,
  ``mpc_call_max_us``);
* kD_min: CPU time of the certified search for kD_min (41) of a chain of 7 uniform rods, folded goal
  (:func:`~paa_mj.theory.kd_search.kd_min_search`, all cores; ``kd_min_cpu_s``, ``kd_min_boxes``).

Every ratio divides two costs measured in this run, on this machine.
"""
from __future__ import annotations

import os
import time

import mujoco
import numpy as np

from ..control.registry import make_controller
from ..limits import check_steps
from ..model.robot import load_robot
from ..task import Task, as_task
from ..sim.analytic.engine import simulate_analytic
from ..sim.compiled import engine, mujoco_batch
from ..sim.batch import build_plan, simulate_batch
from ..sim.rollout import simulate_mujoco


class _Uncompiled:
    """A controller seen only through ``torque`` (how a user's Python controller runs)."""

    def __init__(self, controller):
        self.controller = controller

    @property
    def mode(self):
        return getattr(self.controller, "mode", 0)

    def torque(self, q, qd, t):
        return self.controller.torque(q, qd, t)

    def reset(self):
        self.controller.reset()


class _HoldStraight:
    """A two-line PD law in plain NumPy: the user's controller of the README, as a hand-written loop would run it."""

    def __init__(self, robot):
        self.gain = 0.05 * robot.analytic.gravity_constants[0]

    def torque(self, q, qd, t):
        return -self.gain * (q[..., 1:] + 0.5 * qd[..., 1:])


def python_loop_costs(robot, seconds=2.0, repeats=3):
    """CPU time per step [s] of a user's Python controller: in a plain ``mj_step`` loop written by hand, and
    through the package's engine (which also keeps outcomes, limits and the state checks); (hand, engine).

    Both count steps alone: the hand loop's model and ``MjData`` are made before its clock, and the engine's
    cost is that of its extra steps in a run ten times longer than another (a run's own setup, a model copy,
    ``MjData``, the plan and the results, some milliseconds, would otherwise count as ~1 us a step).
    """
    controller = _HoldStraight(robot)
    model = robot.model.__copy__()
    data = mujoco.MjData(model)
    steps = round(seconds / model.opt.timestep)
    n = robot.params.n_links
    start = Task.named("folded", robot).start

    def by_hand():
        data.qpos[:], data.qvel[:] = start[:n], start[n:]
        for k in range(steps):
            data.ctrl[:] = controller.torque(data.qpos, data.qvel, k * model.opt.timestep)
            mujoco.mj_step(model, data)

    def through_engine(length):
        return lambda: simulate_batch(robot, start[None], length, controller=controller, retire=False)

    through_engine(seconds)()  # its compiled parts loaded before the clock
    long, short = (_best_of(through_engine(length), repeats, time.process_time) for length in (seconds, seconds / 10))
    return _best_of(by_hand, repeats, time.process_time) / steps, (long - short) / (steps - round(steps / 10))


def _best_of(fn, repeats, clock=time.perf_counter):
    """The least time of ``repeats`` runs by ``clock`` [s] (the run least disturbed by other work)."""
    best = np.inf
    for _ in range(repeats):
        start = clock()
        _whole(fn())
        best = min(best, clock() - start)
    return best


def _whole(result):
    """``result`` of a measured run, or ``KeyboardInterrupt`` where Ctrl-C or SIGTERM cut it short: the time of a
    run cut short is no measurement. Reads an engine's outcome, a trajectory's meta and a study's summary."""
    summary = result[0] if isinstance(result, tuple) and result and isinstance(result[0], dict) else result
    meta = getattr(result, "meta", None)
    if getattr(result, "interrupted", False) or (isinstance(meta, dict) and meta.get("interrupted")) or \
            (isinstance(summary, dict) and summary.get("interrupted")):
        raise KeyboardInterrupt
    return result


def _cpu_best_of(fn, repeats):
    """The least CPU time of ``repeats`` runs [s] (this process: the stepping runs in the calling thread)."""
    return _best_of(fn, repeats, time.process_time)


def vector_env_costs(n_envs=64, steps=50, repeats=3, frame_skip=10):
    """CPU time per environment step [s] of ``n_envs`` single environments and of one vector environment, on
    MuJoCo's physics and on the analytic physics (``physics="analytic"``: RK4 of the robot's own equations).

    Both run the kip task (no termination, so no reset inside the clock: every run starts from a reset outside
    it) with the same random actions, measured in turns (single, sync, vector, physics, single, ...) so that
    other work on the machine weighs on all alike. A dict of costs, or None without Gymnasium:

    * ``single``: the ``n_envs`` :class:`~paa_mj.envs.single.GymnastEnv` stepped one after the other in a Python
      loop, the cheapest way to run them one by one (no wrapper, no batching of the results);
    * ``sync``: the same environments in :class:`gymnasium.vector.SyncVectorEnv` (what Gymnasium builds for an
      environment without its own vector version: results batched, as the vector environment returns them);
    * ``vector``: :class:`~paa_mj.envs.vector.GymnastVectorEnv`, one thread;
    * ``physics``: the ``mj_step`` calls alone of the same steps (:func:`~paa_mj.envs.vector.physics_only` on the
      vector environment's MjData, same torques, same starts): what no environment can go below, so
      ``single / physics`` bounds the speedup ``single / vector``;
    * ``single_analytic``, ``vector_analytic``: ``single`` and ``vector`` with ``physics="analytic"``.
    """
    try:
        from gymnasium.vector import SyncVectorEnv

        from ..envs.single import GymnastEnv
        from ..envs.spaces import action_to_torque
        from ..envs.vector import GymnastVectorEnv, physics_only
        from ..mujoco_log import mujoco_log_off
    except ImportError:
        return None
    options = dict(episode="kip", frame_skip=frame_skip, max_episode_seconds=1e4)
    singles = [GymnastEnv(**options) for _ in range(n_envs)]
    sync = SyncVectorEnv([lambda: GymnastEnv(**options) for _ in range(n_envs)])
    vector = GymnastVectorEnv(n_envs, **options)
    singles_analytic = [GymnastEnv(physics="analytic", **options) for _ in range(n_envs)]
    vector_analytic = GymnastVectorEnv(n_envs, physics="analytic", **options)
    actions = np.random.default_rng(0).uniform(-1, 1, (steps, n_envs, 2)).astype(np.float32)
    tau = np.ascontiguousarray(action_to_torque(actions, vector.torque_limits, vector.normalize_actions))
    robots = vector._robots

    def reset_all(envs):
        for i, env in enumerate(envs):
            env.reset(seed=i)

    def run_all(envs):
        for k in range(steps):
            for env, action in zip(envs, actions[k]):
                env.step(action)

    def run_sync():
        for k in range(steps):
            sync.step(actions[k])

    def run_vector(vector_env):
        for k in range(steps):
            vector_env.step(actions[k])

    def run_physics():
        with mujoco_log_off():
            physics_only(vector.model._address, robots.physics.addresses, tau, robots.physics.frame_skip)

    cases = {"single": (lambda: reset_all(singles), lambda: run_all(singles)),
             "sync": (lambda: sync.reset(seed=0), run_sync),
             "vector": (lambda: vector.reset(seed=0), lambda: run_vector(vector)),
             "physics": (lambda: vector.reset(seed=0), run_physics),
             "single_analytic": (lambda: reset_all(singles_analytic), lambda: run_all(singles_analytic)),
             "vector_analytic": (lambda: vector_analytic.reset(seed=0), lambda: run_vector(vector_analytic))}
    best = dict.fromkeys(cases, np.inf)
    for turn in range(repeats + 1):  # the first turn loads the compiled kernels and warms the caches
        for name, (reset, run) in cases.items():
            reset()
            start = time.process_time()
            run()
            if turn:
                best[name] = min(best[name], time.process_time() - start)
    sync.close()
    vector.close()
    vector_analytic.close()
    return {name: cost / (n_envs * steps) for name, cost in best.items()}


def _bare_step_cost(robot, steps, repeats):
    """CPU-time per bare ``mj_step`` of the robot's model, called from a Python loop [s] (the best of ``repeats``)."""
    model = robot.model
    data = mujoco.MjData(model)
    n = robot.params.n_links
    start = np.resize([-2.0, -1.0, 0.5], n), np.resize([1.0, -2.0, 0.5], n)

    def bare():
        data.qpos[:], data.qvel[:] = start
        for _ in range(steps):
            mujoco.mj_step(model, data)

    return _best_of(bare, repeats) / steps


def mujoco_batch_rows(robot, task, controller, x0, seconds, repeats) -> dict:
    """The engine and ``mujoco.batch`` head to head on one plan (``x0``, ``seconds`` long, no early stop): the
    bench's ``mujoco_batch_*`` rows (empty without MuJoCo's batch API).

    Measured in turns (engine, batch, engine, batch, ...), so that other work on the machine weighs on both alike:
    on all cores by the wall clock, on one thread by CPU time; each the best of ``repeats``.
    """
    if not mujoco_batch.available():
        return {}
    controllers = [controller] * len(x0)
    plan = build_plan(robot, task, x0, seconds, controllers, retire=False)
    runs = {"engine": engine.run, "mujoco_batch": mujoco_batch.run}
    outcomes = {name: _whole(fn(plan, controllers)) for name, fn in runs.items()}  # compiled parts loaded first
    cases = {(name, nthread): (fn, nthread) for nthread in (None, 1) for name, fn in runs.items()}
    best = dict.fromkeys(cases, np.inf)
    for _ in range(repeats):
        for key, (fn, nthread) in cases.items():
            clock = time.perf_counter if nthread is None else time.process_time
            start = clock()
            _whole(fn(plan, controllers, nthread=nthread))
            best[key] = min(best[key], clock() - start)
    state_steps = len(plan) * plan.n_steps
    return {"mujoco_batch_rollouts": len(plan), "mujoco_batch_t_final": plan.n_steps * plan.dt,
            "mujoco_batch_state_step_us": best["mujoco_batch", None] / state_steps * 1e6,
            "mujoco_batch_engine_state_step_us": best["engine", None] / state_steps * 1e6,
            "mujoco_batch_vs_engine_ratio": best["mujoco_batch", None] / best["engine", None],
            "mujoco_batch_vs_engine_ratio_1thread": best["mujoco_batch", 1] / best["engine", 1],
            "mujoco_batch_agreement": mujoco_batch.agreement(outcomes["engine"], outcomes["mujoco_batch"])}


def run_bench(batch_size=1024, batch_seconds=2.0, repeats=3, basin_grid=16, basin_seconds=30.0, progress=False,
              vector_envs=64, vector_steps=50, robot="gymnast", task=None, rollout_seconds=30.0,
              python_seconds=2.0, bare_steps=20000, realaigym=None, kd_links=7,
              mujoco_batch_seconds=0.5):
    """Measure every cost of the module docstring; each is the best of ``repeats`` runs (the basin: of 2).

    ``rollout_seconds`` [s] is the length of the single MuJoCo and analytic rollouts (``mujoco_30s_seconds``,
    ``analytic_30s_seconds``: 30 s unless asked otherwise, ``rollout_t_final`` in the result), ``python_seconds``
    [s] that of the Python controllers' runs, ``bare_steps`` the number of bare ``mj_step`` calls timed;
    ``realaigym``: a function ``(bare_step, progress) -> rows`` that also times one whole robustness v2 of
    RealAIGym's (:func:`paa_mj.realaigym.bench.realaigym_rows`: ``realaigym_robustness_v2_cpu_s``; ``paa-mj bench``
    passes it), None: not timed;
    ``kd_links``: the links of the chain whose kD_min (41) is timed; ``mujoco_batch_seconds`` [s]: the length of the
    batch's rollouts in the ``mujoco.batch`` head to head.

    ``robot`` (a name or MJCF path) and ``task`` (a Task or a goal's name, default the folded one) choose the
    robot and task measured; the vector environment is the gymnast's, measured for it alone.
    """
    from .basin import basin

    name = robot
    robot = load_robot(robot)
    dt = robot.model.opt.timestep
    n = robot.params.n_links
    task = as_task(task, robot)
    # the batch and its head to head, counted before the other measurements spend their minutes
    check_steps(batch_size * repeats * (round(batch_seconds / dt) + round(mujoco_batch_seconds / dt)),
                f"{repeats} batches of {batch_size} rollouts", "--batch-size", links=robot.params.n_links,
                runs=batch_size)
    start = task.start
    ctrl = make_controller("vcl", robot, task=task)
    t_single = rollout_seconds
    bare_step = _bare_step_cost(robot, bare_steps, repeats)
    rollouts = _single_rollout_rows(robot, task, ctrl, t_single, python_seconds, bare_step, repeats)

    rng = np.random.default_rng(0)
    x0 = np.zeros((batch_size, 2 * n))
    x0[:, :n] = rng.uniform(-np.pi, np.pi, (batch_size, n))
    simulate_batch(robot, x0[:4], 0.01, task=task, controller=ctrl)
    batch = _best_of(lambda: simulate_batch(robot, x0, batch_seconds, task=task, controller=ctrl, retire=False,
                                            progress=progress), repeats)
    batch_state_step = batch / (batch_size * round(batch_seconds / dt))
    head_to_head = mujoco_batch_rows(robot, task, ctrl, x0, mujoco_batch_seconds, repeats)

    basin_seconds_taken = _best_of(lambda: basin(robot, (0, 1), basin_grid, basin_seconds, task=task,
                                                 progress=progress, scheduler="inline"), min(repeats, 2))
    basin_cell_steps = basin_grid**2 * round(basin_seconds / dt)

    simulate_analytic(robot, make_controller("vcl", robot, task=task), start, 0.01, task=task)
    analytic = _best_of(lambda: simulate_analytic(robot, make_controller("vcl", robot, task=task), start, t_single,
                                                  task=task), 1)
    vector = _vector_rows(vector_envs, vector_steps, repeats) if name == "gymnast" and task.name == "folded" \
        else {}
    protocols = realaigym(bare_step, progress) if realaigym else {}
    bound = _kd_min_rows(kd_links)
    return {
        "robot": robot.name, "goal": task.name,
        "machine_cores": os.cpu_count(),
        "mujoco_version": mujoco.__version__,
        "bare_mj_step_us": bare_step * 1e6,
        **rollouts,
        "batch_size": batch_size,
        "batch_state_step_us": batch_state_step * 1e6,
        "batch_step_ratio": batch_state_step / bare_step,
        **head_to_head,
        "basin_grid": basin_grid,
        "basin_t_final": basin_seconds,
        "basin_seconds": basin_seconds_taken,
        "basin_effective_ratio": basin_seconds_taken / (basin_cell_steps * bare_step),
        "rollout_t_final": t_single,
        "analytic_30s_seconds": analytic,
        "analytic_to_mujoco_ratio": analytic / rollouts["mujoco_30s_seconds"],
        **vector,
        **protocols,
        **bound,
    }


def _single_rollout_rows(robot, task, ctrl, t_single, python_seconds, bare_step, repeats) -> dict:
    """One rollout's step under the compiled controller and under its Python form, against the bare ``mj_step``
    (``bare_step`` [s]), and the Python controllers' hand loop against the engine's."""
    dt = robot.model.opt.timestep
    start = task.start
    simulate_mujoco(robot, ctrl, start, 0.01, task=task)  # compile (or load) the kernels first
    single = _best_of(lambda: simulate_mujoco(robot, ctrl, start, t_single, task=task), repeats)
    single_step = single / round(t_single / dt)
    simulate_mujoco(robot, _Uncompiled(ctrl), start, 0.01, task=task)  # its compiled parts too, before the clock
    python_step = _best_of(lambda: simulate_mujoco(robot, _Uncompiled(ctrl), start, python_seconds, task=task), 1) \
        / round(python_seconds / dt)
    hand_step, engine_step = python_loop_costs(robot, seconds=python_seconds, repeats=repeats)
    return {"single_step_us": single_step * 1e6, "single_step_ratio": single_step / bare_step,
            "python_controller_step_us": python_step * 1e6, "python_step_ratio": python_step / bare_step,
            "python_pd_hand_loop_us": hand_step * 1e6, "python_pd_engine_us": engine_step * 1e6,
            "python_step_vs_hand_loop": engine_step / hand_step, "mujoco_30s_seconds": single}


def _kd_min_rows(n_links) -> dict:
    """CPU time and boxes of the certified search for kD_min (41) of ``n_links`` uniform rods (1 kg, 1 m), folded."""
    from ..model.dynamics import AnalyticModel
    from ..model.params import RobotParams
    from ..theory.kd_search import kd_min_search

    def search(n):
        am = AnalyticModel.from_params(RobotParams.uniform_rods(np.ones(n), np.ones(n)))
        return kd_min_search(am, Task.named("folded", am).goal_energy(am))

    search(3)  # compile (or load) the kernels first
    start = time.process_time()
    kd = search(n_links)
    return {"kd_min_links": n_links, "kd_min_cpu_s": time.process_time() - start, "kd_min_boxes": kd.boxes,
            "kd_min_certified": kd.certified}


def _vector_rows(vector_envs, vector_steps, repeats) -> dict:
    """The vector environments' rows of the bench (empty without Gymnasium), at 10 and 1 ms control periods."""
    costs = vector_env_costs(vector_envs, vector_steps, repeats)
    if costs is None:
        return {}
    vector = {"vector_env_num_envs": vector_envs}
    for suffix, c in (("", costs), ("_frame_skip_1", vector_env_costs(vector_envs, vector_steps, repeats, 1))):
        vector |= {f"single_env_step_us{suffix}": c["single"] * 1e6,
                   f"sync_vector_env_step_us{suffix}": c["sync"] * 1e6,
                   f"vector_env_step_us{suffix}": c["vector"] * 1e6,
                   f"vector_env_physics_us{suffix}": c["physics"] * 1e6,
                   f"vector_env_speedup{suffix}": c["single"] / c["vector"],
                   f"vector_env_speedup_vs_sync{suffix}": c["sync"] / c["vector"],
                   f"vector_env_speedup_bound{suffix}": c["single"] / c["physics"],
                   f"vector_env_physics_share{suffix}": c["physics"] / c["vector"],
                   f"single_env_analytic_step_us{suffix}": c["single_analytic"] * 1e6,
                   f"vector_env_analytic_step_us{suffix}": c["vector_analytic"] * 1e6,
                   f"vector_env_analytic_speedup{suffix}": c["single_analytic"] / c["vector_analytic"],
                   f"vector_env_analytic_vs_single_mujoco{suffix}": c["single"] / c["vector_analytic"]}
    return vector


def format_bench(r) -> str:
    return "\n".join([
        f"paa-mj bench ({r['machine_cores']} cores, MuJoCo {r['mujoco_version']}, robot {r.get('robot', 'gymnast')}"
        f"{', ' + r['goal'] + ' goal' if r.get('goal', 'folded') != 'folded' else ''}, RK4 1 ms)",
        f"  bare mj_step (Python loop)         {r['bare_mj_step_us']:8.2f} us/step        = 1",
        f"  closed loop, compiled controller   {r['single_step_us']:8.2f} us/step        single_step_ratio = {r['single_step_ratio']:.2f}",
        f"  closed loop, controller in Python  {r['python_controller_step_us']:8.2f} us/step        ratio = {r['python_step_ratio']:.1f}",
        f"  a PD law in Python: engine {r['python_pd_engine_us']:.2f}, hand-written mj_step loop"
        f" {r['python_pd_hand_loop_us']:.2f} us CPU/step  python_step_vs_hand_loop = {r['python_step_vs_hand_loop']:.2f}",
        f"  batch of {r['batch_size']}, all cores         {r['batch_state_step_us']:8.2f} us/state-step  batch_step_ratio = {r['batch_step_ratio']:.2f}",
    ] + ([
        f"  the batch's plan ({r['mujoco_batch_rollouts']} x {r['mujoco_batch_t_final']:g} s) through mujoco.batch:"
        f" mujoco_batch_vs_engine_ratio = {r['mujoco_batch_vs_engine_ratio']:.2f} (all cores),"
        f" {r['mujoco_batch_vs_engine_ratio_1thread']:.2f} (one thread, CPU);"
        f" {'identical bit for bit' if r['mujoco_batch_agreement']['identical'] else 'NOT identical'}"
        f" (final states differ by {r['mujoco_batch_agreement']['max_abs_final_state_diff']:.3g})"
    ] if "mujoco_batch_vs_engine_ratio" in r else []) + [
        f"  basin {r['basin_grid']} x {r['basin_grid']}, {r['basin_t_final']:g} s             {r['basin_seconds']:8.2f} s              basin_effective_ratio = {r['basin_effective_ratio']:.2f}",
        f"  {r['rollout_t_final']:g} s Table 1 run: solve_ivp {r['analytic_30s_seconds']:.2f} s, MuJoCo {r['mujoco_30s_seconds']:.2f} s"
        f" (ratio {r['analytic_to_mujoco_ratio']:.1f})",
        f"  kD_min (41), {r['kd_min_links']} uniform links, certified {r['kd_min_certified']}:"
        f" {r['kd_min_cpu_s']:.1f} CPU-s, {r['kd_min_boxes']} boxes",
    ] + ([
        f"  RealAIGym robustness v2 (spong, {r['realaigym_robustness_v2_runs']} runs of 10 s at 2 ms)"
        f" {r['realaigym_robustness_v2_cpu_s']:.1f} CPU-s   realaigym_step_ratio = {r['realaigym_step_ratio']:.2f}",
        f"  mpc per control call (their global v3, {r['mpc_calls']} calls, one core): median"
        f" {r['mpc_call_median_us']:.1f} us, p99 {r['mpc_call_p99_us']:.0f} us, worst {r['mpc_call_max_us']:.0f} us"
        " (their control period: 2000 us)"
    ] if "realaigym_step_ratio" in r else []) + ([
        f"  Gymnasium, {r['vector_env_num_envs']} robots, {period} step: single {r[f'single_env_step_us{s}']:.2f},"
        f" SyncVectorEnv {r[f'sync_vector_env_step_us{s}']:.2f}, vector {r[f'vector_env_step_us{s}']:.2f},"
        f" its mj_step alone {r[f'vector_env_physics_us{s}']:.2f} us CPU/env-step\n"
        f"      vector_env_speedup{s} = {r[f'vector_env_speedup{s}']:.2f}"
        f" (at most {r[f'vector_env_speedup_bound{s}']:.2f}, single / mj_step alone;"
        f" physics {100 * r[f'vector_env_physics_share{s}']:.0f}% of the vector step),"
        f" vs SyncVectorEnv {r[f'vector_env_speedup_vs_sync{s}']:.2f}\n"
        f"      physics=\"analytic\": single {r[f'single_env_analytic_step_us{s}']:.2f}, vector"
        f" {r[f'vector_env_analytic_step_us{s}']:.2f} us CPU/env-step; vector_env_analytic_speedup{s} ="
        f" {r[f'vector_env_analytic_speedup{s}']:.2f}, against single environments on MuJoCo"
        f" {r[f'vector_env_analytic_vs_single_mujoco{s}']:.2f}"
        for period, s in (("10 ms", ""), ("1 ms", "_frame_skip_1"))
    ] if "vector_env_speedup" in r else []))
