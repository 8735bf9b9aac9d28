"""Dense vertex simplex for the working-set LPs: few columns, many dense rows.

The LP  max d^T x  s.t.  lo_i <= a_i^T x <= up_i  (A: (m, n), m >> n; the column bounds are
rows of A too, +-inf allowed) is walked from vertex to vertex. A vertex is given by n active
rows, the *basis*: their outward normals N (n, n) = side_j a_{act_j} (side +1 at up, -1 at lo),
nonsingular, and x = N^-1 b. Its multipliers lam = N^-T d (d = N^T lam) decide everything
(LP duality): lam >= 0 proves x optimal among all points satisfying the basis rows, so an x
that also satisfies every other row is the LP's optimum.

* primal simplex (x feasible): of the rows with lam_j < 0, the one whose edge e = -N^-1 e_j
  (d^T e = -lam_j > 0) gains most per unit of its length, -lam_j / |e|, leaves along it up to the
  first row the edge meets (steepest edge, exact and nearly free here: N^-1 is at hand, its column
  norms cost O(n^2) against the step's O(m n); 36 % fewer steps than the most negative lam_j on the
  Panda's outer ellipsoid, 40 % on the six-joint UR5 study's);
* dual simplex (lam >= 0, x violates rows): the most violated row i enters and replaces the
  row j minimising lam_j / u_j over u = N^-T n_i > 0, which keeps lam >= 0 ([Chvatal1983]
  ch. 10, in the vertex form of the bounded-variable simplex; [refs §LP]).

Both ratio tests are Harris's two passes (the largest pivot among the nearly tied rows); a
primal edge that reaches the other side of its own leaving row first just moves the basis row to
that side (a bound flip, no pivot). After 2 n primal steps that gain nothing, the leaving row is
chosen by lowest index (Bland's leaving rule only: no anti-cycling guarantee; ``max_steps`` and a
cap on primal/dual alternations bound every run). Each step costs one pass over the rows (A e,
or A x), O(m n), and a rank-one update of N^-1, O(n^2): about 20 us at m = 1,700, n = 22, where
HiGHS's sparse simplex pays 0.24 ms a step on the same dense rows (measured on the UR5 study;
same steps, same optima to 1e-11). N^-1 is refactored every ``_REFACTOR`` steps, and the answer
is certified on a fresh N^-1, x and lam each refined by one residual step: every row, basis
rows included, within ``ftol`` of its bounds, lam >= -``dtol`` and |d - N^T lam| <= ``dtol``
(HiGHS's own tolerances).

With a ``target`` the primal simplex stops at the first vertex at or beyond it (status REACHED): for
callers that need only a point of the polytope past a level, which the first steps, gaining most,
usually reach. Anything else returns a status, and the caller solves the same LP with HiGHS: a start that is
neither primal nor dual feasible (or whose basis rows have an infinite side), an unbounded edge,
an infeasible dual step, a singular basis, or no answer within ``max_steps``. This solver never
reports an LP infeasible or unbounded.
"""

from __future__ import annotations

import numpy as np
from numba import njit

#: status codes of :func:`vertex_simplex`
OPTIMAL, NO_START, UNBOUNDED, INFEASIBLE, STEP_LIMIT, SINGULAR, REACHED = 0, 1, 2, 3, 4, 5, 6
#: steps between two refactorisations of N^-1
_REFACTOR = 64
#: smallest |pivot| a ratio test accepts (the callers' rows have norms about 1: unit strips, and
#: [h, 1] for the Chebyshev centre's)
_PIVOT = 1e-9


@njit(cache=True)
def _basis(A, lo, up, act, side):
    """(N, b): the basis rows' outward normals and right-hand sides, N x = b at the vertex."""
    n = act.size
    N = np.empty((n, n))
    b = np.empty(n)
    for j in range(n):
        N[j] = side[j] * A[act[j]]
        b[j] = up[act[j]] if side[j] > 0 else -lo[act[j]]
    return N, b


@njit(cache=True)
def _inverse(N):
    """(N^-1, ok): Gauss-Jordan with partial pivoting; ok False when a pivot falls below
    1e-12 of the largest entry (numerically singular)."""
    n = N.shape[0]
    M = N.copy()
    Inv = np.eye(n)
    big = np.max(np.abs(N))
    if not big > 0.0:
        return Inv, False
    for c in range(n):
        r = c + np.argmax(np.abs(M[c:, c]))
        if abs(M[r, c]) <= 1e-12 * big:
            return Inv, False
        if r != c:
            for k in range(n):
                M[c, k], M[r, k] = M[r, k], M[c, k]
                Inv[c, k], Inv[r, k] = Inv[r, k], Inv[c, k]
        piv = 1.0 / M[c, c]
        for k in range(n):
            M[c, k] *= piv
            Inv[c, k] *= piv
        for r2 in range(n):
            if r2 != c and M[r2, c] != 0.0:
                f = M[r2, c]
                for k in range(n):
                    M[r2, k] -= f * M[c, k]
                    Inv[r2, k] -= f * Inv[c, k]
    return Inv, True


