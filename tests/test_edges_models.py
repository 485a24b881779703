"""What ``make-model`` writes, every command runs (or make-model refuses it up front, in one line).

One gain limit for every command (:func:`paa_mj.limits.max_gain`, scaled to the robot) and geometry sized to the
robot (:func:`paa_mj.model.mjcf.mjcf_from_params`): a plausible robot is never written to be refused later.
"""
from __future__ import annotations

import itertools

import numpy as np
import pytest

from paa_mj.control.gains import check_runnable_gains, family_gains
from paa_mj.limits import MAX_GAIN, max_gain
from paa_mj.model.dynamics import AnalyticModel
from paa_mj.model.params import PLAUSIBLE, RobotParams
from paa_mj.model.robot import load_robot
from paa_mj.task import Task


def _make(run, tmp_path, name, *options):
    path = tmp_path / f"{name}.xml"
    result = run("make-model", *options, "--timestep", "0.001", "--out", path)
    return result, path


def test_a_heavy_gymnast_is_run_by_the_commands_that_read_its_gains(run, tmp_path):
    """1e6 kg links: the family rule's kD (5.6e13) is within the robot's gain limit, so theory and simulate run the
    robot make-model wrote (both refused it: "above 1e+12")."""
    made, path = _make(run, tmp_path, "heavy", "--m", "1e6", "1e6", "1e6", "--l", "1", "1", "1")
    assert made.returncode == 0, made.stderr
    robot = load_robot(str(path))
    assert run("theory", "--robot", path).returncode == 0
    sim = run("simulate", "--robot", path, "--t-final", "0.02", "--sample-dt", "0.01")
    assert sim.returncode == 0, sim.stderr
    p = robot.params
    assert max_gain(p.m, p.l, p.g) > 5.6e13 > MAX_GAIN


def test_the_paper_robots_keep_the_limit_of_1e12(gymnast):
    p = gymnast.params
    assert max_gain(p.m, p.l, p.g) == MAX_GAIN


@pytest.mark.parametrize("m, l", list(itertools.product(PLAUSIBLE["m"], [1e-3, 1.0, 1e3])))
def test_plausible_corners_have_gains_every_command_accepts(m, l):
    """At the corners of the plausible masses and lengths (uniform rods), the family rule's gains of both goals are
    inside the one gain limit: no stored robot nothing can run."""
    try:
        params = RobotParams.uniform_rods([m] * 3, [l] * 3)
    except Exception:  # noqa: BLE001 - refused as implausible up front (J out of range): nothing written
        return
    model = AnalyticModel.from_params(params)
    check_runnable_gains(model)
    for goal in ("folded", "stretched"):
        assert family_gains(model, Task.named(goal, model))["kD"] <= max_gain(params.m, params.l, params.g)


def test_a_robot_of_millimetres_is_valid_mjcf_and_runs(run, tmp_path):
    """The bar, posts, floor and capsules are sized to the robot: links of 1 mm no longer give a bar of radius 0
    ("size 0 must be positive in geom 'bar'")."""
    made, path = _make(run, tmp_path, "small", "--m", "1", "1", "1", "--l", "1e-3", "1e-3", "1e-3")
    assert made.returncode == 0, made.stderr
    sim = run("simulate", "--robot", path, "--t-final", "0.01", "--sample-dt", "0.01")
    assert sim.returncode == 0, sim.stderr


@pytest.mark.parametrize("l", [PLAUSIBLE["l"][0], 3e-4, 0.05, PLAUSIBLE["l"][1]])
def test_geometry_sizes_are_positive_at_every_plausible_length(l):
    from paa_mj.model.mjcf import mjcf_from_params
    from paa_mj.model.mjcf_read import compile_mjcf

    params = RobotParams(m=[1.0, 1.0], l=[l, l], lc=[l / 2, l / 2], J=[max(1e-10, l * l / 12)] * 2)
    model = compile_mjcf(mjcf_from_params(params, name="x"), "test")
    assert np.all(model.geom_size[:, 0] > 0)


def test_make_model_refuses_what_no_command_could_run(run, tmp_path, monkeypatch):
    """Where the family rule's gains would lie outside the gain limit, make-model refuses in one line and writes
    nothing (the limit lowered here to make one)."""
    import paa_mj.limits as limits

    monkeypatch.setattr(limits, "MAX_GAIN_PER_SCALE", 1e-3)
    made, path = _make(run, tmp_path, "refused", "--m", "1e6", "1e6", "1e6", "--l", "1", "1", "1")
    assert made.returncode == 2
    assert made.stderr.count("\n") == 1 and "no command could run this robot" in made.stderr
    assert not path.exists()
