"""Numbers that can be cited: one success definition, honest intervals, studies keyed by what made them."""
import json
import socket
import threading
import time

import numpy as np
import pytest

from paa_mj.cli import main
from paa_mj.control.registry import ControllerSpec
from paa_mj.errors import PaaError
from paa_mj.model.states import X0_HANGING
from paa_mj.sim import simulate_batch
from paa_mj.studies.basin import basin
from paa_mj.studies.robustness import robustness, wilson_interval

from .helpers import cli

NO_MODE = '''
from paa_mj.control.registry import make_controller


class NoMode:
    """The paper's controller, wrapped without saying which of its laws acts."""

    def __init__(self, robot):
        self.inner = make_controller("vcl", robot)

    def reset(self):
        self.inner.reset()

    def torque(self, q, qd, t):
        return self.inner.torque(q, qd, t)
'''

PD = '''
class PD:
    def __init__(self, robot):
        self.gain = GAIN * robot.analytic.b1

    def torque(self, q, qd, t):
        return -self.gain * (q[..., 1:] + 0.5 * qd[..., 1:])
'''


@pytest.mark.slow  # two kips of 25 s, one of them a Python controller (13 CPU-s)
def test_success_does_not_depend_on_the_controllers_mode(gymnast, tmp_path):
    """The paper's controller without `mode` succeeds exactly where it does with it."""
    (tmp_path / "nomode.py").write_text(NO_MODE)
    wrapped = ControllerSpec(f"{tmp_path}/nomode.py:NoMode")
    direct = simulate_batch(gymnast, X0_HANGING[None], 25.0, controller="vcl")
    # the wrapped controller's one rollout (from hanging, no delay: one run however many trials), seen both as
    # the study's arrays and as its summary
    summary, bare = robustness(gymnast, trials=2, t_final=25.0, controller=wrapped, factors=["delay"],
                               levels={"delay": [0.0]}, start="hanging")
    np.testing.assert_array_equal(bare["x0"], X0_HANGING[None])
    assert direct.success[0] and bare["success"][0]
    assert np.isnan(bare["switch_time"][0])  # it never said it switched, and still counts as balanced
    assert summary["factors"]["delay"]["levels"][0]["success_rate"] == 1.0


def test_a_passing_swing_through_the_goal_is_no_success(gymnast):
    """Success asks for the last second inside (68), not one lucky final sample."""
    result = simulate_batch(gymnast, [[0.02, -np.pi, 0.0, 0.0, 0.0, 0.0]], 3.0, controller="passive")
    assert not result.success[0]  # UDD without control falls
    held = simulate_batch(gymnast, [[0.05, -np.pi, 0.0, 0.0, 0.0, 0.0]], 3.0, controller="lqr")
    assert held.success[0]


@pytest.mark.parametrize("k, n", [(0, 1), (0, 48), (1, 48), (24, 48), (47, 48), (48, 48), (3, 7), (7, 7)])
def test_wilson_bounds_hold_the_rate_exactly(k, n):
    low, high = wilson_interval(k, n)
    assert 0.0 <= low <= k / n <= high <= 1.0
    assert (low == 0.0) == (k == 0) and (high == 1.0) == (k == n)


def test_a_deterministic_setting_is_one_run_without_an_interval(gymnast):
    summary, _ = robustness(gymnast, trials=5, t_final=1.0, factors=["model_error", "noise"],
                            levels={"model_error": [0.0, 5.0], "noise": [0.0, 0.01]}, start="hanging")
    model_error, noise = summary["factors"]["model_error"]["levels"], summary["factors"]["noise"]["levels"]
    assert all(lv["trials"] == 1 and not lv["random"] and lv["low"] is None for lv in model_error)
    assert noise[0]["trials"] == 1 and not noise[0]["random"]  # no noise from one start: one run
    assert noise[1]["trials"] == 5 and noise[1]["random"] and noise[1]["low"] is not None
    assert summary["runs"] == 1 + 1 + 1 + 5
    random_starts, _ = robustness(gymnast, trials=3, t_final=1.0, factors=["model_error"],
                                  levels={"model_error": [5.0]}, start="random")
    level = random_starts["factors"]["model_error"]["levels"][0]
    assert level["trials"] == 3 and level["random"]


