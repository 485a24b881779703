"""MuJoCo Warp, loaded once, quietly: the optional GPU dependency (``pip install "paa_mj[gpu]"``).

:func:`load_warp` imports ``warp`` and ``mujoco_warp`` (only where the MuJoCo physics runs on the device: about
5 CPU-s of kernel definitions, which RealAIGym's own simulator on Warp does not use) or refuses in one line that
says how to install them;
it keeps Warp's compiled kernels under the package's cache folder (``$PAA_MJ_CACHE/warp``, or ``$WARP_CACHE_PATH``
where set) and silences Warp's greeting and the CUDA driver's absence on a machine without a GPU.
:func:`device_name` picks the device: the one asked for, else ``$PAA_MJ_WARP_DEVICE``, else Warp's preferred
(the first GPU, or ``cpu``).
"""
from __future__ import annotations

import contextlib
import os
import sys

from ...errors import PaaError

#: How to get the engine.
INSTALL = "pip install 'paa_mj[gpu]'"
#: The environment variable that names the Warp device (``cpu``, ``cuda:0`` ...).
DEVICE_VARIABLE = "PAA_MJ_WARP_DEVICE"

_LOADED = {}


def warp_available() -> bool:
    """Whether ``warp`` and ``mujoco_warp`` can be imported (without importing them)."""
    import importlib.util

    return all(importlib.util.find_spec(name) is not None for name in ("warp", "mujoco_warp"))


@contextlib.contextmanager
def _quiet_stderr():
    """File descriptor 2 to /dev/null for the block: Warp's native library reports a missing CUDA driver there."""
    try:
        sys.stderr.flush()
        saved = os.dup(2)
    except (OSError, ValueError):
        yield
        return
    try:
        with open(os.devnull, "w") as null:
            os.dup2(null.fileno(), 2)
            yield
    finally:
        os.dup2(saved, 2)
        os.close(saved)


def load_warp(mujoco=True):
    """``(warp, mujoco_warp)``, initialised, or a one-line :class:`PaaError` naming the install command.

    ``mujoco=False``: ``mujoco_warp`` is only checked to be installed, not imported, and None stands in its place
    (what needs Warp alone: RealAIGym's simulator, the check of a command's ``--engine warp``)."""
    if "wp" in _LOADED and (not mujoco or "mjw" in _LOADED):
        return _LOADED["wp"], _LOADED.get("mjw")
    if "wp" in _LOADED:
        return _LOADED["wp"], _load_mujoco_warp()
    try:
        import warp as wp
    except ImportError as err:
        raise PaaError(f"the warp engine needs NVIDIA Warp and MuJoCo Warp, not installed here ({err}): {INSTALL}") \
            from None
    wp.config.log_level = max(getattr(wp.config, "log_level", 0), getattr(wp, "LOG_WARNING", 30))
    wp.config.quiet = True
    if not os.environ.get("WARP_CACHE_PATH"):
        from ...provenance import cache_root

        wp.config.kernel_cache_dir = str(cache_root() / "warp")
    try:
        with _quiet_stderr():
            wp.init()
    except Exception as err:  # noqa: BLE001 - any failure of the native runtime, one line
        raise PaaError(f"NVIDIA Warp did not start: {type(err).__name__}: {' '.join(str(err).split())}") from None
    if not mujoco:
        import importlib.util

        if importlib.util.find_spec("mujoco_warp") is None:
            raise PaaError(f"the warp engine needs MuJoCo Warp, not installed here (No module named 'mujoco_warp'):"
                           f" {INSTALL}")
        _LOADED.update(wp=wp)
        return wp, None
    _LOADED.update(wp=wp)
    return wp, _load_mujoco_warp()


def _load_mujoco_warp():
    try:
        import mujoco_warp as mjw
    except ImportError as err:
        raise PaaError(f"the warp engine needs MuJoCo Warp, not installed here ({err}): {INSTALL}") from None
    _LOADED.update(mjw=mjw)
    return mjw


def device_name(wp, device=None) -> str:
    """The Warp device to run on: ``device``, else ``$PAA_MJ_WARP_DEVICE``, else Warp's preferred; checked."""
    name = device if device is not None else os.environ.get(DEVICE_VARIABLE) or str(wp.get_preferred_device())
    names = [str(d) for d in wp.get_devices()]
    if str(name) not in names:
        raise PaaError(f"no Warp device {name!r} here; the devices are {', '.join(names)}"
                       + (f" (set by {DEVICE_VARIABLE})" if device is None and os.environ.get(DEVICE_VARIABLE) else ""))
    return str(name)
