"""RealAIGym's simulator on a Warp device (``paa-mj realaigym --engine warp``), checked on Warp's CPU device.

The device runs the translations of the very functions the CPU's rollout calls, in float64: held here, each kind
of run of the three protocols (the model's changes, both noises, responsiveness, delay, pulses, the global test's
resets, a blow-up) follows the CPU's to 1e-9 over 300 steps, and a whole robustness protocol on fewer levels gives the CPU's
summary. Skipped where Warp is not installed, except the refusals, which need no device.
"""
import json

import numpy as np
import pytest

from paa_mj.control.registry import ControllerSpec
from paa_mj.realaigym import simulator as protocol
from paa_mj.sim.warp.device import warp_available
from paa_mj.realaigym import study as rg
from paa_mj.task import Task

needs_warp = pytest.mark.skipif(not warp_available(), reason="warp and mujoco_warp not installed (paa_mj[gpu])")


@pytest.fixture(scope="module")
def gymnast_vcl(gymnast):
    task = Task.named("folded", gymnast)
    return task, ControllerSpec("vcl", task=task).build(gymnast)


def _runs_of_every_kind(robot, T):
    """(P, x0, disturbances) of each kind of run, from near the folded goal and from hanging."""
    n = robot.params.n_links
    rng = np.random.RandomState(0)
    nominal = rg.plant(robot)
    near = np.r_[0.2, -np.pi + 0.3, -0.2, 0.5, -0.4, 0.3]
    pulses = np.zeros((n, 400))
    pulses[1, 40:90], pulses[2, 100:130] = 3.0, -4.0
    normals = rng.standard_normal((len(T) - 1, 5 * n))
    targets = np.array([[-2.0, 0.5, -0.5], [-1.0, 0.2, 0.1]])
    reset = protocol.reset_record([0.1], targets, 0.2)
    blow_up = np.zeros((n, len(T) - 1))
    blow_up[1, 249] = np.inf  # at the last step of the device's first segment
    return [
        (nominal, near, {"perturbation": blow_up}),
        (nominal, rg.hanging(n), {}),
        (nominal, near, {}),
        (rg.plant(robot, ("Ir", 8e-5)), near, {}),
        (rg.plant(robot, ("b2", 0.07)), near, {}),
        (rg.plant(robot, ("cf3", -0.15)), near, {}),
        (rg.plant(robot, ("m2", 1.2 * robot.params.m[1])), near, {}),
        (nominal, near, {"sigma_meas": np.r_[np.zeros(n), np.full(n, 0.3)], "normals": normals}),
        (nominal, near, {"sigma_u": np.r_[0.0, 0.9, 0.9], "normals": normals}),
        (nominal, near, {"responsiveness": 0.4}),
        (nominal, near, {"delay": 0.02}),
        (nominal, near, {"perturbation": pulses}),
        (rg.plant(robot, global_test=True), rg.hanging(n), {"reset": reset}),
    ]


@needs_warp
@pytest.mark.slow  # thirteen kinds of run on Warp's CPU device (16 CPU-s)
def test_every_kind_of_run_follows_the_cpu(gymnast, gymnast_vcl):
    _, controller = gymnast_vcl
    T = rg.their_times(0.6)
    runs = _runs_of_every_kind(gymnast, T)
    # each run's own record: the reset's is written as the run goes
    cpu = rg.Runs(gymnast, controller).run_many([(P, x, {k: (v.copy() if k == "reset" else v) for k, v in d.items()})
                                                 for P, x, d in runs], T)
    told = []
    device = rg.Runs(gymnast, controller, "warp", "cpu").run_many(runs, T, advanced=told.append)
    assert sum(told) == len(runs) * (len(T) - 1)
    for (Xc, Uc), (Xd, Ud) in zip(cpu, device):
        assert Xc.shape == Xd.shape and Uc.shape == Ud.shape
        np.testing.assert_allclose(Xd, Xc, rtol=0, atol=1e-9)
        np.testing.assert_allclose(Ud, Uc, rtol=0, atol=1e-9)
    # the kinds did differ: the blow-up stopped its run at step 250, the reset drove joint 1, the pulses and the
    # delay moved the run off the nominal one
    assert len(cpu[0][1]) == 250 and all(len(U) == len(T) - 1 for _, U in cpu[1:])
    assert np.max(np.abs(cpu[-1][1][:, 0])) > 0 and np.all(cpu[2][1][:, 0] == 0)
    assert all(np.max(np.abs(cpu[k][0] - cpu[2][0])) > 1e-6 for k in range(3, len(runs) - 1))


