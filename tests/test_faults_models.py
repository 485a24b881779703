"""Made models edited in and out of their shape, bad options of every command, the viewer without a display."""
import os

import pytest

from .faults_shared import M_GEAR, _made, _one_line_error, _strict
from .helpers import cli


M_HIPS = '<joint name="hips" type="hinge" axis="0 1 0"/>'


M_HANDS = '<joint name="hands" type="hinge" axis="0 1 0"/>'


M_HIP = '<motor name="hip" joint="hips" gear="1"/>'


M_MOTORS = '<motor name="shoulder" joint="shoulders" gear="1"/>\n    <motor name="hip" joint="hips" gear="1"/>'


M_LINK1 = '<inertial pos="0 0 0.5" mass="2.0"'


REFUSED_MODELS = [
    ("slide joint", M_HIPS, '<joint name="hips" type="slide" axis="0 1 0"/>', "found 3 joints with 3 DoF"),
    ("ball joint", M_HIPS, '<joint name="hips" type="ball"/>', "found 3 joints with 5 DoF"),
    ("free joint for the hands", M_HANDS, '<freejoint name="hands"/>', "found 3 joints with 8 DoF"),
    ("a fourth joint", M_HIPS, M_HIPS + '<joint name="hips2" type="hinge" axis="0 1 0"/>', "found 4 joints"),
    ("a joint removed", M_HIPS, "", "unknown transmission target 'hips'"),
    ("hinge axis along x", M_HIPS, '<joint name="hips" type="hinge" axis="1 0 0"/>', "hinge axes must be the same"),
    ("one hinge axis reversed", M_HIPS, '<joint name="hips" type="hinge" axis="0 -1 0"/>',
     "hinge axes must be the same"),
    ("vertical hinge axes", '*axis="0 1 0"', 'axis="0 0 1"', "hinge axes must be horizontal"),
    ("no actuators", M_MOTORS, "", "0 actuators"),
    ("one actuator", M_HIP, "", "vcl does not apply to robot custom at the folded goal: it needs joint 1 alone passive,"
     " this one has joints 1, 3 passive, joint 2 driven"),  # a robot now, with the shoulders' motor alone
    ("motors swapped", M_MOTORS, M_MOTORS.split("\n    ")[1] + "\n    " + M_MOTORS.split("\n    ")[0],
     "motors must drive distinct joints in increasing order (one motor per driven joint), found joints [3, 2]"),
    ("a motor on the hands", 'joint="shoulders" gear="1"', 'joint="hands" gear="1"',
     "it needs joint 1 alone passive, this one has joint 2 passive, joints 1, 3 driven"),  # a robot now: (40) refuses
    ("gear -1", M_GEAR, 'joint="hips" gear="-1"', "actuator 1 gear -1 (the model needs gear 1)"),
    ("gear 0", M_GEAR, 'joint="hips" gear="0"', "actuator 1 gear 0 (the model needs gear 1)"),
    ("gear NaN", M_GEAR, 'joint="hips" gear="nan"', "actuator 1 gear nan (the model needs gear 1)"),
    ("ctrlrange inverted", M_GEAR, M_GEAR + ' ctrlrange="5 -5"', "actuator 1 ctrlrange [5, -5] is not a range"),
    ("ctrlrange NaN", M_GEAR, M_GEAR + ' ctrlrange="nan nan"', "actuator 1 ctrlrange [nan, nan] is not a range"),
    ("forcerange inverted", M_GEAR, M_GEAR + ' forcerange="5 -5"', "actuator 1 forcerange [5, -5] is not a range"),
    ("actuatorfrcrange inverted", M_HIPS, M_HIPS.replace("/>", ' actuatorfrcrange="7 -7"/>'),
     "joint 3 actuatorfrcrange [7, -7] is not a range"),
    ("ctrlrange limited and inverted", M_GEAR, M_GEAR + ' ctrllimited="true" ctrlrange="5 -5"',
     "invalid control range"),
    ("ctrlrange infinite", M_GEAR, M_GEAR + ' ctrlrange="-inf inf"', "ctrlrange [-inf, inf]"),
    ("forcerange asymmetric", M_GEAR, M_GEAR + ' forcerange="-5 6"', "forcerange [-5, 6]"),
    ("actuatorfrcrange asymmetric", M_HIPS, M_HIPS.replace("/>", ' actuatorfrcrange="-7 8"/>'),
     "actuatorfrcrange [-7, 8]"),
    ("general actuator with a bias", M_HIP, '<general name="hip" joint="hips" gainprm="1" biastype="affine"'
     ' biasprm="0 0 -1"/>', "is not a <motor>"),
    ("general actuator of gain 2", M_HIP, '<general name="hip" joint="hips" gainprm="2"/>', "is not a <motor>"),
    ("filter dynamics", M_HIP, '<general name="hip" joint="hips" dyntype="filter" dynprm="0.1"/>',
     "is not a <motor>"),
    ("integrator dynamics", M_HIP, '<general name="hip" joint="hips" dyntype="integrator" gainprm="1"/>',
     "is not a <motor>"),
    ("velocity servo", M_HIP, '<velocity name="hip" joint="hips" kv="1"/>', "is not a <motor>"),
    ("damper", M_HIP, '<damper name="hip" joint="hips" kv="1" ctrlrange="0 1"/>', "is not a <motor>"),
    ("a motor on a site", M_HIP, '<motor name="hip" site="feet" gear="1 0 0 0 0 0"/>', "must act on a joint"),
    ("time step 1 s", 'timestep="0.001"', 'timestep="1"', "timestep = 1 s must lie in (0, 0.1]"),
    ("infinite time step", 'timestep="0.001"', 'timestep="inf"', "timestep = inf s"),
    ("unknown integrator", 'integrator="RK4"', 'integrator="leapfrog"', "invalid keyword: 'leapfrog'"),
    ("no gravity", 'gravity="0 0 -9.81"', 'gravity="0 0 0"', "gravity [0.0, 0.0, 0.0]"),
    ("gravity upwards", 'gravity="0 0 -9.81"', 'gravity="0 0 9.81"', "gravity [0.0, 0.0, 9.81]"),
    ("NaN gravity", 'gravity="0 0 -9.81"', 'gravity="0 0 nan"', "gravity [0.0, 0.0, nan]"),
    ("gravity switched off", 'contact="disable"', 'contact="disable" gravity="disable"', "gravity disabled"),
    ("a flag MuJoCo lacks", 'contact="disable"', 'contact="disable" passive="disable"',
     "unrecognized attribute: 'passive'"),
    ("negative damping", M_HIPS, M_HIPS.replace("/>", ' damping="-1"/>'), "joint damping [0.0, 0.0, -1.0]"),
    ("NaN armature", M_HIPS, M_HIPS.replace("/>", ' armature="nan"/>'), "armature [0.0, 0.0, nan]"),
    ("a hinge off its body's origin", M_HIPS, M_HIPS.replace("/>", ' pos="0 0 0.1"/>'),
     "each hinge must sit at its body's origin"),
    ("a rotated link", '<body name="link3" pos="0 0 0.6">', '<body name="link3" pos="0 0 0.6" euler="0 0.1 0">',
     "link bodies must not be rotated"),
    ("link 1 rotated by a quaternion", '<body name="link1">', '<body name="link1" quat="0.9 0 0.1 0">',
     "link bodies must not be rotated"),
    ("a link bent sideways", '<body name="link3" pos="0 0 0.6">', '<body name="link3" pos="0.01 0 0.6">',
     "link 2 must point straight up"),
    ("hands off the bar", '<body name="link1">', '<body name="link1" pos="0 0 0.1">',
     "link 1 must hang from the bar at the world origin"),
    ("hands in front of the bar", '<body name="link1">', '<body name="link1" pos="0.2 0 0">',
     "link 1 must hang from the bar at the world origin"),
    ("zero mass", 'mass="2.0"', 'mass="0"', "mass and inertia of moving bodies"),
    ("negative mass", 'mass="2.0"', 'mass="-2.0"', "mass and inertia of moving bodies"),
    ("mass 1e-9 kg", 'mass="2.0"', 'mass="1e-9"', "m1 = 1e-09 lies outside the plausible range"),
    ("centre of mass beyond the link", M_LINK1, '<inertial pos="0 0 1.5" mass="2.0"', "lc1 = 1.5 must lie in [0, l1]"),
    ("centre of mass above the bar", M_LINK1, '<inertial pos="0 0 -0.5" mass="2.0"',
     "centre of mass must lie on the link"),
    ("centre of mass beside the link", M_LINK1, '<inertial pos="0.1 0 0.5" mass="2.0"',
     "centre of mass must lie on the link"),
    ("inertia against the triangle inequality", 'diaginertia="0.16666666666666666 0.16666666666666666'
     ' 0.0016666666666666666"', 'fullinertia="0.1666 0.1666 0.0016 0.01 0 0"', "inertia must satisfy A + B >= C"),
    ("a fourth body", '<site name="feet"', '<body name="toe" pos="0 0 0.6"><inertial pos="0 0 0" mass="0.1"'
     ' diaginertia="0.001 0.001 0.001"/></body><site name="feet"', "one hinge joint per link (4), found 3 joints"),
    ("a mocap body", '<camera name="side"', '<body name="x" mocap="true" pos="0 0 -1"><geom size="0.1"'
     ' contype="0" conaffinity="0"/></body><camera name="side"', "found 4 bodies"),
    ("a weld", "</actuator>", '</actuator><equality><weld body1="link3"/></equality>', "1 equality constraints"),
    ("coupled joints", "</actuator>", '</actuator><equality><joint joint1="hips" joint2="shoulders"/></equality>',
     "1 equality constraints"),
    ("a contact pair", "</actuator>", '</actuator><contact><pair geom1="legs" geom2="floor"/></contact>',
     "1 explicit contact pairs"),
    ("stored gains of 2 values", "PAA_GAINS", '<numeric name="paa_gains" data="45 120"/>',
     "paa_gains numeric needs 3 values"),
    ("infinite stored gain", "PAA_GAINS", '<numeric name="paa_gains" data="inf 120 45"/>', "paa_gains kD = inf"),
    ("stored gains of 1e300", "PAA_GAINS", '<numeric name="paa_gains" data="1e300 1e300 1e300"/>',
     "is above 1e+12"),
    ("feet above the hips", '<site name="feet" pos="0 0 0.6"', '<site name="feet" pos="0 0 -0.6"',
     "l3 = -0.6 must be > 0"),
    ("feet nearer than the centre of mass", '<site name="feet" pos="0 0 0.6"', '<site name="feet" pos="0 0 0.1"',
     "lc3 = 0.3 must lie in [0, l3]"),
    ("a name of two lines", '<mujoco model="custom"', '<mujoco model="evil&#10;paa-mj: error: a forged line"',
     "the model's name 'evil\\npaa-mj: error: a forged line' has control characters"),
    ("a name that turns the text around", '<mujoco model="custom"', '<mujoco model="a&#8238;b"',
     "has control characters"),
]


