"""Engine against analytic model: MuJoCo's M, bias forces, accelerations and energy.

At random states (angles in [-2 pi, 2 pi], speeds up to 10 rad/s, random
torques) compare, after ``mj_forward``,

* the full inertia matrix (``mj_fullM``) with M(q) ((2) for the gymnast, armature included),
* ``qfrc_bias`` with H(q, qd) + G(q),
* ``qacc`` with M^-1 (B tau - H - G - D qd) of (1) (D the joints' damping, in ``qfrc_passive``),
* ``energy`` (potential + kinetic) with E of (6).

Any chain of the family is compared: the analytic model is the paper's closed
form for the gymnast and the general chain's otherwise.

Errors are relative to the size of the analytic quantity (at least 1), the
worst over all samples.
"""
from __future__ import annotations

from dataclasses import asdict, dataclass

import mujoco
import numpy as np

from .dynamics import AnalyticModel
from .mjcf_read import params_from_model, torque_limits_from_model


#: Largest relative error at which MuJoCo and the analytic model agree: rounding stays below 1e-12 on every chain
#: of the family (64 links included); a feature one of them lacks shows as 1e-3 or more.
AGREEMENT = 1e-9


@dataclass(frozen=True)
class CrossCheck:
    samples: int
    seed: int
    max_rel_err_M: float
    max_rel_err_bias: float
    max_rel_err_qacc: float
    max_rel_err_energy: float

    def as_dict(self):
        return asdict(self)

    def worst(self):
        return max(self.max_rel_err_M, self.max_rel_err_bias, self.max_rel_err_qacc, self.max_rel_err_energy)

    @property
    def agrees(self) -> bool:
        """Every error at most :data:`AGREEMENT`."""
        return bool(self.worst() <= AGREEMENT)


def random_states(n, seed=0, max_angle=2 * np.pi, max_speed=10.0, max_torque=None, analytic=None, links=None):
    """Random (q, qd, tau): angles in [-max_angle, max_angle], speeds up to ``max_speed`` [rad/s].

    Torques are drawn up to ``max_torque`` [N m]; by default 2 b1 / 1 rad, the scale of gravity torques.
    ``links`` (default: the analytic model's, else 3) sets the shapes (n, links) and (n, m), m the analytic model's
    motors (else links - 1).
    """
    links = links or (analytic.n_links if analytic is not None else 3)
    rng = np.random.default_rng(seed)
    q = rng.uniform(-max_angle, max_angle, (n, links))
    qd = rng.uniform(-max_speed, max_speed, (n, links))
    if max_torque is None:
        max_torque = 2 * analytic.gravity_constants[0] if analytic is not None else 100.0
    motors = analytic.n_motors if analytic is not None and analytic.n_links == links else links - 1
    tau = rng.uniform(-max_torque, max_torque, (n, motors))
    return q, qd, tau


def _rel_err(engine, analytic, axes):
    scale = np.maximum(1.0, np.max(np.abs(analytic), axis=axes))
    return float(np.max(np.max(np.abs(engine - analytic), axis=axes) / scale))


def engine_quantities(model: mujoco.MjModel, q, qd, tau):
    """MuJoCo's M, qfrc_bias, qacc and energy at each state, after ``mj_forward``."""
    data = mujoco.MjData(model)
    n, nv = len(q), model.nv
    M = np.zeros((n, nv, nv))
    bias, qacc, energy = np.zeros((n, nv)), np.zeros((n, nv)), np.zeros(n)
    for i in range(n):
        data.qpos[:], data.qvel[:], data.ctrl[:] = q[i], qd[i], tau[i]
        mujoco.mj_forward(model, data)
        mujoco.mj_fullM(model, data, M[i])
        bias[i], qacc[i] = data.qfrc_bias, data.qacc
        energy[i] = data.energy.sum()
    return M, bias, qacc, energy


def cross_check(model: mujoco.MjModel, samples: int = 1000, seed: int = 0) -> CrossCheck:
    """Compare MuJoCo with the analytic model built from the same compiled ``model``."""
    from ..limits import check_memory, check_seed

    seed = check_seed(seed)  # the one range of every seed, as check --seed takes it
    check_memory(samples * 400.0, "cross-check samples", "--samples")
    am = AnalyticModel.from_params(params_from_model(model))
    model = model.__copy__()
    model.opt.enableflags |= int(mujoco.mjtEnableBit.mjENBL_ENERGY)
    q, qd, tau = random_states(samples, seed, analytic=am)
    limits = torque_limits_from_model(model)
    tau = np.clip(tau, -limits, limits)  # MuJoCo clamps ctrl to the motors' ranges
    M, bias, qacc, energy = engine_quantities(model, q, qd, tau)
    return CrossCheck(
        samples=samples, seed=seed,
        max_rel_err_M=_rel_err(M, am.mass_matrix(q), (1, 2)),
        max_rel_err_bias=_rel_err(bias, am.bias(q, qd), 1),
        max_rel_err_qacc=_rel_err(qacc, am.acceleration(q, qd, tau), 1),
        max_rel_err_energy=_rel_err(energy[:, None], am.energy(q, qd)[:, None], 1),
    )
