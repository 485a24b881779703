"""The second-order model of f of (41) on a box, near its maximum (:mod:`paa_mj.theory.bounds`, bound 3).

On a box abs(phi_k - c_k) <= rho_k (delta = phi - c, phi the absolute angles of links 2..n):

- mu <= a + b^2 / (2 a_min) (a and b the parts of z = sum_k b_k e^{i phi_k} along and across z(c), a_min > 0 the
  least a on the box), each part expanded to second order in delta with a third-order remainder:
  mu <= mu(c) + a1.delta + delta^T M2 delta / 2 + Rm (:func:`mu_model`);
- lambda = lambda_max(S) <= lambda_max(N) <= n11 + norm(e)^2 / gap, the 2 x 2 reduction of N = P^T M P in the basis
  (v1, V2) of the eigenvectors of S(c) (n11 = v1^T N v1, e = V2^T N v1, gap <= n11 - lambda_max(V2^T N V2) > 0),
  also expanded to second order: lambda <= lambda(c) + n1.delta + delta^T L2 delta / 2 + Rl (:func:`lambda_model`);
- f = (E_r + mu) lambda <= the product of the two models, a quadratic G.delta + delta^T H delta / 2 plus the
  products of the changes (:func:`product_bound`), whose maximum over the box is bounded by Lagrangian duality
  (:func:`_quad_box_max`).

Each remainder is an infinity where its expansion has no bound (a_min <= 0, no gap): the model then gives nothing.
"""
from __future__ import annotations

import math

import numpy as np
from numba import njit


@njit(cache=True)
def _quad_box_max(G, H, r):
    """An upper bound of max over |delta_j| <= r_j of G.delta + delta^T H delta / 2.

    With s >= 0 such that H' = H - s I < 0, the quadratic is at most G.delta + delta^T H' delta / 2 + s |r|^2 / 2,
    and by duality max over the box of G.delta + delta^T H' delta / 2 <= (G - nu)^T (-H')^-1 (G - nu) / 2
    + sum_j |nu_j| r_j for every nu: nu = 0 (the unconstrained maximum) and nu = G + H' dh, dh the unconstrained
    maximiser clipped to the box. Also sum_j |G_j| r_j + max(lambda_max(H), 0) |r|^2 / 2.
    """
    d = G.size
    w, Q = np.linalg.eigh(H)
    lin, r2 = 0.0, 0.0
    for j in range(d):
        lin += abs(G[j]) * r[j]
        r2 += r[j] * r[j]
    scale = max(abs(w[0]), abs(w[d - 1]))
    if scale == 0.0:
        return lin
    s = max(0.0, w[d - 1] + 1e-9 * scale)
    first = lin + min(max(w[d - 1], 0.0) * r2 / 2.0, _abs_form(H, r))
    xq = np.empty(d)
    unconstrained = 0.0
    for a in range(d):
        gq = 0.0
        for j in range(d):
            gq += Q[j, a] * G[j]
        xq[a] = gq / (s - w[a])
        unconstrained += 0.5 * gq * xq[a]
    dh = np.empty(d)
    for j in range(d):
        dh[j] = min(max(np.sum(Q[j] * xq), -r[j]), r[j])
    clipped = 0.0
    for j in range(d):
        hd = np.sum(H[j] * dh) - s * dh[j]
        clipped += -0.5 * dh[j] * hd + abs(G[j] + hd) * r[j]
    return min(first, min(unconstrained, clipped) + 0.5 * s * r2)


@njit(cache=True)
def _abs_form(H, r):
    """sum_jl |H_jl| r_j r_l / 2: the largest |delta^T H delta| / 2 on the box."""
    total = 0.0
    for j in range(r.size):
        for l in range(r.size):
            total += abs(H[j, l]) * r[j] * r[l]
    return 0.5 * total


