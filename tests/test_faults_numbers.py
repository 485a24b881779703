"""Numbers are what they claim: strict JSON, torque limits applied and reported, counts, determinism, options honoured;
the Python API's refusals.
"""
import json
import signal

import numpy as np
import pytest

from .faults_shared import M_GEAR, PRINTING_AND_FAILING, USER_CONTROLLERS, _made, _one_line_error, _strict




def _one_json_object(proc):
    """stdout is exactly one strict JSON object on one line."""
    assert proc.stdout.endswith("\n") and proc.stdout.count("\n") == 1, proc.stdout[:300]
    value = _strict(proc.stdout)
    assert isinstance(value, dict)
    return value


CHATTY = USER_CONTROLLERS + '''

class Chatty(_Zero):
    def __init__(self, robot=None):
        print("built", robot.name)

    def torque(self, q, qd, t=0.0):
        print("torque at", t, "for", len(q), "states")
        sys.stdout.flush()
        return -10.0 * (q[..., 1:] - 0.3)
'''


JSON_COMMANDS = [
    ["theory", "--json"],
    ["theory", "--robot", "example2", "--kP", "1", "--json"],
    ["theory", "--robot", "example2", "--kD", "40", "--json"],
    ["check", "--samples", "3", "--json"],
    ["simulate", "--t-final", "0.05", "--json"],
    ["simulate", "--engine", "analytic", "--t-final", "0.05", "--json"],
    ["simulate", "--controller", "{chatty}", "--t-final", "0.05", "--json", "--out", "{d}/run"],
    ["simulate", "--controller", "{chatty}", "--engine", "analytic", "--t-final", "0.05", "--json"],
    ["basin", "--grid", "2", "--t-final", "0.05", "--scheduler", "inline", "--json"],
    ["basin", "--grid", "2", "--t-final", "0.05", "--scheduler", "inline", "--json", "--controller", "{chatty}"],
    ["robustness", "--trials", "1", "--t-final", "0.05", "--scheduler", "inline", "--factors", "noise", "--json"],
    ["robustness", "--trials", "1", "--t-final", "0.05", "--scheduler", "inline", "--factors", "delay", "--json",
     "--controller", "{chatty}"],
    ["atlas", "--grid", "2", "--scheduler", "inline", "--json"],
    ["atlas", "--grid", "2", "--scheduler", "inline", "--json", "--simulate", "--starts", "0", "--t-final", "0.05"],
    ["compare", "--controllers", "vcl,{chatty}", "--trials", "1", "--grid", "2", "--t-final", "0.1",
     "--torque-limit", "50", "--scheduler", "inline", "--no-video", "--json"],
]


@pytest.mark.parametrize("args", JSON_COMMANDS, ids=[" ".join(a[:3]) + f"-{i}" for i, a in enumerate(JSON_COMMANDS)])
def test_json_output_of_every_command_is_one_strict_object(args, tmp_path, run):
    (tmp_path / "chatty.py").write_text(CHATTY)
    proc = run(*[a.format(chatty=f"{tmp_path}/chatty.py:Chatty", d=tmp_path) for a in args])
    assert proc.returncode == 0, proc.stderr
    _one_json_object(proc)
    assert "Traceback" not in proc.stderr
    if any("chatty" in a for a in args):
        assert "torque at" in proc.stderr  # the controller's prints went to stderr


def _peaks(value, path=""):
    """Every peak torque reported anywhere in a JSON value: (path, [tau2, tau3])."""
    if isinstance(value, dict):
        for key, item in value.items():
            if key in ("max_abs_tau", "max_tau") and isinstance(item, list):
                yield f"{path}/{key}", item
            else:
                yield from _peaks(item, f"{path}/{key}")
    elif isinstance(value, list):
        for i, item in enumerate(value):
            yield from _peaks(item, f"{path}[{i}]")


