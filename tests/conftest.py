import os

import numpy as np
import pytest
from hypothesis import settings

from paa_mj.model import load_robot

# No progress lines in a log, in this process and in every one a test starts: what a command writes on stderr is
# then the same on a fast machine and on a loaded one (a "still working" line after 20 s of silence, a count after
# 2 s). tests/test_progress.py checks those lines themselves.
os.environ["PAA_MJ_PROGRESS"] = "off"

# Property tests draw the same examples on every run: a CI run is reproducible, and a failure found once is found
# again (a new example is found by changing a test, not by chance).
settings.register_profile("reproducible", derandomize=True, print_blob=True)
settings.load_profile("reproducible")

# The paper's values, used only to check what the package computes.
TABLE1 = dict(m=[5.4, 29.5, 18.5], l=[0.58, 0.50, 0.79], lc=[0.31, 0.20, 0.33], J=[0.15, 1.93, 1.03])
TABLE2 = dict(m=[1.0, 0.5, 0.5], l=[3.0, 0.5, 0.5], lc=[1.5, 0.25, 0.25],
              J=[1.0 * 9 / 12, 0.5 * 0.25 / 12, 0.5 * 0.25 / 12])
GAINS1 = dict(kD=4550.0, kP=16000.0, kV=5000.0)
GAINS2 = dict(kD=31.0, kP=90.0, kV=90.0)


# Modules whose tests share an expensive module-scoped fixture: the reproduction, the atlas of 36 robots, the Dask
# cluster and the uninterrupted basin. Under ``pytest -n N`` each would be computed again on every worker that draws
# one of their tests.
SHARED_FIXTURE_MODULES = ("tests/test_reproduce.py", "tests/test_atlas.py", "tests/test_distributed.py")


@pytest.hookimpl(tryfirst=True)  # before ``-m`` deselects by the marks
def pytest_collection_modifyitems(config, items):
    """The checks :mod:`tests.tiers` lists run under ``slow``; an entry that names no test is refused (when the whole
    suite is collected), so that a renamed test cannot slip back into the quick suite unseen."""
    from pathlib import Path

    from tests.tiers import SLOW, matches, reason

    for item in items:
        why = reason(item.nodeid)
        if why is not None:
            item.add_marker(pytest.mark.slow(reason=why))
    files = {item.nodeid.split("::", 1)[0] for item in items}
    if all(f"tests/{path.name}" in files for path in Path(__file__).parent.glob("test_*.py")):
        stale = [entry for entry in SLOW if not any(matches(entry, item.nodeid) for item in items)]
        if stale:
            raise pytest.UsageError(f"tests/tiers.py names no test: {', '.join(stale)}")


#: The model-predictive controller's solver, which the quick suite never compiles (tests/tiers.py): module, kernels.
MPC_SOLVER = {"paa_mj.control.mpc": ("mpc_kernel",), "paa_mj.control.mpc_law": ("replan",),
              "paa_mj.control.mpc_kernels": ("ilqr",)}
_solver_reported = []


@pytest.fixture(autouse=True)
def quick_tests_leave_the_mpc_solver_alone(request):
    """In the quick suite (``slow`` deselected), a test that loads mpc's solver fails, naming tests/tiers.py: on a
    fresh install the solver's compilation alone is a fifth of the quick suite's budget."""
    yield
    markexpr = request.config.option.markexpr or ""
    if "not slow" not in markexpr or _solver_reported:
        return
    import sys

    loaded = [f"{module}.{name}" for module, names in MPC_SOLVER.items() if module in sys.modules
              for name in names if getattr(sys.modules[module], name).signatures]
    if loaded:
        _solver_reported.append(request.node.nodeid)
        pytest.fail(f"this quick test loads {', '.join(loaded)} (mpc's solver): list it in tests/tiers.py (slow)")


