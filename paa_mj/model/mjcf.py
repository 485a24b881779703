"""The MJCF file of a chain on the bar, written from its parameters.

The MuJoCo model is the single source of truth. The named robots in ``models/``
(``gymnast.xml``: Table 1 of the paper, ``example2.xml``: Table 2, ``acrobot.xml``,
``chain4.xml``, RealAIGym's acrobots) are written by :func:`mjcf_from_params`; any other
parameter set gives a model of the same shape, which :mod:`paa_mj.model.mjcf_read` reads,
validates and reads back.
"""
from __future__ import annotations

import math
from pathlib import Path
from xml.sax.saxutils import quoteattr

import numpy as np

from ..errors import PaaError
from .params import RobotParams

#: Gravity of the paper's world [m/s^2], straight down (-z); a model may set its own.
GRAVITY = 9.81
#: Largest physics time step accepted from a model file [s].
MAX_TIMESTEP = 0.1


def _model_dir() -> Path:
    """The folder of the named robots: ``models/`` of the repository, installed as the package ``paa_mj.models``."""
    from importlib.resources import files

    try:
        return Path(str(files("paa_mj.models")))
    except ModuleNotFoundError:  # the package run from a clone that is not installed (PYTHONPATH)
        return Path(__file__).resolve().parents[2] / "models"


MODEL_DIR = _model_dir()

#: Names in the MJCF of a chain of n links: (bodies, joints, geoms and their materials, motors, the tip site).
_GYMNAST_NAMES = (("link1", "link2", "link3"), ("hands", "shoulders", "hips"), ("arms", "trunk", "legs"),
                  ("shoulder", "hip"), "feet")
_ACROBOT_NAMES = (("link1", "link2"), ("shoulder", "elbow"), ("upper_arm", "lower_arm"), ("elbow",), "tip")
_COLOURS = {"arms": "0.85 0.33 0.2 1", "trunk": "0.2 0.45 0.8 1", "legs": "0.25 0.65 0.3 1",
            "upper_arm": "0.85 0.33 0.2 1", "lower_arm": "0.2 0.45 0.8 1"}
_PALETTE = ("0.85 0.33 0.2 1", "0.2 0.45 0.8 1", "0.25 0.65 0.3 1", "0.8 0.65 0.15 1", "0.55 0.3 0.7 1",
            "0.15 0.6 0.65 1")


def chain_names(n):
    """The MJCF names of an n-link chain: the gymnast's for 3 links, an acrobot's for 2, numbered beyond."""
    if n == 3:
        return _GYMNAST_NAMES
    if n == 2:
        return _ACROBOT_NAMES
    links = tuple(f"link{i + 1}" for i in range(n))
    return links, tuple(f"joint{i + 1}" for i in range(n)), links, tuple(f"motor{i + 2}" for i in range(n - 1)), "tip"


_HEADER = """\
<mujoco model={name}>
  <!--
    {what}
    {title}
    {joints}
    q = 0 is every link straight up; the bar is at the world origin so that MuJoCo's
    potential energy equals the paper's P(q) of (7).
    Masses and inertias come from <inertial> alone: geoms are visual only.
{values}  -->
  <compiler angle="radian" autolimits="true"/>
  <option timestep="{timestep}" integrator="RK4" gravity="0 0 -{g}">
    <flag energy="enable" contact="disable"/>
  </option>

  <visual>
    <global offwidth="1280" offheight="960" azimuth="90" elevation="0"/>
    <headlight ambient="0.35 0.35 0.35" diffuse="0.5 0.5 0.5" specular="0.1 0.1 0.1"/>
    <quality shadowsize="2048"/>
  </visual>

  <asset>
    <texture name="sky" type="skybox" builtin="gradient" rgb1="0.55 0.7 0.9" rgb2="0.15 0.2 0.3" width="256" height="256"/>
    <texture name="grid" type="2d" builtin="checker" rgb1="0.75 0.75 0.72" rgb2="0.62 0.62 0.6" width="256" height="256"/>
    <material name="floor" texture="grid" texrepeat="{texrepeat} {texrepeat}" reflectance="0.1"/>
    <material name="steel" rgba="0.75 0.75 0.8 1" specular="0.8" shininess="0.8"/>
{materials}  </asset>

  <worldbody>
    <light name="key" pos="{light_x} -{light_y} {light_z}" dir="-0.3 0.6 -1" directional="true" castshadow="true"/>
    <geom name="floor" type="plane" pos="0 0 -{floor}" size="{floor_size} {floor_size} 0.1" material="floor" contype="0" conaffinity="0" group="0"/>
    <geom name="bar" type="cylinder" fromto="0 -{bar_half} 0 0 {bar_half} 0" size="{bar_radius}" material="steel" contype="0" conaffinity="0" group="0"/>
    <geom name="post_left" type="cylinder" fromto="0 -{bar_half} 0 0 -{bar_half} -{floor}" size="{post_radius}" material="steel" contype="0" conaffinity="0" group="0"/>
    <geom name="post_right" type="cylinder" fromto="0 {bar_half} 0 0 {bar_half} -{floor}" size="{post_radius}" material="steel" contype="0" conaffinity="0" group="0"/>
    <camera name="side" pos="{cam_x} -{cam_y} {cam_z}" xyaxes="{cam_cos} {cam_sin} 0 0 0 1" fovy="45"/>

{bodies}  </worldbody>

  <actuator>
{motors}  </actuator>
{custom}</mujoco>
"""