LIMITED_RUNS = [
    ["simulate", "--t-final", "0.5"],
    ["simulate", "--controller", "vc", "--t-final", "0.5"],
    ["simulate", "--controller", "vcl-only", "--t-final", "0.5", "--dt", "0.002", "--integrator", "Euler"],
    ["simulate", "--controller", "lqr", "--t-final", "0.5", "--x0", "0.2", "-2.9", "0.1", "0", "0", "0"],
    ["simulate", "--engine", "analytic", "--t-final", "0.3"],
    ["simulate", "--engine", "analytic", "--controller", "vc-only", "--t-final", "0.3"],
    ["simulate", "--engine", "analytic", "--controller", "lqr", "--t-final", "0.3", "--x0", "0.2", "-2.9", "0.1",
     "0", "0", "0"],
    ["basin", "--grid", "2", "--t-final", "0.3", "--scheduler", "inline"],
    ["basin", "--grid", "2", "--t-final", "0.3", "--scheduler", "inline", "--controller", "lqr", "--axes", "d1,d2"],
    ["robustness", "--trials", "2", "--t-final", "0.3", "--scheduler", "inline", "--factors",
     "noise,torque_limit,model_error,delay,torque_noise,pushes,initial_state"],
    ["atlas", "--grid", "2", "--scheduler", "inline", "--simulate", "--starts", "1", "--t-final", "0.3"],
    ["compare", "--controllers", "vcl,lqr", "--trials", "1", "--grid", "2", "--t-final", "0.3", "--scheduler",
     "inline", "--no-video"],
]


@pytest.mark.parametrize("args", LIMITED_RUNS, ids=[" ".join(a[:4]) + f"-{i}" for i, a in enumerate(LIMITED_RUNS)])
def test_no_reported_torque_exceeds_the_torque_limit_given(args, run):
    limit = 7.0
    proc = run(*args, "--torque-limit", limit, "--json")
    assert proc.returncode == 0, proc.stderr
    summary = _one_json_object(proc)
    peaks = list(_peaks(summary))
    assert peaks, "no peak torque reported"
    for where, peak in peaks:
        assert all(p is not None and p <= limit + 1e-9 for p in peak), (where, peak)
    assert any(max(peak) == pytest.approx(limit) for _, peak in peaks)  # saturated somewhere: the limit is applied


def test_a_studys_counts_add_up(run):
    basin = _strict(run("basin", "--grid", "3", "--t-final", "0.2", "--scheduler", "inline", "--json").stdout)
    assert basin["cells"] == 9 and sum(basin["outcomes"].values()) == 9 and basin["completed_fraction"] == 1.0
    assert basin["success"] <= 1.0 - basin["diverged_fraction"]
    rob = _strict(run("robustness", "--trials", "3", "--t-final", "0.1", "--scheduler", "inline", "--factors",
                      "noise,delay,torque_limit", "--start", "hanging", "--json").stdout)
    levels = [level for factor in rob["factors"].values() for level in factor["levels"]]
    assert sum(level["trials"] for level in levels) == rob["runs"]  # no more trials claimed than were run
    assert all(level["trials"] <= rob["trials"] and (level["trials"] == 1 or level["random"]) for level in levels)
    atlas = _strict(run("atlas", "--grid", "3", "--scheduler", "inline", "--simulate", "--starts", "1", "--t-final",
                        "0.1", "--json").stdout)
    assert atlas["counts"]["robots"] == 9 == len(atlas["robots"])
    outcomes = ("success", "switched, no success", "never switched, stuck at DUU", "never switched", "diverged")
    assert sum(atlas["counts"][name] for name in outcomes) == 9


@pytest.mark.parametrize("args", [
    ["theory", "--robot", "example2", "--json"],
    ["check", "--samples", "7", "--seed", "5", "--json"],
    ["simulate", "--controller", "{damped}", "--t-final", "0.3", "--json"],
    ["simulate", "--controller", "{damped}", "--engine", "analytic", "--t-final", "0.1", "--json"],
    ["basin", "--grid", "2", "--t-final", "0.2", "--scheduler", "inline", "--json", "--controller", "{damped}"],
    ["robustness", "--trials", "2", "--t-final", "0.2", "--scheduler", "inline", "--factors",
     "noise,torque_noise,pushes", "--seed", "3", "--json"],
    ["atlas", "--grid", "2", "--scheduler", "inline", "--json", "--simulate", "--starts", "1", "--t-final", "0.2"],
], ids=["theory", "check", "simulate python controller", "analytic python controller", "basin python controller",
        "robustness noise", "atlas simulate"])
