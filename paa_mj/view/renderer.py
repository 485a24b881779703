"""The robot drawn offscreen at given joint angles: one frame at a time, for videos and the environments.

Links are coloured by controller mode (warm colours during swing-up (40), gold once the LQR (67) balances)
and the tip of the last link can leave a fading trace. Select the GL backend with
:func:`paa_mj.view.gl.select_backend` first.
"""
from __future__ import annotations

import mujoco
import numpy as np

from ..errors import PaaError
from ..model.robot import Robot

LINK_MATERIALS = ("arms", "trunk", "legs")
BALANCE_RGBA = np.array([[0.95, 0.75, 0.15, 1.0], [0.85, 0.6, 0.1, 1.0], [0.75, 0.5, 0.05, 1.0]])


class GymnastRenderer:
    """Renders the gymnast at given joint angles, coloured by mode, with a fading feet trace.

    Use as a context manager so the GL context is released explicitly.
    """

    def __init__(self, robot: Robot, width=640, height=480, camera="side"):
        for name, value in (("width", width), ("height", height)):
            if not (isinstance(value, (int, np.integer)) and 16 <= value <= 4096):
                raise PaaError(f"--{name} must be an integer in [16, 4096], got {value}")
        self.model = robot.model.__copy__()
        self.model.vis.global_.offwidth = max(self.model.vis.global_.offwidth, width)
        self.model.vis.global_.offheight = max(self.model.vis.global_.offheight, height)
        if mujoco.mj_name2id(self.model, mujoco.mjtObj.mjOBJ_CAMERA, camera) < 0:
            cams = [self.model.camera(i).name for i in range(self.model.ncam)]
            raise PaaError(f"no camera named {camera!r} in the model (cameras: {', '.join(cams) or 'none'})")
        self.camera = camera
        self.data = mujoco.MjData(self.model)
        # the tip of the last link: the gymnast's feet, another chain's tip site (the last body's origin else)
        tips = [mujoco.mj_name2id(self.model, mujoco.mjtObj.mjOBJ_SITE, name) for name in ("feet", "tip")]
        self.feet = max(tips)
        self.materials = [mujoco.mj_name2id(self.model, mujoco.mjtObj.mjOBJ_MATERIAL, n) for n in LINK_MATERIALS]
        self.swing_rgba = np.array([self.model.mat_rgba[m] for m in self.materials if m >= 0])
        self.trace_size = 0.012 * float(np.sum(robot.params.l))
        try:
            self.renderer = mujoco.Renderer(self.model, height, width)
        except Exception as err:  # GL failures come as several exception types
            raise PaaError(f"cannot start the offscreen renderer: {' '.join(str(err).split())}") from None

    def __enter__(self):
        return self

    def __exit__(self, *exc):
        self.close()

    def close(self):
        if getattr(self, "renderer", None) is not None:
            self.renderer.close()
            self.renderer = None

    def feet_positions(self, q):
        out = np.empty((len(q), 3))
        for i, qi in enumerate(q):
            self.data.qpos[:] = qi
            mujoco.mj_kinematics(self.model, self.data)
            out[i] = self.data.site_xpos[self.feet] if self.feet >= 0 else self.data.xpos[-1]
        return out

    def render(self, q, mode=0, trace=()):
        """One RGB frame (height, width, 3) uint8."""
        for k, mat in enumerate(m for m in self.materials if m >= 0):
            self.model.mat_rgba[mat] = BALANCE_RGBA[k] if mode == 1 else self.swing_rgba[k]
        self.data.qpos[:] = q
        mujoco.mj_forward(self.model, self.data)
        self.renderer.update_scene(self.data, self.camera)
        scene = self.renderer.scene
        scene.flags[mujoco.mjtRndFlag.mjRND_SHADOW] = False
        scene.flags[mujoco.mjtRndFlag.mjRND_REFLECTION] = False
        n = len(trace)
        for i, pos in enumerate(trace):
            if scene.ngeom >= scene.maxgeom:
                break
            alpha = 0.9 * (i + 1) / n
            mujoco.mjv_initGeom(scene.geoms[scene.ngeom], mujoco.mjtGeom.mjGEOM_SPHERE,
                                np.full(3, self.trace_size * (0.4 + 0.6 * (i + 1) / n)), pos, np.eye(3).ravel(),
                                np.array([1.0, 0.85, 0.1, alpha], dtype=np.float32))
            scene.ngeom += 1
        return self.renderer.render()
