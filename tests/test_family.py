"""The gymnast's family: planar chains of 2 to 6 links, with damping and armature, read from their MJCF."""
import re
import tomllib
from pathlib import Path

import numpy as np
import pytest

from paa_mj.errors import PaaError
from paa_mj.model import chain
from paa_mj.model.crosscheck import cross_check
from paa_mj.model.dynamics import AnalyticModel
from paa_mj.model.mjcf import MODEL_DIR, compile_mjcf, mjcf_from_params, params_from_model
from paa_mj.model.params import RobotParams
from paa_mj.model.robot import NAMED_ROBOTS, load_robot, model_from_params

from .helpers import cli

ROOT = Path(__file__).resolve().parents[1]
TOL = 1e-9


def random_chain(rng, n, damping=True, armature=True):
    m, l = rng.uniform(0.1, 80, n), rng.uniform(0.1, 3, n)
    return RobotParams(m=m, l=l, lc=rng.uniform(0, 1, n) * l, J=rng.uniform(0.05, 3, n) * m * l**2 / 12,
                       g=rng.uniform(1.0, 20.0), damping=rng.uniform(0, 2, n) if damping else None,
                       armature=rng.uniform(0, 0.5, n) if armature else None)


@pytest.mark.parametrize("n", [2, 3, 4, 5, 6])
def test_engine_equals_the_chain_model_for_random_robots_of_2_to_6_links(n):
    rng = np.random.default_rng(100 + n)
    for k in range(3):
        params = random_chain(rng, n, damping=k != 1, armature=k != 2)
        result = cross_check(model_from_params(params), samples=150, seed=k)
        assert result.worst() < TOL, (n, k, result)


def test_the_chain_formulas_are_the_papers_for_three_links(gymnast, rng):
    """(2)-(7) in closed form and the general chain agree: the same robot, two derivations."""
    A, b = chain.chain_constants(gymnast.params)
    am = gymnast.analytic
    assert am.paper_shape
    assert np.allclose(b, am.beta, rtol=1e-15)
    q, qd = rng.uniform(-7, 7, (40, 3)), rng.uniform(-10, 10, (40, 3))
    assert np.allclose(chain.batch_mass_matrix(A, np.zeros(3), q), am.mass_matrix(q), rtol=1e-13, atol=1e-13)
    assert np.allclose(chain.batch_bias(A, b, q, qd), am.bias(q, qd), rtol=1e-13, atol=1e-10)
    assert np.allclose(chain.batch_bias(A, b, q, 0 * qd), am.gravity(q), rtol=1e-13, atol=1e-12)
    assert np.allclose(chain.batch_gravity_jacobian(b, q), am.gravity_jacobian(q), rtol=1e-13, atol=1e-12)
    assert np.allclose(chain.batch_potential(b, q), am.potential(q), rtol=1e-13, atol=1e-12)


def test_the_small_solver_solves_and_reports_singular_systems():
    rng = np.random.default_rng(3)
    for n in (1, 2, 5):
        matrix, rhs = rng.normal(size=(n, n)), rng.normal(size=(n, 3))
        out = np.empty_like(rhs)
        chain.solve_into(matrix, rhs, out)
        assert np.allclose(out, np.linalg.solve(matrix, rhs), rtol=1e-10)
    out = np.empty((2, 1))
    chain.solve_into(np.array([[1.0, 2.0], [2.0, 4.0]]), np.ones((2, 1)), out)
    assert np.all(np.isnan(out))


def test_damping_enters_the_acceleration_and_the_linearisation():
    rng = np.random.default_rng(5)
    params = random_chain(rng, 3, damping=True, armature=False)
    am = AnalyticModel.from_params(params)
    assert not am.paper_shape
    q, qd, tau = rng.normal(size=3), rng.normal(size=3), rng.normal(size=2)
    undamped = AnalyticModel.from_params(RobotParams(m=params.m, l=params.l, lc=params.lc, J=params.J, g=params.g))
    difference = am.acceleration(q, qd, tau) - undamped.acceleration(q, qd, tau)
    assert np.allclose(difference, -np.linalg.solve(am.mass_matrix(q), params.damping * qd), rtol=1e-10)
    A, B = am.linearize(np.zeros(3))
    assert np.allclose(A[3:, 3:], -np.linalg.solve(am.mass_matrix(np.zeros(3)), np.diag(params.damping)))
    assert B.shape == (6, 2)