def test_the_same_command_twice_gives_the_same_numbers(args, tmp_path, run):
    (tmp_path / "mine.py").write_text(PRINTING_AND_FAILING)
    args = [a.format(damped=f"{tmp_path}/mine.py:Damped") for a in args]
    first, second = run(*args), run(*args)
    assert first.returncode == second.returncode == 0, first.stderr
    assert first.stdout == second.stdout


def test_simulate_options_are_honoured_not_ignored(run):
    base = _strict(run("simulate", "--t-final", "0.2", "--json").stdout)
    cases = {
        ("--dt", "0.002"): lambda s: s["dt"] == 0.002,
        ("--integrator", "Euler"): lambda s: s["integrator"] == "Euler",
        ("--integrator", "implicit"): lambda s: s["integrator"] == "implicit",
        ("--sample-dt", "0.05"): lambda s: s["samples"] == 5 and s["sample_dt"] == 0.05,
        ("--kD", "5000"): lambda s: s["gains"] == {"kD": 5000.0, "kP": 16000.0, "kV": 5000.0},
        ("--kP", "17000", "--kV", "4000"): lambda s: s["gains"] == {"kD": 4550.0, "kP": 17000.0, "kV": 4000.0},
        ("--no-switch",): lambda s: s["controller"] == "vcl-only" and s["switch_time"] is None,
        ("--x0", "-3", "0.1", "0", "0", "0", "0"): lambda s: s["x0"] == [-3.0, 0.1, 0.0, 0.0, 0.0, 0.0],
        ("--torque-limit", "20"): lambda s: s["torque_limit"] == [20.0, 20.0],
    }
    for option, holds in cases.items():
        summary = _strict(run("simulate", "--t-final", "0.2", "--json", *option).stdout)
        assert holds(summary), (option, summary)
        if option[0] not in ("--sample-dt", "--no-switch"):  # vcl-only swings up exactly as vcl before any switch
            assert summary["final_state"] != base["final_state"], option  # and the run is not the default's


def test_analytic_and_study_options_are_honoured(run):
    analytic = _strict(run("simulate", "--engine", "analytic", "--t-final", "0.2", "--sample-dt", "0.04",
                           "--json").stdout)
    assert analytic["samples"] == 6 and analytic["sample_dt"] == 0.04
    theory = _strict(run("theory", "--kD", "4600", "--kP", "16500", "--kV", "5100", "--json").stdout)
    assert theory["gains"] == {"kD": 4600.0, "kP": 16500.0, "kV": 5100.0}
    check = [_strict(run("check", "--samples", "4", "--seed", str(s), "--json").stdout) for s in (1, 2)]
    assert [c["seed"] for c in check] == [1, 2] and all(c["samples"] == 4 for c in check)
    basin = _strict(run("basin", "--grid", "2", "--t-final", "0.05", "--scheduler", "inline", "--axes", "d1,d3",
                        "--json").stdout)
    assert basin["axes"] == ["d1", "d3"]
    rob = _strict(run("robustness", "--trials", "1", "--t-final", "0.05", "--scheduler", "inline", "--factors",
                      "delay", "--start", "hanging", "--seed", "4", "--json").stdout)
    assert rob["start"] == "hanging" and rob["seed"] == 4 and list(rob["factors"]) == ["delay"]
    atlas = _strict(run("atlas", "--grid", "2", "--scheduler", "inline", "--vary", "m2,l3", "--range", "0.5:2",
                        "--json").stdout)
    assert atlas["vary"] == ["m2", "l3"] and atlas["factors"][0] == [0.5, 2.0]


def test_a_robustness_seed_changes_the_draws(gymnast):
    from paa_mj.studies.robustness import robustness

    draws = [robustness(gymnast, trials=3, t_final=0.05, seed=seed, factors=["noise"])[1]["x0"] for seed in (0, 1)]
    assert draws[0].shape == draws[1].shape == (12, 6) and not np.array_equal(draws[0], draws[1])


