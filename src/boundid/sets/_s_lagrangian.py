"""The S-procedure outer ellipsoid of strips, solved in its multipliers alone.

For strips |g_k^T z - mid_k| <= half_k (k = 1..m, the rows of G (m, n), unit normals, among them
a bounding box, so that A below is positive definite for tau > 0) and multipliers tau >= 0, the
combined quadric

    q(z) = z^T A z + 2 b^T z + c,   A = sum tau_k g_k g_k^T,  b = -sum tau_k mid_k g_k,
                                     c = sum tau_k (mid_k^2 - half_k^2)

is <= 0 on every strip, so the set lies in {q <= 0} = {(z - z_c)^T A (z - z_c) <= r^2}, with
z_c = -A^-1 b and r^2 = b^T A^-1 b - c. The S-procedure's minimum-volume such ellipsoid
([Boyd1994] §3.7.2) solves

    (P)  max ln det A(tau)  s.t.  s(tau) = 1 + c - b^T A^-1 b >= 0,  tau >= 0

(the multipliers scale freely; s is concave: affine minus a matrix-fractional function).
:func:`boundid.sets.sdp._s_procedure` gives it to Clarabel as an (n+1)-square LMI plus ln det,
which cvxpy writes with a 2n-square semidefinite cone: its Nesterov-Todd block is dense in
n^2 x n^2, so each interior-point step costs O(n^6) (n = 52: 60 s a solve on the six-joint UR5).

The multiplier of s >= 0 is known: ln det A is log-homogeneous (sum_k tau_k d/dtau_k ln det A = n)
and s - 1 is homogeneous of degree 1 (sum_k tau_k ds/dtau_k = s - 1), so the stationarity of the
Lagrangian ln det A + lam s, summed against tau, gives n + lam (s - 1) = 0, and complementary
slackness (s = 0) gives lam = n. So (P)'s optimum maximises the concave Lagrangian at lam = n over tau >= 0 alone:

    (L)  max f(tau) = ln det A(tau) + n s(tau)  s.t.  tau >= 0,

and conversely every maximiser of (L) is optimal for (P): along the ray alpha tau the
derivative of f at alpha = 1 is n s, so a maximiser has s = 0, is feasible, and f bounds
ln det A at every feasible point (Lagrangian duality). (L) has only bound constraints, which a
primal-dual interior-point method ([NocedalWright2006] ch. 14, 19) solves in a few dozen Newton
steps. With u_k = mid_k + g_k^T A^-1 b (= mid_k - g_k^T z_c) and K = G A^-1 G^T (m, m):

    df / dtau_k = K_kk + n (u_k^2 - half_k^2)
    d2f / dtau_k dtau_l = -K_kl^2 - 2 n u_k u_l K_kl

(the first term from ln det A, the second from the matrix-fractional b^T A^-1 b), so a step costs
O(m^2 n + m^3) (K, then the Cholesky factor of the m-square Newton matrix).

The dual's pseudo-moments are mean z_c and covariance A^-1 / n; a strip not among the m can enlarge
ln det A only if its reduced cost df/dtau_k / n = K_kk / n + (g_k^T z_c - mid_k)^2 - half_k^2 is
positive (:func:`boundid.sets.sdp._reduced_costs`). The caller verifies the answer as it did
Clarabel's: the ellipsoid is built from the multipliers (the certificate holds by construction)
and checked against the known points of the set. tests/test_s_lagrangian.py checks the optimum
against Clarabel's on the same strips (a second algorithm) and the derivatives against finite
differences.
"""

from __future__ import annotations

import numpy as np
from scipy.linalg import LinAlgError, cho_factor, cho_solve, solve_triangular

from boundid.errors import SolverError

#: the centring parameter: each step aims at sigma times the current complementarity
SIGMA = 0.1
#: fraction of the step to the boundary of tau, nu >= 0 taken
_TO_BOUNDARY = 0.99
#: stop when the mean complementarity nu_k tau_k and the relative dual residual are below this
TOL = 1e-9
#: Newton steps allowed (the studies' problems take 25-45)
MAX_STEPS = 200


def lagrangian_parts(G: np.ndarray, mid: np.ndarray, half: np.ndarray, tau: np.ndarray):
    """(K, u, s) at tau (module docstring); SolverError if A is not positive definite."""
    A = (G.T * tau) @ G
    try:
        L = np.linalg.cholesky(A)
    except LinAlgError:
        raise SolverError("outer_ellipsoid: the strips' quadric is not positive definite (the strips do not "
                          "bound the set).") from None
    b = -(G.T @ (tau * mid))
    x = cho_solve((L, True), b)
    R = solve_triangular(L, G.T, lower=True)          # (n, m): K = R^T R
    s = 1.0 + float(tau @ (mid**2 - half**2)) - float(b @ x)
    return R.T @ R, mid + G @ x, s


