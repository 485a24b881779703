"""Progress in a log: the watchdog's lines in a silence, none on a terminal; a one-chunk study starts no cluster.

The watchdog reads the time from the progress module's clock, replaced here by one that moves only when a test
moves it: what it writes depends on the silences a test makes, not on how fast this machine runs the test.
"""
import io
import time
import types

import numpy as np
import pytest

from paa_mj import progress
from paa_mj.model.states import X0_HANGING
from paa_mj.studies.runner import RolloutSet, run_study
from paa_mj.task import Task


class _Terminal(io.StringIO):
    def isatty(self):
        return True


@pytest.fixture(autouse=True)
def progress_in_logs(monkeypatch):
    """These tests check the lines the suite otherwise leaves out of logs (tests/conftest.py)."""
    monkeypatch.delenv("PAA_MJ_PROGRESS", raising=False)


@pytest.fixture
def clock(monkeypatch):
    """The progress module's clock, moved by the test (``clock.now += seconds``)."""
    fake = types.SimpleNamespace(now=1000.0)
    fake.monotonic = lambda: fake.now
    monkeypatch.setattr(progress, "time", fake)
    return fake


def _until(condition):
    """Wait for the watchdog's thread to look (as long as it takes: a hang guard, not a time to meet)."""
    end = time.monotonic() + 600
    while not condition() and time.monotonic() < end:
        time.sleep(0.01)
    return condition()


def test_watchdog_fills_a_silence_in_a_log_and_names_the_last_line(clock):
    log = io.StringIO()
    with progress.watchdog("paa-mj test", silence=0.2, stream=log):
        progress._said("step one")
        clock.now += 0.25  # a silence
        assert _until(lambda: log.getvalue())
        time.sleep(0.2)  # many more looks (one each 0.05 s), no more silence: no more lines
        clock.now += 0.25  # a second silence
        assert _until(lambda: len(log.getvalue().splitlines()) == 2)
    lines = log.getvalue().splitlines()
    assert lines and all(line.startswith("paa-mj test: still working") for line in lines)
    assert "(last: step one)" in lines[0]
    assert len(lines) == 2  # one per silence, not one per look


def test_watchdog_says_nothing_on_a_terminal_or_when_off(clock, monkeypatch):
    for stream, enabled, variable in ((_Terminal(), True, None), (io.StringIO(), False, None),
                                      (io.StringIO(), True, "off")):
        if variable:
            monkeypatch.setenv("PAA_MJ_PROGRESS", variable)
        with progress.watchdog("paa-mj test", enabled=enabled, silence=0.1, stream=stream):
            clock.now += 1.0
            time.sleep(0.1)
        assert stream.getvalue() == ""


def test_a_progress_line_resets_the_watchdog(clock):
    log = io.StringIO()
    with progress.watchdog("paa-mj test", silence=0.5, stream=log):
        for _ in range(8):
            progress._said("busy")
            clock.now += 0.4  # never 0.5 s without a line
            time.sleep(0.03)
    assert log.getvalue() == ""


def test_progress_off_leaves_a_log_without_counts(monkeypatch, capsys):
    monkeypatch.setattr(progress, "LOG_DELAY", 0.0)
    monkeypatch.setattr(progress, "LOG_INTERVAL", 0.0)
    for _ in progress.progress(range(3), desc="counted"):
        pass
    assert "counted" in capsys.readouterr().err
    monkeypatch.setenv("PAA_MJ_PROGRESS", "off")
    for _ in progress.progress(range(3), desc="counted"):
        pass
    assert capsys.readouterr().err == ""


def test_a_json_run_keeps_stdout_for_its_object_and_still_fills_its_silences_on_stderr(monkeypatch, capsys, clock):
    import contextlib
    import json

    from paa_mj.cli import main

    log, real = io.StringIO(), progress.watchdog

    @contextlib.contextmanager
    def slow(command, enabled=True, **kwargs):  # the command's own watchdog, and a silence it cannot miss
        with real(command, enabled=enabled, silence=0.05, stream=log):
            yield
            clock.now += 1.0
            assert _until(lambda: log.getvalue())

    monkeypatch.setattr(progress, "watchdog", slow)
    assert main(["theory", "--robot", "acrobot", "--goal", "stretched", "--json"]) == 0
    assert json.loads(capsys.readouterr().out)["goal"] == "stretched"
    assert log.getvalue().startswith("paa-mj theory: still working")


def test_a_study_of_one_chunk_runs_here_even_when_a_local_cluster_is_asked(gymnast, monkeypatch):
    import paa_mj.studies.runner as runner

    def no_cluster(*args, **kwargs):
        raise AssertionError("a local cluster was started for one chunk")

    monkeypatch.setattr(runner, "_run_on_dask", no_cluster)
    x0 = np.tile(X0_HANGING, (2, 1))
    result = run_study(gymnast, RolloutSet(x0, "vcl", Task.named("folded", 3)), 0.05, scheduler="local")
    assert result.meta["completed"].all() and result.meta["scheduler"] == "inline"