def test_the_files_of_simulate_agree_with_its_json(tmp_path, run):
    from paa_mj.sim.trajectory import Trajectory

    proc = run("simulate", "--t-final", "0.3", "--json", "--out", tmp_path / "run")
    summary = _one_json_object(proc)
    assert json.loads((tmp_path / "run" / "summary.json").read_text()) == summary
    rows = (tmp_path / "run" / "trajectory.csv").read_text().strip().splitlines()
    traj = Trajectory.load(tmp_path / "run" / "trajectory.npz")
    assert len(rows) - 1 == summary["samples"] == len(traj) == 31
    assert traj.summary()["max_abs_tau"] == summary["max_abs_tau"]
    assert np.concatenate([traj.q[-1], traj.qd[-1]]).tolist() == summary["final_state"]


@pytest.mark.parametrize("engine", ["mujoco", "analytic"])
def test_a_diverged_run_reports_no_success_and_keeps_its_samples(engine, tmp_path, run):
    (tmp_path / "mine.py").write_text(PRINTING_AND_FAILING)
    proc = run("simulate", "--engine", engine, "--controller", f"{tmp_path}/mine.py:LateNaN", "--t-final", "1",
               "--x0", "0", "-3.14", "0", "0", "0", "0", "--json", "--out", tmp_path / "run")
    _one_line_error(proc, "non-finite torque", code=3)
    summary = _one_json_object(proc)
    assert summary["balanced"] is False and summary.get("success", False) is False
    assert summary["status"].startswith("diverged")
    kept = json.loads((tmp_path / "run" / "summary.json").read_text())
    assert kept == summary and kept["samples"] >= 5


def test_the_peak_torque_of_a_run_does_not_depend_on_the_recording_interval(run):
    fine = _strict(run("simulate", "--t-final", "2", "--sample-dt", "0.001", "--json").stdout)
    coarse = _strict(run("simulate", "--t-final", "2", "--sample-dt", "0.1", "--json").stdout)
    assert coarse["max_abs_tau"] == pytest.approx(fine["max_abs_tau"], rel=1e-9)  # 456.4 against 512.5 N m


@pytest.mark.parametrize("command", [
    ["simulate", "--t-final", "0.2"],
    ["basin", "--grid", "2", "--t-final", "0.2", "--scheduler", "inline"],
    ["robustness", "--trials", "1", "--t-final", "0.2", "--scheduler", "inline", "--factors", "noise"],
], ids=["simulate", "basin", "robustness"])
def test_the_torque_limit_reported_is_the_one_applied(command, made_xml, tmp_path, run):
    robot = tmp_path / "limited.xml"
    robot.write_text(_made(_made(made_xml, M_GEAR, M_GEAR + ' ctrlrange="-0.3 0.3"'), 'joint="shoulders" gear="1"',
                           'joint="shoulders" gear="1" ctrlrange="-0.3 0.3"'))
    summary = _strict(run(*command, "--robot", robot, "--torque-limit", "7", "--json").stdout)
    assert summary["torque_limit"] == [0.3, 0.3] and max(summary["max_abs_tau"]) <= 0.3


