"""Port of RealAIGym's acrobot "TVLQR" leaderboard entry (ilqr_tvlqr) as a paa_mj user controller.

Their entry (simulation_v2 and robustness_v2 boards, user fwiebe): an iLQR swing-up trajectory, tracked by
time-varying LQR, handed to their LQR near the top.

Source (dfki-ric-underactuated-lab/double_pendulum @ 1e8544e67f3da72a51ee52fbbb278e131ce2a43f):
  leaderboard/acrobot/simulation_v2/con_ilqr_tvlqr.py     (the same file in robustness_v2/): Q, R, Qf, Q_lqr,
                                                          R_lqr, the switch condition2, cost_to_go_cut 1000
  leaderboard/acrobot/simulation_v2/sim_parameters.py     design_C.1/model_1.0, tl = [0, 6], Ir = b = cf = 0
  src/python/double_pendulum/controller/tvlqr/tvlqr_controller.py    TVLQRController (num_break 40, cubic)
  src/python/double_pendulum/controller/lqr/lqr.py                   iterative_riccati, lqr
  src/python/double_pendulum/controller/lqr/lqr_controller.py        LQRController
  src/python/double_pendulum/controller/combined_controller.py       CombinedController
  src/python/double_pendulum/utils/pcw_polynomial.py                 InterpolateVector / InterpolateMatrix
  src/python/double_pendulum/utils/wrap_angles.py                    wrap_angles_top, wrap_angles_diff
  src/python/double_pendulum/model/symbolic_plant.py                 f(x, u), its Jacobians ("UnderactuatedLecture")

The trajectory is their data/trajectories/design_C.1/model_1.1/acrobot/ilqr_1/trajectory.csv (git blob
f5e36b4945e43a4a71960ee732cfd60561ac8931, committed in 252bfbec3f8e9ce2128055bc2daa5ed8b067be5d, 2023-06-29,
unchanged through 1e8544e6), copied byte for byte to data/ilqr_1_design_C.1_model_1.1_acrobot_trajectory.csv.
Their repository is BSD-3-Clause.

Conventions: paa_mj has q1 = 0 straight up; double_pendulum has q1 = 0 hanging down.
q1_dp = q1_paa + pi, q2_dp = q2_paa; velocities and the elbow torque are the same.

Their formulas, in NumPy (no sympy: the Jacobians of their f are written out by hand; no pandas: the CSV is
read with numpy). The piecewise cubic fits call scipy's ``curve_fit`` exactly as theirs do (same data splits,
same default start, maxfev=2000), so that the fitted coefficients are theirs to the last bit given the same
MINPACK.

    paa-mj realaigym --protocol performance-v2 --robot realaigym_acrobot \
        --controller examples/realaigym/tvlqr_controller.py:ILQRTVLQR_C11 --json --out run
"""
import os
import warnings

import numpy as np
import scipy.linalg
from scipy.optimize import curve_fit

HERE = os.path.dirname(os.path.abspath(__file__))
TRAJECTORY = os.path.join(HERE, "data", "ilqr_1_design_C.1_model_1.1_acrobot_trajectory.csv")
MIRROR = ("/work/.mirror/dfki-ric-underactuated-lab+double_pendulum/repo "
          "(git show HEAD:data/trajectories/design_C.1/model_1.1/acrobot/ilqr_1/trajectory.csv)")

# design_C.1/model_1.0 (sim_parameters.py), with the leaderboard's overrides Ir = 0, b = 0, cf = 0, tl = [0, 6]
C10 = dict(m=(0.5234602302310271, 0.6255677234174437), l=(0.2, 0.3), r=(0.2, 0.25569305436052964),
           I=(0.031887199591513114, 0.05086984812807257), g=9.81, b=(0.0, 0.0), cf=(0.0, 0.0), tl=(0.0, 6.0))


