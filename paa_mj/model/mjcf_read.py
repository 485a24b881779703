"""The MJCF file of a chain on the bar: read, validated and read back from the compiled model.

Any model of the shape that :func:`~paa_mj.model.mjcf.mjcf_from_params` writes is read back into
:class:`~paa_mj.model.params.RobotParams` by :func:`params_from_model` from the *compiled* ``MjModel``
(masses, inertias, body and COM positions, damping, armature), so the analytic model is always the one
MuJoCo runs.

The shape (``docs/model.md``): n >= 2 bodies in a chain hanging from the world at
the bar, one hinge per body at its origin, all hinge axes parallel and
horizontal, every link pointing straight up at q = 0, gravity straight down, a
``<motor>`` with gear 1 on each driven joint in joint order, at least one joint
passive: by default joints 2..n (the gymnast's shoulders and hips) with joint 1
(the hands) passive, the paper's family; any other pattern (a pendubot's motor on
joint 1 alone) is read back as the robot's driven joints
(:attr:`~paa_mj.model.params.RobotParams.actuated`). Joint damping and armature are in the
analytic model. Anything else MuJoCo would add and the analytic model lacks
(joint ranges, friction loss, springs, gravity compensation, a medium, contacts,
tendons, equality constraints, other actuators) is refused by name. Actuator limits
(``ctrlrange``, ``forcerange``, ``actuatorfrcrange``) are a real feature: they
are read back as the robot's torque limits (:func:`torque_limits_from_model`),
which every rollout then applies.
"""
from __future__ import annotations

import copy
import functools
import re
import xml.etree.ElementTree as ET
from pathlib import Path

import mujoco
import numpy as np

from ..errors import PaaError
from .mjcf import MAX_TIMESTEP
from .params import MAX_LINKS, RobotParams


def one_line(message) -> str:
    """An error text folded onto one line."""
    return " ".join(str(message).split())


def _regular_file(path: Path, what: str) -> Path:
    if not path.exists():
        raise PaaError(f"{what} not found: {path}")
    if not path.is_file():
        raise PaaError(f"{what} is not a regular file: {path}")
    return path


def read_text(path: Path, what="model file") -> str:
    _regular_file(path, what)
    try:
        return path.read_text()
    except (OSError, UnicodeDecodeError) as err:
        raise PaaError(f"cannot read {what} {path}: {one_line(err)}") from None


def _parse(text, source):
    try:
        return ET.fromstring(text)
    except ET.ParseError as err:
        raise PaaError(f"malformed MJCF in {source}: {one_line(err)}") from None


def _inline_includes(element, folder: Path, source: str, depth=0):
    """Replace every ``<include file=...>`` below ``element`` by the included file's children."""
    if depth > 16:
        raise PaaError(f"malformed MJCF in {source}: includes nested more than 16 deep")
    for parent in list(element.iter()):
        for index, child in reversed(list(enumerate(list(parent)))):
            if child.tag != "include":
                continue
            name = child.get("file")
            if not name:
                raise PaaError(f"malformed MJCF in {source}: <include> without a file attribute")
            path = Path(name) if Path(name).is_absolute() else folder / name
            included = _parse(read_text(path, "included file"), str(path))
            _inline_includes(included, path.parent, str(path), depth + 1)
            parent.remove(child)
            for offset, grandchild in enumerate(list(included)):
                parent.insert(index + offset, grandchild)


def flatten_mjcf(text: str, folder: Path, source: str) -> str:
    """MJCF text with its includes inlined and its asset folders made absolute.

    The result compiles anywhere on this machine (a Dask worker included) and
    resolves every path against the model file's ``folder``, as MuJoCo does for
    a file, not against the current directory.
    """
    if "<include" not in text and not re.search(r"\bfile\s*=", text):
        return text
    root = _parse(text, source)
    _inline_includes(root, folder, source)
    compiler = root.find("compiler")
    if compiler is None:
        compiler = ET.Element("compiler")
        root.insert(0, compiler)
    for key in ("meshdir", "texturedir", "assetdir"):
        value = compiler.get(key)
        if value is not None and not Path(value).is_absolute():
            compiler.set(key, str(folder / value))
    if compiler.get("assetdir") is None:
        compiler.set("assetdir", str(folder))
    return ET.tostring(root, encoding="unicode")