def _api_cases(gymnast):
    """The Python calls of the table below, by name: each must raise PaaError with one line naming the problem."""
    from paa_mj.control import make_controller
    from paa_mj.control.registry import ControllerSpec
    from paa_mj.control.trajopt import solve_kip
    from paa_mj.model import load_robot
    from paa_mj.sim import simulate_mujoco
    from paa_mj.sim.analytic.engine import simulate_analytic

    am, x0 = gymnast.analytic, np.array([-np.pi, 0, 0, 0, 0, 0])

    def analytic(**options):
        return lambda: simulate_analytic(gymnast, "passive", x0, 0.05, **options)

    def kip(**options):
        return lambda: solve_kip(am, options.pop("bound", [300.0, 150.0]), options.pop("objective", "min-effort"),
                                 **{"duration": 1.0, "intervals": 8, "use_cache": False, **options})

    return {
        "load_robot('')": lambda: load_robot(""),
        "load_robot(None)": lambda: load_robot(None),
        "load_robot(5)": lambda: load_robot(5),
        "make_controller unknown gain name": lambda: make_controller("vcl", gymnast, gains={"kX": 1.0}),
        "make_controller gain as text": lambda: make_controller("vcl", gymnast, gains={"kD": "5000"}),
        "make_controller gain True": lambda: make_controller("vcl", gymnast, gains={"kD": True}),
        "make_controller gains a list": lambda: make_controller("vcl", gymnast, gains=[5000.0]),
        "make_controller name 5": lambda: make_controller(5, gymnast),
        "make_controller name None": lambda: make_controller(None, gymnast),
        "make_controller robot None": lambda: make_controller("vcl", None),
        "make_controller robot a name": lambda: make_controller("vcl", "gymnast", gains={"kD": 5000.0}),
        "make_controller limit as text": lambda: make_controller("trajopt", gymnast, limit="abc"),
        "make_controller limit of 3 values": lambda: make_controller("trajopt", gymnast, limit=(1.0, 2.0, 3.0)),
        "make_controller limit negative": lambda: make_controller("trajopt", gymnast, limit=-1.0),
        "make_controller unknown option": lambda: make_controller("trajopt", gymnast, bogus=1),
        "ControllerSpec 4 gains": lambda: ControllerSpec("vcl", gains=(5000.0, 16000.0, 5000.0, 1.0)),
        "ControllerSpec 2 gains": lambda: ControllerSpec("vcl", gains=(5000.0, 16000.0)),
        "ControllerSpec gains as text": lambda: ControllerSpec("vcl", gains=("a", "b", "c")),
        "ControllerSpec one gain": lambda: ControllerSpec("vcl", gains=5000.0),
        "ControllerSpec options not pairs": lambda: ControllerSpec("trajopt", options=("limit",)),
        "ControllerSpec believed a name": lambda: ControllerSpec("vcl", believed="gymnast"),
        "ControllerSpec check as text": lambda: ControllerSpec("vcl", check="no"),
        "ControllerSpec name None": lambda: ControllerSpec(None),
        "ControllerSpec built for no robot": lambda: ControllerSpec("vcl").build(None),
        "simulate_mujoco of a robot name": lambda: simulate_mujoco("gymnast", "passive", x0, 0.05),
        "analytic rtol NaN (hung)": analytic(rtol=float("nan")),
        "analytic atol NaN (hung)": analytic(atol=float("nan")),
        "analytic rtol inf (hung)": analytic(rtol=float("inf")),
        "analytic rtol negative": analytic(rtol=-1.0),
        "analytic event resolution 0": analytic(event_resolution=0.0),
        "analytic event resolution NaN": analytic(event_resolution=float("nan")),
        "analytic event resolution negative": analytic(event_resolution=-1.0),
        "analytic event resolution 1e-300": analytic(event_resolution=1e-300),
        "analytic torque limit of 3 values": analytic(torque_limit=[1.0, 2.0, 3.0]),
        "analytic torque limit as text": analytic(torque_limit="abc"),
        "analytic method unknown": analytic(method="Euler"),
        "solve_kip bounds of 3 values": kip(bound=[1.0, 2.0, 3.0]),
        "solve_kip bounds as text": kip(bound="abc"),
        "solve_kip x0 of 5 values": kip(x0=np.zeros(5)),
        "solve_kip x0 NaN": kip(x0=[np.nan] * 6),
        "solve_kip x0 as text": kip(x0="abc"),
        "solve_kip xN of 7 values": kip(xN=np.zeros(7)),
        "solve_kip max_iter negative": kip(max_iter=-5),
        "solve_kip max_iter 1.5": kip(max_iter=1.5),
        "solve_kip duration as text": kip(duration="1"),
        "solve_kip of a Robot": lambda: solve_kip(gymnast, [300.0, 150.0]),
        "solve_kip objective None": kip(objective=None),
    }