# ---- their plant's f(x, u) and its Jacobians (symbolic_plant.py, Ir = 0, B = diag(0, 1)) ---------------------
class Plant:
    def __init__(self, p, generated=None):
        self.generated = None
        if generated is not None:   # their lambdified sympy code (data/their_sympy_linear_matrices_C10.py.txt)
            space = {"array": np.array, "sin": np.sin, "cos": np.cos}
            with open(generated) as f:
                exec(compile(f.read(), generated, "exec"), space)
            self.generated = (space["Alin"], space["Blin"])
        self.m1, self.m2 = p["m"]
        self.l1, self.l2 = p["l"]
        self.r1, self.r2 = p["r"]
        self.I1, self.I2 = p["I"]
        self.g = p["g"]
        self.b1, self.b2 = p["b"]
        self.cf1, self.cf2 = p["cf"]
        tl = p["tl"]
        if tl[0] == 0:
            self.B = np.array([[0.0, 0.0], [0.0, 1.0]])
        elif tl[1] == 0:
            self.B = np.array([[1.0, 0.0], [0.0, 0.0]])
        else:
            self.B = np.eye(2)

    def linear_matrices(self, x0, u0):
        """A = df/dx, B = df/du at (x0, u0): f = [qd; M^-1 (-C qd + G + B u - F)]."""
        if self.generated is not None:
            return (np.asarray(self.generated[0](x0, u0), dtype=float),
                    np.asarray(self.generated[1](x0, u0), dtype=float))
        q1, q2, d1, d2 = (float(v) for v in x0)
        u = np.asarray(u0, float)
        m1, m2, l1, r1, r2, g = self.m1, self.m2, self.l1, self.r1, self.r2, self.g
        c2, s2 = np.cos(q2), np.sin(q2)
        k = m2 * l1 * r2
        M = np.array([[self.I1 + self.I2 + m2 * l1 ** 2.0 + 2 * k * c2, self.I2 + k * c2],
                      [self.I2 + k * c2, self.I2]])
        dM = np.array([[-2 * k * s2, -k * s2], [-k * s2, 0.0]])
        Minv = np.linalg.inv(M)
        s = k * s2
        ds = k * c2
        mCqd = np.array([2 * s * d1 * d2 + s * d2 * d2, -s * d1 * d1])           # -C(q, qd) qd
        G = np.array([-m1 * g * r1 * np.sin(q1) - m2 * g * (l1 * np.sin(q1) + r2 * np.sin(q1 + q2)),
                      -m2 * g * r2 * np.sin(q1 + q2)])
        F = np.array([self.b1 * d1 + self.cf1 * np.arctan(100 * d1), self.b2 * d2 + self.cf2 * np.arctan(100 * d2)])
        h = mCqd + G + self.B @ u - F
        c1, c12 = np.cos(q1), np.cos(q1 + q2)
        dh_dq1 = np.array([-m1 * g * r1 * c1 - m2 * g * (l1 * c1 + r2 * c12), -m2 * g * r2 * c12])
        dh_dq2 = np.array([ds * (2 * d1 * d2 + d2 * d2) - m2 * g * r2 * c12, -ds * d1 * d1 - m2 * g * r2 * c12])
        dh_dd1 = np.array([2 * s * d2 - self.b1 - self.cf1 * 100 / (1 + (100 * d1) ** 2), -2 * s * d1])
        dh_dd2 = np.array([2 * s * d1 + 2 * s * d2, -self.b2 - self.cf2 * 100 / (1 + (100 * d2) ** 2)])
        A = np.zeros((4, 4))
        A[0, 2] = A[1, 3] = 1.0
        A[2:, 0] = Minv @ dh_dq1
        A[2:, 1] = -Minv @ dM @ Minv @ h + Minv @ dh_dq2
        A[2:, 2] = Minv @ dh_dd1
        A[2:, 3] = Minv @ dh_dd2
        Bl = np.zeros((4, 2))
        Bl[2:, :] = Minv @ self.B
        return A, Bl

    def linear_matrices_discrete(self, x0, u0, dt):
        A, B = self.linear_matrices(x0, u0)
        return np.identity(4) + dt * A, B * dt


# ---- pcw_polynomial.py ----------------------------------------------------------------------------------------
def poly3(t, A, B, C, D):
    return A * pow(t, 3) + B * pow(t, 2) + C * pow(t, 1) + D


class FitPiecewisePolynomial:
    """Theirs (poly_degree 3): np.array_split into num_break pieces, curve_fit of a cubic on each."""

    def __init__(self, data_x, data_y, num_break, coeff=None):
        xs, ys = np.array_split(data_x, num_break), np.array_split(data_y, num_break)
        self.ends = np.array([np.linspace(sx[0], sx[-1], len(sx))[-1] for sx in xs])
        if coeff is not None:  # fits made elsewhere (another SciPy), see ``dump_fits``
            self.coeff = list(np.asarray(coeff, float))
            return
        self.coeff = []
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")  # their OptimizeWarning (covariance) is harmless
            for sx, sy in zip(xs, ys):
                p, _ = curve_fit(poly3, sx, sy, maxfev=2000)
                self.coeff.append(p)

    def get_value(self, value):
        # theirs: min index of the sections whose x_sec_data has any element >= value (= its last element)
        i = int(np.searchsorted(self.ends, value, side="left"))
        if i >= len(self.ends):
            raise ValueError("min() arg is an empty sequence")  # as theirs, past the last break
        return poly3(value, *self.coeff[i])


