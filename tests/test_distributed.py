"""Studies on a real local Dask cluster (loopback) give exactly the results of the inline path."""
import numpy as np
import pytest

distributed = pytest.importorskip("distributed")

from paa_mj.cli import main  # noqa: E402
from paa_mj.distributed import run_rollouts  # noqa: E402
from paa_mj.rollout import X0_HANGING  # noqa: E402
from paa_mj.studies import basin  # noqa: E402


@pytest.fixture(scope="module")
def scheduler_address():
    from distributed import LocalCluster

    with LocalCluster(n_workers=2, threads_per_worker=1, processes=True, host="127.0.0.1",
                      dashboard_address=None) as cluster:
        yield cluster.scheduler_address


def test_basin_identical_on_dask_and_inline(gymnast, scheduler_address):
    on_dask = basin(gymnast, (0, 1), grid=4, t_final=3.0, scheduler=scheduler_address)
    inline = basin(gymnast, (0, 1), grid=4, t_final=3.0, scheduler="inline")
    assert on_dask[0] == inline[0]
    for key, value in inline[1].items():
        np.testing.assert_array_equal(on_dask[1][key], value, err_msg=key)


def test_chunked_noisy_rollouts_identical(gymnast, scheduler_address):
    x0 = np.tile(X0_HANGING, (12, 1))
    x0[:, 1] += np.linspace(-0.5, 0.5, 12)
    kwargs = dict(t_final=1.0, noise_std=np.full((12, 2), 0.01), delay_steps=np.arange(12) % 3, seed=7, chunk=5)
    a = run_rollouts(gymnast, x0, scheduler=scheduler_address, **kwargs)
    b = run_rollouts(gymnast, x0, scheduler="inline", **kwargs)
    for key in ("final_state", "max_abs_tau", "switch_time", "held"):
        np.testing.assert_array_equal(getattr(a, key), getattr(b, key), err_msg=key)
    assert a.meta["completed"].all()
    assert np.max(np.abs(a.final_state[0] - a.final_state[5])) > 0  # chunks draw different noise


def test_unreachable_scheduler_is_one_line(capsys):
    code = main(["basin", "--grid", "2", "--t-final", "0.1", "--scheduler", "tcp://127.0.0.1:9"])
    err = capsys.readouterr().err
    assert code == 2
    assert "cannot reach the Dask scheduler tcp://127.0.0.1:9" in err
    assert len(err.strip().splitlines()) == 1


def test_bad_scheduler_value(capsys):
    assert main(["basin", "--grid", "2", "--scheduler", "somewhere"]) == 2
    assert "--scheduler must be inline, local or an address" in capsys.readouterr().err


def test_ctrl_c_stops_cleanly_and_keeps_finished_chunks(tmp_path):
    import os
    import signal
    import subprocess
    import sys
    import time

    out = tmp_path / "basin"
    proc = subprocess.Popen([sys.executable, "-m", "paa_mj.cli", "basin", "--grid", "24", "--t-final", "6",
                             "--scheduler", "inline", "--json", "--out", str(out)],
                            stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
    time.sleep(11)  # past start-up; how many chunks finish by then depends on the machine's load
    proc.send_signal(signal.SIGINT)
    stdout, stderr = proc.communicate(timeout=120)
    assert proc.returncode == 130, stderr
    assert "Traceback" not in stderr
    import json

    summary = json.loads(stdout)
    assert summary["interrupted"] is True and summary["cells"] == 576
    assert summary["completed_fraction"] < 1  # that what finished is kept: the next test, deterministically
    assert (out / "basin.npz").exists() and (out / "basin.png").exists()
    assert not [p for p in os.listdir(out) if p.startswith(".")]  # no half-written temporary files


def test_shared_and_per_rollout_arguments_split_alike(gymnast):
    x0 = np.tile(X0_HANGING, (7, 1))
    shared = run_rollouts(gymnast, x0, scheduler="inline", chunk=3, t_final=0.3, gains=[4600.0, 16000.0, 5000.0],
                          torque_limit=100.0)
    rows = run_rollouts(gymnast, x0, scheduler="inline", chunk=3, t_final=0.3,
                        gains=np.tile([4600.0, 16000.0, 5000.0], (7, 1)), torque_limit=np.full(7, 100.0))
    whole = run_rollouts(gymnast, x0, scheduler="inline", chunk=128, t_final=0.3, gains=[4600.0, 16000.0, 5000.0],
                         torque_limit=100.0)
    np.testing.assert_array_equal(shared.final_state, rows.final_state)
    np.testing.assert_array_equal(shared.final_state, whole.final_state)
    assert np.all(shared.max_abs_tau <= 100.0)


def test_interrupt_keeps_the_chunks_already_finished(gymnast, monkeypatch):
    import paa_mj.distributed as dist

    x0 = np.tile(X0_HANGING, (7, 1))
    x0[:, 1] += np.linspace(-0.3, 0.3, 7)
    whole = run_rollouts(gymnast, x0, scheduler="inline", chunk=3, t_final=0.5)
    calls = []
    real = dist.simulate_batch

    def interrupted_on_second_chunk(*args, **kwargs):
        calls.append(1)
        if len(calls) == 2:
            raise KeyboardInterrupt
        return real(*args, **kwargs)

    monkeypatch.setattr(dist, "simulate_batch", interrupted_on_second_chunk)
    part = run_rollouts(gymnast, x0, scheduler="inline", chunk=3, t_final=0.5)
    assert len(calls) == 2  # stopped at the interrupt, the third chunk never started
    assert part.interrupted
    assert list(part.meta["completed"]) == [True] * 3 + [False] * 4
    np.testing.assert_array_equal(part.final_state[:3], whole.final_state[:3])
    assert np.all(np.isnan(part.final_state[3:]))
