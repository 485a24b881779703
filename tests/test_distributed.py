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
    from distributed import LocalCluster

    # one worker process: the chunks still cross a process boundary (pickled, run apart from this process)
    with LocalCluster(n_workers=1, threads_per_worker=1, processes=True, host="127.0.0.1",
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


def _basin_cmd(out, grid=6, t_final=4, chunk=2):  # 18 chunks: a signal lands long before the last
    return [sys.executable, "-m", "paa_mj.cli", "basin", "--grid", str(grid), "--t-final", str(t_final),
            "--chunk", str(chunk), "--scheduler", "inline", "--json", "--out", str(out)]


def _files(out):
    return {name: (out / name).read_bytes() for name in ("basin.npz", "summary.json", "basin.png", "basin.svg")}


@pytest.fixture(scope="module")
def uninterrupted(tmp_path_factory):
    """The files of the whole study, computed in this process (the command's ``main``, no start-up to pay)."""
    reference = tmp_path_factory.mktemp("reference")
    assert main(_basin_cmd(reference)[3:]) == 0
    return _files(reference)


@pytest.mark.parametrize("sig, code", [(signal.SIGINT, 130), (signal.SIGTERM, 143)])
def test_signal_then_rerun_is_byte_identical_to_an_uninterrupted_run(tmp_path, sig, code, uninterrupted):
    """Stopped by a signal after at least one chunk, resumed by the same command: the same bytes."""
    out = tmp_path / "stopped"
    # Ctrl-C as a terminal delivers it, even when this test runs where SIGINT is ignored (a background job)
    proc = subprocess.Popen(_basin_cmd(out), stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True,
                            preexec_fn=lambda: signal.signal(signal.SIGINT, signal.SIG_DFL))
    chunks = out / ".chunks"
    deadline = time.time() + 120
    while time.time() < deadline and not list(chunks.glob("*/chunk-*.npz")):
        time.sleep(0.02)
    proc.send_signal(sig)
    stdout, stderr = proc.communicate(timeout=120)
    assert proc.returncode == code, stderr
    assert "Traceback" not in stderr and len(stderr.strip().splitlines()) == 1
    summary = json.loads(stdout)
    assert summary["interrupted"] is True and 0 < summary["completed_fraction"] < 1
    assert not [p for p in os.listdir(out)
                if p.startswith(".") and p not in (".chunks", ".paa-mj.lock", ".paa-mj-study.json")]
    assert main(_basin_cmd(out)[3:]) == 0  # the same command resumes (in this process: the stop was the real one)
    assert _files(out) == uninterrupted


def test_a_second_run_into_the_same_folder_is_refused(tmp_path):
    from paa_mj.io import OutputLock

    with OutputLock(tmp_path):
        proc = subprocess.run(_basin_cmd(tmp_path, grid=2, t_final=0.1), capture_output=True, text=True)
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


def test_losing_every_worker_stops_with_one_line_and_keeps_chunks(gymnast, tmp_path, run):
    """Every worker of a local cluster killed mid-study: one line, finished chunks kept, a rerun resumes."""
    script = tmp_path / "kill.py"
    script.write_text(f'''
import os, signal, sys, threading, time
os.environ["DASK_DISTRIBUTED__SCHEDULER__ALLOWED_FAILURES"] = "0"  # the first lost task stops the study
sys.argv = ["paa-mj", "basin", "--grid", "8", "--t-final", "2", "--chunk", "8", "--json", "--out",
            {str(tmp_path / "out")!r}]
import distributed
from paa_mj.cli import main

def killer():
    chunks = {str(tmp_path / "out" / ".chunks")!r}
    while True:
        time.sleep(0.05)
        if os.path.isdir(chunks) and any(f.startswith("chunk") for d in os.listdir(chunks)
                                         for f in os.listdir(os.path.join(chunks, d))):
            break
    import psutil
    end = time.time() + 20
    while time.time() < end:  # the nannies restart their workers: kill them again until Dask gives up
        for child in psutil.Process().children(recursive=True):
            try:
                if any("spawn_main" in part for part in child.cmdline()):
                    child.kill()
            except psutil.Error:
                pass
        time.sleep(0.1)

if __name__ == "__main__":  # Dask's worker processes import this file again
    threading.Thread(target=killer, daemon=True).start()
    sys.exit(main())
''')
    proc = subprocess.run([sys.executable, str(script)], capture_output=True, text=True, timeout=300)
    if proc.returncode == 0:
        pytest.skip("the study finished before the workers were killed")
    assert proc.returncode == 4, proc.stderr
    assert "Traceback" not in proc.stderr
    lines = [line for line in proc.stderr.strip().splitlines() if line.startswith("paa-mj")]
    assert len(lines) == 1 and "run the same command again to resume" in lines[0]
    kept = list((tmp_path / "out" / ".chunks").glob("*/chunk-*.npz"))
    assert kept
    rerun = run("basin", "--grid", "8", "--t-final", "2", "--chunk", "8", "--json", "--out", tmp_path / "out",
                "--scheduler", "inline")  # in this process: the exit code that matters was the killed run's
    assert rerun.returncode == 0, rerun.stderr
    assert json.loads(rerun.stdout)["completed_fraction"] == 1.0