@pytest.mark.parametrize("name, links", [("gymnast", 3), ("example2", 3), ("acrobot", 2), ("chain4", 4)])
def test_named_robots_live_in_models_at_the_top_level(name, links):
    robot = load_robot(name)
    assert robot.params.n_links == links
    assert robot.torque_limits.shape == (links - 1,)
    assert (ROOT / "models" / f"{name}.xml").is_file()
    assert MODEL_DIR.resolve() == (ROOT / "models").resolve()
    assert cross_check(robot.model, samples=100).worst() < TOL


def test_the_package_installs_the_models_folder():
    """The wheel's package list names ``paa_mj.models`` (from ``models/``) and every package of the tree."""
    config = tomllib.loads((ROOT / "pyproject.toml").read_text())["tool"]["setuptools"]
    assert config["package-dir"]["paa_mj.models"] == "models"
    assert "*.xml" in config["package-data"]["paa_mj.models"]
    found = {".".join(p.relative_to(ROOT).parent.parts) for p in (ROOT / "paa_mj").rglob("*.py")
             if "__pycache__" not in p.parts}
    assert set(config["packages"]) == found | {"paa_mj.models"}
    assert set(NAMED_ROBOTS) == {p.stem for p in (ROOT / "models").glob("*.xml")}


def test_the_acrobot_is_drakes():
    """Drake's AcrobotPlant defaults (m, l, lc, Ic, damping b; one motor at the elbow)."""
    p = load_robot("acrobot").params
    assert p.m.tolist() == [1.0, 1.0] and p.l.tolist() == [1.0, 2.0] and p.lc.tolist() == [0.5, 1.0]
    assert np.allclose(p.J, [0.083, 0.33], rtol=1e-12)
    assert p.damping.tolist() == [0.1, 0.1] and p.g == 9.81
    am = load_robot("acrobot").analytic
    # the folded goal of an acrobot is the up-down point of Lemma 1: E_r = b1 - b2
    assert am.E_r == pytest.approx((0.5 * 1 + 1 * 1 - 1 * 1) * 9.81)


def test_make_model_takes_every_parameter_per_link(tmp_path):
    out = tmp_path / "five.xml"
    result = cli("make-model", "--links", 5, "--m", 1, 2, 3, 4, 5, "--l", 0.5, 0.6, 0.7, 0.8, 0.9,
                 "--damping", 0.05, "--armature", 0.01, 0, 0, 0, 0.02, "--gravity", 3.7, "--torque-limit", 7,
                 "--out", out)
    assert result.returncode == 0, result.stderr
    robot = load_robot(out)
    p = robot.params
    assert p.n_links == 5 and p.m.tolist() == [1, 2, 3, 4, 5] and p.g == pytest.approx(3.7)
    assert np.allclose(p.lc, p.l / 2) and np.allclose(p.J, p.m * p.l**2 / 12)
    assert p.damping.tolist() == [0.05] * 5 and p.armature.tolist() == [0.01, 0, 0, 0, 0.02]
    assert robot.torque_limits.tolist() == [7.0] * 4
    bad = cli("make-model", "--links", 4, "--m", 1, 2, 3, "--l", 1, 1, 1, 1, "--out", tmp_path / "x.xml")
    assert bad.returncode == 2 and "--m needs 4 values (one per link) for --links 4, got 3" in bad.stderr
    assert not (tmp_path / "x.xml").exists()
    bad = cli("make-model", "--links", 1, "--m", 1, "--l", 1, "--out", tmp_path / "x.xml")
    assert bad.returncode == 2 and "from 2 to 64" in bad.stderr


def test_every_parameter_is_read_back_from_the_written_file():
    params = random_chain(np.random.default_rng(9), 4)
    back = params_from_model(compile_mjcf(mjcf_from_params(params, torque_limits=[1, 2, 3])))
    for key in ("m", "l", "lc", "J", "damping", "armature"):
        assert np.allclose(getattr(back, key), getattr(params, key), rtol=1e-12, atol=1e-15), key
    assert back.g == pytest.approx(params.g, rel=1e-12)


@pytest.mark.parametrize("field, value, message", [
    ("damping", [-1.0, 0.0], "damping1 = -1 must be >= 0"),
    ("armature", [0.0, np.nan], "armature = [0.0, nan] is not finite"),
    ("m", [1.0], "for 2 to 64 links"),
])
def test_non_physical_chains_are_refused(field, value, message):
    base = dict(m=[1.0, 1.0], l=[1.0, 1.0], lc=[0.5, 0.5], J=[0.1, 0.1])
    base[field] = value
    with pytest.raises(PaaError, match=re.escape(message)):
        RobotParams(**base)
