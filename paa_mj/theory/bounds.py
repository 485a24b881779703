"""The function whose maximum is kD_min of (41), for any chain, and its upper bounds on boxes of postures.

The bound (41) is the maximum over the (n - 1)-torus of

.. math::

    f(x) = (E_r + \\mu(x))\\,\\lambda(x), \\qquad \\mu = \\Big|\\sum_k b_k e^{i\\phi_k}\\Big|, \\qquad
    \\lambda = \\lambda_{max}(S), \\qquad S = M_{aa} - M_{a1} M_{1a} / M_{11},

with x = (phi_2, ..., phi_n) the absolute link angles measured from link 1 (phi_1 = 0; the actuated relative angles
are q_a = diff(phi)), mu [J] the largest -P over q1 (42) and lambda [kg m^2] the largest eigenvalue of
(B^T M^-1 B)^-1, the Schur complement S (M does not depend on q1). f [J kg m^2] is even, f(-x) = f(x), so phi_2 runs
over [0, pi]. Absolute angles make a box's pairs move by at most rho_i + rho_k, where relative ones would add up
along the chain.

Upper bounds of f on a box, abs(phi_k - phi_k(c)) <= rho_k (:func:`box_bounds`), the least of:

1. The factors apart. S(x) <= N(x) = P^T M(x) P for any P = [p^T; I], since v^T S v = min over w1 of w^T M w with
   w = (w1, v); p is the centre's -M_a1 / M_11, so N(c) = S(c). In the eigenbasis V of S(c), each entry of
   V^T (N(x) - N(c)) V is bounded over the box, and lambda_max(N(x)) <= lambda_max(B), B those bounds (lambda_m plus
   the largest change on the diagonal, the largest absolute change off it): u^T V^T N V u <= abs(u)^T B abs(u) for
   unit u. An entry is bounded to first order with a Lagrange remainder, by intervals of each cos(phi_i - phi_k),
   and in the top row through the kinetic energy, y^T (A o C) y = sum_k m_k abs(sum_{i<=k} Gamma_ki y_i
   e^{i phi_i})^2 + sum_k J_k y_k^2, linear in the e^{i phi_i} up to a product of two small changes: the linear part
   is maximised exactly, arc by arc. mu <= sqrt(max a^2 + max b^2), a and b the parts of z = sum b_k e^{i phi_k}
   along and across z(c), sums of one-angle terms maximised exactly. Then f <= (E_r + mu_ub)^+ lambda_ub.
2. The factors together (they pull against each other: a straighter chain has a larger mu and a smaller lambda).
   With X = E_r + a + beta >= E_r + mu (mu <= a + beta, beta = max b^2 / (2 min a)) and Y = lambda_max(N),
   XY <= (t X + Y / t)^2 / 4 for every t > 0, and t X + Y / t = lambda_max(N / t + t X I) is bounded like B with
   the changes of a and of the top entry of N maximised together (:func:`_amgm`); t = sqrt(lambda_ub / (E_r +
   mu_ub)) makes it at most bound 1 where the changes do not help.
3. Near a maximum, a second-order model of each factor, and the maximum of their product over the box by duality
   (:mod:`paa_mj.theory.second_order`).

Every bound is computed in floating point and widened by :data:`SAFETY`; the search (a best-first branch and bound,
:func:`~paa_mj.theory.maxima.branch_and_bound`, driven by :func:`~paa_mj.theory.kd_search.kd_min_search`) prunes a
box when its bound is within the tolerance of the best value found, which a Newton ascent refines to rounding.
"""
from __future__ import annotations

import math

import numpy as np
from numba import njit

from ..model.chain import relative_coordinates_into
from .second_order import lambda_model, mu_model, product_bound

#: Relative widening of every bound for the rounding of the floating-point arithmetic that computes it.
SAFETY = 1e-10


@njit(cache=True)
def _arc_max(re, im, c, s):
    """max over |t| <= rho of Re((re + i im) e^{i t}), with c = cos rho and s = sin rho (c = -1, s = 0 for
    rho >= pi): |w| where the arc reaches the direction of w, else at the nearer end."""
    size = math.hypot(re, im)
    return size if re >= size * c else re * c + abs(im) * s


