"""Studies on a real local Dask cluster (loopback) give exactly the results of the inline path; chunks resume."""
import json
import os
import signal
import subprocess
import sys
import time

import numpy as np
import pytest

distributed = pytest.importorskip("distributed")

from paa_mj.cli import main  # noqa: E402
from paa_mj.model.states import X0_HANGING  # noqa: E402
from paa_mj.task import Task  # noqa: E402
from paa_mj.studies.basin import basin  # noqa: E402
from paa_mj.studies.runner import RolloutSet, run_study  # noqa: E402
from paa_mj.studies.store import ChunkStore  # noqa: E402



@pytest.fixture(scope="module")
def scheduler_address():
    import dask
    from distributed import LocalCluster

    # one worker process: the chunks still cross a process boundary (pickled, run apart from this process); a task
    # whose worker dies is not tried again (the first lost worker stops a study, as when every worker is lost)
    with dask.config.set({"distributed.scheduler.allowed-failures": 0}), \
            LocalCluster(n_workers=1, threads_per_worker=1, processes=True, host="127.0.0.1",
                         dashboard_address=None) as cluster:
        yield cluster.scheduler_address


def test_basin_identical_on_dask_and_inline(gymnast, scheduler_address):
    on_dask = basin(gymnast, (0, 1), grid=4, t_final=3.0, scheduler=scheduler_address)
    inline = basin(gymnast, (0, 1), grid=4, t_final=3.0, scheduler="inline")
    assert on_dask[0] == inline[0]
    for key, value in inline[1].items():
        np.testing.assert_array_equal(on_dask[1][key], value, err_msg=key)


def _noisy_set(n=12):
    x0 = np.tile(X0_HANGING, (n, 1))
    x0[:, 1] += np.linspace(-0.5, 0.5, n)
    return RolloutSet(x0, "vcl", Task.named("folded", 3), noise_std=np.full((n, 2), 0.01), delay_steps=np.arange(n) % 3)


def test_chunked_noisy_rollouts_identical(gymnast, scheduler_address):
    a = run_study(gymnast, _noisy_set(), 1.0, seed=7, chunk=5, scheduler=scheduler_address)
    b = run_study(gymnast, _noisy_set(), 1.0, seed=7, chunk=5, scheduler="inline")
    c = run_study(gymnast, _noisy_set(), 1.0, seed=7, chunk=128, scheduler="inline")
    for key in ("final_state", "max_abs_tau", "switch_time", "success"):
        np.testing.assert_array_equal(getattr(a, key), getattr(b, key), err_msg=key)
        np.testing.assert_array_equal(getattr(a, key), getattr(c, key), err_msg=key)
    assert a.meta["completed"].all()
    assert np.max(np.abs(a.final_state[0] - a.final_state[5])) > 0  # rollouts draw different noise


def test_unreachable_scheduler_is_one_line(capsys):
    code = main(["basin", "--grid", "2", "--t-final", "0.1", "--scheduler", "tcp://127.0.0.1:9"])
    err = capsys.readouterr().err
    assert code == 2
    assert "cannot reach the Dask scheduler tcp://127.0.0.1:9" in err
    assert len(err.strip().splitlines()) == 1


def test_bad_scheduler_value(capsys):
    assert main(["basin", "--grid", "2", "--scheduler", "somewhere"]) == 2
    assert "--scheduler must be inline, local or an address" in capsys.readouterr().err


def test_interrupt_keeps_the_chunks_already_finished_and_a_rerun_resumes(gymnast, monkeypatch, tmp_path):
    import paa_mj.studies.runner as runner

    whole = run_study(gymnast, _noisy_set(7), 0.5, chunk=3)
    calls = []
    real = runner.simulate_batch

    def interrupted_on_second_chunk(*args, **kwargs):
        calls.append(1)
        if len(calls) == 2:
            raise KeyboardInterrupt
        return real(*args, **kwargs)

    monkeypatch.setattr(runner, "simulate_batch", interrupted_on_second_chunk)
    store = ChunkStore(tmp_path, "study")
    part = run_study(gymnast, _noisy_set(7), 0.5, chunk=3, store=store)
    assert len(calls) == 2  # stopped at the interrupt, the third chunk never started
    assert part.interrupted and store.count() == 1
    assert list(part.meta["completed"]) == [True] * 3 + [False] * 4
    np.testing.assert_array_equal(part.final_state[:3], whole.final_state[:3])
    assert np.all(np.isnan(part.final_state[3:]))
    monkeypatch.setattr(runner, "simulate_batch", real)
    calls.clear()
    resumed = run_study(gymnast, _noisy_set(7), 0.5, chunk=3, store=ChunkStore(tmp_path, "study"))
    assert not resumed.interrupted
    np.testing.assert_array_equal(resumed.final_state, whole.final_state)