@njit(cache=True)
def _worst_row(Ax, lo, up, isact):
    """(row, side, violation) of the most violated non-basis row (violation <= 0: none; a NaN
    activity counts as infinitely violated)."""
    worst, wi, ws = 0.0, -1, 0.0
    for i in range(Ax.size):
        if isact[i]:
            continue
        if np.isnan(Ax[i]):
            return i, 1.0, np.inf
        v = Ax[i] - up[i]
        if v > worst:
            worst, wi, ws = v, i, 1.0
        v = lo[i] - Ax[i]
        if v > worst:
            worst, wi, ws = v, i, -1.0
    return wi, ws, worst


@njit(cache=True)
def _certified(A, lo, up, d, N, Ninv, b, ftol, dtol):
    """(x, lam, ok) at the basis (N, b) with a fresh N^-1: x = N^-1 b and lam = N^-T d each refined
    by one residual step (an explicit inverse leaves cond(N) eps on the basis rows); ok when every
    row, basis rows included, lies within ftol of its bounds, lam >= -dtol and |d - N^T lam| <= dtol."""
    x = Ninv @ b
    x += Ninv @ (b - N @ x)
    lam = Ninv.T @ d
    lam += Ninv.T @ (d - N.T @ lam)
    if np.min(lam) < -dtol or np.max(np.abs(d - N.T @ lam)) > dtol:
        return x, lam, False
    return x, lam, _within(A @ x, lo, up, ftol)


@njit(cache=True)
def _within(Ax, lo, up, ftol):
    """Whether every row's activity Ax lies within ftol of its bounds."""
    for i in range(Ax.size):
        if not (Ax[i] <= up[i] + ftol and Ax[i] >= lo[i] - ftol):
            return False
    return True


@njit(cache=True)
def _replace(Ninv, N, b, j, row, rhs):
    """Row j of the basis becomes ``row`` (right-hand side ``rhs``): Sherman-Morrison on N^-1
    for N' = N + e_j (row - N_j)^T."""
    u = row - N[j]
    v = u @ Ninv
    c = Ninv[:, j] / (1.0 + v[j])
    n = Ninv.shape[0]
    for r in range(n):                          # in place: no n x n temporary
        cr = c[r]
        for k in range(n):
            Ninv[r, k] -= cr * v[k]
    N[j] = row
    b[j] = rhs


