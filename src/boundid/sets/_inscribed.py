"""The maximum-volume ellipsoid inscribed in a polytope, by a primal-dual interior-point method.

For the polytope {z : a_i^T z <= b_i, i = 1..m} (rows of A (m, n)) and the ellipsoid
{x + E u : |u| <= 1}, E symmetric positive definite, the largest ellipsoid inside
([BoydVandenberghe2004] §8.4.2) solves

    max ln det E  s.t.  |E a_i| + a_i^T x <= b_i   (i = 1..m).

With multipliers lambda_i >= 0, stationarity of the Lagrangian in x gives A^T lambda = 0 and in E
gives E^-1 = sum_i lambda_i (E a_i a_i^T + a_i a_i^T E) / (2 |E a_i|), which holds exactly when
E^2 = (A^T Y A)^-1 with Y = diag(y) and lambda_i = y_i h_i, h_i = |E a_i| = sqrt(Q_ii),
Q = A E^2 A^T (m, m) ([ZhangGao2003]). So E is a function of y, and with the slack z of the sides
the optimum solves, for mu -> 0,

    (1)  R1 = -A^T (y o h)      = 0
    (2)  R2 = b - A x - h - z   = 0
    (3)  R3 = mu - y o z        = 0,     y, z > 0

(o: the entrywise product). Since dE^2 = -E^2 A^T dY A E^2, dQ = -Q dY Q and
dh = -((Q o Q) dy) / (2 h). Newton's step on (1)-(3) (dR = -R),

    A^T (h o dy + y o dh) = R1,   A dx + dh + dz = R2,   z o dy + y o dz = R3,

eliminates dz = R3 / y - z o dy / y from the third; the second, times -2 h, becomes
K dy = 2 h o (A dx - R23) with K = Q o Q + diag(2 h o z / y) (m, m, symmetric positive definite)
and R23 = R2 - R3 / y; and since (Q o Q) dy = K dy - (2 h o z / y) o dy, the first becomes
A^T ((h + z) o dy - y o (A dx - R23)) = R1, that is (M A) dx = R1 + M R23 with the n x m matrix

    M^T = 2 h o (K^-1 ((h + z) o A)) - y o A     (row scalings of the m x n matrices),

after which dy = K^-1 (2 h o (A dx - R23)). K is [ZhangGao2003]'s Newton matrix
Y (Q o Q) Y + diag(2 y o h o z) scaled by Y^-1 on both sides: an inactive side (y_i -> 0)
then only grows its diagonal entry instead of shrinking its row and column. A step costs
O(m^2 n + m^3): Q, the Cholesky factor of K and its solve with n right-hand sides (no m x m
inverse). The step is a fraction
tau = max(0.75, 1 - |R|) of the largest alpha <= 1 keeping b - A x, y, z positive; the centring
target is mu = max(min(0.5, g) g, MU_MIN), g = mean(y o z).

The start is [ZhangGao2003]'s: x0 strictly interior (by default the Chebyshev centre, a small LP,
[BoydVandenberghe2004] §8.5), each row scaled by 1 / (b_i - a_i^T x0) so that b = 1 at x = 0 (E does
not change: the polytope is the same), y = 1; then y is scaled so the first ellipsoid touches the
nearest side. It stops when (1) and (2) hold to TOL (relative to 1 + |b|) and the Lagrangian's
duality gap sum lambda_i z_i = sum y_i h_i z_i is below TOL n: with (1) exact the Lagrangian
ln det E + lambda^T (b - A x - h), maximised over x and E at these lambda, exceeds ln det E by
that gap plus lambda^T R2, so ln det E is optimal to about TOL n.

:func:`boundid.sets.sdp.inner_ellipsoid` calls it on each working set and verifies the answer as
it did Clarabel's: every side of the polytope is checked and the ellipsoid shrunk about x until it
lies inside exactly (a shrink of more than 1e-4 raises SolverError); should this method fail it
solves the working set with Clarabel. tests/test_inscribed.py checks the optimum against Clarabel's
on the same polytopes (a second algorithm), against the closed forms of the box, the simplex and
the regular polygon, and the failures on polytopes without an interior; tests/test_sdp.py checks
inner_ellipsoid with it.
"""

from __future__ import annotations

import numpy as np
from scipy.linalg import LinAlgError, cho_factor, cho_solve, solve_triangular
from scipy.optimize import linprog

from boundid.errors import SolverError
from boundid.sets._working_set import one_blas_thread

#: stop when the residuals (1), (2) are below this (relative to 1 + |b|) and the duality gap below this times n
TOL = 1e-9
#: the smallest centring target mu
MU_MIN = 1e-14
#: the least fraction of the step to the boundary taken
_TAU0 = 0.75
#: Newton steps allowed (the study's working sets take 20-30)
MAX_STEPS = 100


def chebyshev_centre(A: np.ndarray, b: np.ndarray) -> np.ndarray:
    """The centre (n,) of the largest ball in {z : A z <= b} (A (m, n), b (m,)): max r s.t.
    a_i^T x + r |a_i| <= b_i, by HiGHS. Raises SolverError if the LP fails (an empty polytope, or
    balls of any radius inside) or the polytope has no interior (r <= 0)."""
    m, n = A.shape
    nrm = np.linalg.norm(A, axis=1)
    res = linprog(np.r_[np.zeros(n), -1.0], A_ub=np.hstack([A, nrm[:, None]]), b_ub=b,
                  bounds=[(None, None)] * (n + 1), method="highs")
    if res.status != 0:
        raise SolverError(f"inner_ellipsoid: the Chebyshev centre's LP failed ({res.message}); the polytope "
                          "must be bounded with a non-empty interior.")
    if not res.x[n] > 0:
        raise SolverError(f"inner_ellipsoid: the polytope has no interior (Chebyshev radius {res.x[n]:.3g}).")
    return res.x[:n]