@pytest.mark.parametrize("what, old, new, fragment", REFUSED_MODELS, ids=[m[0] for m in REFUSED_MODELS])
def test_made_models_edited_out_of_shape_are_refused_in_one_line(what, old, new, fragment, made_xml, tmp_path,
                                                                   run):
    path = tmp_path / "robot.xml"
    path.write_text(_made(made_xml, old, new))
    proc = run("simulate", "--robot", path, "--t-final", "0.05", "--json", cwd=tmp_path)
    _one_line_error(proc, fragment)
    assert proc.stdout == ""
    assert sorted(p.name for p in tmp_path.iterdir()) == ["robot.xml"]  # no MUJOCO_LOG.TXT for NaN in the file


ACCEPTED_MODELS = [
    ("hinge axis of length 2", M_HIPS, '<joint name="hips" type="hinge" axis="0 2 0"/>', {"check": True}),
    ("hands moved along the bar", '<body name="link1">', '<body name="link1" pos="0 0.5 0">', {"check": True}),
    ("link 3 weighed from its geom", '<inertial pos="0 0 0.3" mass="1.0" diaginertia="0.03 0.03 0.0003"/>\n'
     '          <geom name="legs"', '<geom name="legs"', {"check": True}),
    ("no feet site", '<site name="feet" pos="0 0 0.6" size="0.044" rgba="1 1 0 1" group="2"/>', "",
     {"check": True}),
    ("energy flag off", 'energy="enable"', 'energy="disable"', {"check": True}),
    ("a keyframe and a sensor", "</actuator>", '</actuator><keyframe><key qpos="1 2 3"/></keyframe><sensor>'
     '<jointpos joint="hips"/></sensor>', {"check": True}),
    ("ctrlrange 0 0 (none)", M_GEAR, M_GEAR + ' ctrlrange="0 0"', {"torque_limit": None}),
    ("ctrllimited false with a range", M_GEAR, M_GEAR + ' ctrllimited="false" ctrlrange="-5 5"',
     {"torque_limit": None}),
    ("symmetric ctrlrange", M_GEAR, M_GEAR + ' ctrlrange="-0.5 0.5"', {"torque_limit": [None, 0.5]}),
    ("symmetric forcerange", M_GEAR, M_GEAR + ' forcerange="-0.4 0.4"', {"torque_limit": [None, 0.4]}),
    ("symmetric actuatorfrcrange", M_HIPS, M_HIPS.replace("/>", ' actuatorfrcrange="-0.3 0.3"/>'),
     {"torque_limit": [None, 0.3]}),
    ("Euler in the file", 'integrator="RK4"', 'integrator="Euler"', {"integrator": "Euler"}),
    ("implicitfast in the file", 'integrator="RK4"', 'integrator="implicitfast"', {"integrator": "implicitfast"}),
    ("time step 2 ms in the file", 'timestep="0.001"', 'timestep="0.002"', {"dt": 0.002}),
]