@needs_warp
@pytest.mark.slow  # MuJoCo Warp compiled for Warp's CPU device (16 CPU-s)
def test_robustness_on_fewer_levels_is_the_cpu_s(gymnast, gymnast_vcl, monkeypatch, tmp_path):
    """The whole protocol on 2 levels, 1 repetition and 1 pulse run, 0.6 s runs: the same summary on both
    engines (each in its own folder: a folder holds one study), and a rerun on the device finds its chunks."""
    monkeypatch.setattr(rg, "LEVELS", 2)
    monkeypatch.setattr(rg, "REPETITIONS", 1)
    monkeypatch.setattr(rg, "PERTURBATION_RUNS", 1)
    monkeypatch.setattr(rg, "T_FINAL", 0.6)
    task, _ = gymnast_vcl
    spec = ControllerSpec("vcl", task=task)
    x0 = np.r_[0.2, -np.pi + 0.3, -0.2, 0.5, -0.4, 0.3]
    summaries = {engine: rg.run_protocol("robustness-v2", gymnast, spec, task, x0, seed=3, progress=False,
                                         engine=engine, device="cpu" if engine == "warp" else None,
                                         out_dir=tmp_path / engine)[0] for engine in ("cpu", "warp")}
    assert summaries["warp"].pop("engine") == "warp" and summaries["cpu"].pop("engine") == "cpu"
    summaries["warp"].pop("device"), summaries["cpu"].pop("device")
    result = summaries["cpu"]["result"]
    assert result["runs"] == 15 * 2 + 2 + 2 + 2 + 2 + 1 and result["completed_fraction"] == 1.0
    assert json.dumps(summaries["warp"], sort_keys=True) == json.dumps(summaries["cpu"], sort_keys=True)
    # a rerun finds every chunk kept and runs nothing
    again = rg.run_protocol("robustness-v2", gymnast, spec, task, x0, seed=3, progress=False, engine="warp",
                            device="cpu", out_dir=tmp_path / "warp")[0]
    assert again["result"] == summaries["warp"]["result"]


def test_a_controller_without_a_device_law_is_refused_in_one_line(tmp_path, run):
    """A user's Python controller has no compiled law to translate: one line naming it and the engine to use."""
    mine = tmp_path / "mine.py"
    mine.write_text("import numpy as np\n\nclass Mine:\n    def __init__(self, robot):\n        pass\n\n"
                    "    def torque(self, q, qd, t):\n        return np.zeros(q.shape[:-1] + (2,))\n")
    result = run("realaigym", "--protocol", "performance-v2", "--controller", f"{mine}:Mine", "--engine", "warp",
                 "--device", "cpu")
    if not warp_available():
        assert result.returncode == 2 and "pip install 'paa_mj[gpu]'" in result.stderr
        return
    assert result.returncode == 2 and result.stderr.count("\n") == 1, result.stderr
    assert "controller mine.py:Mine has no law on the device" in result.stderr and "use --engine cpu" in result.stderr


def test_a_device_needs_the_warp_engine(run):
    result = run("realaigym", "--protocol", "performance-v2", "--device", "cpu")
    assert result.returncode == 2 and result.stderr == ("paa-mj: error: --device chooses the Warp device of --engine"
                                                        " warp; drop it or add --engine warp\n")
