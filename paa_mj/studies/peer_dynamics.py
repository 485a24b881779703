"""paa_mj's dynamics against Drake's, a part of ``paa-mj peers`` (:mod:`paa_mj.studies.peers`).

**Dynamics.** Drake's ``MultibodyPlant`` loads paa_mj's own MJCF files (the named robots, and random
chains written by :func:`paa_mj.model.mjcf.mjcf_from_params`) with its MJCF parser, which ignores the
visual-only elements (lights, textures, cameras, sites, the ``<visual>`` block, the MuJoCo-only
options): the warnings it gives are kept in the results. At random states (angles in [-2 pi, 2 pi],
speeds up to 10 rad/s, torques of the size of gravity's, :func:`paa_mj.model.crosscheck.random_states`)
it compares, against paa_mj's analytic model and against MuJoCo,

- the mass matrix M(q) (Drake's ``CalcMassMatrix``, MuJoCo's ``mj_fullM``),
- the Coriolis and centrifugal forces H(q, qd) (Drake's ``CalcBiasTerm``, C(q, v) v; MuJoCo's
  ``qfrc_bias`` less its value at qd = 0),
- gravity G(q) = dP/dq (minus Drake's ``CalcGravityGeneralizedForces``, which is the generalised force
  of gravity; MuJoCo's ``qfrc_bias`` at qd = 0),
- the potential energy P(q) (Drake's ``CalcPotentialEnergy``, MuJoCo's ``energy[0]``),
- the accelerations qdd = M^-1 (B tau - H - G - D qd) (Drake's time derivatives with the torques on
  its actuators, MuJoCo's ``qacc``): damping, armature and the motors' map enter here.

Drake's MJCF parser puts a joint's ``armature`` into the rotor inertia of the actuator on that joint
(the reflected inertia in M), not into a passive joint: the random chains have armature on their
driven joints only. Each difference is relative as in :mod:`paa_mj.model.crosscheck`: the largest
abs(a - b) of a sample over max(1, the largest abs of the reference), the worst sample. Drake's own
``AcrobotPlant`` (its analytic acrobot) is compared with paa_mj's acrobot under the map of
coordinates of :mod:`paa_mj.control.spong`, theta = (q1 + pi, q2), which the comparison checks:
``MassMatrix``, ``DynamicsBiasTerm`` (H + G + D qd), the potential energy and the accelerations.
"""
from __future__ import annotations

import contextlib
import logging
import tempfile
from pathlib import Path

import numpy as np

from ..errors import PaaError
from .drake import theta_from_x

#: Named robots compared, and random chains (links of each).
NAMED = ("gymnast", "example2", "acrobot", "chain4")
QUICK_NAMED = ("acrobot", "gymnast")
RANDOM_LINKS = (2, 3, 5)
QUICK_RANDOM_LINKS = (3,)


class _Collect(logging.Handler):
    def __init__(self):
        super().__init__(logging.WARNING)
        self.messages = []

    def emit(self, record):
        self.messages.append(record.getMessage())


@contextlib.contextmanager
def _drake_warnings():
    """Drake's parser warnings collected (not printed): yields their list."""
    logger = logging.getLogger("drake")
    handler, level, propagate = _Collect(), logger.level, logger.propagate
    logger.addHandler(handler)
    logger.propagate = False
    try:
        yield handler.messages
    finally:
        logger.removeHandler(handler)
        logger.propagate = propagate
        logger.setLevel(level)


def _ignored(messages):
    """The MJCF elements and attributes Drake said it ignores, one short phrase each, sorted."""
    import re

    found = set()
    for text in messages:
        match = re.search(r"The (attribute|tag) '([^']+)' found (?:in an? |as a child of )'([^']+)'", text)
        if match:
            found.add(f"{match.group(1)} {match.group(2)} of {match.group(3)}")
        elif "texture element" in text:
            found.add("texture")
        elif "camera element" in text:
            found.add("camera")
        else:
            found.add(" ".join(text.split(": warning: ", 1)[-1].split())[:80])
    return sorted(found)


def load_drake_plant(path=None, xml=None):
    """A finalised continuous ``MultibodyPlant`` from an MJCF file (or text), and the warnings of its parser."""
    from pydrake.multibody.parsing import Parser
    from pydrake.multibody.plant import MultibodyPlant

    plant = MultibodyPlant(0.0)
    with _drake_warnings() as messages:
        parser = Parser(plant)
        if path is not None:
            parser.AddModels(str(path))
        else:
            parser.AddModelsFromString(xml, "xml")
    plant.Finalize()
    return plant, _ignored(messages)


def _drake_maps(plant, mj_model):
    """Drake's velocity index of each MuJoCo joint (by name), and the actuation vector of MuJoCo's motors."""
    import mujoco

    n = mj_model.nv
    joints = [mujoco.mj_id2name(mj_model, mujoco.mjtObj.mjOBJ_JOINT, j) for j in range(mj_model.njnt)]
    order = np.array([plant.GetJointByName(name).velocity_start() for name in joints])
    B = plant.MakeActuationMatrix()  # (nv, nu), Drake's velocities
    if B.shape != (n, mj_model.nu):
        raise PaaError(f"Drake reads {B.shape[1]} actuators from the model, MuJoCo {mj_model.nu}")
    B_mj = B[order]  # rows in MuJoCo's joint order
    return order, B_mj


