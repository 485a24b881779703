"""What the test_faults_* files share: the gymnast's MJCF and its variants, users' controllers (their fixtures
``saved_trajectory`` and ``made_xml`` are in conftest.py, computed once a session)."""
import json

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


M_GEAR = 'joint="hips" gear="1"'