def compile_mjcf(xml: str, source: str = "<string>") -> mujoco.MjModel:
    """Compile MJCF text (one-line error when MuJoCo refuses it); a new model each call.

    MuJoCo's log is off meanwhile: its compiler warns of a NaN in the text (among others) on the
    console and in ``MUJOCO_LOG.TXT`` in the current folder, which loading a robot must not leave
    behind; what the compiler refuses comes back as the error. The same text is compiled once per process
    (some milliseconds each time: studies load the same robots again and again); each caller gets its own
    copy of the compiled model, which it may change.
    """
    try:
        return copy.copy(_compiled(xml))
    except ValueError as err:
        raise PaaError(f"malformed MJCF in {source}: {one_line(err)}") from None


@functools.lru_cache(maxsize=64)
def _compiled(xml: str) -> mujoco.MjModel:
    from ..mujoco_log import mujoco_log_off

    with mujoco_log_off():
        return mujoco.MjModel.from_xml_string(xml)


# --- reading the compiled model back ---------------------------------------------------

def _shape_error(source, what):
    return PaaError(f"{source} is not a planar chain on the bar (the gymnast's family): {what}")


def _feature_error(source, what):
    return PaaError(f"{source} has a feature the analytic model lacks: {what}")


def _axis_inertia(model, body, axis):
    """Moment of inertia of ``body`` about ``axis`` (body frame) through its COM [kg m^2]."""
    rot = np.empty(9)
    mujoco.mju_quat2Mat(rot, model.body_iquat[body])
    rot = rot.reshape(3, 3)
    inertia = rot @ np.diag(model.body_inertia[body]) @ rot.T
    return float(axis @ inertia @ axis)


def _check_options(model, source):
    step = float(model.opt.timestep)
    if not (np.isfinite(step) and 0 < step <= MAX_TIMESTEP):
        raise PaaError(f"non-physical parameters in {source}: timestep = {step:g} s must lie in (0, {MAX_TIMESTEP:g}]")
    gravity = np.asarray(model.opt.gravity, float)
    if not np.all(np.isfinite(gravity)) or np.max(np.abs(gravity[:2])) > 1e-12 or not gravity[2] < 0:
        raise _feature_error(source, f"gravity {gravity.tolist()} m/s^2 (the model needs gravity straight down, -z)")
    if model.opt.disableflags & mujoco.mjtDisableBit.mjDSBL_GRAVITY:
        raise _feature_error(source, "gravity disabled")
    if model.opt.disableflags & mujoco.mjtDisableBit.mjDSBL_ACTUATION:
        raise _feature_error(source, "actuation disabled (the motors would apply no torque)")
    if model.opt.disableflags & mujoco.mjtDisableBit.mjDSBL_DAMPER and np.any(model.dof_damping != 0):
        raise _feature_error(source, "joint damping switched off (flag damper=\"disable\") on joints that have it"
                                     " (the analytic model would still damp them)")
    if model.opt.enableflags & mujoco.mjtEnableBit.mjENBL_SLEEP:
        raise _feature_error(source, "sleeping bodies (a link at rest would stop being simulated)")
    if model.opt.density != 0 or model.opt.viscosity != 0:
        raise _feature_error(source, f"a medium (density {model.opt.density:g}, viscosity {model.opt.viscosity:g})")
    if np.any(model.body_gravcomp != 0):
        raise _feature_error(source, "gravity compensation (gravcomp)")
    for what, count in (("tendons", model.ntendon), ("equality constraints", model.neq),
                        ("explicit contact pairs", model.npair), ("flexes", model.nflex)):
        if count:
            raise _feature_error(source, f"{count} {what}")