def _drake_quantities(plant, order, B_mj, q, qd, tau):
    """Drake's M, H, G, P and qdd at each state, in MuJoCo's joint order."""
    context = plant.CreateDefaultContext()
    n = q.shape[1]
    count = len(q)
    M, H, G, qdd, P = np.zeros((count, n, n)), np.zeros((count, n)), np.zeros((count, n)), np.zeros((count, n)), \
        np.zeros(count)
    port = plant.get_actuation_input_port()
    # u with B_mj u = [0, tau]: the motors act on joints 2..n
    solve = np.linalg.pinv(B_mj)
    for i in range(count):
        qs, vs = np.empty(n), np.empty(n)
        qs[order], vs[order] = q[i], qd[i]
        plant.SetPositions(context, qs)
        plant.SetVelocities(context, vs)
        port.FixValue(context, solve @ np.concatenate([[0.0], tau[i]]))
        M[i] = plant.CalcMassMatrix(context)[np.ix_(order, order)]
        H[i] = plant.CalcBiasTerm(context)[order]
        G[i] = -plant.CalcGravityGeneralizedForces(context)[order]
        P[i] = plant.CalcPotentialEnergy(context)
        qdd[i] = plant.EvalTimeDerivatives(context).CopyToVector()[n:][order]
    return M, H, G, P, qdd


def _mujoco_quantities(model, q, qd, tau):
    from ..model.crosscheck import engine_quantities

    model = model.__copy__()
    import mujoco

    model.opt.enableflags |= int(mujoco.mjtEnableBit.mjENBL_ENERGY)
    M, bias, qacc, _ = engine_quantities(model, q, qd, tau)
    _, gravity, _, _ = engine_quantities(model, q, np.zeros_like(qd), tau)
    data = mujoco.MjData(model)
    P = np.zeros(len(q))
    for i in range(len(q)):
        data.qpos[:], data.qvel[:] = q[i], 0.0
        mujoco.mj_forward(model, data)
        P[i] = data.energy[0]
    return M, bias - gravity, gravity, P, qacc


def _rel(a, b, axes):
    """max over samples of max abs(a - b) / max(1, max abs(b)) (:mod:`paa_mj.model.crosscheck`)."""
    from ..model.crosscheck import _rel_err

    return _rel_err(a, b, axes)


QUANTITIES = ("M", "H", "G", "P", "qdd")
_AXES = {"M": (1, 2), "H": 1, "G": 1, "P": 1, "qdd": 1}


def _differences(x, y):
    out = {}
    for key, a, b in zip(QUANTITIES, x, y):
        if key == "P":
            a, b = a[:, None], b[:, None]
        out[key] = _rel(a, b, _AXES[key])
    return out


def random_chain_params(links, seed):
    """A random chain of ``links`` links: masses, lengths, COMs, inertias, damping, and armature on joints 2..n."""
    from ..model.params import RobotParams

    rng = np.random.default_rng(seed)
    m = rng.uniform(0.5, 5.0, links)
    l = rng.uniform(0.3, 1.5, links)
    lc = l * rng.uniform(0.1, 0.9, links)
    J = m * l**2 / 12 * rng.uniform(0.3, 1.5, links)
    damping = rng.uniform(0.0, 0.5, links)
    armature = np.concatenate([[0.0], rng.uniform(0.0, 0.1, links - 1)])
    return RobotParams(m=m, l=l, lc=lc, J=J, damping=damping, armature=armature, name=f"random{links}")


def compare_dynamics(robot_name=None, params=None, samples=200, seed=0):
    """One robot's row: Drake's MultibodyPlant (from the MJCF) against the analytic model and MuJoCo.

    Give ``robot_name`` (a named robot, loaded from its file by both) or ``params`` (a random chain, written
    by :func:`~paa_mj.model.mjcf.mjcf_from_params`).
    """
    from ..model.crosscheck import random_states
    from ..model.mjcf import MODEL_DIR, mjcf_from_params
    from ..model.robot import load_robot, robot_from_xml

    if robot_name is not None:
        robot = load_robot(robot_name)
        plant, ignored = load_drake_plant(path=MODEL_DIR / f"{robot_name}.xml")
        source = f"models/{robot_name}.xml"
    else:
        xml = mjcf_from_params(params, name=params.name, torque_limits=None)
        robot = robot_from_xml(xml, name=params.name, source=f"random chain {params.name}")
        with tempfile.TemporaryDirectory(prefix="paa-mj-peers-") as folder:
            path = Path(folder) / f"{params.name}.xml"
            path.write_text(xml)
            plant, ignored = load_drake_plant(path=path)
        source = "mjcf_from_params(random parameters)"
    am = robot.analytic
    n = am.n_links
    q, qd, tau = random_states(samples, seed, analytic=am)
    limits = robot.torque_limits
    tau = np.clip(tau, -limits, limits)
    order, B_mj = _drake_maps(plant, robot.model)
    drake = _drake_quantities(plant, order, B_mj, q, qd, tau)
    ours = (am.mass_matrix(q), am.bias(q, qd) - am.gravity(q), am.gravity(q), am.potential(q),
            am.acceleration(q, qd, tau))
    mj = _mujoco_quantities(robot.model, q, qd, tau)
    p = robot.params
    return {"robot": robot.name, "source": source, "links": n, "samples": samples, "seed": seed,
            "params": {"m": p.m.tolist(), "l": p.l.tolist(), "lc": p.lc.tolist(), "J": p.J.tolist(),
                       "damping": p.damping.tolist(), "armature": p.armature.tolist(), "g": p.g},
            "drake_vs_analytic": _differences(drake, ours), "drake_vs_mujoco": _differences(drake, mj),
            "mujoco_vs_analytic": _differences(mj, ours), "ignored_by_drake": ignored}


