"""The MJCF model: named robots, any parameter set, read-back, and the shape checks."""
import re

import mujoco
import numpy as np
import pytest
from hypothesis import given, settings, strategies as st

from paa_mj.errors import PaaError
from paa_mj.model import load_model, load_robot, mjcf_from_params, model_from_params, params_from_model, robot_from_xml
from paa_mj.model.mjcf import MODEL_DIR as MODELS_DIR
from paa_mj.model.params import RobotParams

from .conftest import GAINS1, GAINS2, TABLE1, TABLE2


@pytest.mark.parametrize("name, table, gains", [("gymnast", TABLE1, GAINS1), ("example2", TABLE2, GAINS2)])
def test_named_robots_read_back_as_the_papers_tables(name, table, gains):
    robot = load_robot(name)
    for key, values in table.items():
        np.testing.assert_allclose(getattr(robot.params, key), values, rtol=1e-12, err_msg=key)
    assert robot.params.g == pytest.approx(9.81)
    assert robot.gains == gains


def test_named_model_options(gymnast):
    m = gymnast.model
    assert m.opt.timestep == 0.001
    assert m.opt.integrator == mujoco.mjtIntegrator.mjINT_RK4
    assert m.opt.enableflags & mujoco.mjtEnableBit.mjENBL_ENERGY
    assert mujoco.mj_name2id(m, mujoco.mjtObj.mjOBJ_CAMERA, "side") >= 0
    assert m.nlight >= 1
    # joint 1 passive, motors on shoulders and hips
    assert [m.joint(i).name for i in range(3)] == ["hands", "shoulders", "hips"]
    assert list(m.actuator_trnid[:, 0]) == [1, 2]


def test_checked_in_models_are_what_the_template_writes(gymnast, example2):
    for robot in (gymnast, example2):
        text = (MODELS_DIR / f"{robot.name}.xml").read_text()
        title = re.search(r"\n    (Table .*)\n", text).group(1)
        assert mjcf_from_params(robot.params, name=robot.name, title=title, gains=robot.gains) == text


def test_upright_at_zero_and_hanging_at_65(gymnast):
    d = mujoco.MjData(gymnast.model)
    mujoco.mj_forward(gymnast.model, d)
    feet = d.site("feet").xpos
    np.testing.assert_allclose(feet, [0, 0, sum(TABLE1["l"])], atol=1e-12)
    d.qpos[:] = [-np.pi, 0, 0]
    mujoco.mj_forward(gymnast.model, d)
    np.testing.assert_allclose(d.site("feet").xpos, [0, 0, -sum(TABLE1["l"])], atol=1e-12)


@settings(max_examples=30, deadline=None)
@given(m=st.lists(st.floats(0.1, 50), min_size=3, max_size=3),
       l=st.lists(st.floats(0.1, 3), min_size=3, max_size=3),
       frac=st.lists(st.floats(0, 1), min_size=3, max_size=3),
       jscale=st.lists(st.floats(0.05, 2), min_size=3, max_size=3))
def test_any_parameter_set_round_trips(m, l, frac, jscale):
    m, l = np.array(m), np.array(l)
    params = RobotParams(m=m, l=l, lc=np.array(frac) * l, J=np.array(jscale) * m * l**2 / 12)
    back = params_from_model(model_from_params(params))
    for key in ("m", "l", "J"):
        np.testing.assert_allclose(getattr(back, key), getattr(params, key), rtol=1e-12, atol=1e-15)
    # MuJoCo merges a COM within ~1e-6 of the joint into the joint; the read-back says so.
    np.testing.assert_allclose(back.lc, params.lc, rtol=1e-12, atol=2e-6)


@pytest.mark.parametrize("kwargs, message", [
    (dict(m=[1, 0, 1]), "m2 = 0 must be > 0"),
    (dict(J=[1, 1, -1]), "J3 = -1 must be > 0"),
    (dict(lc=[0.5, 1.2, 0.5]), "lc2 = 1.2 must lie in [0, l2]"),
    (dict(lc=[-0.1, 0.5, 0.5]), "lc1 = -0.1 must lie"),
    (dict(l=[1, np.nan, 1]), "not finite"),
    (dict(m=[1e308, 1, 1]), "m1 = 1e+308 lies outside the plausible range"),
])
def test_non_physical_parameters_are_refused(kwargs, message):
    base = dict(m=[1, 1, 1], l=[1, 1, 1], lc=[0.5, 0.5, 0.5], J=[0.1, 0.1, 0.1])
    base.update(kwargs)
    with pytest.raises(PaaError, match=re.escape(message)):
        RobotParams(**base)