class InterpolateVector:
    def __init__(self, T, X, num_break=40, coeffs=None, name="X"):
        get = (lambda key: None) if coeffs is None else (lambda key: coeffs[key])
        self.fits = [None if np.count_nonzero(X[:, d]) == 0
                     else FitPiecewisePolynomial(T, X[:, d], num_break, get(f"{name}_{d}"))
                     for d in range(X.shape[1])]
        self.names = [f"{name}_{d}" for d in range(X.shape[1])]

    def get_value(self, value):
        x = np.empty(len(self.fits))
        for d, f in enumerate(self.fits):
            x[d] = 0.0 if f is None else f.get_value(value)
        return x


class InterpolateMatrix:
    def __init__(self, T, X, num_break=40, coeffs=None, name="K"):
        get = (lambda key: None) if coeffs is None else (lambda key: coeffs[key])
        self.shape = X.shape[1:]
        self.fits = [[None if np.count_nonzero(X[:, i, j]) == 0
                      else FitPiecewisePolynomial(T, X[:, i, j], num_break, get(f"{name}_{i}_{j}"))
                      for j in range(self.shape[1])] for i in range(self.shape[0])]
        self.names = [f"{name}_{i}_{j}" for i in range(self.shape[0]) for j in range(self.shape[1])]

    def get_value(self, value):
        x = np.empty(self.shape)
        for i, row in enumerate(self.fits):
            for j, f in enumerate(row):
                x[i, j] = 0.0 if f is None else f.get_value(value)
        return x


# ---- wrap_angles.py ---------------------------------------------------------------------------------------------
def wrap_angles_top(x):
    y = np.copy(x)
    y[0] = x[0] % (2 * np.pi)
    y[1] = (x[1] + np.pi) % (2 * np.pi) - np.pi
    return y


def wrap_angles_diff(x):
    y = np.copy(x)
    y[0] = x[0] % (2 * np.pi)
    y[1] = x[1] % (2 * np.pi)
    while np.abs(y[0]) > np.pi:
        y[0] -= 2 * np.pi
    while np.abs(y[1]) > np.pi:
        y[1] -= 2 * np.pi
    return y


# ---- lqr.py -----------------------------------------------------------------------------------------------------
def iterative_riccati(plant, Q, R, Qf, dt, x_traj, u_traj):
    N, n, m = x_traj.shape[0], x_traj.shape[1], u_traj.shape[1]
    P = np.zeros((N, n, n))
    K = np.zeros((N, m, n))
    P[-1] = Qf
    for i in range(N - 2, -1, -1):
        A, B = plant.linear_matrices_discrete(x_traj[i], u_traj[i], dt)
        K[i] = np.linalg.multi_dot([np.linalg.inv(R + np.linalg.multi_dot([B.T, P[i + 1], B])), B.T, P[i + 1], A])
        P[i] = Q + np.linalg.multi_dot([A.T, P[i + 1], (A - np.dot(B, K[i]))])
    return K, P


def lqr(A, B, Q, R):
    X = scipy.linalg.solve_continuous_are(A, B, Q, R)
    K = scipy.linalg.inv(R) @ (B.T @ X)
    return K, X


def load_trajectory(path):
    if not os.path.exists(path):
        raise FileNotFoundError(f"their iLQR trajectory is not at {path}; take it from {MIRROR}")
    with open(path) as f:
        header = [h.strip() for h in f.readline().split(",")]
    data = np.loadtxt(path, delimiter=",", skiprows=1, ndmin=2)
    col = {h: data[:, i] for i, h in enumerate(header)}
    T = col["time"]
    X = np.array([col["pos1"], col["pos2"], col["vel1"], col["vel2"]]).T
    U = np.array([col["tau1"], col["tau2"]]).T
    return T, X, U