def _check_joints(model, source):
    n = model.nbody - 1
    if not 2 <= n <= MAX_LINKS or list(model.body_parentid[1:]) != list(range(n)):
        raise _shape_error(source, f"needs a chain of 2 to {MAX_LINKS} bodies under the world, each the child of the"
                                   f" one before, found {n} bod{'y' if n == 1 else 'ies'}")
    if model.njnt != n or model.nv != n or np.any(model.jnt_type != mujoco.mjtJoint.mjJNT_HINGE):
        raise _shape_error(source, f"needs one hinge joint per link ({n}), found {model.njnt} joints with"
                                   f" {model.nv} DoF")
    if list(model.jnt_bodyid) != list(range(1, n + 1)):
        raise _shape_error(source, "needs one hinge on each link")
    if np.any(np.abs(model.jnt_pos) > 1e-12):
        raise _shape_error(source, "each hinge must sit at its body's origin")
    hands = np.asarray(model.body_pos[1], float)
    across = hands - (hands @ model.jnt_axis[0]) * model.jnt_axis[0] / (model.jnt_axis[0] @ model.jnt_axis[0])
    if not np.all(np.abs(across) <= 1e-12):
        # the bar is the world origin: MuJoCo's potential energy is the paper's P(q) of (7) only there
        raise _shape_error(source, f"link 1 must hang from the bar at the world origin (its hinge, the hands, is at"
                                   f" {hands.tolist()} m)")
    if np.any(model.qpos0 != 0):
        raise _feature_error(source, f"joint reference angles (ref {np.asarray(model.qpos0).tolist()} rad; q = 0 must"
                                     " be every link straight up)")
    for body in range(1, n + 1):
        if not np.allclose(model.body_quat[body], [1, 0, 0, 0], atol=1e-12):
            raise _shape_error(source, "link bodies must not be rotated (q = 0 is every link straight up)")
    axis = model.jnt_axis[0] / np.linalg.norm(model.jnt_axis[0])
    if not np.allclose(model.jnt_axis, axis, atol=1e-9):
        raise _shape_error(source, "the hinge axes must be the same")
    if abs(axis[2]) > 1e-9:
        raise _shape_error(source, "hinge axes must be horizontal (perpendicular to gravity)")
    if np.any(model.jnt_limited):
        raise _feature_error(source, f"joint ranges (limited joints {[int(j) + 1 for j in np.flatnonzero(model.jnt_limited)]})")
    # viscous damping and armature are in the analytic model; these are not
    for what, values in (("friction loss", model.dof_frictionloss), ("joint stiffness", model.jnt_stiffness)):
        if np.any(values != 0):
            raise _feature_error(source, f"{what} {np.asarray(values).tolist()}")
    for what, values in (("joint damping", model.dof_damping), ("armature", model.dof_armature)):
        if not np.all(np.isfinite(values) & (values >= 0)):
            raise PaaError(f"non-physical parameters in {source}: {what} {np.asarray(values).tolist()} must be finite"
                           " and >= 0")
    contacts_on = not (model.opt.disableflags & mujoco.mjtDisableBit.mjDSBL_CONTACT)
    colliding = (model.geom_contype | model.geom_conaffinity) != 0
    if contacts_on and np.any(colliding[model.geom_bodyid > 0]):
        raise _feature_error(source, "contacts (link geoms that collide; set contype = conaffinity = 0"
                                     " or disable contacts)")
    return axis


def makes_no_constraints(model: mujoco.MjModel) -> bool:
    """Whether MuJoCo makes no constraint row for ``model`` in any state: True for every robot this reader accepts.

    The features that make constraint rows (joint ranges, friction loss, tendons, equality constraints, contact
    pairs, flexes, link geoms that collide) are the ones this reader refuses, so MuJoCo's constraint solver has
    nothing to do for these robots: its acceleration is the smooth one, ``qacc = qacc_smooth``.
    """
    try:
        _check_options(model, "model")
        _check_joints(model, "model")
    except PaaError:
        return False
    return True


