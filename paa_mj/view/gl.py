"""Choosing the offscreen OpenGL backend before MuJoCo is imported.

MuJoCo reads ``MUJOCO_GL`` once, when ``mujoco`` is first imported, so the
choice must be made first. ``auto`` probes EGL, then OSMesa, each in a short
subprocess (a backend that fails to start can leave the process unusable).
"""
from __future__ import annotations

import os
import subprocess
import sys

from ..errors import PaaError

BACKENDS = ("egl", "osmesa")
INSTALL_HINT = {
    "egl": "install the Debian packages libegl1 libegl-mesa0 libgl1-mesa-dri (or an NVIDIA driver)",
    "osmesa": "install the Debian package libosmesa6 and the Python package PyOpenGL",
}
_PROBE = """
import mujoco
m = mujoco.MjModel.from_xml_string('<mujoco><worldbody><geom size="1"/></worldbody></mujoco>')
d = mujoco.MjData(m)
mujoco.mj_forward(m, d)
with mujoco.Renderer(m, 8, 8) as r:
    r.update_scene(d)
    r.render()
"""


def _valid_mujoco_gl():
    """The values of ``MUJOCO_GL`` that MuJoCo's import accepts here (lower case, stripped), as in its gl_context."""
    import platform

    valid = ("disable", "disabled", "off", "false", "0", "enable", "enabled", "on", "true", "1", "glfw", "")
    return valid + {"Linux": ("glx", "egl", "osmesa"), "Windows": ("wgl",), "Darwin": ("cgl",)}.get(platform.system(), ())


def check_mujoco_gl():
    """Refuse a ``MUJOCO_GL`` that MuJoCo would refuse, before anything imports it.

    MuJoCo reads the variable when it is first imported, by any command (not only the ones
    that render), and answers an unknown value with a RuntimeError from deep in that import.

    Raises
    ------
    PaaError
        One line naming the value and the ones to use instead.
    """
    value = os.environ.get("MUJOCO_GL")
    if value is not None and value.lower().strip() not in _valid_mujoco_gl():
        raise PaaError(f"the environment variable MUJOCO_GL={value!r} is not a GL backend MuJoCo knows: set it to egl"
                       " or osmesa (offscreen), glfw, or unset it")


def probe(backend: str, timeout=60) -> str | None:
    """None if ``backend`` renders in a fresh process, else the last line of its error."""
    env = dict(os.environ, MUJOCO_GL=backend)
    env.pop("PYOPENGL_PLATFORM", None)
    try:
        proc = subprocess.run([sys.executable, "-c", _PROBE], env=env, capture_output=True, text=True, timeout=timeout)
    except subprocess.TimeoutExpired:
        return "timed out"
    if proc.returncode == 0:
        return None
    lines = [line for line in proc.stderr.strip().splitlines() if line.strip()]
    return lines[-1] if lines else f"exit code {proc.returncode}"


def select_backend(gl: str = "auto") -> str:
    """Set ``MUJOCO_GL`` (and ``PYOPENGL_PLATFORM``) for ``gl`` in {auto, egl, osmesa}; return the backend.

    Raises
    ------
    PaaError
        Unknown value, a backend that cannot start (naming what to install), or
        MuJoCo already imported with another backend.
    """
    if gl not in ("auto",) + BACKENDS:
        raise PaaError(f"unknown GL backend {gl!r}: use auto, egl or osmesa")
    current = os.environ.get("MUJOCO_GL")
    if "mujoco" in sys.modules and current in BACKENDS and gl in (current, "auto"):
        return current  # already set up in this process
    candidates = BACKENDS if gl == "auto" else (gl,)
    reasons = {}
    for backend in candidates:
        reason = probe(backend)
        if reason is None:
            _activate(backend)
            return backend
        reasons[backend] = reason
    if gl == "auto":
        raise PaaError("no offscreen GL backend works: "
                       + "; ".join(f"{b}: {reasons[b]} ({INSTALL_HINT[b]})" for b in BACKENDS))
    raise PaaError(f"GL backend {gl} cannot start: {reasons[gl]}; {INSTALL_HINT[gl]}")


def _activate(backend):
    loaded = os.environ.get("PYOPENGL_PLATFORM") if "OpenGL" in sys.modules else None
    if loaded not in (None, backend):
        raise PaaError(f"PyOpenGL was already loaded for {loaded} in this process; set MUJOCO_GL={backend} before"
                       " importing mujoco or paa_mj (or use --gl auto)")
    os.environ["MUJOCO_GL"] = backend
    os.environ["PYOPENGL_PLATFORM"] = backend
    if "mujoco" in sys.modules:
        # mujoco chose its GLContext class when it was imported; Renderer reads it from
        # gl_context when it is built, so pointing it at the chosen backend is enough.
        import importlib

        from mujoco.rendering.classic import gl_context

        try:
            gl_context.GLContext = importlib.import_module(f"mujoco.{backend}").GLContext
        except (ImportError, AttributeError) as err:
            raise PaaError(f"cannot switch MuJoCo to {backend} in this process ({' '.join(str(err).split())});"
                           f" set MUJOCO_GL={backend} before importing mujoco") from None