_GAINS_TEMPLATE = """
  <custom>
    <!-- Default gains kD, kP, kV of controller (40) for this robot. -->
    <numeric name="paa_gains" data="{kD} {kP} {kV}"/>
  </custom>
"""


def _num(x):
    return repr(float(x))


def comment_text(text: str) -> str:
    """``text`` made safe inside an XML comment: one line, printable, no ``--``."""
    text = "".join(ch if ch.isprintable() else " " for ch in str(text))
    while "--" in text:
        text = text.replace("--", "- -")
    return text.rstrip("-")


def _bodies(params, names, radius, site_size):
    """The nested <body> elements of the chain, link 1 hanging from the bar at the world origin."""
    bodies, joints, geoms, _, tip = names
    n = params.n_links
    lines = []
    for i in range(n):
        pad = "    " + "  " * i
        offset = "" if i == 0 else f' pos="0 0 {_num(params.l[i - 1])}"'
        extra = "".join(f' {key}="{_num(getattr(params, key)[i])}"' for key in ("damping", "armature")
                        if getattr(params, key)[i] != 0)
        lines += [f'{pad}<body name="{bodies[i]}"{offset}>',
                  f'{pad}  <joint name="{joints[i]}" type="hinge" axis="0 1 0"{extra}/>',
                  f'{pad}  <inertial pos="0 0 {_num(params.lc[i])}" mass="{_num(params.m[i])}"'
                  f' diaginertia="{_num(params.J[i])} {_num(params.J[i])} {_num(params.J[i] / 100)}"/>',
                  f'{pad}  <geom name="{geoms[i]}" type="capsule" fromto="0 0 0 0 0 {_num(params.l[i])}"'
                  f' size="{radius}" material="{geoms[i]}" contype="0" conaffinity="0" group="1"/>']
    pad = "    " + "  " * n
    lines.append(f'{pad}<site name="{tip}" pos="0 0 {_num(params.l[-1])}" size="{site_size}" rgba="1 1 0 1" group="2"/>')
    lines += ["    " + "  " * i + "</body>" for i in reversed(range(n))]
    return "".join(line + "\n" for line in lines)


#: Motor names by joint where joint 1 is not the only passive one: the acrobot's and the gymnast's joints, numbered
#: beyond (a motor on joint 1 of two links is a pendubot's shoulder).
_MOTOR_NAMES = {2: ("shoulder", "elbow"), 3: ("hand", "shoulder", "hip")}


def motor_names(n, actuated):
    """The MJCF names of the motors on the 0-based joints ``actuated`` of an n-link chain (the family's own where
    joint 1 alone is passive)."""
    if tuple(actuated) == tuple(range(1, n)):
        return chain_names(n)[3]
    names = _MOTOR_NAMES.get(n, tuple(f"motor{i + 1}" for i in range(n)))
    return tuple(names[j] for j in actuated)


def _motors(names, actuated, torque_limits):
    joints, motors = names[1], motor_names(len(names[1]), actuated)
    lines = []
    for k, motor in enumerate(motors):
        limit = None if torque_limits is None else float(np.broadcast_to(torque_limits, (len(motors),))[k])
        bound = "" if limit is None or not np.isfinite(limit) else f' ctrlrange="{_num(-limit)} {_num(limit)}"'
        lines.append(f'    <motor name="{motor}" joint="{joints[actuated[k]]}" gear="1"{bound}/>')
    return "".join(line + "\n" for line in lines)


def _check_arguments(params: RobotParams, name, title, torque_limits, timestep):
    """Refuse, in one line, what :func:`mjcf_from_params` cannot write as a model MuJoCo and every command read."""
    params.validate()
    for what, text in (("name", str(name)), ("title", str(title))):
        if not text.isprintable():
            raise PaaError(f"the model's {what} {text!r} has control characters (a new line, a tab...): give one line")
    if not (np.isfinite(timestep) and 0 < timestep <= MAX_TIMESTEP):
        raise PaaError(f"timestep = {timestep:g} s must lie in (0, {MAX_TIMESTEP:g}]")
    if torque_limits is not None:
        limits = np.asarray(torque_limits, float)
        if limits.size not in (1, params.n_motors) or np.any(np.isnan(limits)) or np.any(limits <= 0):
            raise PaaError(f"torque limits must be one positive number or one per motor ({params.n_motors}),"
                           f" got {limits.reshape(-1).tolist()}")


