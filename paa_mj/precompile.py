"""Every compiled kernel of the package at once: ``paa-mj compile``.

The package's numba kernels are compiled the first time a process needs them and kept in numba's cache on disk
(a folder of the package's cache keyed by the digest of its code, :func:`paa_mj.provenance.key_numba_cache_by_code`),
so a later process only loads them. Processes started together on a fresh install (the workers of a Dask
cluster, pytest's workers, scripts run in parallel) each find the cache empty and each compile the same kernels,
about 27 CPU-s apiece on a 2-core machine. :func:`compile_kernels` compiles all of them once, beforehand; when
they are cached already it only loads them (about a second).

A kernel is compiled for the argument types it is called with, so the only sure way to compile it as the
package uses it is to call it as the package does: each stage below runs the package's own code on a tiny case
(a rollout of 10 ms, a batch of two starts, one step of each Gymnasium environment). :func:`uncached_kernels`
names the cached kernels whose cache index is still missing afterwards (a test holds it empty).
"""
from __future__ import annotations

import importlib
import pkgutil
import time
from pathlib import Path

import numpy as np

#: A rollout of this many seconds [s] compiles everything a longer one runs.
_T = 0.01


class _Damped:
    """A user's Python controller as ``simulate`` loads one (``torque`` only): the engine's Python path."""

    def __init__(self, robot):
        self.gain = 0.1

    def torque(self, q, qd, t):
        return -self.gain * qd[..., 1:]


def _rollouts():
    from .model import load_robot
    from .sim.analytic.engine import simulate_analytic
    from .sim.batch import simulate_batch
    from .sim.rollout import simulate_mujoco

    gymnast = load_robot("gymnast")
    simulate_mujoco(gymnast, "vcl", t_final=_T)
    simulate_analytic(gymnast, "vcl", t_final=_T)
    simulate_mujoco(gymnast, _Damped(gymnast), t_final=_T)
    simulate_batch(gymnast, np.zeros((2, 6)), t_final=_T)


def _family():
    from .control.registry import RECORDS, make_controller
    from .model import load_robot
    from .sim.rollout import simulate_mujoco

    acrobot = load_robot("acrobot")
    # every compiled law that needs no plan, on the acrobot's stretched goal (every controller's record says
    # whether it applies there): a short rollout, and its law over a batch of states as ``torque`` evaluates it
    for name, record in RECORDS.items():
        if record.compiled and not record.plans and record.applies_to(2, "stretched"):
            simulate_mujoco(acrobot, name, t_final=_T, task="stretched")
            make_controller(name, acrobot, task="stretched").torque(np.zeros((2, 2)), np.zeros((2, 2)))
    model = acrobot.analytic
    q = np.zeros((2, 2))
    model.mass_matrix(q), model.bias(q, q), model.potential(q), model.gravity_jacobian(q)


def _environments():
    try:
        from .envs.single import GymnastEnv
        from .envs.spaces import observation
        from .envs.stepper import finish_rows
        from .envs.vector import GymnastVectorEnv, physics_only
    except ImportError:  # Gymnasium is an extra: without it there is nothing to compile here
        return
    from .mujoco_log import mujoco_log_off

    for physics in ("mujoco", "analytic"):
        for env in (GymnastEnv(physics=physics), GymnastVectorEnv(2, physics=physics)):
            env.reset(seed=0)
            env.step(np.zeros(env.action_space.shape, env.action_space.dtype))
            if physics == "mujoco" and isinstance(env, GymnastVectorEnv):
                with mujoco_log_off():
                    physics_only(env.model._address, env._robots.physics.addresses, np.zeros((1, 2, 2)), 1)
                # what the engine on MuJoCo Warp runs on the host after its worlds' step
                finish_rows(env._robots.rules, env._robots.episodes, np.zeros(0, np.int64), np.zeros(2, np.int32))
            env.close()
    observation(np.zeros(3), np.zeros((2, 3)))  # the observation map of any states, broadcast