@pytest.mark.parametrize("what, old, new, expect", ACCEPTED_MODELS, ids=[m[0] for m in ACCEPTED_MODELS])
def test_made_models_edited_within_the_shape_run_as_written(what, old, new, expect, made_xml, tmp_path, run):
    path = tmp_path / "robot.xml"
    path.write_text(_made(made_xml, old, new))
    if expect.get("check"):
        proc = run("check", "--robot", path, "--samples", "20", "--json")
        assert proc.returncode == 0, proc.stderr
        errors = _strict(proc.stdout)
        assert all(errors[k] < 1e-9 for k in errors if k.startswith("max_rel_err")), errors  # the paper's equations
        return
    proc = run("simulate", "--robot", path, "--controller", "vcl-only", "--t-final", "0.3", "--json")
    assert proc.returncode == 0, proc.stderr
    summary = _strict(proc.stdout)
    for key, value in expect.items():
        assert summary[key] == value, (key, summary[key])
    if "torque_limit" in expect and expect["torque_limit"] is not None:
        assert summary["max_abs_tau"][1] <= expect["torque_limit"][1]  # the file's limit is applied
        assert summary["max_abs_tau"][1] == pytest.approx(expect["torque_limit"][1])  # and reached (saturated)


BAD_OPTIONS = [
    # simulate: numbers
    (["simulate", "--t-final", "1e-9"], "final time 1e-09 s is shorter than one time step (0.001 s)"),
    (["simulate", "--t-final", "-1e3"], "argument --t-final: must be a positive finite number, got -1e3"),
    (["simulate", "--t-final", "-inf"], "argument --t-final: must be a positive finite number, got -inf"),
    (["simulate", "--t-final", "infinity"], "must be a positive finite number, got infinity"),
    (["simulate", "--t-final", "1_0"], "write numbers without underscores"),
    (["simulate", "--dt", "1e-300", "--t-final", "0.1"], "would need about 1e+299 physics steps"),
    (["simulate", "--dt", "1", "--t-final", "0.5"], "shorter than one time step (1 s)"),
    (["simulate", "--dt", "0.0007", "--t-final", "0.1"], "not a whole number of time steps (dt = 0.0007 s)"),
    (["simulate", "--torque-limit", "-0"], "argument --torque-limit: must be a positive finite number, got -0"),
    (["simulate", "--torque-limit", "-1E2"], "argument --torque-limit: must be a positive finite number, got -1E2"),
    (["simulate", "--torque-limit", "0x10"], "not a number: '0x10'"),
    (["simulate", "--torque-limit", "1e"], "not a number: '1e'"),
    (["simulate", "--torque-limit", ""], "not a number: ''"),
    (["simulate", "--kD", "1e-300"], "gain kD = 1e-300 is not above kD_min"),
    (["simulate", "--kD", "1e20"], "gain kD = 1e+20 is above 1e+12"),
    (["simulate", "--kV", "-1e3"], "argument --kV: must be a positive finite number, got -1e3"),
    (["simulate", "--kip-duration", "nan", "--controller", "trajopt-effort"], "argument --kip-duration"),
    (["simulate", "--kip-duration", "0"], "argument --kip-duration: must be a positive finite number, got 0"),
    (["simulate", "--x0", "0", "0", "0", "0", "0"], "--x0 needs 6 numbers for robot gymnast (q1 q2 q3 d1 d2 d3), got 5"),
    (["simulate", "--x0", "0", "0", "0", "0", "0", "0", "0"], "--x0 needs 6 numbers for robot gymnast (q1 q2 q3 d1 d2 d3), got 7"),
    (["simulate", "--x0", "0", "0", "0", "1e3", "0", "0"], "initial joint speed 1000 rad/s is above 100 rad/s"),
    (["simulate", "--x0", "-1e5", "0", "0", "0", "0", "0"], "initial angle 100000 rad is beyond 10000 rad"),
    (["simulate", "--x0", "0", "0", "0", "-1e-3", "0", "-inf"], "argument --x0: must be finite, got -inf"),
    # simulate: names, paths and contradictions
    (["simulate", "--controller", ""], "unknown controller ''"),
    (["simulate", "--controller", "VCL"], "unknown controller 'VCL'"),
    (["simulate", "--controller", "vcl "], "unknown controller 'vcl '"),
    (["simulate", "--controller", "mine.py"], "unknown controller 'mine.py'"),
    (["simulate", "--controller", ":Damped"], "unknown controller ':Damped'"),
    (["simulate", "--controller", "mine.py:"], "controller file not found"),
    (["simulate", "--controller", "nowhere/mine.py:Damped"], "controller file not found: /"),
    (["simulate", "--robot", ""], "unknown robot '' (an empty name)"),
    (["simulate", "--robot", " "], "unknown robot ' ' (an empty name)"),
    (["simulate", "--robot", "GYMNAST"], "unknown robot 'GYMNAST'"),
    (["simulate", "--robot", "gymnast.xml"], "model file not found: gymnast.xml"),
    (["simulate", "--robot", "/dev/null"], "model file is not a regular file: /dev/null"),
    (["simulate", "--robot", "/etc/hostname.xml"], "model file not found"),
    (["simulate", "--robot", "/"], "model file is not a regular file: /"),
    (["simulate", "--integrator", "rk4"], "invalid choice: 'rk4'"),
    (["simulate", "--engine", "exact"], "invalid choice: 'exact'"),
    (["simulate", "--engine", "analytic", "--dt", "0.001"], "--dt does not apply to --engine analytic"),
    (["simulate", "--controller", "passive", "--no-switch"], "it contradicts --controller passive"),
    (["simulate", "--controller", "lqr", "--kD", "5000"], "apply to the controllers vcl, vcl-only, vcl-roa, vc, vc-only, vc-roa"),
    (["simulate", "--out", " "], "--out: an empty path names no folder"),
    # check, theory, make-model
    (["check", "--samples", "0"], "argument --samples: must be >= 1, got 0"),
    (["check", "--samples", "1e3"], "not a whole number: '1e3'"),
    (["check", "--seed", "1.5"], "not a whole number: '1.5'"),
    (["check", "--seed", "0x10"], "not a whole number: '0x10'"),
    (["check", "--seed", "-1e3"], "argument --seed: not a whole number: '-1e3'"),
    (["theory", "--kD", "0"], "argument --kD: must be a positive finite number, got 0"),
    (["theory", "--kP", "-1e3"], "argument --kP: must be a positive finite number, got -1e3"),
    (["theory", "--robot", "example2", "--kD", "nan"], "argument --kD: must be a positive finite number, got nan"),
    (["make-model", "--m", "1", "1", "--l", "1", "1", "1", "--out", "x.xml"], "--m needs 3 values (one per link) for --links 3, got 2"),
    (["make-model", "--m", "1", "1", "1", "--l", "1", "1", "1"], "the following arguments are required: --out"),
    # the lengths are checked before the rods' inertias are made of them (no overflow, no J the user never gave)
    (["make-model", "--m", "1", "1", "1", "--l", "1e300", "1", "1", "--out", "x.xml"],
     "l1 = 1e+300 lies outside the plausible range [0.0001, 1000]"),
    (["make-model", "--m", "1", "1", "1", "--l", "1e-300", "1", "1", "--out", "x.xml"],
     "l1 = 1e-300 lies outside the plausible range [0.0001, 1000]"),
    (["make-model", "--m", "1", "1", "1", "--l", "1", "1", "1", "--lc", "0.5", "0.5", "0.5", "--out", "x.xml"],
     "give --J with --lc"),
    (["make-model", "--m", "1", "1", "1", "--l", "1", "1", "1", "--J", "1", "1", "1", "--out", "x.xml"],
     "give --lc with --J"),
    (["make-model", "--m", "1", "1", "1", "--l", "1", "1", "1", "--lc", "2", "0.5", "0.5", "--J", "1", "1", "1",
      "--out", "x.xml"], "lc1 = 2 must lie in [0, l1] = [0, 1]"),
    (["make-model", "--m", "1", "1", "1", "--l", "1", "1", "1", "--lc", "-1e-3", "0.5", "0.5", "--J", "1", "1", "1",
      "--out", "x.xml"], "lc1 = -0.001 must lie in [0, l1]"),
    (["make-model", "--m", "1e7", "1", "1", "--l", "1", "1", "1", "--out", "x.xml"],
     "m1 = 1e+07 lies outside the plausible range"),
    (["make-model", "--m", "1", "1", "1", "--l", "1e-5", "1", "1", "--out", "x.xml"],
     "l1 = 1e-05 lies outside the plausible range"),
    (["make-model", "--m", "1", "1", "1", "--l", "1", "1", "1", "--J", "0", "1", "1", "--lc", "0", "0", "0",
      "--out", "x.xml"], "argument --J: must be a positive finite number, got 0"),
    (["make-model", "--m", "1", "1", "1", "--l", "1", "1", "1", "--kD", "100", "--out", "x.xml"],
     "give all three of --kD --kP --kV"),
    (["make-model", "--m", "1", "1", "1", "--l", "1", "1", "1", "--title", "\x00", "--out", "x.xml"],
     "has control characters"),
    (["make-model", "--m", "1", "1", "1", "--l", "1", "1", "1", "--out", "/proc/x.xml"], "cannot write /proc/x.xml"),
    (["make-model", "--m", "1", "1", "1", "--l", "1", "1", "1", "--out", "sub/"], "names a folder"),
    # render and view
    (["render", "--out", "v.avi"], "--out must end in .mp4 or .gif, got v.avi"),
    (["render", "--out", "video"], "--out must end in .mp4 or .gif, got video"),
    (["render", "--width", "15", "--out", "v.gif"], "--width must be an integer in [16, 4096], got 15"),
    (["render", "--height", "4097", "--out", "v.gif"], "--height must be an integer in [16, 4096], got 4097"),
    (["render", "--width", "0", "--out", "v.gif"], "argument --width: must be >= 1, got 0"),
    (["render", "--fps", "-1e1", "--out", "v.gif"], "argument --fps: must be a positive finite number, got -1e1"),
    (["render", "--from", "nowhere.npz", "--out", "v.gif"], "trajectory file not found: nowhere.npz"),
    (["render", "--from", "/", "--out", "v.gif"], "trajectory file is not a regular file: /"),
    (["render", "--gl", "vulkan", "--out", "v.gif"], "invalid choice: 'vulkan'"),
    (["view", "--t-final", "nan"], "argument --t-final: must be a positive finite number, got nan"),
    (["view", "--x0", "0", "0", "0", "0", "0", "nan"], "argument --x0: must be finite, got nan"),
    (["view", "--integrator", "leapfrog"], "invalid choice: 'leapfrog'"),
    # basin
    (["basin", "--grid", "1"], "--grid must be an integer in [2, 2048], got 1"),
    (["basin", "--grid", "2049"], "--grid must be an integer in [2, 2048], got 2049"),
    (["basin", "--grid", "2.5"], "argument --grid: not a whole number: '2.5'"),
    (["basin", "--axes", "q1"], "--axes needs two different coordinates"),
    (["basin", "--axes", "q1,q1"], "--axes needs two different coordinates"),
    (["basin", "--axes", "q1,q4"], "--axes needs two different coordinates"),
    (["basin", "--axes", "Q1,q2"], "--axes needs two different coordinates"),
    (["basin", "--axes", "q1,q2,q3"], "--axes needs two different coordinates"),
    (["basin", "--chunk", "0"], "argument --chunk: must be >= 1, got 0"),
    (["basin", "--scheduler", "bogus"], "--scheduler must be inline, local or an address"),
    (["basin", "--scheduler", ""], "--scheduler must be inline, local or an address"),
    (["basin", "--scheduler", "tcp://"], "give tcp://HOST:PORT with a port in 1..65535"),
    (["basin", "--scheduler", "tcp://host:0"], "give tcp://HOST:PORT with a port in 1..65535"),
    (["basin", "--scheduler", "tcp://host:99999"], "give tcp://HOST:PORT with a port in 1..65535"),
    (["basin", "--scheduler", "udp://host:1"], "only tcp:// scheduler addresses are supported"),
    (["basin", "--torque-limit", "nan"], "argument --torque-limit: must be a positive finite number, got nan"),
    (["basin", "--controller", "passive", "--kD", "5000", "--scheduler", "inline"],
     "apply to the controllers vcl, vcl-only, vcl-roa, vc, vc-only, vc-roa, not to passive"),
    (["basin", "--torque-limit", "-1e3"], "argument --torque-limit: must be a positive finite number"),
    # robustness
    (["robustness", "--factors", "bogus"], "unknown robustness factor(s) ['bogus']"),
    (["robustness", "--factors", ",,,"], "no robustness factor given"),
    (["robustness", "--start", "upside"], "invalid choice: 'upside'"),
    (["robustness", "--factors", "noise", "--model-error", "5"], "levels given for model_error"),
    (["robustness", "--trials", "1e3"], "argument --trials: not a whole number: '1e3'"),
    (["robustness", "--model-error", "inf"], "argument --model-error: must be a finite number >= 0, got inf"),
    (["robustness", "--kip-duration", "2", "--scheduler", "inline"], "--kip-duration applies to the controllers"),
    # compare
    (["compare", "--controllers", ""], "--controllers needs at least one controller"),
    (["compare", "--controllers", ",,"], "--controllers needs at least one controller"),
    (["compare", "--controllers", "bogus", "--scheduler", "inline"], "unknown controller 'bogus'"),
    (["compare", "--trials", "0"], "argument --trials: must be >= 1, got 0"),
    (["compare", "--t-final", "nan"], "argument --t-final: must be a positive finite number, got nan"),
    (["compare", "--torque-limit", "-3"], "argument --torque-limit"),
    (["compare", "--gl", "egl"], "which is only made with --out"),
    (["compare", "--gl", "egl", "--no-video"], "which --no-video skips"),
    # atlas
    (["atlas", "--vary", "l1"], "--vary needs two different parameters"),
    (["atlas", "--vary", "l1,l1"], "--vary needs two different parameters"),
    (["atlas", "--vary", "l4,m1"], "--vary needs two different parameters"),
    (["atlas", "--vary", "J1,m1"], "--vary needs two different parameters"),
    (["atlas", "--range", "4:0.25"], "--range must be LOW:HIGH with 0 < LOW < HIGH, got '4:0.25'"),
    (["atlas", "--range", "0:4"], "--range must be LOW:HIGH with 0 < LOW < HIGH, got '0:4'"),
    (["atlas", "--range", "1:1"], "--range must be LOW:HIGH with 0 < LOW < HIGH"),
    (["atlas", "--range", "nan:4"], "--range must be LOW:HIGH with 0 < LOW < HIGH"),
    (["atlas", "--range", "1:inf"], "--range must be LOW:HIGH with 0 < LOW < HIGH"),
    (["atlas", "--range", "abc"], "--range must be LOW:HIGH, two positive factors, got 'abc'"),
    (["atlas", "--range", "1:2:3"], "--range must be LOW:HIGH, two positive factors"),
    (["atlas", "--grid", "257"], "--grid must be an integer in [2, 256], got 257"),
    (["atlas", "--simulate", "--starts", "-1"], "--starts must be >= 0, got -1"),
    (["atlas", "--simulate", "--starts", "10001", "--scheduler", "inline"], "--starts must be an integer in [0, 10000]"),
    (["atlas", "--torque-limit", "5"], "--torque-limit applies with --simulate only"),
    (["atlas", "--seed", "1"], "--seed applies with --simulate only"),
    (["atlas", "--range", "1e-300:1e300", "--grid", "2", "--scheduler", "inline"], "--range"),
    # bench, reproduce
    (["bench", "--batch-size", "0"], "argument --batch-size: must be >= 1, got 0"),
    (["bench", "--batch-size", "1e99"], "argument --batch-size: not a whole number: '1e99'"),
    (["reproduce", "--out", ""], "argument --out: an empty path names no folder"),
    (["reproduce", "--gl", "osmesa", "--no-video"], "--no-video skips"),
]