@njit(cache=True)
def lambda_model(A, lam, Ut, Wyy, cs, sn, Om, n1, wz, rem2, B, eta, r):
    """lambda <= l1 + n1.delta + delta^T L2 delta / 2 + Rl on the box, the 2 x 2 reduction expanded to second
    order (module docstring); Rl = inf where the reduction has no gap: (L2, Rl)."""
    n, d = Ut.shape
    t = d - 1
    L2, rowsum = np.zeros((d, d)), np.zeros(n)
    R3n = 0.0
    for i in range(n):
        for k in range(n):
            rowsum[i] += Wyy[i, k] * cs[i, k]
            R3n += abs(Wyy[i, k]) * Om[i, k] ** 3 / 6.0
    for j in range(d):  # the Hessian of n11: -2 (Laplacian of Wyy o cos) over phi_2..phi_n
        for l in range(d):
            L2[j, l] = 2.0 * Wyy[j + 1, l + 1] * cs[j + 1, l + 1]
        L2[j, j] -= 2.0 * rowsum[j + 1]
    if d == 1:
        return L2, R3n
    n11_min = lam[t] - R3n - _abs_form(L2, r)  # the least n11 = v1^T N v1 on the box
    for j in range(d):
        n11_min -= abs(n1[j]) * r[j]
    gap = max(lam[t] - eta, n11_min) - min(lam[t - 1] + eta, np.linalg.eigvalsh(B[:t, :t].copy())[t - 1])
    if gap <= 0.0:
        return L2, np.inf
    E1 = np.empty((t, d))  # d e_m / d phi_{j+1}, e = V2^T N v1
    rho_e, e1_max = 0.0, 0.0
    for m in range(t):
        rho_e += rem2[m, t] ** 2
    for j in range(d):
        zy = 0.0
        for k in range(n):
            zy += A[j + 1, k] * sn[j + 1, k] * Ut[k, t]
        column = 0.0
        for m in range(t):
            E1[m, j] = -(Ut[j + 1, m] * zy + Ut[j + 1, t] * wz[j, m])
            column += E1[m, j] ** 2
        e1_max += r[j] * math.sqrt(column)
    rho_e = math.sqrt(rho_e)
    for j in range(d):
        for l in range(d):
            L2[j, l] += 2.0 * np.sum(E1[:, j] * E1[:, l]) / gap
    return L2, R3n + (2.0 * e1_max * rho_e + rho_e * rho_e) / gap


@njit(cache=True)
def mu_model(b, phi, th, mu, amin, rho, r):
    """mu <= mu + a1.delta + delta^T M2 delta / 2 + Rm on the box, from mu <= a + b^2 / (2 a) expanded to second
    order; Rm = inf where a may vanish: (a1, M2, Rm)."""
    d = r.size
    a1, b1, M2 = np.empty(d), np.empty(d), np.zeros((d, d))
    R3m, first, second, b_first, b_second = 0.0, 0.0, 0.0, 0.0, 0.0
    for k in range(d + 1):
        R3m += b[k] * rho[k] ** 3 / 6.0
    for j in range(d):
        c, s = math.cos(phi[j + 1] - th), math.sin(phi[j + 1] - th)
        a1[j], b1[j] = -b[j + 1] * s, b[j + 1] * c
        M2[j, j] = -b[j + 1] * c
        first += abs(a1[j]) * r[j]
        second += 0.5 * abs(M2[j, j]) * r[j] ** 2
        b_first += abs(b1[j]) * r[j]
        b_second += 0.5 * abs(b[j + 1] * s) * r[j] ** 2
    a_min = max(amin, mu - first - second - R3m)
    if a_min <= 0.0:
        return a1, M2, np.inf
    for j in range(d):
        for l in range(d):
            M2[j, l] += b1[j] * b1[l] / a_min
    b_second += R3m
    return a1, M2, R3m + (2.0 * b_first * b_second + b_second ** 2) / (2.0 * a_min)


@njit(cache=True)
def product_bound(E_r, mu, l1, n1, a1, M2, Rm, L2, Rl, r):
    """The product of the two models: (E_r + mu model)(lambda model) <= A0 L0 + a quadratic + products of changes."""
    d = r.size
    A0, L0 = E_r + mu + Rm, l1 + Rl
    G, H = np.empty(d), np.empty((d, d))
    m1, k1 = 0.0, 0.0
    for j in range(d):
        G[j] = A0 * n1[j] + L0 * a1[j]
        m1 += abs(a1[j]) * r[j]
        k1 += abs(n1[j]) * r[j]
        for l in range(d):
            H[j, l] = A0 * L2[j, l] + L0 * M2[j, l] + a1[j] * n1[l] + n1[j] * a1[l]
    m2, k2 = _abs_form(M2, r), _abs_form(L2, r)
    return max(A0 * L0 + _quad_box_max(G, H, r) + m1 * k2 + m2 * k1 + m2 * k2, 0.0)
