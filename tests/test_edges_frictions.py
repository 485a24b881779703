"""Frictions: a run that did nothing is said, a bar of simulated seconds shows them rounded, a solver's bar
finishes where the solver stopped."""
import io
import json

from paa_mj import progress as progress_module


def test_a_controller_at_rest_at_its_own_equilibrium_is_said(run):
    result = run("realaigym", "--protocol", "performance-v2", "--json")  # vcl on their acrobot, from hanging at rest
    summary = json.loads(result.stdout)
    assert summary["result"]["score"] == 0.0 and summary["result"]["no_action"]["max_abs_tau"] < 1e-9
    assert "vcl exerted no torque" in result.stderr and "never left its start" in result.stderr
    assert "--x0" in result.stderr and len(result.stderr.strip().splitlines()) == 1


def _log_bar(monkeypatch, **kwargs):
    stream = io.StringIO()
    monkeypatch.setattr(progress_module.sys, "stderr", stream)
    monkeypatch.setattr(progress_module, "LOG_DELAY", 0.0)
    monkeypatch.delenv("PAA_MJ_PROGRESS", raising=False)  # the suite leaves progress out of logs
    return progress_module.progress(**kwargs), stream


def test_a_bar_of_simulated_seconds_shows_them_rounded(monkeypatch):
    bar, stream = _log_bar(monkeypatch, total=30.0, unit="s simulated", desc="rollouts")
    bar.update(11.778875)
    bar.close()
    line = stream.getvalue().strip().splitlines()[0]
    assert "11.8/30.0" in line and "11.778875" not in line


def test_a_bar_whose_total_was_a_bound_finishes_at_the_count_reached(monkeypatch):
    bar, stream = _log_bar(monkeypatch, total=3000, unit="iteration", desc="IPOPT")
    for _ in range(150):
        bar.update(1)
    progress_module.finish(bar)
    last = stream.getvalue().strip().splitlines()[-1]
    assert "150/150" in last and "100%" in last


def test_a_terminal_bar_of_simulated_seconds_shows_them_rounded():
    from tqdm import tqdm

    line = tqdm.format_meter(11.778875, 30.0, 5, bar_format=progress_module.FLOAT_BAR, ncols=100,
                             unit="s simulated", prefix="rollouts")
    assert "11.8/30.0" in line and "11.778875" not in line