def _check_actuators(model, source):
    mask = int(model.opt.disableactuator)  # a bit per group 0..30
    off = [act for act, group in enumerate(model.actuator_group) if 0 <= group <= 30 and mask >> int(group) & 1]
    if off:
        raise _feature_error(source, f"actuator{'s' if len(off) > 1 else ''} {', '.join(map(str, off))} in a disabled"
                                     " group (option actuatorgroupdisable: its motor would apply no torque)")
    n = model.njnt
    if not 1 <= model.nu <= n - 1:
        raise _feature_error(source, f"{model.nu} actuators (a chain of {n} links has 1 to {n - 1} motors: at least"
                                     " one joint passive, at least one driven)")
    driven = []
    for act in range(model.nu):
        if model.actuator_trntype[act] != mujoco.mjtTrn.mjTRN_JOINT:
            raise _shape_error(source, f"actuator {act} must act on a joint")
        gear = np.asarray(model.actuator_gear[act], float)
        others = [f"{i + 1} = {value:g}" for i, value in enumerate(gear) if i > 0 and value != 0]
        if others:
            # on a hinge MuJoCo uses the first component alone: the others would be dropped in silence
            raise _feature_error(source, f"actuator {act} gear \"{' '.join(f'{v:g}' for v in gear)}\": gear component"
                                         f"{'s' if len(others) > 1 else ''} {', '.join(others)} must be 0 (a motor on a"
                                         " hinge uses the first component only, and the model needs it to be 1)")
        if not abs(gear[0] - 1) <= 1e-12:  # written so that a NaN gear is refused too
            raise _feature_error(source, f"actuator {act} gear {gear[0]:g} (the model needs gear 1)")
        is_motor = (model.actuator_gaintype[act] == mujoco.mjtGain.mjGAIN_FIXED
                    and model.actuator_biastype[act] == mujoco.mjtBias.mjBIAS_NONE
                    and model.actuator_dyntype[act] == mujoco.mjtDyn.mjDYN_NONE
                    and abs(model.actuator_gainprm[act, 0] - 1) < 1e-12)
        if not is_motor:
            raise _feature_error(source, f"actuator {act} is not a <motor> (gain 1, no bias, no dynamics)")
        driven.append(int(model.actuator_trnid[act, 0]))
    if driven != sorted(set(driven)):
        raise _shape_error(source, f"motors must drive distinct joints in increasing order (one motor per driven"
                                   f" joint), found joints {[d + 1 for d in driven]}")
    return tuple(driven)


def _symmetric_limit(low, high, what, source):
    if not (np.isfinite(low) and np.isfinite(high) and low < 0 < high and abs(low + high) <= 1e-12 * high):
        raise _feature_error(source, f"{what} [{low:g}, {high:g}] (only symmetric ranges -T..T with T > 0 are modelled)")
    return float(high)


def _check_unused_range(limited, values, what, source):
    """Refuse a range that is written but not a range (inverted, empty or NaN): MuJoCo then leaves the limit off
    in silence, so the motor would run unlimited although the file asks for a limit."""
    low, high = (float(v) for v in values)
    if not limited and (low != 0 or high != 0) and not (np.isfinite(low) and np.isfinite(high) and low < high):
        raise _feature_error(source, f"{what} [{low:g}, {high:g}] is not a range (MuJoCo would apply no limit at all):"
                                     " give -T T with T > 0, or leave it out")


def torque_limits_from_model(model: mujoco.MjModel, source: str = "model") -> np.ndarray:
    """The torque limit of each motor [N m], shape (m,) (the model's actuators), +inf where none.

    The smallest of the actuator's ``ctrlrange`` (gear 1, so torque = control),
    its ``forcerange`` and the driven joint's ``actuatorfrcrange``; each must be
    symmetric about 0.
    """
    limits = np.full(min(model.nu, max(model.njnt - 1, 0)), np.inf)
    for act in range(min(model.nu, limits.size)):
        joint = int(model.actuator_trnid[act, 0])
        _check_unused_range(model.actuator_ctrllimited[act], model.actuator_ctrlrange[act], f"actuator {act} ctrlrange",
                            source)
        _check_unused_range(model.actuator_forcelimited[act], model.actuator_forcerange[act],
                            f"actuator {act} forcerange", source)
        if 0 <= joint < model.njnt:
            _check_unused_range(model.jnt_actfrclimited[joint], model.jnt_actfrcrange[joint],
                                f"joint {joint + 1} actuatorfrcrange", source)
        ranges = []
        if model.actuator_ctrllimited[act]:
            ranges.append(("ctrlrange", model.actuator_ctrlrange[act]))
        if model.actuator_forcelimited[act]:
            ranges.append(("forcerange", model.actuator_forcerange[act]))
        if 0 <= joint < model.njnt and model.jnt_actfrclimited[joint]:
            ranges.append(("actuatorfrcrange", model.jnt_actfrcrange[joint]))
        for what, (low, high) in ranges:
            limits[act] = min(limits[act], _symmetric_limit(float(low), float(high), f"actuator {act} {what}", source))
    return limits