API_FRAGMENTS = {
    "load_robot('')": "unknown robot '' (an empty name)", "load_robot(None)": "unknown robot None",
    "load_robot(5)": "unknown robot 5",
    "make_controller unknown gain name": "gains must be a dict with some of kD, kP, kV",
    "make_controller gain as text": "gain kD must be a number, got '5000'",
    "make_controller gain True": "gain kD must be a number, got True",
    "make_controller gains a list": "gains must be a dict with some of kD, kP, kV",
    "make_controller name 5": "a controller is named by a string",
    "make_controller name None": "a controller is named by a string",
    "make_controller robot None": "controllers are built for a robot of load_robot(), got NoneType",
    "make_controller robot a name": "controllers are built for a robot of load_robot(), got str",
    "make_controller limit as text": "the option limit must be one number or one per motor (2)",
    "make_controller limit of 3 values": "the option limit must be one number or one per motor (2)",
    "make_controller limit negative": "torque bounds of the kip must be finite and > 0",
    "make_controller unknown option": "option(s) bogus do not apply to the controller trajopt",
    "ControllerSpec 4 gains": "gains must be three numbers (kD, kP, kV)",
    "ControllerSpec 2 gains": "gains must be three numbers (kD, kP, kV)",
    "ControllerSpec gains as text": "gains must be three numbers (kD, kP, kV)",
    "ControllerSpec one gain": "gains must be three numbers (kD, kP, kV)",
    "ControllerSpec options not pairs": "options must be (name, value) pairs",
    "ControllerSpec believed a name": "believed must be the RobotParams",
    "ControllerSpec check as text": "check must be True or False, got 'no'",
    "ControllerSpec name None": "a controller is named by a string",
    "ControllerSpec built for no robot": "controllers are built for a robot of load_robot()",
    "simulate_mujoco of a robot name": "controllers are built for a robot of load_robot(), got str",
    "analytic rtol NaN (hung)": "rtol must be a positive finite number, got nan",
    "analytic atol NaN (hung)": "atol must be a positive finite number, got nan",
    "analytic rtol inf (hung)": "rtol must be a positive finite number, got inf",
    "analytic rtol negative": "rtol must be a positive finite number, got -1",
    "analytic event resolution 0": "event_resolution must be a positive finite number, got 0",
    "analytic event resolution NaN": "event_resolution must be a positive finite number, got nan",
    "analytic event resolution negative": "event_resolution must be a positive finite number",
    "analytic event resolution 1e-300": "event_resolution 1e-300 s is below 1e-09 s",
    "analytic torque limit of 3 values": "torque limit must be one number or one per motor (2)",
    "analytic torque limit as text": "torque limit must be one number or one per motor (2)",
    "analytic method unknown": "unknown method 'Euler'",
    "solve_kip bounds of 3 values": "torque bounds of the kip are one number or two (T2, T3)",
    "solve_kip bounds as text": "torque bounds of the kip must be real numbers",
    "solve_kip x0 of 5 values": "the kip's x0 must be 6 finite numbers",
    "solve_kip x0 NaN": "the kip's x0 must be 6 finite numbers",
    "solve_kip x0 as text": "the kip's initial state x0 must be real numbers",
    "solve_kip xN of 7 values": "the kip's xN must be 6 finite numbers",
    "solve_kip max_iter negative": "max_iter must be a whole number >= 0",
    "solve_kip max_iter 1.5": "max_iter must be a whole number >= 0",
    "solve_kip duration as text": "the kip duration must be real numbers",
    "solve_kip of a Robot": "solve_kip needs the robot's AnalyticModel (robot.analytic), got Robot",
    "solve_kip objective None": "unknown objective None",
}


@pytest.mark.parametrize("name", list(API_FRAGMENTS))
def test_the_python_api_refuses_bad_arguments_with_one_paa_error(name, gymnast):
    from paa_mj.errors import PaaError

    def hung(signum, frame):
        raise TimeoutError(f"{name}: still running after 20 s")

    call = _api_cases(gymnast)[name]
    previous = signal.signal(signal.SIGALRM, hung)  # a NaN tolerance used to keep SciPy stepping for ever
    signal.alarm(20)
    try:
        with pytest.raises(PaaError) as caught:
            call()
    finally:
        signal.alarm(0)
        signal.signal(signal.SIGALRM, previous)
    message = str(caught.value)
    assert API_FRAGMENTS[name] in message and "\n" not in message, message