#: A user's controller that, in a process given PAA_MJ_TEST_READY (the stopped run's, not this one), waits once a
#: chunk is kept: the signal lands in the second chunk, whatever the machine's load.
PAUSING = '''
import os
import time
from pathlib import Path


class PausesOnceAChunkIsKept:
    """Damps the motors; where PAA_MJ_TEST_READY names a file, built once the study's first chunk is kept (in
    PAA_MJ_TEST_CHUNKS), writes that file and waits."""

    def __init__(self, robot):
        ready, chunks = os.environ.get("PAA_MJ_TEST_READY"), os.environ.get("PAA_MJ_TEST_CHUNKS")
        if ready and list(Path(chunks).glob("*/chunk-*.npz")):
            Path(ready).write_text("waiting for a signal")
            end = time.monotonic() + 600
            while time.monotonic() < end:
                time.sleep(0.01)

    def torque(self, q, qd, t):
        return -0.1 * qd[..., 1:]
'''


@pytest.fixture(scope="module")
def pausing(tmp_path_factory):
    path = tmp_path_factory.mktemp("controller") / "pausing.py"
    path.write_text(PAUSING)
    return f"{path}:PausesOnceAChunkIsKept"


def _basin_cmd(out, controller="vcl", grid=3, t_final=1, chunk=2):
    return [sys.executable, "-m", "paa_mj.cli", "basin", "--controller", controller, "--grid", str(grid),
            "--t-final", str(t_final), "--chunk", str(chunk), "--scheduler", "inline", "--json", "--out", str(out)]


def _files(out):
    return {name: (out / name).read_bytes() for name in ("basin.npz", "summary.json", "basin.png", "basin.svg")}


@pytest.fixture(scope="module")
def uninterrupted(tmp_path_factory, pausing):
    """The files of the whole study, computed in this process (the command's ``main``, no start-up to pay)."""
    reference = tmp_path_factory.mktemp("reference")
    assert main(_basin_cmd(reference, pausing)[3:]) == 0
    return _files(reference)


# SIGTERM takes the same path as SIGINT (one handler for both; its exit code 143 is checked in test_faults_input):
# its case here (7 CPU-s, a process and a resumed study) is under ``slow``
@pytest.mark.parametrize("sig, code", [(signal.SIGINT, 130), pytest.param(signal.SIGTERM, 143, marks=pytest.mark.slow)])
def test_signal_then_rerun_is_byte_identical_to_an_uninterrupted_run(tmp_path, sig, code, pausing, uninterrupted):
    """Stopped by a signal after its first chunk, resumed by the same command: the same bytes."""
    out, ready = tmp_path / "stopped", tmp_path / "ready"
    # Ctrl-C as a terminal delivers it, even when this test runs where SIGINT is ignored (a background job)
    proc = subprocess.Popen(_basin_cmd(out, pausing), stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True,
                            env=dict(os.environ, PAA_MJ_TEST_READY=str(ready),
                                     PAA_MJ_TEST_CHUNKS=str(out / ".chunks")),
                            preexec_fn=lambda: signal.signal(signal.SIGINT, signal.SIG_DFL))
    while not ready.exists() and proc.poll() is None:  # the run waits in its second chunk: no deadline to miss
        time.sleep(0.02)
    proc.send_signal(sig)
    stdout, stderr = proc.communicate(timeout=600)
    assert proc.returncode == code, stderr
    assert "Traceback" not in stderr and len(stderr.strip().splitlines()) == 1, stderr
    summary = json.loads(stdout)
    assert summary["interrupted"] is True and summary["completed_fraction"] == pytest.approx(2 / 9, abs=1e-3)
    assert not [p for p in os.listdir(out)
                if p.startswith(".") and p not in (".chunks", ".paa-mj.lock", ".paa-mj-study.json")]
    assert main(_basin_cmd(out, pausing)[3:]) == 0  # the same command resumes (here: the stop was the real one)
    assert _files(out) == uninterrupted