def test_a_factors_draws_do_not_depend_on_the_other_factors(gymnast):
    alone, a = robustness(gymnast, trials=3, t_final=2.0, factors=["noise"], levels={"noise": [0.05]},
                          start="random")
    beside, b = robustness(gymnast, trials=3, t_final=2.0, factors=["delay", "noise"],
                           levels={"delay": [0.0], "noise": [0.05]}, start="random")
    rows = slice(len(b["x0"]) - 3, None)
    np.testing.assert_array_equal(a["x0"], b["x0"][rows])
    np.testing.assert_array_equal(a["switch_time"], b["switch_time"][rows])
    np.testing.assert_array_equal(a["final_state"], b["final_state"][rows])  # the same noise, step by step
    assert alone["factors"]["noise"] == beside["factors"]["noise"]


def test_every_study_applies_the_torque_limit_and_reports_the_peak(gymnast, capsys):
    summary, _ = basin(gymnast, (0, 1), 2, 3.0, torque_limit=40.0)
    assert summary["torque_limit"] == [40.0, 40.0] and max(summary["max_abs_tau"]) <= 40.0 + 1e-9
    unlimited, _ = basin(gymnast, (0, 1), 2, 3.0)
    assert max(unlimited["max_abs_tau"]) > 40.0  # the limit was what held it
    assert main(["robustness", "--trials", "2", "--t-final", "2", "--factors", "noise", "--torque-limit", "30",
                 "--scheduler", "inline", "--json"]) == 0
    rob = json.loads(capsys.readouterr().out)
    assert rob["torque_limit"] == [30.0, 30.0] and max(rob["max_abs_tau"]) <= 30.0 + 1e-9
    assert main(["atlas", "--grid", "2", "--simulate", "--starts", "0", "--t-final", "1", "--torque-limit", "25",
                 "--scheduler", "inline", "--json"]) == 0
    atlas = json.loads(capsys.readouterr().out)
    assert atlas["torque_limit"] == [25.0, 25.0] and max(atlas["max_abs_tau"]) <= 25.0 + 1e-9
    assert "region (68)" in atlas["success_definition"] and "region (68)" in rob["success_definition"]


def _basin_arrays(out):
    with np.load(out / "basin.npz") as z:
        return {k: z[k].copy() for k in z.files}


def test_a_changed_controller_file_is_not_resumed_from_old_chunks(tmp_path, capsys, one_panel_figures):
    """Studies are keyed by the controller's source, not its path."""
    one_panel_figures("basin_figure")  # four runs of a study: its chunks (the figure: test_engine, test_distributed)
    path = tmp_path / "pd.py"
    args = ["basin", "--controller", f"{path}:PD", "--grid", "2", "--t-final", "0.5", "--scheduler", "inline",
            "--chunk", "2"]
    path.write_text("GAIN = 0.05\n" + PD)
    assert main([*args, "--out", str(tmp_path / "a")]) == 0
    first = _basin_arrays(tmp_path / "a")
    path.write_text("GAIN = 0.5\n" + PD)
    assert main([*args, "--out", str(tmp_path / "a")]) == 2  # another study's chunks: refused, not removed
    assert "keeps the finished chunks of another basin study" in capsys.readouterr().err
    assert np.array_equal(_basin_arrays(tmp_path / "a")["max_abs_tau"], first["max_abs_tau"])
    assert main([*args, "--out", str(tmp_path / "a"), "--fresh"]) == 0
    second = _basin_arrays(tmp_path / "a")
    assert main([*args, "--out", str(tmp_path / "b")]) == 0
    fresh = _basin_arrays(tmp_path / "b")
    assert not np.array_equal(first["max_abs_tau"], second["max_abs_tau"])
    np.testing.assert_array_equal(second["max_abs_tau"], fresh["max_abs_tau"])
    assert len(list((tmp_path / "a" / ".chunks").iterdir())) == 1  # the old study's chunks are not kept
    assert "--fresh: removed the kept chunks of an earlier" in capsys.readouterr().err


def test_kept_chunks_that_do_not_fit_are_computed_again(tmp_path, capsys, one_panel_figures):
    from paa_mj.io import write_npz

    one_panel_figures("basin_figure")  # two runs of a study: its chunks (the figure: test_engine, test_distributed)

    args = ["basin", "--grid", "2", "--t-final", "0.5", "--scheduler", "inline", "--chunk", "2",
            "--out", str(tmp_path)]
    assert main(args) == 0
    whole = _basin_arrays(tmp_path)
    (folder,) = (tmp_path / ".chunks").iterdir()
    chunks = sorted(folder.glob("chunk-*.npz"))
    with np.load(chunks[0]) as z:
        short = {k: z[k][:1] for k in z.files}  # one row where the chunk has two
    write_npz(chunks[0], **short)
    with np.load(chunks[1]) as z:
        missing = {k: z[k] for k in z.files if k != "max_abs_tau"}
    write_npz(chunks[1], **missing)
    capsys.readouterr()
    assert main(args) == 0
    assert "2 kept chunk(s)" in capsys.readouterr().err
    again = _basin_arrays(tmp_path)
    assert set(again) == set(whole)
    for key in whole:
        np.testing.assert_array_equal(again[key], whole[key])


