"""Port of RealAIGym's acrobot "Energy PFL" (pflcol_lqr) and of its LQR, as paa_mj user controllers.

Source (double_pendulum @ 1e8544e67f3da72a51ee52fbbb278e131ce2a43f):
  leaderboard/acrobot/simulation_v1/con_pflcol_lqr.py            (gains, Q, R, torque limit 5 N m)
  src/python/double_pendulum/controller/partial_feedback_linearization/symbolic_pfl.py
  src/python/double_pendulum/controller/lqr/lqr_controller.py    (switch: cost-to-go y^T S y > 15 -> NaN)
  src/python/double_pendulum/model/symbolic_plant.py             (M, C, G "UnderactuatedLecture")

Conventions: paa_mj has q1 = 0 straight up; double_pendulum has q1 = 0 hanging down.
q1_dp = q1_paa + pi, q2_dp = q2_paa, velocities and the elbow torque are the same.

Its own formulas and parameters, as theirs (not paa_mj's model): a run of it in paa_mj's MuJoCo is a check of
the model files ``models/realaigym_acrobot*.xml`` and of the coordinate map against the published leaderboard.

    paa-mj simulate --robot realaigym_acrobot_v1 --goal stretched --x0 -3.141592653589793 0 0 0 --dt 0.002 \
        --t-final 10 --sample-dt 0.002 --controller examples/realaigym/pfl_controller.py:PFLCollocatedLQR_C03 --out run
"""
import numpy as np
from scipy.linalg import solve_continuous_are

# design_C.1/model_1.1 (= model_1.0 link parameters), leaderboard overrides Ir = b = cf = 0
C11 = dict(m1=0.5234602302310271, m2=0.6255677234174437, l1=0.2, l2=0.3, r1=0.2, r2=0.25569305436052964,
           I1=0.031887199591513114, I2=0.05086984812807257, g=9.81)
# design_C.0/model_3.0 (simulation_v1 leaderboard, where Energy PFL is published)
C03 = dict(m1=0.6416937799349799, m2=0.563935954099688, l1=0.2, l2=0.3, r1=0.2, r2=0.3212669909674605,
           I1=0.02671076499939512, I2=0.053878129629650884, g=9.81)


class _DP:
    def __init__(self, p):
        self.__dict__.update(p)

    def M(self, q2):
        c2 = np.cos(q2)
        m11 = self.I1 + self.I2 + self.m2 * self.l1 ** 2 + 2 * self.m2 * self.l1 * self.r2 * c2
        m12 = self.I2 + self.m2 * self.l1 * self.r2 * c2
        return m11, m12, self.I2

    def Cqd(self, q2, d1, d2):
        s = self.m2 * self.l1 * self.r2 * np.sin(q2)
        return -2 * s * d2 * d1 - s * d2 * d2, s * d1 * d1

    def G(self, q1, q2):
        g = self.g
        g0 = -self.m1 * g * self.r1 * np.sin(q1) - self.m2 * g * (self.l1 * np.sin(q1) + self.r2 * np.sin(q1 + q2))
        g1 = -self.m2 * g * self.r2 * np.sin(q1 + q2)
        return g0, g1

    def energy(self, q1, q2, d1, d2):
        m11, m12, m22 = self.M(q2)
        kin = 0.5 * (m11 * d1 * d1 + 2 * m12 * d1 * d2 + m22 * d2 * d2)
        pot = (-self.m1 * self.g * self.r1 * np.cos(q1)
               - self.m2 * self.g * (self.l1 * np.cos(q1) + self.r2 * np.cos(q1 + q2)))
        return kin + pot

    def linearization(self, goal=(np.pi, 0.0)):
        m11, m12, m22 = self.M(goal[1])
        Mm = np.array([[m11, m12], [m12, m22]])
        g = self.g
        c1, c12 = np.cos(goal[0]), np.cos(goal[0] + goal[1])
        dG = np.array([[-(self.m1 * self.r1 + self.m2 * self.l1) * g * c1 - self.m2 * g * self.r2 * c12,
                        -self.m2 * g * self.r2 * c12],
                       [-self.m2 * g * self.r2 * c12, -self.m2 * g * self.r2 * c12]])
        Minv = np.linalg.inv(Mm)
        A = np.zeros((4, 4))
        A[:2, 2:] = np.eye(2)
        A[2:, :2] = Minv @ dG
        B = np.zeros((4, 1))
        B[2:, 0] = Minv @ np.array([0.0, 1.0])
        return A, B