def _factor(K: np.ndarray):
    """The Cholesky factor of K (cho_factor form). K is positive definite in exact arithmetic, but
    its Q o Q part is singular once more than n (n + 1) / 2 sides bind and the rest, 2 h z / y,
    vanishes on them: then a shift of 1e-14 of K's largest diagonal entry, growing by 100 until the
    factorisation succeeds; SolverError past 1e-4 of it."""
    shift, top = 0.0, float(np.max(np.diag(K)))
    if not np.isfinite(top):
        raise SolverError("inner_ellipsoid: the interior-point method's Newton matrix is not finite.")
    while True:
        try:
            return cho_factor(K + shift * np.eye(K.shape[0]) if shift else K, check_finite=False)
        except LinAlgError:
            shift = 1e-14 * top if shift == 0.0 else 100.0 * shift
            if shift > 1e-4 * top:
                raise SolverError("inner_ellipsoid: the interior-point method's Newton matrix is singular.") from None


def _shape(A: np.ndarray, y: np.ndarray):
    """(L, Q, h) at the multipliers y (m,): L (n, n) lower triangular with L L^T = A^T Y A = E^-2,
    Q = A E^2 A^T (m, m), h = sqrt(diag Q) (m,). SolverError if A^T Y A is not positive definite
    (the sides do not bound the polytope)."""
    try:
        L = np.linalg.cholesky((A.T * y) @ A)
    except LinAlgError:
        raise SolverError("inner_ellipsoid: the sides do not bound the polytope (A^T Y A is singular).") from None
    R = solve_triangular(L, A.T, lower=True, check_finite=False)          # (n, m): Q = R^T R
    Q = R.T @ R
    return L, Q, np.sqrt(np.diag(Q))


@one_blas_thread
def max_volume_inscribed(A: np.ndarray, b: np.ndarray, x0: np.ndarray | None = None):
    """The maximum-volume ellipsoid {z : (z - x)^T E2^-1 (z - x) <= 1} inside {z : A z <= b}
    (A (m, n), b (m,)), as (x (n,), E2 (n, n), Newton steps taken). ``x0`` (n,): a strictly
    interior point to start from (default: the Chebyshev centre). Raises SolverError if x0 is not
    strictly interior, the polytope is unbounded or has no interior, a Newton matrix is singular
    or the steps run out.

    Runs with one BLAS thread: on the shared 2-core machine (two other processes busy) OpenBLAS's
    threads made the six-joint UR5's working set (1,393 sides, n = 52) take 15-48 s instead of
    1.7-2.3 s with one thread (the m-square Cholesky factorisations dominate)."""
    A, b = np.asarray(A, dtype=float), np.asarray(b, dtype=float)
    m, n = A.shape
    x0 = chebyshev_centre(A, b) if x0 is None else np.asarray(x0, dtype=float)
    slack0 = b - A @ x0
    if not np.all(slack0 > 0):
        raise SolverError(f"inner_ellipsoid: the starting point is not strictly inside the polytope (least slack "
                          f"{float(np.min(slack0)):.3g}).")
    A = A / slack0[:, None]                           # b = 1 at x = 0
    scale = 1.0 + np.sqrt(m)                          # 1 + |b|
    x, y = np.zeros(n), np.ones(m)
    _, _, h = _shape(A, y)
    t = float(np.min(1.0 / h))                        # the first ellipsoid, scaled by t, touches the nearest side
    y = y / t**2
    z = np.maximum(0.1, 1.0 - t * h)
    alpha = 0.0
    for step in range(MAX_STEPS):
        s = 1.0 - A @ x
        L, Q, h = _shape(A, y)
        R1 = -(A.T @ (y * h))
        R2 = s - h - z
        yz = y * z
        g = float(np.mean(yz))
        feas = max(float(np.max(np.abs(R1))), float(np.max(np.abs(R2))))
        if not np.isfinite(feas):
            raise SolverError("inner_ellipsoid: the interior-point iterates are not finite.")
        if feas < TOL * scale and float(yz @ h) < TOL * n:
            Linv = solve_triangular(L, np.eye(n), lower=True)
            return x0 + x, Linv.T @ Linv, step
        mu = max(min(0.5, g) * g, MU_MIN)
        R3 = mu - yz
        K = Q * Q
        K[np.diag_indices(m)] += 2.0 * h * z / y
        cK = _factor(K)
        R23 = R2 - R3 / y
        MT = 2.0 * h[:, None] * cho_solve(cK, (h + z)[:, None] * A, check_finite=False) - y[:, None] * A
        try:
            dx = np.linalg.solve(MT.T @ A, R1 + MT.T @ R23)
        except LinAlgError:
            raise SolverError("inner_ellipsoid: the interior-point method's step in x is singular.") from None
        Adx = A @ dx
        dy = cho_solve(cK, 2.0 * h * (Adx - R23), check_finite=False)
        dz = R3 / y - z * dy / y
        # a fraction tau of the step to the boundary of s, y, z > 0 (1 / bound), at most 1
        bound = max(1.0, float(np.max(Adx / s)), float(np.max(-dy / y)), float(np.max(-dz / z)))
        tau = max(_TAU0, 1.0 - max(feas, float(np.max(np.abs(R3)))))
        alpha = tau / bound
        x, y, z = x + alpha * dx, y + alpha * dy, z + alpha * dz
    raise SolverError(f"inner_ellipsoid: the interior-point method did not converge in {MAX_STEPS} Newton steps "
                      f"(last step {alpha:.3g}).")