def _bad_option_id(case):
    args = case.values[0] if hasattr(case, "values") else case[0]
    return " ".join(a if a.isprintable() else repr(a) for a in args)[:70] or "empty"


@pytest.mark.parametrize("args, fragment", BAD_OPTIONS, ids=[_bad_option_id(c) for c in BAD_OPTIONS])
def test_bad_options_of_every_command_are_one_line(args, fragment, tmp_path, monkeypatch, run):
    monkeypatch.delenv("DISPLAY", raising=False)
    monkeypatch.delenv("WAYLAND_DISPLAY", raising=False)
    proc = run(*args, cwd=tmp_path)
    _one_line_error(proc, fragment)
    assert proc.stdout == ""
    assert not list(tmp_path.iterdir())  # nothing written, not even a lock or a log


def test_compare_refuses_a_reach_grid_before_any_rollout(monkeypatch, tmp_path, run):
    import paa_mj.studies.compare as compare

    def no_work(*args, **kwargs):
        raise AssertionError("a kip was simulated before --grid 1 was refused")

    monkeypatch.setattr(compare, "performance", no_work)
    proc = run("compare", "--controllers", "vcl", "--grid", "1", "--trials", "1", "--t-final", "0.1",
               "--torque-limit", "5", "--scheduler", "inline", "--no-video", cwd=tmp_path)
    _one_line_error(proc, "--grid must be an integer in [2,")


def test_the_viewer_without_a_display_is_one_line_whatever_else_is_wrong(monkeypatch, run):
    monkeypatch.delenv("DISPLAY", raising=False)
    monkeypatch.delenv("WAYLAND_DISPLAY", raising=False)
    proc = run("view", "--controller", "trajopt", "--kP", "1")
    _one_line_error(proc, "no display (DISPLAY and WAYLAND_DISPLAY are unset)")
    assert proc.stdout == ""


@pytest.mark.parametrize("env", [{"DISPLAY": ":99"}, {"DISPLAY": ":0", "MUJOCO_GL": "egl"}],
                         ids=["display that does not answer", "offscreen backend forced"])
def test_the_viewer_that_cannot_open_is_one_line(env, tmp_path):
    inherited = {k: v for k, v in os.environ.items() if k not in ("MUJOCO_GL", "PYOPENGL_PLATFORM")}
    proc = cli("view", "--t-final", "0.05", cwd=tmp_path, env={**inherited, **env}, timeout=120)
    _one_line_error(proc, "cannot open the viewer" if env.get("DISPLAY") == ":99" else "unset it to open the viewer")
    assert list(tmp_path.iterdir()) == []
