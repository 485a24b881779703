"""MuJoCo's own log, turned off while rollouts run.

MuJoCo prints each warning (an unstable state, a non-finite control) to the
console and appends it to ``MUJOCO_LOG.TXT`` in the working folder. A study of
thousands of rollouts would flood both, and leave that file wherever it was
started. The engine reads MuJoCo's warning counters instead and ends such a
rollout as *diverged*, with the reason in its status.
"""
from __future__ import annotations

import contextlib

import mujoco


@contextlib.contextmanager
def mujoco_log_off():
    """MuJoCo's console and file log off inside the block, restored after it."""
    config = mujoco.MjLogConfig.get()
    before = (config.logto_console, config.logto_file)
    config.logto_console = config.logto_file = False
    config.set()
    try:
        yield
    finally:
        config.logto_console, config.logto_file = before
        config.set()