def _protocols():
    from .control.registry import make_controller
    from .model import load_robot
    from .realaigym import simulator as protocol
    from .realaigym.study import Runs, plant, their_times

    acrobot = load_robot("realaigym_acrobot")
    times = their_times(_T)
    reset = protocol.reset_record([0.0], np.zeros((2, 2)), 0.2)
    for controller in (make_controller("spong", acrobot, task="stretched"), _Damped(acrobot)):
        runs = Runs(acrobot, controller)
        runs.run(plant(acrobot), np.zeros(4), times, perturbation=np.zeros((2, 5)))
        runs.run(plant(acrobot, global_test=True), np.zeros(4), times, reset=reset)


def _bounds():
    from .model import load_robot
    from .task import Task
    from .theory.kd_search import kd_min_search

    chain4 = load_robot("chain4")  # the search itself: a certificate kept from an earlier command would skip it
    kd_min_search(chain4.analytic, Task.named("folded", chain4).goal_energy(chain4.analytic))


def _signed():
    from .jit import LazyDispatcher

    for kernel in cached_kernels().values():
        if isinstance(kernel, LazyDispatcher):
            kernel.compile_lazily()


#: The stages of :func:`compile_kernels`: what each compiles, and the code that compiles it.
STAGES = (("the rollouts: compiled and Python controllers, single and batched", _rollouts),
          ("the family: the chain's dynamics and controllers", _family),
          ("the Gymnasium environments, single and vector", _environments),
          ("RealAIGym's simulator (paa-mj realaigym)", _protocols),
          ("the certified search for kD_min (41) of a chain (paa-mj theory)", _bounds),
          ("every other kernel of a fixed signature (controllers and conditions no stage ran)", _signed))


def compile_kernels(progress=None) -> list[dict]:
    """Compile (or load from the cache) every kernel of the package; the CPU-seconds of each stage.

    Kernels of a fixed signature (every controller's and condition's) compile at their first use
    (:func:`paa_mj.jit.lazy_njit`), in the stage that first runs them; the last stage compiles those no stage ran.
    ``progress``: called with each stage's description as it starts.
    """
    start = time.process_time()
    from .control import registry  # noqa: F401  (imports every controller's module)

    stages = []
    for description, stage in STAGES:
        if progress is not None:
            progress(description)
        stage()
        now = time.process_time()
        stages.append({"stage": description, "cpu_s": now - start})
        start = now
    return stages


def cached_kernels() -> dict:
    """Every numba kernel of the package cached on disk, by its qualified name (the package's modules imported).

    A helper compiled inline into its caller (``inline="always"``) has no machine code of its own to cache: it is
    compiled, and cached, as part of its caller, and is not listed."""
    from numba.core.caching import FunctionCache
    from numba.core.registry import CPUDispatcher

    import paa_mj

    kernels = {}
    for info in pkgutil.walk_packages(paa_mj.__path__, "paa_mj."):
        if info.name.startswith("paa_mj.cli"):
            continue
        try:
            module = importlib.import_module(info.name)
        except ImportError:  # a module of an extra that is not installed
            continue
        for name, value in vars(module).items():
            if (isinstance(value, CPUDispatcher) and value.__module__ == module.__name__
                    and isinstance(value._cache, FunctionCache) and value.targetoptions.get("inline") != "always"):
                kernels[f"{module.__name__}.{name}"] = value
    return kernels


def uncached_kernels() -> list[str]:
    """The cached kernels (:func:`cached_kernels`) with no index in numba's cache folder."""
    return sorted(name for name, kernel in cached_kernels().items()
                  if not Path(kernel._cache._cache_file._index_path).exists())


def kernels_of_several_signatures() -> dict:
    """The cached kernels this process compiled or loaded for more than one signature, by name, with how many.

    After :func:`compile_kernels` it is empty: a helper called with two array layouts (a strided slice here, a
    contiguous array there) would be compiled twice, about a second of compilation for nothing each time.
    """
    return {name: len(kernel.signatures) for name, kernel in sorted(cached_kernels().items())
            if len(kernel.signatures) > 1}


def cache_folder() -> str:
    """Where numba keeps the package's compiled kernels."""
    from numba.core import config

    return str(config.CACHE_DIR or "beside the sources (__pycache__)")