class _Server:
    """A local TCP server that answers like something other than a Dask scheduler."""

    def __init__(self, reply):
        self.sock = socket.socket()
        self.sock.bind(("127.0.0.1", 0))
        self.sock.listen(4)
        self.port = self.sock.getsockname()[1]
        self.reply = reply
        self.done = False
        self.closed = threading.Event()
        threading.Thread(target=self._serve, daemon=True).start()

    def _serve(self):
        self.sock.settimeout(0.2)
        while not self.done:
            try:
                conn, _ = self.sock.accept()
            except OSError:
                continue
            if self.reply:
                conn.sendall(self.reply)
            # hold the connection until the test ends (a web server waits for a request): only the probe's own
            # timeout ends the wait, however slowly a loaded machine runs the command
            self.closed.wait()
            conn.close()

    def close(self):
        self.done = True
        self.closed.set()
        self.sock.close()


@pytest.mark.parametrize("reply, message", [(b"", "sent no Dask handshake"),
                                            (b"\xff" * 64, "not a Dask handshake")],
                         ids=["silent server", "junk"])
def test_a_scheduler_address_that_is_no_scheduler_fails_fast(reply, message, capsys):
    server = _Server(reply)
    try:
        start = time.monotonic()
        code = main(["basin", "--grid", "2", "--t-final", "0.1", "--scheduler", f"tcp://127.0.0.1:{server.port}"])
        took = time.monotonic() - start
    finally:
        server.close()
    err = capsys.readouterr().err
    assert code == 2 and message in err and f"127.0.0.1:{server.port}" in err
    assert len(err.strip().splitlines()) == 1 and took < 20


@pytest.mark.parametrize("address", ["tls://127.0.0.1:8786", "ucx://127.0.0.1:8786", "tcp://127.0.0.1:x",
                                     "tcp://:8786"])
def test_unsupported_scheduler_addresses_are_one_line(address, capsys):
    assert main(["basin", "--grid", "2", "--t-final", "0.1", "--scheduler", address]) == 2
    err = capsys.readouterr().err
    assert address in err and len(err.strip().splitlines()) == 1


@pytest.mark.slow  # a process and its local cluster (9 CPU-s)
def test_a_controller_that_prints_on_dask_workers_leaves_json_alone(tmp_path):
    (tmp_path / "loud.py").write_text("GAIN = 0.05\n" + PD.replace("def torque(self, q, qd, t):",
                                                                  "def torque(self, q, qd, t):\n        print('hello')"))
    proc = cli("basin", "--controller", f"{tmp_path}/loud.py:PD", "--grid", "2", "--t-final", "0.05",
               "--chunk", "2", "--scheduler", "local", "--json", cwd=tmp_path)  # two chunks: on workers
    assert proc.returncode == 0, proc.stderr
    assert json.loads(proc.stdout)["cells"] == 4
    assert "hello" in proc.stderr


@pytest.mark.slow  # the theory of four robots and eight kips (7 CPU-s); --chunk in a quick form: compare's, below
def test_chunk_is_honoured_by_atlas(tmp_path):
    assert main(["atlas", "--grid", "2", "--simulate", "--starts", "1", "--t-final", "0.2", "--chunk", "3",
                 "--scheduler", "inline", "--out", str(tmp_path), "--json"]) == 0
    folders = {p.name.split("-")[1]: p for p in (tmp_path / ".chunks").iterdir()}
    assert len(list(folders["theory"].glob("chunk-*.npz"))) == 2  # 4 robots in chunks of 3
    assert len(list(folders["kips"].glob("chunk-*.npz"))) == 3  # 8 kips in chunks of 3


def test_an_interrupted_atlas_says_its_findings_are_partial(gymnast, monkeypatch):
    import paa_mj.studies.atlas as atlas_module

    real = atlas_module.map_chunks

    def stopped(*args, **kwargs):
        finished, _ = real(*args, **kwargs)
        finished.pop(max(finished))
        return finished, True

    monkeypatch.setattr(atlas_module, "map_chunks", stopped)
    summary, _ = atlas_module.atlas(gymnast, grid=2, chunk=2)
    assert summary["interrupted"] and summary["findings"][0].startswith("INCOMPLETE")