def test_a_second_run_into_the_same_folder_is_refused(tmp_path):
    from paa_mj.io import OutputLock

    with OutputLock(tmp_path):
        proc = subprocess.run(_basin_cmd(tmp_path, grid=2, t_final=0.1), capture_output=True, text=True,
                              timeout=600)
    assert proc.returncode == 2
    assert "another paa-mj run" in proc.stderr and len(proc.stderr.strip().splitlines()) == 1
    assert not (tmp_path / "summary.json").exists()


def test_fresh_starts_over(tmp_path, capsys):
    assert main(["basin", "--grid", "2", "--t-final", "0.2", "--scheduler", "inline", "--out", str(tmp_path),
                 "--json"]) == 0
    chunk = next((tmp_path / ".chunks").glob("*/chunk-00000.npz"))
    stamp = chunk.stat().st_mtime_ns
    assert main(["basin", "--grid", "2", "--t-final", "0.2", "--scheduler", "inline", "--out", str(tmp_path),
                 "--json"]) == 0
    assert chunk.stat().st_mtime_ns == stamp  # resumed: nothing recomputed
    assert main(["basin", "--grid", "2", "--t-final", "0.2", "--scheduler", "inline", "--out", str(tmp_path),
                 "--json", "--fresh"]) == 0
    assert chunk.stat().st_mtime_ns != stamp


def test_losing_every_worker_stops_with_one_line_and_keeps_chunks(scheduler_address, tmp_path, run):
    """The cluster's worker dies in its second chunk (its process ends, as when killed): exit 4 and one line,
    the finished chunk kept, and the same command resumes. The death is the controller's own, on a chunk
    named in advance: nothing here depends on timing or on the machine's load."""
    mine = tmp_path / "dies.py"
    mine.write_text(f'''
import os
import time
from pathlib import Path


class DiesInItsSecondChunk:
    """Damps the motors; built in a Dask worker (once per chunk) for the second time, it ends that process once the
    first chunk is kept (its result fetched from this worker and saved: nothing of it is lost with the worker)."""

    def __init__(self, robot):
        if os.getpid() != {os.getpid()}:  # not in the test's own process, which checks the controller
            builds = Path({str(tmp_path / "builds")!r})
            with builds.open("a") as f:
                f.write("x")
            if len(builds.read_text()) >= 2:
                end = time.monotonic() + 600
                while not list(Path({str(tmp_path / "out" / ".chunks")!r}).glob("*/chunk-*.npz")) \
                        and time.monotonic() < end:
                    time.sleep(0.01)
                os._exit(1)

    def torque(self, q, qd, t):
        return -0.1 * qd[..., 1:]
''')
    args = ["basin", "--controller", f"{mine}:DiesInItsSecondChunk", "--grid", "2", "--t-final", "0.2",
            "--chunk", "2", "--json", "--out", tmp_path / "out"]
    stopped = run(*args, "--scheduler", scheduler_address)
    assert stopped.returncode == 4, stopped.stderr
    assert "Traceback" not in stopped.stderr
    lines = [line for line in stopped.stderr.strip().splitlines() if line.startswith("paa-mj")]
    assert len(lines) == 1 and "run the same command again to resume" in lines[0], stopped.stderr
    assert "1 of 2 chunks are done" in lines[0]
    kept = list((tmp_path / "out" / ".chunks").glob("*/chunk-*.npz"))
    assert [p.name for p in kept] == ["chunk-00000.npz"]
    kept_stamp = kept[0].stat().st_mtime_ns
    rerun = run(*args, "--scheduler", "inline")  # the same study: its kept chunk is not computed again
    assert rerun.returncode == 0, rerun.stderr
    assert json.loads(rerun.stdout)["completed_fraction"] == 1.0
    assert kept[0].stat().st_mtime_ns == kept_stamp