def _described(params: RobotParams, names) -> tuple[str, str]:
    """The header comment's two lines: what the robot is, and which joints carry motors."""
    n, motors = params.n_links, params.n_motors
    if not params.passive_first:
        def listed(joints):
            return f"joint{'s' if len(joints) > 1 else ''} " + ", ".join(f"{j + 1} ({names[1][j]})" for j in joints)

        passive = params.passive
        return (f"Planar {n}-link chain hanging from a bar (see docs/model.md of paa_mj).",
                f"{listed(passive).capitalize()} {'are' if len(passive) > 1 else 'is'} passive; {listed(params.actuated)}"
                f" carr{'y motors' if motors > 1 else 'ies a motor'}{' (a pendubot)' if params.actuated == (0,) else ''}.")
    if n == 3:
        return ("Three-link gymnast on a high bar (Liu & Xin 2015; see docs/model.md of paa_mj).",
                "Joint 1 (hands on the bar) is passive; joints 2 (shoulders) and 3 (hips) carry motors.")
    return (f"Planar {n}-link chain hanging from a bar (the gymnast's family; see docs/model.md of paa_mj).",
            f"Joint 1 ({names[1][0]}, on the bar) is passive; joint{'s 2..' if n > 2 else ' '}{n}"
            f" ({', '.join(names[1][1:])}) carr{'y motors' if n > 2 else 'ies a motor'}.")


def mjcf_from_params(params: RobotParams, name: str = "gymnast", title: str = "", gains=None, torque_limits=None,
                     timestep=0.001) -> str:
    """Return the MJCF text of the chain with the given parameters (the gymnast for three links).

    Parameters
    ----------
    params : RobotParams
        Link masses, lengths, COM distances and inertias, joint damping and armature.
    name : str
        The MJCF ``model`` attribute (escaped).
    title : str
        One line for the header comment, for example where the numbers come from
        (made safe for a comment: it cannot end the comment or add elements).
    gains : dict, optional
        Default gains ``{"kD", "kP", "kV"}`` of controller (40), stored as a
        ``<custom><numeric name="paa_gains">`` so they travel with the model.
    torque_limits : float or array_like (m,), optional
        Each motor's torque limit [N m], written as its ``ctrlrange``; none (or +inf): unlimited.
    timestep : float
        The physics time step [s].
    """
    _check_arguments(params, name, title, torque_limits, timestep)
    names = chain_names(params.n_links)
    total = float(np.sum(params.l))
    # sizes rounded to decimals of the robot's own scale: a chain of millimetres gets a bar of some micrometres, not
    # one rounded to 0 (MuJoCo refuses a size of 0); one of 10 cm or more keeps the decimals of the metre
    shift = max(0, math.ceil(-math.log10(total)) - 1)

    def size(x, decimals):
        return _num(round(x, decimals + shift))

    # The side camera looks at the bar 20 degrees off the normal of the plane of motion (so the
    # posts do not hide the hanging robot), from where the whole circle of its tip fits.
    cam_angle, cam_dist = np.radians(20.0), 2.7 * total
    values = [f"    {key:<2} = {' '.join(_num(x) for x in getattr(params, key))}  {unit}\n"
              for key, unit in (("m", "kg"), ("l", "m"), ("lc", "m"), ("J", "kg m^2"))]
    values += [f"    {key} = {' '.join(_num(x) for x in getattr(params, key))}  {unit}\n"
               for key, unit in (("damping", "N m s/rad"), ("armature", "kg m^2")) if np.any(getattr(params, key))]
    what, joints = _described(params, names)
    materials = "".join(f'    <material name="{geom}" rgba="{_COLOURS.get(geom, _PALETTE[i % len(_PALETTE)])}"/>\n'
                        for i, geom in enumerate(names[2]))
    subs = dict(
        name=quoteattr(str(name)), what=what, joints=joints, values="".join(values),
        title=comment_text(title) or "Parameters given by the user.", g=_num(params.g),
        timestep=repr(float(timestep)) if timestep != 0.001 else "0.001",
        materials=materials, bodies=_bodies(params, names, size(0.022 * total, 4), size(0.02 * total, 4)),
        motors=_motors(names, params.actuated, torque_limits),
        floor=size(1.12 * total, 3), floor_size=size(3 * total, 3),
        texrepeat=_num(max(2, round(3 * total))),
        bar_half=size(0.45 * total, 3), bar_radius=size(0.012 * total, 4),
        post_radius=size(0.008 * total, 4),
        cam_x=size(cam_dist * np.sin(cam_angle), 3), cam_y=size(cam_dist * np.cos(cam_angle), 3),
        cam_z=size(-0.05 * total, 3),
        cam_cos=_num(round(np.cos(cam_angle), 6)), cam_sin=_num(round(np.sin(cam_angle), 6)),
        light_x=size(total, 3), light_y=size(2 * total, 3), light_z=size(3 * total, 3),
        custom=_GAINS_TEMPLATE.format(**{k: _num(gains[k]) for k in ("kD", "kP", "kV")}) if gains else "",
    )
    return _HEADER.format(**subs)


# --- reading files -----------------------------------------------------------------