# ---- the controllers --------------------------------------------------------------------------------------------
class TVLQRController:
    """tvlqr_controller.py: u = U(t) - K(t) wrap(x - X(t)), every one of U, X, K a piecewise cubic fit; t held at
    the trajectory's last time after it ends."""

    def __init__(self, params, csv_path, Q, R, Qf, num_break=40, fits=None, generated=None):
        self.tl = params["tl"]
        self.plant = Plant(params, generated)
        self.T, self.X, self.U = load_trajectory(csv_path)
        self.max_t = self.T[-1]
        self.dt = self.T[1] - self.T[0]
        coeffs = None if fits is None else np.load(fits)
        self.X_interp = InterpolateVector(self.T, self.X, num_break, coeffs, "X")
        self.U_interp = InterpolateVector(self.T, self.U, num_break, coeffs, "U")
        self.K, self.P = iterative_riccati(self.plant, np.asarray(Q), np.asarray(R), np.asarray(Qf), self.dt,
                                           self.X, self.U)
        self.K_interp = InterpolateMatrix(self.T, self.K, num_break, coeffs, "K")

    def dump_fits(self, path):
        """Every fitted cubic's coefficients (40, 4) by name, to give another run the same fits."""
        out = {}
        for interp in (self.X_interp, self.U_interp):
            out.update({n: f.coeff for n, f in zip(interp.names, interp.fits) if f is not None})
        flat = [f for row in self.K_interp.fits for f in row]
        out.update({n: f.coeff for n, f in zip(self.K_interp.names, flat) if f is not None})
        np.savez(path, **{k: np.array(v) for k, v in out.items()})

    def __call__(self, x, t):
        tt = min(t, self.max_t)
        x_error = wrap_angles_diff(np.asarray(x) - self.X_interp.get_value(tt))
        tau = self.U_interp.get_value(tt) - np.dot(self.K_interp.get_value(tt), x_error)
        return [np.clip(tau[0], -self.tl[0], self.tl[0]), np.clip(tau[1], -self.tl[1], self.tl[1])]


class LQRController:
    """lqr_controller.py: -K y about the goal, failure_value where y'Sy > cost_to_go_cut."""

    def __init__(self, params, Q, R, goal=(np.pi, 0.0, 0.0, 0.0), failure_value=0.0, cost_to_go_cut=1000.0,
                 generated=None):
        self.tl = params["tl"]
        y = np.array(goal, float)
        y[0] = y[0] % (2 * np.pi)
        y[1] = (y[1] + np.pi) % (2 * np.pi) - np.pi
        self.xd = y
        self.failure_value, self.cost_to_go_cut = failure_value, cost_to_go_cut
        A, B = Plant(params, generated).linear_matrices(self.xd, [0.0, 0.0])
        self.K, self.S = lqr(A, B, np.asarray(Q), np.asarray(R))

    def __call__(self, x, t=None):
        y = np.array(x, float)
        y[0] = (y[0] + np.pi - self.xd[0]) % (2 * np.pi) - (np.pi - self.xd[0])
        y[1] = (y[1] + np.pi - self.xd[1]) % (2 * np.pi) - (np.pi - self.xd[1])
        y -= self.xd
        u = list(-self.K.dot(y))
        if y.dot(self.S.dot(y)) > self.cost_to_go_cut:
            u = [self.failure_value, self.failure_value]
        return [np.clip(u[0], -self.tl[0], self.tl[0]), np.clip(u[1], -self.tl[1], self.tl[1])]


def near_top(t, x, eps=(0.1, 0.1, 0.5, 0.5)):
    """con_ilqr_tvlqr.py condition2."""
    goal = [np.pi, 0.0, 0.0, 0.0]
    delta = np.abs(np.subtract(wrap_angles_top(x), goal))
    return not np.max(np.subtract(delta, eps)) > 0.0