@njit(cache=True)
def _arc(rho):
    """(cos rho, sin rho) for :func:`_arc_max`, the whole circle from rho = pi."""
    return (math.cos(rho), math.sin(rho)) if rho < math.pi else (-1.0, 0.0)


@njit(cache=True)
def _centre(A, arm, x, phi, cs, sn, M, S):
    """phi, cos and sin of phi_i - phi_k, M and its Schur complement S at the absolute angles x."""
    n = A.shape[0]
    phi[0] = 0.0
    for k in range(1, n):
        phi[k] = x[k - 1]
    for i in range(n):
        for k in range(i, n):
            cs[i, k] = cs[k, i] = math.cos(phi[i] - phi[k])
            sn[i, k] = math.sin(phi[i] - phi[k])
            sn[k, i] = -sn[i, k]
            M[i, k] = M[k, i] = A[i, k] * cs[i, k]
    relative_coordinates_into(M, arm)  # T^T (A o C) T + diag(arm)
    for j in range(n - 1):
        for l in range(n - 1):
            S[j, l] = M[j + 1, l + 1] - M[j + 1, 0] * M[0, l + 1] / M[0, 0]


@njit(cache=True)
def _mu(b, phi):
    """z = sum_k b_k e^{i phi_k}: (mu = |z|, its angle theta)."""
    zr, zi = 0.0, 0.0
    for i in range(b.size):
        zr += b[i] * math.cos(phi[i])
        zi += b[i] * math.sin(phi[i])
    return math.hypot(zr, zi), math.atan2(zi, zr)


@njit(cache=True)
def centre_matrices(A, arm, x):
    """M and its Schur complement S at the absolute angles x (n - 1)."""
    n = A.shape[0]
    M, S = np.empty((n, n)), np.empty((n - 1, n - 1))
    _centre(A, arm, x, np.empty(n), np.empty((n, n)), np.empty((n, n)), M, S)
    return M, S


@njit(cache=True)
def values_into(A, b, arm, E_r, X, out):
    """f at each row of X (K, n - 1) into ``out`` [J kg m^2]."""
    n = A.shape[0]
    phi, cs, sn, M, S = np.empty(n), np.empty((n, n)), np.empty((n, n)), np.empty((n, n)), np.empty((n - 1, n - 1))
    for k in range(X.shape[0]):
        _centre(A, arm, X[k], phi, cs, sn, M, S)
        out[k] = (E_r + _mu(b, phi)[0]) * np.linalg.eigvalsh(S)[n - 2]


@njit(cache=True)
def _mu_box(b, phi, th, rho):
    """Bounds on the box of mu, and of the parts of z along and across z(c), a = Re(z e^{-i theta}) and
    b = Im(z e^{-i theta}), sums of one-angle terms each maximised exactly: (max mu, min a, max a, max |b|)."""
    amax, amin, smax, smin, total = 0.0, 0.0, 0.0, 0.0, 0.0
    for i in range(b.size):
        re, im = b[i] * math.cos(phi[i] - th), b[i] * math.sin(phi[i] - th)
        c, s = _arc(rho[i])
        amax += _arc_max(re, im, c, s)
        amin -= _arc_max(-re, -im, c, s)
        smax += _arc_max(im, -re, c, s)
        smin -= _arc_max(-im, re, c, s)
        total += b[i]
    across = max(smax, -smin)
    return min(total, math.hypot(max(amax, -amin), across)), amin, amax, across


