"""Progress in a log: the watchdog's lines in a silence, none on a terminal; a one-chunk study starts no cluster."""
import io
import time

import numpy as np

from paa_mj import progress
from paa_mj.model.states import X0_HANGING
from paa_mj.studies.runner import RolloutSet, run_study
from paa_mj.task import Task


class _Terminal(io.StringIO):
    def isatty(self):
        return True


def test_watchdog_fills_a_silence_in_a_log_and_names_the_last_line():
    log = io.StringIO()
    with progress.watchdog("paa-mj test", silence=0.2, stream=log):
        progress._said("step one")
        time.sleep(0.9)
    lines = log.getvalue().splitlines()
    assert lines and all(line.startswith("paa-mj test: still working") for line in lines)
    assert "(last: step one)" in lines[0]
    assert len(lines) <= 5  # one per silence, not one per look


def test_watchdog_says_nothing_on_a_terminal_or_when_off():
    for stream, enabled in ((_Terminal(), True), (io.StringIO(), False)):
        with progress.watchdog("paa-mj test", enabled=enabled, silence=0.1, stream=stream):
            time.sleep(0.4)
        assert stream.getvalue() == ""


def test_a_progress_line_resets_the_watchdog():
    log = io.StringIO()
    with progress.watchdog("paa-mj test", silence=0.5, stream=log):
        for _ in range(8):
            progress._said("busy")
            time.sleep(0.1)
    assert log.getvalue() == ""


def test_a_json_run_keeps_stdout_for_its_object_and_still_fills_its_silences_on_stderr(monkeypatch, capsys):
    import contextlib
    import json

    from paa_mj.cli import main

    log, real = io.StringIO(), progress.watchdog

    @contextlib.contextmanager
    def slow(command, enabled=True, **kwargs):  # the command's own watchdog, with a silence it cannot miss
        with real(command, enabled=enabled, silence=0.05, stream=log):
            yield
            time.sleep(0.3)

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