def compare_acrobot_plant(samples=200, seed=0):
    """Drake's analytic ``AcrobotPlant`` against paa_mj's acrobot under theta = (q1 + pi, q2), same torque."""
    from pydrake.examples import AcrobotPlant

    from ..model.crosscheck import random_states
    from ..model.robot import load_robot

    robot = load_robot("acrobot")
    am = robot.analytic
    q, qd, tau = random_states(samples, seed, analytic=am)
    tau = np.clip(tau, -robot.torque_limits, robot.torque_limits)
    plant = AcrobotPlant()
    context = plant.CreateDefaultContext()
    port = plant.get_input_port(0)
    M, bias, P, qdd = np.zeros((samples, 2, 2)), np.zeros((samples, 2)), np.zeros(samples), np.zeros((samples, 2))
    for i in range(samples):
        context.SetContinuousState(theta_from_x(np.concatenate([q[i], qd[i]])))
        port.FixValue(context, tau[i])
        M[i] = plant.MassMatrix(context)
        bias[i] = plant.DynamicsBiasTerm(context)
        P[i] = plant.EvalPotentialEnergy(context)
        qdd[i] = plant.EvalTimeDerivatives(context).CopyToVector()[2:]
    ours_bias = am.bias(q, qd) + am.damping_force(qd)
    return {"robot": "acrobot (Drake's AcrobotPlant)", "source": "pydrake.examples.AcrobotPlant, theta = (q1 + pi, q2)",
            "links": 2, "samples": samples, "seed": seed,
            "drake_vs_analytic": {"M": _rel(M, am.mass_matrix(q), (1, 2)),
                                  "H + G + D qd": _rel(bias, ours_bias, 1),
                                  "P": _rel(P[:, None], am.potential(q)[:, None], 1),
                                  "qdd": _rel(qdd, am.acceleration(q, qd, tau), 1)}}


#: Memory [bytes] and one core's time [s] per random state of a robot's comparison (Drake's, MuJoCo's and the analytic
#: quantities, Drake's in a loop over the states), the largest chain's: 1506 B (tracemalloc's peak, a random five-link
#: chain, 20000 and 40000 states) and 0.19 to 0.21 ms (process time of compare_dynamics, 20000 states, each named
#: robot and random chain of 2 to 5 links; 0.06 ms for Drake's AcrobotPlant).
SAMPLE_BYTES = 1600.0
SAMPLE_SECONDS = 2.2e-4


def dynamics(samples=200, seed=0, quick=False, progress=False):
    """Rows of :func:`compare_dynamics` for the named robots and random chains, then Drake's AcrobotPlant; ``samples``
    sized first (memory and time, one line where it is more than this machine gives)."""
    from ..limits import check_memory, check_seconds
    from ..progress import stage

    named, chains = (QUICK_NAMED, QUICK_RANDOM_LINKS) if quick else (NAMED, RANDOM_LINKS)
    robots = len(named) + len(chains) + 1
    check_memory(samples * SAMPLE_BYTES, "the dynamics' random states", "--samples")
    check_seconds(robots * samples * SAMPLE_SECONDS, f"the dynamics of {robots} robots at {samples} states each",
                  "--samples")
    rows = []
    for name in named:
        stage(f"peers: dynamics of {name} (Drake's MultibodyPlant from the MJCF, MuJoCo, analytic)", progress)
        rows.append(compare_dynamics(robot_name=name, samples=samples, seed=seed))
    for k, links in enumerate(chains):
        stage(f"peers: dynamics of a random chain of {links} links", progress)
        rows.append(compare_dynamics(params=random_chain_params(links, seed + 1000 + k), samples=samples, seed=seed))
    stage("peers: Drake's AcrobotPlant against paa_mj's acrobot", progress)
    rows.append(compare_acrobot_plant(samples=samples, seed=seed))
    return rows