class _Base:
    params = C11
    torque_limit = 5.0                      # con_pflcol_lqr.py: torque_limit = [0.0, 5.0]
    Q = np.diag((0.97, 0.93, 0.39, 0.26))   # con_pflcol_lqr.py
    R = np.array([[0.11]])
    k = (1.0, 1.0, 1.0)                     # par = [1.0, 1.0, 1.0] -> kpos, kvel, ken
    cost_to_go_cut = 15.0                   # LQRController.set_parameters default
    goal = np.array([np.pi, 0.0, 0.0, 0.0])

    def __init__(self, robot=None):
        self.dp = _DP(self.params)
        A, B = self.dp.linearization()
        self.S = solve_continuous_are(A, B, self.Q, self.R)
        self.K = np.linalg.solve(self.R, B.T @ self.S)[0]
        self.E_des = self.dp.energy(np.pi, 0.0, 0.0, 0.0)

    # ---- LQR (lqr_controller.py get_control_output_) --------------------------------------------
    def _lqr(self, x):
        y = x.copy()
        y[0] = (y[0] + np.pi - self.goal[0]) % (2 * np.pi) - (np.pi - self.goal[0])
        y[1] = (y[1] + np.pi - self.goal[1]) % (2 * np.pi) - (np.pi - self.goal[1])
        y = y - self.goal
        u = -self.K @ y
        ok = y @ self.S @ y <= self.cost_to_go_cut
        return float(np.clip(u, -self.torque_limit, self.torque_limit)), ok

    # ---- collocated PFL with energy shaping (symbolic_pfl.py SymbolicPFLController) --------------
    def _pfl(self, x):
        q1, q2, d1, d2 = x
        q2 = (q2 + np.pi) % (2 * np.pi) - np.pi
        q1 = q1 % (2 * np.pi)
        if abs(q1) < 0.01 and q2 < 0.01 and d1 < 0.01 and d2 < 0.01:
            return self.torque_limit       # their kick out of the resting state
        k1, k2, k3 = self.k
        E = self.dp.energy(q1, q2, d1, d2)
        ubar = d1 * (E - self.E_des)
        qdd2 = -k1 * (q2 - self.goal[1]) - k2 * (d2 - self.goal[3]) + k3 * ubar
        m11, m12, m22 = self.dp.M(q2)
        c0, c1 = self.dp.Cqd(q2, d1, d2)
        g0, g1 = self.dp.G(q1, q2)
        # passive row: m11 qdd1 + m12 qdd2 + c0 - g0 = 0 ; active row: u = m12 qdd1 + m22 qdd2 + c1 - g1
        qdd1 = (g0 - c0 - m12 * qdd2) / m11
        u = m12 * qdd1 + m22 * qdd2 + c1 - g1
        return float(np.clip(u, -self.torque_limit, self.torque_limit))

    def _one(self, q, qd):
        x = np.array([q[0] + np.pi, q[1], qd[0], qd[1]], float)   # paa -> double_pendulum
        return self._law(x)

    def torque(self, q, qd, t=0.0):
        q, qd = np.asarray(q, float), np.asarray(qd, float)
        flat_q, flat_qd = q.reshape(-1, 2), qd.reshape(-1, 2)
        out = np.array([[self._one(a, b)] for a, b in zip(flat_q, flat_qd)])
        return out.reshape(q.shape[:-1] + (1,))


class PFLCollocatedLQR_C11(_Base):
    """pflcol_lqr: LQR where its cost-to-go < 15, else collocated energy PFL (memoryless switch, as theirs)."""
    def _law(self, x):
        u, ok = self._lqr(x)
        return u if ok else self._pfl(x)


class PFLCollocatedLQR_C03(PFLCollocatedLQR_C11):
    params = C03


class LQRTheirs_C11(_Base):
    """Their LQR weights alone (no cost-to-go cut), torque limit 5 N m."""
    def _law(self, x):
        return self._lqr(x)[0]