def _api_refusal_cases(gymnast):
    from paa_mj.sim import Disturbances, simulate_batch, simulate_mujoco
    from paa_mj.studies.atlas import atlas
    from paa_mj.studies.basin import basin
    from paa_mj.studies.robustness import robustness

    x = np.tile([-np.pi, 0, 0, 0, 0, 0], (3, 1))
    return {
        "simulate_batch rollout_ids shorter than the batch": lambda: simulate_batch(
            gymnast, x, 0.05, disturbances=Disturbances(noise_std=0.01, rollout_ids=[7])),
        "simulate_batch plants that are names": lambda: simulate_batch(gymnast, x[:2], 0.05, plants=["a", "b"]),
        "simulate_mujoco x0 as text": lambda: simulate_mujoco(gymnast, "passive", "abc", 0.05),
        "simulate_mujoco seed 2**70": lambda: simulate_mujoco(
            gymnast, "passive", x[0], 0.05, disturbances=Disturbances(noise_std=0.01, seed=2**70)),
        "basin over one axis twice": lambda: basin(gymnast, (0, 0), 2, 0.05),
        "basin chunk 0": lambda: basin(gymnast, (0, 1), 2, 0.05, chunk=0),
        "basin scheduler unknown": lambda: basin(gymnast, (0, 1), 2, 0.05, scheduler="bogus"),
        "robustness seed -1": lambda: robustness(gymnast, trials=1, t_final=0.05, factors=["noise"], seed=-1),
        "atlas of unknown parameters": lambda: atlas(gymnast, vary=("x", "y"), grid=2),
        "atlas range from 0": lambda: atlas(gymnast, factor_range=(0.0, 2.0), grid=2),
    }


API_REFUSALS = (
    "simulate_batch rollout_ids shorter than the batch",
    "simulate_batch plants that are names",
    "simulate_mujoco x0 as text",
    "simulate_mujoco seed 2**70",
    "basin over one axis twice",
    "basin chunk 0",
    "basin scheduler unknown",
    "robustness seed -1",
    "atlas of unknown parameters",
    "atlas range from 0",
)


@pytest.mark.parametrize("name", list(API_REFUSALS), ids=list(API_REFUSALS))
def test_the_simulation_and_study_functions_refuse_bad_arguments_with_one_paa_error(name, gymnast):
    from paa_mj.errors import PaaError

    with pytest.raises(PaaError):
        _api_refusal_cases(gymnast)[name]()


BAD_GYM_CALLS = [
    ("max_episode_seconds 1e308", dict(max_episode_seconds=1e308), None, "is too long"),
    ("torque_limit 1e308", dict(torque_limit=1e308), None, "torque_limit must be a positive finite number"),
    ("torque_limit True", dict(torque_limit=True), None, "torque_limit must be a number, got True"),
    ("torque_limit a list", dict(torque_limit=[1, 2]), None, "torque_limit must be a number"),
    ("frame_skip as text", dict(frame_skip="2"), None, "frame_skip must be a number"),
    ("width True", dict(width=True), None, "width must be a whole number"),
    ("height 4096.5", dict(height=4096.5), None, "height must be a whole number"),
    ("render_mode human", dict(render_mode="human"), None, "render_mode must be None or 'rgb_array'"),
    ("reset options a list", {}, ("reset", dict(options=[1, 2])), "options must be a dict"),
    ("reset option misspelt", {}, ("reset", dict(options={"x_0": [0.0] * 6})), "unknown reset option(s) x_0"),
    ("reset x0 as text", {}, ("reset", dict(options={"x0": "abc"})), "options['x0'] must be 6 finite numbers"),
    ("reset x0 complex", {}, ("reset", dict(options={"x0": [1j, 0, 0, 0, 0, 0]})), "must be 6 finite numbers"),
    ("reset x0 of 5 values", {}, ("reset", dict(options={"x0": [0.0] * 5})), "must be 6 finite numbers"),
    ("action a scalar", {}, ("step", 5.0), "an action is two real numbers [tau2, tau3], shape (2,), got shape ()"),
    ("action of one value", {}, ("step", [5.0]), "got shape (1,)"),
    ("action of three values", {}, ("step", [5.0, 1.0, 2.0]), "got shape (3,)"),
    ("action a column", {}, ("step", [[5.0], [1.0]]), "got shape (2, 1)"),
    ("action a row", {}, ("step", [[5.0, 1.0]]), "got shape (1, 2)"),
    ("action NaN", {}, ("step", [np.nan, 0.0]), "an action must be finite"),
    ("action inf", {}, ("step", [np.inf, 0.0]), "an action must be finite"),
    ("action as text", {}, ("step", ["a", "b"]), "an action is two real numbers"),
    ("action complex", {}, ("step", [1j, 0.0]), "an action is two real numbers"),
    ("action booleans", {}, ("step", [True, False]), "an action is two real numbers"),
]