@njit(cache=True)
def _top_row(mass, gam, Ut, phi, rho):
    """Bounds of the changes over the box of the top row of V^T N V by the kinetic energy (module docstring):
    row[m] >= |change of entry (t, m)|, the largest change of entry (t, t), the coefficients w_i of its linear
    part Re sum_i (e^{i dphi_i} - 1) w_i, the largest |change| and the bound of the rest (a product of two
    changes); t the top eigenvalue's index."""
    n, d = Ut.shape
    t = d - 1
    g0 = np.zeros((n, d), np.complex128)  # g0[k, m] = sum_{i<=k} Gamma_ki U_im e^{i phi_i}
    hk = np.zeros((n, d))  # the largest |change| of g[k, m]: sum_i |Gamma_ki U_im| |e^{i dphi_i} - 1|
    for k in range(n):
        for i in range(k + 1):
            z = complex(math.cos(phi[i]), math.sin(phi[i]))
            s = 2.0 * math.sin(min(rho[i], math.pi) / 2.0)
            for m in range(d):
                g0[k, m] += gam[k, i] * Ut[i, m] * z
                hk[k, m] += abs(gam[k, i] * Ut[i, m]) * s
    up, down, top = np.zeros(d), np.zeros(d), np.empty(n, np.complex128)
    for i in range(n):
        z = complex(math.cos(phi[i]), math.sin(phi[i]))
        c, s = _arc(rho[i])
        for m in range(d):
            coef = 0j  # the change is Re(sum_i (e^{i dphi_i} - 1) z_i coef_i) plus a product of two changes
            for k in range(i, n):
                coef += mass[k] * gam[k, i] * (Ut[i, t] * g0[k, m].conjugate() + Ut[i, m] * g0[k, t].conjugate())
            w = z * coef
            if m == t:
                top[i] = w
            up[m] += _arc_max(w.real, w.imag, c, s) - w.real
            down[m] -= _arc_max(-w.real, -w.imag, c, s) + w.real
    row, quad = np.empty(d), np.zeros(d)
    for m in range(d):
        for k in range(n):
            quad[m] += mass[k] * hk[k, m] * hk[k, t]
        row[m] = max(up[m], -down[m]) + quad[m]
    return row, up[t] + quad[t], top, max(up[t], -down[t]) + quad[t], quad[t]


@njit(cache=True)
def _entry_bounds(A, Y, Ut, sn, Om, r):
    """eta >= ||N(x) - N(c)||_2 (Weyl) and B, bounds of the |changes| of the entries of V^T N V over the box (first
    order with a Lagrange remainder, or intervals); also wz = (A o sin)[1:] U and the Lagrange remainders."""
    n, d = Ut.shape
    T1, T2, T3 = np.zeros((n, d)), np.zeros((n, d)), np.zeros((n, d))
    for i in range(n):
        for k in range(n):
            om = Om[i, k]
            a = A[i, k] * min(2.0, om, abs(sn[i, k]) * om + 0.5 * om * om)  # >= |A_ik (cos(s + w) - cos s)|
            o = 0.5 * A[i, k] * om * om
            for j in range(d):
                T1[i, j] += a * abs(Y[k, j])
                T2[i, j] += a * abs(Ut[k, j])
                T3[i, j] += o * abs(Ut[k, j])
    R, zero, rem2, wz = np.zeros((d, d)), np.zeros((d, d)), np.zeros((d, d)), np.zeros((d, d))
    for m in range(d):
        for l in range(d):
            for i in range(n):
                R[m, l] += abs(Y[i, m]) * T1[i, l]
                zero[m, l] += abs(Ut[i, m]) * T2[i, l]
                rem2[m, l] += abs(Ut[i, m]) * T3[i, l]
            for p in range(n):  # wz[j, m] = sum_p (A o sin)[j + 1, p] U[p, m]
                wz[m, l] += A[m + 1, p] * sn[m + 1, p] * Ut[p, l]
    frobenius, row = 0.0, 0.0
    for m in range(d):
        frobenius += np.sum(R[m] * R[m])
        row = max(row, np.sum(R[m]))
    B = np.empty((d, d))
    for m in range(d):
        for l in range(m, d):
            first = 0.0
            for j in range(d):  # d/dphi_{j+1} of entry (m, l) = -(U[j+1, m] wz[j, l] + wz[j, m] U[j+1, l])
                first += r[j] * abs(Ut[j + 1, m] * wz[j, l] + wz[j, m] * Ut[j + 1, l])
            B[m, l] = B[l, m] = min(first + rem2[m, l], zero[m, l])
    return min(math.sqrt(frobenius), row), B, wz, rem2