class ILQRTVLQR_C11:
    """ilqr_tvlqr: TVLQR on the iLQR trajectory, then (latched) their LQR once within (0.1, 0.1, 0.5, 0.5) of the
    top (CombinedController: condition1 never, condition2 near_top). Their constants (con_ilqr_tvlqr.py)."""
    params = C10
    trajectory = TRAJECTORY
    Q = np.diag([0.64, 0.56, 0.13, 0.037])
    R = np.eye(2) * 0.82
    Qf = 100 * np.diag([0.64, 0.56, 0.13, 0.037])
    Q_lqr = np.diag((0.97, 0.93, 0.39, 0.26))
    R_lqr = np.diag((0.11, 0.11))

    fits = None        # None: curve_fit here; else an .npz of ``dump_fits`` (e.g. made under SciPy 1.13, see below)
    generated = None   # None: A, B by the hand-written Jacobians; else their lambdified sympy code

    def __init__(self, robot=None, **_):
        self.tvlqr = TVLQRController(self.params, self.trajectory, self.Q, self.R, self.Qf, fits=self.fits,
                                     generated=self.generated)
        self.lqr = LQRController(self.params, self.Q_lqr, self.R_lqr, generated=self.generated)
        self.controllers = [self.tvlqr, self.lqr]
        self.conditions = [lambda t, x: False, near_top]
        self.active = 0
        self.switch_time = None

    def reset(self):
        # their benchmark calls controller.reset(); controller.init() before each run: init_ sets active = 0
        # (and recomputes the same TVLQR gains)
        self.active = 0
        self.switch_time = None

    def _law(self, x, t):
        inactive = 1 - self.active
        if self.conditions[inactive](t, x):
            self.active = inactive
            if self.switch_time is None:
                self.switch_time = t
        return self.controllers[self.active](x, t)

    def _one(self, q, qd, t):
        x = np.array([q[0] + np.pi, q[1], qd[0], qd[1]], float)   # paa -> double_pendulum
        return float(self._law(x, t)[1])

    def torque(self, q, qd, t=0.0):
        q, qd = np.asarray(q, float), np.asarray(qd, float)
        flat_q, flat_qd = q.reshape(-1, 2), qd.reshape(-1, 2)
        out = np.array([[self._one(a, b, float(t))] for a, b in zip(flat_q, flat_qd)])
        return out.reshape(q.shape[:-1] + (1,))


class TVLQROnly_C11(ILQRTVLQR_C11):
    """Their TVLQR alone (no LQR hand-over), for checks."""
    def _law(self, x, t):
        return self.tvlqr(x, t)


FITS_SCIPY_1_13 = os.path.join(HERE, "data", "ilqr_tvlqr_fits_scipy1.13.1_numpy1.26.4.npz")


class ILQRTVLQR_C11_Scipy113(ILQRTVLQR_C11):
    """As ILQRTVLQR_C11, with the piecewise cubic fits that SciPy 1.13.1 (Fortran MINPACK; NumPy 1.26.4) makes of
    the same data. SciPy >= 1.15 translated MINPACK to C, and curve_fit's Levenberg-Marquardt stops at its
    tolerance (~1.5e-8) on a slightly different iterate: the fits differ by ~1e-9. Made with

        python -m venv /tmp/oldsci && /tmp/oldsci/bin/pip install numpy==1.26.4 scipy==1.13.1
        /tmp/oldsci/bin/python examples/realaigym/tvlqr_controller.py --dump-fits FITS_SCIPY_1_13
    """
    fits = FITS_SCIPY_1_13


GENERATED_C10 = os.path.join(HERE, "data", "their_sympy_linear_matrices_C10.py.txt")
FITS_SCIPY_1_13_GENERATED = os.path.join(HERE, "data", "ilqr_tvlqr_fits_scipy1.13.1_numpy1.26.4_sympyA.npz")


class ILQRTVLQR_C11_Exact(ILQRTVLQR_C11):
    """As ILQRTVLQR_C11_Scipy113, with A and B evaluated from their lambdified sympy expressions (15-digit
    constants) instead of the hand-written Jacobians: the Riccati gains then equal theirs to the last bits, and
    so do the cubic fits of them (which move by up to 0.02 N m/rad for a 1e-12 relative change of the gains:
    curve_fit's cubic in absolute time is ill-conditioned and stops at its tolerance). Fits made with

        /tmp/oldsci/bin/python examples/realaigym/tvlqr_controller.py --exact --dump-fits FITS_SCIPY_1_13_GENERATED
    """
    fits = FITS_SCIPY_1_13_GENERATED
    generated = GENERATED_C10


if __name__ == "__main__":
    import argparse
    import scipy
    parser = argparse.ArgumentParser(description="dump the TVLQR port's fitted cubics (this Python's SciPy)")
    parser.add_argument("--dump-fits", required=True, metavar="OUT.npz")
    parser.add_argument("--exact", action="store_true", help="A, B from their lambdified sympy code")
    args = parser.parse_args()
    cls = type("Fresh", (ILQRTVLQR_C11,), {"fits": None, "generated": GENERATED_C10 if args.exact else None})
    cls().tvlqr.dump_fits(args.dump_fits)
    print(f"fits of SciPy {scipy.__version__}, NumPy {np.__version__} -> {args.dump_fits}")