@pytest.mark.parametrize("what, kwargs, call, fragment", BAD_GYM_CALLS, ids=[c[0] for c in BAD_GYM_CALLS])
def test_the_gym_env_refuses_what_it_would_misread_second_pass(what, kwargs, call, fragment):
    pytest.importorskip("gymnasium")
    from paa_mj.envs import GymnastKipEnv

    with pytest.raises(ValueError) as caught:
        env = GymnastKipEnv(**kwargs)
        env.reset(seed=0)
        before = env.data.qpos.copy()
        if call[0] == "reset":
            env.reset(seed=0, **call[1])
        else:
            env.step(call[1])
    assert fragment in str(caught.value) and "\n" not in str(caught.value), str(caught.value)
    if call is not None:
        np.testing.assert_array_equal(env.data.qpos, before)  # nothing was stepped or reset


def test_the_gym_env_still_takes_float32_and_integer_actions():
    pytest.importorskip("gymnasium")
    from paa_mj.envs import GymnastKipEnv

    env = GymnastKipEnv(init_noise=0.0)
    env.reset(seed=0)
    env.step(np.array([3, -2]))
    np.testing.assert_array_equal(env.data.ctrl, [3.0, -2.0])
    env.step(np.array([1.5, 0.5], np.float32))
    np.testing.assert_array_equal(env.data.ctrl, [1.5, 0.5])


@pytest.mark.parametrize("how", ["torques beyond MuJoCo's range", "a start beyond MuJoCo's range"])
def test_a_diverging_gym_step_leaves_no_mujoco_log_and_prints_nothing(how, tmp_path, monkeypatch, capfd):
    pytest.importorskip("gymnasium")
    from paa_mj.envs import GymnastKipEnv

    monkeypatch.chdir(tmp_path)
    env = GymnastKipEnv(torque_limit=1e12)
    if how.startswith("torques"):
        env.reset(seed=0)
        _, reward, terminated, truncated, info = env.step(np.array([1e12, -1e12]))
    else:
        env.reset(seed=0, options={"x0": [0, 0, 0, 1e11, 0, 0]})
        _, reward, terminated, truncated, info = env.step(np.zeros(2))
    assert terminated and not truncated and info["diverged"] and reward == -10.0
    out, err = capfd.readouterr()
    assert "WARNING" not in out + err
    assert list(tmp_path.iterdir()) == []  # no MUJOCO_LOG.TXT where the agent runs


def test_the_time_budget_counts_a_step_by_the_links_and_the_cores_a_run_can_use():
    """A step of a 40-link chain costs tens of times the gymnast's, and one rollout uses one core."""
    from paa_mj.errors import PaaError
    from paa_mj.limits import MAX_SECONDS, check_steps, step_seconds

    assert step_seconds(40) > 20 * step_seconds(3)
    steps = 0.5 * MAX_SECONDS / step_seconds(3)  # half a day on one core at 3 links
    check_steps(steps, "a run", "--t-final", cores=1, links=3)
    with pytest.raises(PaaError, match="days here"):
        check_steps(steps, "a run", "--t-final", cores=1, links=40)
    check_steps(4 * steps, "runs", "--t-final", cores=8, links=3, runs=8)
    with pytest.raises(PaaError, match="days here"):
        check_steps(4 * steps, "one run", "--t-final", cores=8, links=3, runs=1)