def test_a_min_time_plan_that_cannot_fit_its_time_range_is_refused(gymnast, monkeypatch):
    import paa_mj.control.trajopt as trajopt

    monkeypatch.setattr(trajopt, "TIME_RANGE", (0.2, 0.5))  # below the true minimum of about 0.9 s
    with pytest.raises(PaaError, match="Infeasible_Problem_Detected"):  # 10 intervals: IPOPT tells it in half the CPU
        trajopt.solve_kip(gymnast.analytic, [470.0, 217.0], "min-time", duration=0.4, intervals=10, use_cache=False)


def test_a_cached_plan_that_is_not_the_one_asked_for_is_solved_again(gymnast, tmp_path, monkeypatch):
    import paa_mj.control.trajopt as trajopt
    from paa_mj.io import write_npz

    monkeypatch.setenv("PAA_MJ_CACHE", str(tmp_path))
    first = trajopt.solve_kip(gymnast.analytic, [300.0, 150.0], "min-effort", duration=1.5, intervals=12)
    (entry,) = (tmp_path / "trajopt").glob("*.npz")
    damaged = first.arrays()
    damaged["u"] = damaged["u"][:-2]  # a short torque table
    write_npz(entry, **damaged)
    again = trajopt.solve_kip(gymnast.analytic, [300.0, 150.0], "min-effort", duration=1.5, intervals=12)
    np.testing.assert_allclose(again.u, first.u, atol=1e-6)
    foreign = first.arrays()
    foreign["x"] = foreign["x"] + 0.1  # the right shapes, but not a solution of (1)
    write_npz(entry, **foreign)
    third = trajopt.solve_kip(gymnast.analytic, [300.0, 150.0], "min-effort", duration=1.5, intervals=12)
    assert third.defects(gymnast.analytic) < 1e-6


def test_study_summaries_identify_the_robot_by_its_model(gymnast):
    import hashlib

    summary, _ = basin(gymnast, (0, 1), 2, 0.1)
    assert summary["robot_sha256"] == hashlib.sha256(gymnast.xml.encode()).hexdigest()


def test_chunk_is_honoured_by_compare(tmp_path):
    assert main(["compare", "--controllers", "lqr", "--quick", "--trials", "1", "--grid", "2", "--t-final", "0.5",
                 "--chunk", "1", "--torque-limit", "100", "--scheduler", "inline", "--no-video",
                 "--out", str(tmp_path), "--json"]) == 0
    folders = {p.name.split("-")[0]: p for p in (tmp_path / "studies" / "lqr" / ".chunks").iterdir()}
    assert len(list(folders["basin"].glob("chunk-*.npz"))) == 4  # one start per chunk
    board = json.loads((tmp_path / "leaderboard.json").read_text())
    runs = sum(rate["trials"] for rate in board["controllers"]["lqr"]["robustness"].values())
    assert len(list(folders["robustness"].glob("chunk-*.npz"))) == runs  # one run per chunk, each run counted once


def test_every_controller_of_a_leaderboard_meets_the_same_torque_noise(capsys):
    """Torque noise is a fraction of the common limit, not of each controller's own peak (passive has none)."""
    assert main(["compare", "--controllers", "passive,lqr", "--quick", "--trials", "1", "--grid", "2",
                 "--t-final", "0.3", "--torque-limit", "80", "--scheduler", "inline", "--json"]) == 0
    board = json.loads(capsys.readouterr().out)
    assert board["torque_noise_scale"] == 80.0 and set(board["controllers"]) == {"passive", "lqr"}
    from paa_mj.outputs.results import leaderboard_markdown

    # a board printed without --out points to no files; the one written beside them does
    assert leaderboard_markdown(board, written=False).rstrip().endswith("Nothing was written: give --out DIR for"
                                                                         " leaderboard.json, the charts and the runs.")
    assert "Every number is in `leaderboard.json`" in leaderboard_markdown(board)


def test_chunks_of_an_older_version_do_not_pile_up(tmp_path, capsys):
    legacy = tmp_path / ".chunks" / ("0123456789abcdef" + "0123")
    legacy.mkdir(parents=True)
    args = ["basin", "--grid", "2", "--t-final", "0.1", "--scheduler", "inline", "--out", str(tmp_path)]
    assert main(args) == 2 and legacy.exists()  # another study's: refused, never removed unasked
    assert "keeps the finished chunks of another basin study" in capsys.readouterr().err
    assert main([*args, "--fresh"]) == 0
    assert not legacy.exists() and len(list((tmp_path / ".chunks").iterdir())) == 1