@pytest.hookimpl(optionalhook=True)
def pytest_xdist_make_scheduler(config, log):
    """``-n N`` as usual (one test at a time to a free worker), but each module above whole to one worker.

    (xdist's own ``--dist loadgroup`` marks do not reach pytest 9's test ids, hence this scheduler.)
    """
    if config.getvalue("dist") != "load":
        return None
    from xdist.scheduler import LoadScopeScheduling

    class SharedFixturesTogether(LoadScopeScheduling):
        def _split_scope(self, nodeid):
            module = nodeid.split("::", 1)[0]
            return module if module in SHARED_FIXTURE_MODULES else nodeid

    return SharedFixturesTogether(config, log)


@pytest.fixture(scope="session", autouse=True)
def figures_at_test_resolution():
    """Figures drawn in the tests' own processes at 100 dpi instead of 200, a quarter of the pixels: the tests
    check each figure's files and content, not its pixel density (commands run as subprocesses keep 200)."""
    from paa_mj.outputs import plots

    with pytest.MonkeyPatch.context() as patch:
        patch.setattr(plots, "DPI", 100)
        yield


@pytest.fixture
def one_panel_figures(monkeypatch):
    """``one_panel_figures("basin_figure", ...)``: those figures of :mod:`paa_mj.outputs.plots` drawn as one empty
    panel, for a test of a study's runs, folders or chunks rather than of its drawing (about 0.6 CPU-s a figure,
    5 for the atlas's maps); each figure is drawn and checked in full by a test of its own."""
    from paa_mj.outputs import plots

    def stand_in(*names):
        for name in names:
            monkeypatch.setattr(plots, name, lambda *args, **kwargs: plots.new_figure()[0])

    return stand_in


@pytest.fixture(scope="session")
def gymnast():
    return load_robot("gymnast")


@pytest.fixture(scope="session")
def example2():
    return load_robot("example2")


class Result:
    """What a finished ``paa-mj`` run left: its exit code, standard output and standard error."""

    def __init__(self, returncode, stdout, stderr):
        self.returncode, self.stdout, self.stderr = returncode, stdout, stderr


@pytest.fixture
def run(capsys, monkeypatch):
    """``paa-mj ARGS`` in this process (no interpreter start-up, no numba cache load), as a completed process.

    The GL variables a ``render`` sets are put back afterwards, so later tests and their subprocesses see
    the environment they started with.
    """
    import os

    from paa_mj.cli import main

    for name in ("MUJOCO_GL", "PYOPENGL_PLATFORM"):
        if name in os.environ:
            monkeypatch.setenv(name, os.environ[name])
        else:
            monkeypatch.delenv(name, raising=False)

    def call(*args, cwd=None):
        if cwd is not None:
            monkeypatch.chdir(cwd)
        code = main([str(a) for a in args])
        out, err = capsys.readouterr()
        return Result(code, out, err)

    return call


@pytest.fixture
def rng():
    return np.random.default_rng(1234)


# Shared by the test_faults_* files: once a session (per xdist worker), not once per file.
@pytest.fixture(scope="session")
def saved_trajectory(tmp_path_factory):
    from paa_mj.cli import main

    d = tmp_path_factory.mktemp("traj")
    assert main(["simulate", "--t-final", "0.3", "--out", str(d)]) == 0  # in this process: no start-up to pay
    return d / "trajectory.npz"


@pytest.fixture(scope="session")
def made_xml(tmp_path_factory):
    """The MJCF text that 'paa-mj make-model' writes for a small robot: the base of the model variants in tests/test_faults_*."""
    import contextlib
    import io

    from paa_mj.cli import main

    path = tmp_path_factory.mktemp("made") / "robot.xml"
    with contextlib.redirect_stdout(io.StringIO()), contextlib.redirect_stderr(io.StringIO()):
        # at 1 ms, the step the fault tests were written for (its LQR balance is stable from a shorter one)
        assert main(["make-model", "--m", "2", "1", "1", "--l", "1", "0.6", "0.6", "--timestep", "0.001",
                     "--out", str(path)]) == 0
    return path.read_text()