@njit(cache=True, nogil=True)   # releases the GIL: the LP threads (polytope.LP_THREADS) run at once
def vertex_simplex(A, lo, up, d, act, side, ftol, dtol, max_steps, target=np.inf):
    """max d^T x over lo <= A x <= up from the basis (act, side), both (n,), updated in place.

    A : (m, n) rows (column bounds included as unit rows); lo, up : (m,) (+-inf allowed).
    ftol : largest violation of a row accepted at the answer; dtol : largest negative
    multiplier accepted (both absolute). Returns (status, x (n,), lam (n,), steps): status
    OPTIMAL with x the optimum and lam its certificate (d = N^T lam, lam >= -dtol), else one
    of NO_START, UNBOUNDED, INFEASIBLE, STEP_LIMIT, SINGULAR (x, lam then meaningless).
    ``target``: the primal simplex stops at the first vertex with d^T x >= target (status REACHED;
    x that vertex, refined from its basis and checked within ftol of every row; (act, side) its
    basis): when only a point of the polytope beyond a level is wanted, the first steps, which gain
    most, are enough (UR5, six joints: 20 of a support's median 175 steps already gain 28 % of its
    objective).
    """
    m, n = A.shape
    isact = np.zeros(m, dtype=np.bool_)
    for j in range(n):
        isact[act[j]] = True
    cand = np.empty(m, dtype=np.int64)          # the ratio test's candidate rows
    steps, stalled, switches, was_primal = 0, 0, 0, True
    while True:
        N, b = _basis(A, lo, up, act, side)
        if not np.all(np.isfinite(b)):          # a basis row on an infinite side: no vertex
            return NO_START, b, b, steps
        Ninv, ok = _inverse(N)
        if not ok:
            return SINGULAR, b, b, steps
        x, lam, ok = _certified(A, lo, up, d, N, Ninv, b, ftol, dtol)
        if ok:
            return OPTIMAL, x, lam, steps
        Ax = A @ x
        primal = _worst_row(Ax, lo, up, isact)[2] <= ftol
        dual = np.min(lam) >= -dtol
        if not primal and not dual:
            return NO_START, x, lam, steps
        if primal and dual:                     # a basis row off its bound (crossed bounds, or cond(N) too large)
            return NO_START, x, lam, steps
        if steps > 0 and primal != was_primal:
            switches += 1                       # rounding can bounce a near-singular basis between
            if switches > 2 * n + 10:           # the two phases: give up, HiGHS decides
                return STEP_LIMIT, x, lam, steps
        was_primal = primal
        for _ in range(_REFACTOR):
            if steps >= max_steps:
                return STEP_LIMIT, x, lam, steps
            steps += 1
            if primal:
                if d @ x >= target:
                    # the vertex refined from its basis, as _certified does, and every row checked
                    xr = Ninv @ b
                    xr += Ninv @ (b - N @ xr)
                    if d @ xr >= target and _within(A @ xr, lo, up, ftol):
                        return REACHED, xr, lam, steps
                lam = d @ Ninv                      # N^-T d, as a product with the rows of N^-1
                j = -1
                if stalled > 2 * n:                 # Bland: the lowest row index leaves
                    for k in range(n):
                        if lam[k] < -dtol and (j < 0 or act[k] < act[j]):
                            j = k
                else:                               # steepest edge: most gain per unit length of the edge
                    best = 0.0
                    for k in range(n):
                        if lam[k] < -dtol:
                            nk = 0.0
                            for r in range(n):
                                nk += Ninv[r, k] * Ninv[r, k]
                            score = lam[k] / np.sqrt(nk)
                            if score < best:
                                j, best = k, score
                if j < 0:
                    break
                e = -Ninv[:, j]
                alpha = A @ e
                tmax = np.inf                       # Harris pass 1: the step with slack ftol
                nc = 0                              # rows whose exact ratio is within the running tmax:
                for i in range(m):                  # pass 2 needs no others
                    if isact[i]:
                        continue
                    a = alpha[i]
                    if a > _PIVOT:
                        t0 = (up[i] - Ax[i]) / a
                        t = t0 + ftol / a
                    elif a < -_PIVOT:
                        t0 = (lo[i] - Ax[i]) / a
                        t = t0 - ftol / a
                    else:
                        continue
                    if t0 <= tmax:
                        cand[nc] = i
                        nc += 1
                    if t < tmax:
                        tmax = t
                kl = act[j]
                width = up[kl] - lo[kl]             # the leaving row's own other side: a bound flip
                if width <= tmax and np.isfinite(width):
                    stalled = stalled + 1 if width * (-lam[j]) <= dtol else 0
                    x += width * e
                    Ax += width * alpha
                    side[j] = -side[j]
                    N[j] = -N[j]
                    b[j] = up[kl] if side[j] > 0 else -lo[kl]
                    for r in range(n):
                        Ninv[r, j] = -Ninv[r, j]
                    continue
                if tmax == np.inf:
                    return UNBOUNDED, x, lam, steps
                best, bi, bs, bt = 0.0, -1, 0.0, 0.0    # pass 2: the largest pivot within tmax
                for c in range(nc):
                    i = cand[c]
                    a = alpha[i]
                    if a > _PIVOT:
                        t, s = (up[i] - Ax[i]) / a, 1.0
                    elif a < -_PIVOT:
                        t, s = (lo[i] - Ax[i]) / a, -1.0
                    else:
                        continue
                    if t <= tmax and (abs(a) > best or (stalled > 2 * n and abs(a) == best and i < bi)):
                        best, bi, bs, bt = abs(a), i, s, t
                t = max(bt, 0.0)
                stalled = stalled + 1 if t * (-lam[j]) <= dtol else 0
                x += t * e
                Ax += t * alpha
                isact[act[j]] = False
                isact[bi] = True
                act[j], side[j] = bi, bs
                _replace(Ninv, N, b, j, bs * A[bi], up[bi] if bs > 0 else -lo[bi])
            else:
                i, s, v = _worst_row(Ax, lo, up, isact)
                if v <= ftol:
                    break
                row = s * A[i]
                u = row @ Ninv                      # row = N^T u
                tmax = np.inf
                for k in range(n):
                    if u[k] > _PIVOT:
                        tmax = min(tmax, (max(lam[k], 0.0) + dtol) / u[k])
                if tmax == np.inf:
                    return INFEASIBLE, x, lam, steps
                j, best = -1, 0.0
                for k in range(n):
                    if u[k] > _PIVOT and max(lam[k], 0.0) / u[k] <= tmax and u[k] > best:
                        j, best = k, u[k]
                isact[act[j]] = False
                isact[i] = True
                act[j], side[j] = i, s
                _replace(Ninv, N, b, j, row, up[i] if s > 0 else -lo[i])
                x = Ninv @ b
                Ax = A @ x
                lam = Ninv.T @ d