@njit(cache=True)
def _amgm(b, E_r, mu, th, amin, amax, across, l1, phi, rho, top, quad, B, t):
    """f <= (t X + Y / t)^2 / 4 on the box, for the t > 0 given: bound 2 of the module's docstring.

    X = E_r + a + beta >= E_r + mu and Y = lambda_max(N) >= lambda; t X + Y / t is the largest eigenvalue of
    N / t + t X I, bounded like B, with its top entry's changes, Re sum_i (e^{i dphi_i} - 1) (top_i / t
    + t b_i e^{i(phi_i - theta)}), maximised arc by arc together. Infinite where a may vanish or X(c) <= 0."""
    if amin <= 0.0:
        return np.inf
    beta = across * across / (2.0 * amin)
    X0 = E_r + mu + beta
    if X0 <= 0.0:
        return np.inf
    d = B.shape[0]
    tt = d - 1
    linear = 0.0
    for i in range(b.size):
        wr = top[i].real / t + t * b[i] * math.cos(phi[i] - th)
        wi = top[i].imag / t + t * b[i] * math.sin(phi[i] - th)
        c, s = _arc(rho[i])
        linear += _arc_max(wr, wi, c, s) - wr
    G = B / t
    xmax = t * (E_r + amax + beta)
    for m in range(d):
        G[m, m] += xmax
    G[tt, tt] = min(G[tt, tt], (l1 + quad) / t + t * X0 + linear)
    return max(np.linalg.eigvalsh(G)[tt], 0.0) ** 2 / 4.0


@njit(cache=True)
def _basis(M, V):
    """Y = T P, P = [p^T; I] with p = -M_a1 / M_11 (n, n - 1), and U = Y V."""
    n = M.shape[0]
    d = n - 1
    Y, Ut = np.empty((n, d)), np.zeros((n, d))
    for i in range(n):
        for j in range(d):
            Y[i, j] = -M[0, j + 1] / M[0, 0] + (1.0 if i > j else 0.0)
        for j in range(d):
            for m in range(d):
                Ut[i, m] += Y[i, j] * V[j, m]
    return Y, Ut


@njit(cache=True)
def _top_entry(A, Ut, cs, sn, rho, r):
    """The top entry n11 = v1^T N v1 = sum_ik Wyy_ik cos(phi_i - phi_k): the pairs' largest moves Om_ik =
    rho_i + rho_k, Wyy, its gradient n1 at the centre, and two bounds of its change on the box (first order
    with a Lagrange remainder; each pair's cosine over its arc)."""
    n, d = Ut.shape
    t = d - 1
    cr, sr = np.empty(n), np.empty(n)
    for i in range(n):
        cr[i], sr[i] = math.cos(rho[i]), math.sin(rho[i])
    Om, Wyy, n1 = np.empty((n, n)), np.empty((n, n)), np.zeros(d)
    first, interval = 0.0, 0.0
    for i in range(n):
        for k in range(n):
            Om[i, k] = rho[i] + rho[k] if i != k else 0.0
            Wyy[i, k] = A[i, k] * Ut[i, t] * Ut[k, t]
            first += 0.5 * abs(Wyy[i, k]) * Om[i, k] ** 2
            if Om[i, k] < math.pi:  # cos and sin of rho_i + rho_k
                c, s = cr[i] * cr[k] - sr[i] * sr[k], sr[i] * cr[k] + cr[i] * sr[k]
            else:
                c, s = -1.0, 0.0
            if i == k:
                c, s = 1.0, 0.0
            interval += _arc_max(Wyy[i, k] * cs[i, k], Wyy[i, k] * sn[i, k], c, s) - Wyy[i, k] * cs[i, k]
            if i > 0:
                n1[i - 1] -= 2.0 * Wyy[i, k] * sn[i, k]
    for j in range(d):
        first += abs(n1[j]) * r[j]
    return Om, Wyy, n1, first, interval