def _variant(text, old, new):
    assert old in text
    return text.replace(old, new, 1)


@pytest.mark.parametrize("old, new, message", [
    # a motor on every joint: the family is underactuated (any one motor less is a robot of it: tests/test_actuation.py)
    ('<motor name="hip" joint="hips" gear="1"/>',
     '<motor name="hip" joint="hips" gear="1"/><motor name="hand" joint="hands" gear="1"/>', "3 actuators"),
    ('<motor name="hip" joint="hips" gear="1"/>', '<motor name="hip" joint="shoulders" gear="1"/>', "distinct joints"),
    ('<motor name="shoulder" joint="shoulders" gear="1"/>\n    <motor name="hip" joint="hips" gear="1"/>',
     '<motor name="hip" joint="hips" gear="1"/>\n    <motor name="shoulder" joint="shoulders" gear="1"/>',
     "increasing order"),
    ('<motor name="hip" joint="hips" gear="1"/>', '<motor name="hip" joint="hips" gear="2"/>', "gear 1"),
    ('<joint name="hips" type="hinge" axis="0 1 0"/>', '<joint name="hips" type="slide" axis="0 1 0"/>', "one hinge joint per link"),
    ('<joint name="hips" type="hinge" axis="0 1 0"/>', '<joint name="hips" type="hinge" axis="1 0 0"/>', "hinge axes"),
    ('<joint name="hips" type="hinge" axis="0 1 0"/>', '<joint name="hips" type="hinge" axis="0 1 0" frictionloss="0.1"/>', "friction loss"),
    ('<site name="feet"', '<body name="extra"><inertial pos="0 0 0" mass="1" diaginertia="1 1 1"/><joint type="hinge"/></body><site name="feet"', "hinge axes must be the same"),
    ('<body name="link2" pos="0 0 0.58">', '<body name="link2" pos="0.1 0 0.58">', "straight up"),
    ('<inertial pos="0 0 0.31"', '<inertial pos="0.05 0 0.31"', "centre of mass"),
])
def test_models_of_the_wrong_shape_are_refused(old, new, message):
    text = (MODELS_DIR / "gymnast.xml").read_text()
    with pytest.raises(PaaError, match=message):
        robot_from_xml(_variant(text, old, new))


def test_missing_and_malformed_files(tmp_path):
    with pytest.raises(PaaError, match="not found"):
        load_model(tmp_path / "missing.xml")
    bad = tmp_path / "bad.xml"
    bad.write_text("<mujoco><worldbody>")
    with pytest.raises(PaaError, match="malformed MJCF"):
        load_model(bad)
    with pytest.raises(PaaError, match="unknown robot"):
        load_model("pendubot")


def test_a_runs_torque_limits_are_the_actuator_ranges_capped_by_the_request():
    import numpy as np
    import pytest

    from paa_mj.errors import PaaError
    from paa_mj.model import load_robot

    robot = load_robot("realaigym_acrobot")  # an actuator range of 6 N m on its one motor
    assert robot.capped_torque_limits().tolist() == [6.0] and robot.capped_torque_limits(4.0).tolist() == [4.0]
    assert robot.capped_torque_limits(9.0).tolist() == [6.0]
    assert robot.capped_torque_limits(np.array([[2.0], [8.0]]), rollouts=2).tolist() == [[2.0], [6.0]]
    assert robot.capped_torque_limits(3.0, rollouts=2).tolist() == [[3.0], [3.0]]  # one row per rollout
    gymnast = load_robot("gymnast")  # no ranges
    assert gymnast.capped_torque_limits().tolist() == [np.inf, np.inf]
    assert gymnast.capped_torque_limits([5.0, 7.0]).tolist() == [5.0, 7.0]
    for wrong in ([1.0, 2.0, 3.0], [[1.0, 2.0], [3.0, 4.0]]):  # rows only for a batch of rollouts
        with pytest.raises(PaaError, match=r"the torque limit must be one number or one per motor \(2\)"):
            gymnast.capped_torque_limits(wrong)
