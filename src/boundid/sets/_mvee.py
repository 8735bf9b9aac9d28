"""Minimum-volume ellipsoid around points, with a certified lower bound (Todd 2016,
"Minimum-Volume Ellipsoids: Theory and Algorithms", ch. 3; [refs §SDP]).

The Wolfe-Atwood (Khachiyan) algorithm with Todd-Yildirim away steps on the lifted points
q_i = (x_i, 1): weights u on the points, Lambda(u) = sum u_i q_i q_i^T, omega_i = q_i^T
Lambda^-1 q_i; each step moves weight toward the point of largest omega or away from the
supported point of smallest one, with Sherman-Morrison updates of Lambda^-1 and omega
(O(m n) per step; compiled with numba, since it takes 1e4-1e5 steps at p = 14).

Duality gives the bound. For ANY probability weights u, with weighted mean c_u and covariance
S_u, every ellipsoid {(x - c)^T A (x - c) <= 1} containing the points has tr(A S_u) <= 1, so by
AM-GM det A <= (n^n det S_u)^-1 and ln vol >= ln vol(unit ball) + (n ln n + ln det S_u) / 2.
"""

from __future__ import annotations

import numpy as np
from numba import njit

from boundid.errors import InputError
from boundid.sets.ellipsoid import log_unit_ball_volume


@njit(cache=True)
def _wolfe_atwood(Q, u, tol, max_iter):
    """Weights u (in place) until max omega <= (n + 1) with n ln((max omega - 1) / n) / 2 <= tol n;
    returns the number of steps."""
    m, d = Q.shape
    n = d - 1
    L = np.zeros((d, d))
    for i in range(m):
        L += u[i] * np.outer(Q[i], Q[i])
    Linv = np.ascontiguousarray(np.linalg.inv(L))  # updated in place below: one array layout
    omega = np.empty(m)
    for i in range(m):
        omega[i] = Q[i] @ Linv @ Q[i]
    for it in range(1, max_iter + 1):
        j = np.argmax(omega)
        if omega[j] - 1.0 <= n * np.exp(2.0 * tol):
            return it
        k, wk = -1, np.inf
        for i in range(m):
            if u[i] > 0 and omega[i] < wk:
                k, wk = i, omega[i]
        if omega[j] - d >= d - omega[k]:
            i, lam = j, (omega[j] - d) / (d * (omega[j] - 1.0))
        else:
            i = k
            lam = max(-u[k] / (1.0 - u[k]), (omega[k] - d) / (d * (omega[k] - 1.0)))
        Lq = Linv @ Q[i]
        v = Q @ Lq
        den = (1.0 - lam) + lam * omega[i]
        Linv[:] = (Linv - (lam / den) * np.outer(Lq, Lq)) / (1.0 - lam)
        omega = (omega - (lam / den) * v * v) / (1.0 - lam)
        u *= 1.0 - lam
        u[i] += lam
        for t in range(m):
            if u[t] < 1e-14:
                u[t] = 0.0
        if it % 200 == 0:                       # refresh against rounding drift
            u /= u.sum()
            L[:] = 0.0
            for t in range(m):
                if u[t] > 0:
                    L += u[t] * np.outer(Q[t], Q[t])
            Linv[:] = np.linalg.inv(L)
            for t in range(m):
                omega[t] = Q[t] @ Linv @ Q[t]
    return max_iter


def mvee_dual(X: np.ndarray, tol: float = 1e-7, max_iter: int = 1_000_000, u0: np.ndarray | None = None):
    """Minimum-volume ellipsoid around the rows of X (m, n), bracketed.

    Returns (lower, upper, center, shape, steps, u): ``lower`` the dual bound of the module
    docstring (valid whatever the convergence), ``upper`` ln vol of {(x - c_u)^T S_u^-1 (x - c_u)
    <= R^2} with R^2 the largest such distance of a point (it contains every point),
    upper - lower <= tol n at convergence; ``u0`` a warm start (default uniform weights).
    """
    X = np.ascontiguousarray(X, dtype=float)
    m, n = X.shape
    if m < n + 1 or np.linalg.matrix_rank(X - X.mean(axis=0)) < n:
        raise InputError(f"points must span R^{n} affinely (at least {n + 1} points, not all on a hyperplane).")
    Q = np.hstack([X, np.ones((m, 1))])
    u = np.full(m, 1.0 / m) if u0 is None else np.asarray(u0, dtype=float) / np.sum(u0)
    steps = _wolfe_atwood(Q, u, tol, max_iter)
    u /= u.sum()
    c = u @ X
    Xc = X - c
    S = (Xc.T * u) @ Xc
    sign, logdet = np.linalg.slogdet(S)
    if sign <= 0:
        raise InputError("the weighted covariance of the points is singular; they must span R^n affinely.")
    R2 = float(np.max(np.einsum("ij,jk,ik->i", Xc, np.linalg.inv(S), Xc)))
    lv = log_unit_ball_volume(n)
    return lv + 0.5 * (n * np.log(n) + logdet), lv + 0.5 * (n * np.log(R2) + logdet), c, R2 * S, steps, u
