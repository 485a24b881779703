"""What the test_faults_* files share: the gymnast's MJCF and its variants, users' controllers, fixtures."""
import json

import pytest

from paa_mj.model.mjcf import MODEL_DIR

GYMNAST = (MODEL_DIR / "gymnast.xml").read_text()


def _one_line_error(proc, fragment, code=2):
    assert proc.returncode == code, proc.stderr
    lines = proc.stderr.strip().splitlines()
    assert lines and lines[-1].startswith("paa-mj: error:") and fragment in lines[-1], proc.stderr
    assert "Traceback" not in proc.stderr


def _variant(old, new):
    assert old in GYMNAST, old
    return GYMNAST.replace(old, new, 1)


@pytest.fixture(scope="module")
def saved_trajectory(tmp_path_factory):
    from paa_mj.cli import main

    d = tmp_path_factory.mktemp("traj")
    assert main(["simulate", "--t-final", "0.3", "--out", str(d)]) == 0  # in this process: no start-up to pay
    return d / "trajectory.npz"


USER_CONTROLLERS = '''
import sys
import numpy as np


class _Zero:
    def __init__(self, robot=None):
        pass

    def torque(self, q, qd, t=0.0):
        return np.zeros(np.shape(q)[:-1] + (2,))


class ResetFails(_Zero):
    def reset(self):
        raise RuntimeError("reset boom")


class ModeNotInteger(_Zero):
    mode = "banana"


class ModeFails(_Zero):
    @property
    def mode(self):
        raise RuntimeError("mode boom")


class Exits(_Zero):
    def torque(self, q, qd, t=0.0):
        sys.exit(0)
'''


PRINTING_AND_FAILING = USER_CONTROLLERS + '''

class Chatty(_Zero):
    def __init__(self, robot=None):
        print("hello from __init__")

    def torque(self, q, qd, t=0.0):
        print("tick", t)
        return np.zeros(np.shape(q)[:-1] + (2,))


class LateNaN(_Zero):
    def torque(self, q, qd, t=0.0):
        return np.full(np.shape(q)[:-1] + (2,), np.nan if t > 0.05 else 0.0)


class Damped(_Zero):
    def torque(self, q, qd, t=0.0):
        return -10.0 * qd[..., 1:]
'''


def _strict(text):
    def refuse(constant):
        raise ValueError(f"{constant} is not JSON")
    return json.loads(text, parse_constant=refuse)


def _made(text, old, new):
    """``text`` (make-model's MJCF) with ``old`` replaced by ``new`` once (all occurrences when old starts with *)."""
    if old.startswith("*"):
        assert old[1:] in text, old
        return text.replace(old[1:], new)
    if old == "PAA_GAINS":
        import re

        return re.sub(r'<numeric name="paa_gains" data="[^"]*"/>', new, text)
    assert old in text, old
    return text.replace(old, new, 1)


@pytest.fixture(scope="module")
def made_xml(tmp_path_factory):
    """The MJCF text that 'paa-mj make-model' writes for a small robot: the base of the model variants below."""
    import contextlib
    import io

    from paa_mj.cli import main

    path = tmp_path_factory.mktemp("made") / "robot.xml"
    with contextlib.redirect_stdout(io.StringIO()), contextlib.redirect_stderr(io.StringIO()):
        assert main(["make-model", "--m", "2", "1", "1", "--l", "1", "0.6", "0.6", "--out", str(path)]) == 0
    return path.read_text()


M_GEAR = 'joint="hips" gear="1"'
