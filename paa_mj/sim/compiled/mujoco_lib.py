"""MuJoCo's C library linked into numba: ``mj_step`` and ``mj_resetData`` callable from compiled code.

The library is the one the Python bindings load, so compiled code and the bindings share one
MuJoCo; models and data are passed as their addresses (``MjModel._address``), pointers as integers
(the same ABI).
"""
from __future__ import annotations

import ctypes.util
import glob
import os

import mujoco
from numba import types

from ...provenance import require_compiled_kernels

require_compiled_kernels()  # uncompiled, the calls below would never step MuJoCo

#: MuJoCo's warnings that mean the simulation has become unstable (bad qacc, qpos, qvel or ctrl).
WARNINGS = (int(mujoco.mjtWarning.mjWARN_BADQACC), int(mujoco.mjtWarning.mjWARN_BADQPOS),
            int(mujoco.mjtWarning.mjWARN_BADQVEL), int(mujoco.mjtWarning.mjWARN_BADCTRL))


def mujoco_library():
    """Path of the MuJoCo C library that the Python bindings load."""
    folder = os.path.dirname(mujoco.__file__)
    found = sorted(glob.glob(os.path.join(folder, "libmujoco.so*")) + glob.glob(os.path.join(folder, "libmujoco*.dylib"))
                   + glob.glob(os.path.join(folder, "mujoco.dll")))
    return found[0] if found else ctypes.util.find_library("mujoco")


def _link_mujoco():
    import llvmlite.binding as llvm

    path = mujoco_library()
    if path is None:
        return False
    llvm.load_library_permanently(path)
    return True


COMPILED_PHYSICS = _link_mujoco()
mj_step = types.ExternalFunction("mj_step", types.void(types.intp, types.intp))
mj_reset = types.ExternalFunction("mj_resetData", types.void(types.intp, types.intp))