def params_from_model(model: mujoco.MjModel, source: str = "model") -> RobotParams:
    """Read a chain's parameters back from its compiled model (the gymnast's are the paper's).

    Reads masses (``body_mass``), COM distances (the norm of ``body_ipos``, or 0 where the
    compiler merged the inertial frame into the body frame), link lengths
    (child body offsets; the last link's from its tip site, ``feet`` or ``tip``, or the
    farthest geom or site of that link when there is none), inertias about the hinge axis
    through the COM (``body_inertia`` rotated by ``body_iquat``), joint damping and
    armature (``dof_damping``, ``dof_armature``) and gravity.

    Raises
    ------
    PaaError
        If the model is not a chain of the family, has a feature the analytic
        model lacks (module docstring), or its parameters are not physical.
    """
    _check_options(model, source)
    axis = _check_joints(model, source)
    actuated = _check_actuators(model, source)
    torque_limits_from_model(model, source)
    n = model.nbody - 1
    up = np.array([0.0, 0.0, 1.0])
    m = model.body_mass[1:].copy()
    lc = np.linalg.norm(model.body_ipos[1:], axis=1)
    # MuJoCo's compiler snaps an inertial frame within ~1e-6 of the body frame onto it
    # (body_sameframe = 1) and then simulates the COM at the joint: read what it runs.
    lc[model.body_sameframe[1:] == mujoco.mjtSameFrame.mjSAMEFRAME_BODY] = 0.0
    lengths = [float(np.linalg.norm(model.body_pos[i])) for i in range(2, n + 1)]
    for i, length in enumerate(lengths):
        if not (length > 0) or np.linalg.norm(model.body_pos[i + 2] / length - up) > 1e-9:
            raise _shape_error(source, f"link {i + 1} must point straight up at q = 0 (next joint on the +z axis)")
    for i in range(n):
        if lc[i] > 0 and np.linalg.norm(model.body_ipos[i + 1] / lc[i] - up) > 1e-9:
            raise _shape_error(source, f"link {i + 1}'s centre of mass must lie on the link, between its joints")
    lengths.append(_last_link_length(model, up, source))
    J = np.array([_axis_inertia(model, b, axis) for b in range(1, n + 1)])
    name = model.names.split(b"\0", 1)[0].decode() or "model"
    if not name.isprintable():  # it is quoted in one-line messages and summaries
        raise PaaError(f"{source}: the model's name {name!r} has control characters (a new line, a tab...): give one"
                       " line")
    try:
        return RobotParams(m=m, l=np.array(lengths), lc=lc, J=J, g=float(np.linalg.norm(model.opt.gravity)), name=name,
                           damping=model.dof_damping.copy(), armature=model.dof_armature.copy(), actuated=actuated)
    except PaaError as err:
        raise PaaError(f"{err} (in {source})") from None


def _last_link_length(model, up, source):
    last = model.nbody - 1
    for tip_name in ("feet", "tip"):
        tip = mujoco.mj_name2id(model, mujoco.mjtObj.mjOBJ_SITE, tip_name)
        if tip >= 0 and model.site_bodyid[tip] == last:
            return float(model.site_pos[tip] @ up)
    reach = [model.site_pos[s] @ up for s in range(model.nsite) if model.site_bodyid[s] == last]
    reach += [model.geom_pos[g] @ up + model.geom_rbound[g] for g in range(model.ngeom) if model.geom_bodyid[g] == last]
    if not reach:
        raise _shape_error(source, f"link {last} needs a 'feet' or 'tip' site (or a geom) to give its length")
    return float(max(reach))


def default_gains(model: mujoco.MjModel):
    """The gains stored in the model's ``paa_gains`` numeric, or None."""
    idx = mujoco.mj_name2id(model, mujoco.mjtObj.mjOBJ_NUMERIC, "paa_gains")
    if idx < 0:
        return None
    adr, size = model.numeric_adr[idx], model.numeric_size[idx]
    if size != 3:
        raise PaaError("the model's paa_gains numeric needs 3 values: kD kP kV")
    gains = {name: float(v) for name, v in zip(("kD", "kP", "kV"), model.numeric_data[adr:adr + size])}
    for name, value in gains.items():
        if not (np.isfinite(value) and value > 0):
            raise PaaError(f"the model's paa_gains {name} = {value:g} must be a positive finite number")
    return gains