def _newton_solve(H: np.ndarray, rhs: np.ndarray) -> np.ndarray:
    """H^-1 rhs by Cholesky. H is positive definite in exact arithmetic, but with more strips than
    n (n + 1) / 2 its K o K part is singular and the rest, nu / tau, vanishes on the strips that
    bind: then a shift of 1e-14 of H's largest diagonal entry, growing by 100 until the
    factorisation succeeds (a Levenberg step, still an ascent direction)."""
    shift, top = 0.0, float(np.max(np.diag(H)))
    while True:
        try:
            return cho_solve(cho_factor(H + shift * np.eye(H.shape[0]) if shift else H), rhs)
        except LinAlgError:
            shift = 1e-14 * top if shift == 0.0 else 100.0 * shift
            if shift > 1e-4 * top:
                raise SolverError("outer_ellipsoid: the Newton matrix of the S-procedure is singular.") from None


def _derivatives(K: np.ndarray, u: np.ndarray, half: np.ndarray, n: int) -> tuple[np.ndarray, np.ndarray]:
    """grad f (m,) and the negated Hessian -d2f (m, m) (positive semidefinite) from K and u."""
    return np.diag(K) + n * (u**2 - half**2), K**2 + (2.0 * n) * (np.outer(u, u) * K)


def lagrangian_derivatives(G: np.ndarray, mid: np.ndarray, half: np.ndarray, tau: np.ndarray):
    """(grad (m,), -Hessian (m, m), s) of (L) at tau, as the solver computes them."""
    K, u, s = lagrangian_parts(G, mid, half, tau)
    return (*_derivatives(K, u, half, G.shape[1]), s)


def s_procedure_multipliers(G: np.ndarray, mid: np.ndarray, half: np.ndarray) -> tuple[np.ndarray, int]:
    """The S-procedure multipliers tau (m,) of the strips (G (m, n), mid (m,), half (m,)) maximising
    (L) of the module docstring, and the Newton steps taken; at the answer r^2 = 1 - s = 1 to
    about TOL. Raises SolverError if the strips do not bound a set with an interior or the
    steps run out.

    Each iterate is first moved to the best point of its ray: f(alpha tau) = const + n ln alpha
    - n alpha r^2 is largest at alpha = 1 / r^2, where s = 0 (nu scales by r^2, keeping every
    nu_k tau_k). This closed-form step along the one direction f is known in keeps the Newton
    steps few whatever the start (random strips, n = 52 and 500 strips: 35 steps instead of 102).
    """
    m, n = G.shape
    tau, nu = np.ones(m), np.ones(m)                  # nu: the multipliers of tau >= 0
    for step in range(MAX_STEPS):
        K, u, s = lagrangian_parts(G, mid, half, tau)
        r2 = 1.0 - s
        if not r2 > 0:
            raise SolverError("outer_ellipsoid: the strips do not bound a set with an interior (r^2 <= 0: the "
                              "S-procedure has no ellipsoid).")
        # the best point of the ray: tau / r2, where A^-1 and so K scale by r2, u stays and s = 0
        tau, nu, K = tau / r2, nu * r2, K * r2
        grad, H = _derivatives(K, u, half, n)
        mu = float(nu @ tau) / m
        if mu < TOL and float(np.max(np.abs(grad + nu))) < TOL * (1.0 + float(np.max(np.abs(grad)))):
            return tau, step
        # Newton on grad f + nu = 0, nu_k tau_k = SIGMA mu, eliminating the step in nu
        H[np.diag_indices(m)] += nu / tau
        target = SIGMA * mu
        d_tau = _newton_solve(H, grad + target / tau)
        d_nu = (target - nu * tau - nu * d_tau) / tau
        alpha = 1.0
        for v, d in ((tau, d_tau), (nu, d_nu)):
            neg = d < 0
            if neg.any():
                alpha = min(alpha, _TO_BOUNDARY * float(np.min(-v[neg] / d[neg])))
        tau, nu = tau + alpha * d_tau, nu + alpha * d_nu
    raise SolverError(f"outer_ellipsoid: the S-procedure's interior-point method did not converge in {MAX_STEPS} "
                      "Newton steps.")