@njit(cache=True)
def _box(A, b, mass, gam, E_r, lam_global, r, rho, phi, cs, sn, M, S, target, score):
    """(an upper bound of f on the box, f at its centre) for the centre :func:`_centre` prepared; the split
    scores into ``score``. Bounds 1 and 2 of the module's docstring, and 3 where they do not reach ``target``."""
    n = A.shape[0]
    d, t = n - 1, n - 2
    lam, V = np.linalg.eigh(S)
    Y, Ut = _basis(M, V)
    mu, th = _mu(b, phi)
    mu_ub, amin, amax, across = _mu_box(b, phi, th, rho)
    Om, Wyy, n1, first, interval = _top_entry(A, Ut, cs, sn, rho, r)
    row, diagonal, top, change, quad = _top_row(mass, gam, Ut, phi, rho)
    eta, B, wz, rem2 = _entry_bounds(A, Y, Ut, sn, Om, r)
    for m in range(d):
        B[m, t] = B[t, m] = min(B[m, t], row[m])
    B[t, t] = min(B[t, t], first, interval, diagonal)
    for m in range(d):
        B[m, m] += lam[m]
    lam_ub = min(lam[t] + eta, np.linalg.eigvalsh(B)[t], lam_global)
    push = max(E_r + mu_ub, 0.0)
    upper = push * lam_ub
    if push > 0.0 and upper > target:  # t balancing the two factors' bounds: never far above push lam_ub
        upper = min(upper, _amgm(b, E_r, mu, th, amin, amax, across, lam[t], phi, rho, top, quad, B,
                                 math.sqrt(lam_ub / push)))
    a1, M2, Rm = mu_model(b, phi, th, mu, amin, rho, r)
    for j in range(d):  # how much the bound owes to each radius: first-order terms and the pairs it moves
        pairs = 0.0
        for k in range(n):
            pairs += abs(Wyy[j + 1, k]) * Om[j + 1, k]
        score[j] = r[j] * (abs((E_r + mu) * n1[j] + lam[t] * a1[j]) + push * pairs + lam[t] * b[j + 1] * r[j])
    if upper > target and Rm < np.inf:
        L2, Rl = lambda_model(A, lam, Ut, Wyy, cs, sn, Om, n1, wz, rem2, B, eta, r)
        if Rl < np.inf:
            upper = min(upper, product_bound(E_r, mu, lam[t], n1, a1, M2, Rm, L2, Rl, r))
    return upper * (1.0 + SAFETY) + SAFETY * (abs(E_r) + np.sum(b)) * lam[t], (E_r + mu) * lam[t]


@njit(cache=True, nogil=True)
def box_bounds(A, b, arm, mass, gam, E_r, lam_global, c, r, target, upper, value, score):
    """Upper bounds of f on the boxes c +- r (K, n - 1) into ``upper``, f at their centres into ``value`` and each
    radius's share of the bound into ``score`` (the axis to split); a box whose first-order bound is at most
    ``target`` skips the second-order model."""
    n = A.shape[0]
    phi, rho = np.empty(n), np.zeros(n)
    cs, sn, M, S = np.empty((n, n)), np.empty((n, n)), np.empty((n, n)), np.empty((n - 1, n - 1))
    for k in range(c.shape[0]):
        _centre(A, arm, c[k], phi, cs, sn, M, S)
        for j in range(n - 1):
            rho[j + 1] = r[k, j]
        upper[k], value[k] = _box(A, b, mass, gam, E_r, lam_global, r[k], rho, phi, cs, sn, M, S, target, score[k])


@njit(cache=True)
def gradient(A, b, arm, E_r, x):
    """f and its gradient at the absolute angles x (n - 1): df = (E_r + mu) dlambda + lambda dmu, where
    dlambda = v1^T dN v1 (N = S at x, and lambda_max(N) >= lambda_max(S) everywhere) and dmu = Re(conj(z) dz) / mu."""
    n = A.shape[0]
    d = n - 1
    phi, cs, sn, M, S = np.empty(n), np.empty((n, n)), np.empty((n, n)), np.empty((n, n)), np.empty((d, d))
    _centre(A, arm, x, phi, cs, sn, M, S)
    lam, V = np.linalg.eigh(S)
    y = np.zeros(n)  # T P v1
    for i in range(n):
        for j in range(d):
            y[i] += (-M[0, j + 1] / M[0, 0] + (1.0 if i > j else 0.0)) * V[j, d - 1]
    mu, th = _mu(b, phi)
    g = np.zeros(d)
    for j in range(d):
        for k in range(n):
            g[j] -= 2.0 * (E_r + mu) * A[j + 1, k] * y[j + 1] * y[k] * sn[j + 1, k]
        g[j] -= lam[d - 1] * b[j + 1] * math.sin(phi[j + 1] - th)
    return (E_r + mu) * lam[d - 1], g
