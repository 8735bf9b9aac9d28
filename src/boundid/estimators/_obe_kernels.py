"""Compiled (numba) kernels of the recursive OBE estimators: weights and the two batch loops.

Notation ([refs §OBE]): ellipsoid E = {theta : (theta - c)^T M (theta - c) <= sigma}, n = dim,
row w, target y, bound e; innovation eps = y - w^T c, G = w^T M^-1 w, T = tr M^-1,
H = |M^-1 w|^2. The weight rules below take the strip *after clipping and normalising* to
gamma = 1 (the row divided by the clipped half-width), and return the convex-combination weight
lambda together with alpha = 1 - lambda (computed without cancellation), so that
M' = alpha M + lambda w w^T, sigma' = alpha sigma + lambda - lambda alpha eps^2 / (alpha + lambda G)
(computed as a sum of non-negative terms, :func:`sigma_update`).

Numerical watch. Both loops accumulate in state[S_BOUND] a first-order bound on how far rounding
may have moved the Mahalanobis^2 of any point of E: each update adds its own rounding (a few u
for the factorized form; :func:`downdate_error` for the standard form, whose M^-1 is updated by
subtraction), and older errors are carried with the factor alpha sigma / sigma': the pencil
sigma' - q'(theta) = alpha (sigma - q(theta)) + lambda (1 - residual^2) passes an error in q to
the next step multiplied by alpha, and d2 = q / sigma. A row where M^-1 proves indefinite, or
sigma' leaves (0, 1], makes the bound infinite. The estimator turns the bound into kind
"guaranteed" or "unverified" (:mod:`boundid.estimators.obe`).
"""

from __future__ import annotations

import math

import numpy as np
from numba import njit

# Clipped half-widths are floored at KAPPA times the larger of the ellipsoid's half-extent along
# w and the strip's half-width: a strip that only grazes E, or a feasible set with an empty
# interior (errors exactly at opposite bounds), would otherwise make M' singular and, step after
# step, shrink E to nothing. The floor only widens the clipped strip (a superset of E ∩ strip),
# so the guarantee is kept.
KAPPA = 1e-8
# Outward rounding guard: every bound is widened by ROUND_GUARD (|y| + e), far below any
# measurement accuracy, so that data consistent with the bounds only up to rounding (errors
# exactly at the bounds, a feasible set with an empty interior) neither become outliers nor fall
# a rounding error outside the ellipsoid.
ROUND_GUARD = 1e-12

CRITERIA = {"volume": 0, "trace": 1, "dasgupta-huang": 2}

# Unit roundoff of float64 (2^-53).
UNIT_ROUNDOFF = 2.0**-53
# sigma stays in (0, 1] in exact arithmetic (sigma0 = 1, sigma' <= alpha sigma + lambda); rounding
# may add a few units in the last place.
SIGMA_SLACK = 1e-12

# The state vector both loops update in place:
S_SIGMA = 0  # sigma
S_LOGDET = 1  # ln det M
S_TRACE = 2  # tr M^-1 (trace criterion only)
S_OMEGA = 3  # standard form: upper bound on ||C^-1||_2, C = M^-1 scaled to a unit diagonal
S_BOUND = 4  # first-order bound on the rounding error of the Mahalanobis^2 of any point of E
S_WORST = 5  # the largest error one step added to the bound ...
S_WORST_ROW = 6  # ... at this row (global index) ...
S_WORST_RHO = 7  # ... where the step shrank the ellipsoid along w by this factor (den / alpha) ...
S_WORST_OMEGA = 8  # ... and left ||C^-1|| at most this (standard form; 1 for the factorized form)
N_STATE = 9
# Error added to the bound by one factorized step, in units of n u: Givens rotations are backward
# stable, and M' = alpha M + lambda w w^T adds positive semidefinite terms (no cancellation).
FACTORIZED_STEP_ERROR = 4.0
# Relative rounding of sigma' from sigma_update (a sum of non-negative terms over den).
SIGMA_ERROR = 8.0 * UNIT_ROUNDOFF
# Error added by one standard-form downdate, in units of u (rmax + 1) ||C'^-1|| (downdate_error).
STANDARD_STEP_ERROR = 6.0

# Let LLVM reassociate the O(n^2) loops (SIMD reductions); NaN/inf semantics are kept.
FASTMATH = {"reassoc", "contract", "nsz"}


@njit(cache=True)
def weight_volume(n, sigma, G, eps):
    """Fogel-Huang volume-optimal weight ([FogelHuang1982], [refs §OBE]), gamma = 1. Returns (lambda, alpha).

    q* is the positive root of a2 q^2 + a1 q + a0 with a2 = (n-1) G^2,
    a1 = G [(2n-1) - sigma G + eps^2], a0 = n (1 - eps^2) - sigma G; no update when a0 >= 0.
    For n = 1 the clipped strip is itself the exact intersection: q* = inf (lambda = 1).
    """
    a0 = n * (1.0 - eps * eps) - sigma * G
    if not a0 < 0.0:
        return 0.0, 1.0
    if n == 1:
        return 1.0, 0.0
    a2 = (n - 1.0) * G * G
    a1 = G * ((2.0 * n - 1.0) - sigma * G + eps * eps)
    disc = math.sqrt(a1 * a1 - 4.0 * a2 * a0)
    if a1 >= 0.0:  # stable form of the positive root
        q = -2.0 * a0 / (a1 + disc)
    else:
        q = (disc - a1) / (2.0 * a2)
    return q / (1.0 + q), 1.0 / (1.0 + q)


@njit(cache=True)
def _cubic(b3, b2, b1, b0, q):
    return ((b3 * q + b2) * q + b1) * q + b0


@njit(cache=True)
def smallest_positive_cubic_root(b3, b2, b1, b0):
    """Smallest positive real root of b3 q^3 + b2 q^2 + b1 q + b0 (b3 > 0, b0 < 0), by Cardano's
    formula (trigonometric form when three roots are real), polished by two Newton steps."""
    A = b2 / b3
    B = b1 / b3
    C = b0 / b3
    p = B - A * A / 3.0
    r = 2.0 * A * A * A / 27.0 - A * B / 3.0 + C
    disc = 0.25 * r * r + p * p * p / 27.0
    best = np.inf
    if disc > 0.0:
        s = math.sqrt(disc)
        u = -0.5 * r - s if r > 0.0 else -0.5 * r + s
        u = math.copysign(abs(u) ** (1.0 / 3.0), u)
        t = u - p / (3.0 * u) if u != 0.0 else 0.0
        best = t - A / 3.0
    else:
        m = 2.0 * math.sqrt(-p / 3.0)
        arg = 3.0 * r / (p * m) if p != 0.0 else 0.0
        arg = min(1.0, max(-1.0, arg))
        phi = math.acos(arg) / 3.0
        for k in range(3):
            q = m * math.cos(phi - 2.0 * math.pi * k / 3.0) - A / 3.0
            if 0.0 < q < best:
                best = q
    q = best
    for _ in range(2):
        d = (3.0 * b3 * q + 2.0 * b2) * q + b1
        if d != 0.0:
            qn = q - _cubic(b3, b2, b1, b0, q) / d
            if qn > 0.0:
                q = qn
    return q


@njit(cache=True)
def weight_trace(n, sigma, G, eps, T, H):
    """Trace-optimal weight ([refs §OBE]), gamma = 1: q* = smallest positive root of
    b3 q^3 + b2 q^2 + b1 q + b0; update only if b0 < 0. Returns (lambda, alpha)."""
    b0 = T * (1.0 - eps * eps) - H * sigma
    if not b0 < 0.0:
        return 0.0, 1.0
    if n == 1:
        return 1.0, 0.0
    d = G * T - H  # >= 0 (Cauchy-Schwarz); 0 only for a singular M^-1
    b1 = 3.0 * G * T - 2.0 * H + 2.0 * H * eps * eps - G * T * eps * eps - G * H * sigma
    if not d > 1e-14 * G * T:
        if b1 > 0.0:
            q = -b0 / b1
            return q / (1.0 + q), 1.0 / (1.0 + q)
        return 0.0, 1.0
    q = smallest_positive_cubic_root(G * G * d, 3.0 * G * d, b1, b0)
    if not (q > 0.0 and q < np.inf):
        return 0.0, 1.0
    return q / (1.0 + q), 1.0 / (1.0 + q)


@njit(cache=True)
def weight_dh(sigma, G, eps, alpha_max):
    """[DasguptaHuang1987] weight minimising sigma', capped at alpha_max < 1 ([refs §OBE]),
    gamma = 1. Returns (lambda, 1 - lambda)."""
    if sigma + eps * eps <= 1.0:
        return 0.0, 1.0
    beta = (1.0 - sigma) / (eps * eps)
    if G == 1.0:
        nu = 0.5 * (1.0 - beta)
    elif 1.0 + beta * (G - 1.0) <= 0.0:
        nu = alpha_max
    else:
        nu = (1.0 - math.sqrt(G / (1.0 + beta * (G - 1.0)))) / (1.0 - G)
    lam = min(alpha_max, nu)
    if not lam > 0.0:
        return 0.0, 1.0
    return lam, 1.0 - lam


@njit(cache=True)
def choose_weight(crit, n, sigma, G, eps, T, H, alpha_max):
    if crit == 0:
        return weight_volume(n, sigma, G, eps)
    if crit == 1:
        return weight_trace(n, sigma, G, eps, T, H)
    return weight_dh(sigma, G, eps, alpha_max)


@njit(cache=True)
def clip_strip(y, e, m, r):
    """Clip the strip |y - w^T theta| <= e to E's extent [m - r, m + r] along w ([refs §OBE]).

    Returns (centre y', half-width gamma', q) with q = r^2 - (y' - m)^2 >= 0 computed without
    cancellation as (gap_hi + h)(gap_lo + h): h = (hi - lo) / 2 is the clipped half-width before
    the KAPPA floor and gap_hi = m + r - hi, gap_lo = lo - (m - r) >= 0 are what the clipped strip
    leaves of E's extent on either side (0 on a clipped side). :func:`sigma_update` needs q."""
    lo = max(y - e, m - r)
    hi = min(y + e, m + r)
    h = 0.5 * (hi - lo)
    q = ((m + r - hi) + h) * ((lo - (m - r)) + h)
    return 0.5 * (lo + hi), max(h, KAPPA * max(r, e)), q


@njit(cache=True)
def sigma_update(sigma, lam, alpha, Gn, en, qn):
    """sigma' of the pencil ([refs §OBE], gamma = 1), and whether it is consistent.

    The textbook form alpha sigma + lambda - lambda alpha eps^2 / den (den = alpha + lambda G)
    cancels when sigma' is much smaller than its terms (a strip that grazes E: the unit disc cut
    by 1 <= x <= 2 leaves sigma' ~ 2e-8 from terms ~ 1, eight digits lost). Over the common
    denominator the numerator is a sum of non-negative terms,
        sigma' den = alpha^2 sigma + lambda^2 G + lambda alpha (1 + r^2 - eps^2),   r^2 = sigma G,
    where r^2 - eps^2 = qn (normalised q of :func:`clip_strip`) >= 0 because the clipped strip
    lies inside E's extent; computed that way sigma' is accurate to a few units of roundoff
    (SIGMA_ERROR). ok is False when sigma' leaves (0, 1]: sigma0 = 1 and sigma' <= alpha sigma +
    lambda in exact arithmetic, so anything else means the state is corrupt."""
    new = (alpha * alpha * sigma + lam * lam * Gn + lam * alpha * (1.0 + qn)) / (alpha + lam * Gn)
    return new, bool(new > 0.0 and new <= 1.0 + SIGMA_SLACK)


@njit(cache=True)
def _record(j, k, c, lv, hist_idx, hist_c, hist_lv):
    hist_idx[j] = k
    hist_c[j, :] = c
    hist_lv[j] = lv


@njit(cache=True, fastmath=FASTMATH)
def downdate(P, c, w, g, kc, kp, inv_a):
    """The Sherman-Morrison step of the standard form, in place ([H4Paper] eqs. 28-30):
    c += kc g,  P = (P - kp g g^T) / alpha  with inv_a = 1 / alpha.

    Only the upper triangle is computed and mirrored, so P stays exactly symmetric: computing
    P[a, b] and P[b, a] separately rounds them differently (and fused multiply-adds make that
    worse), and the antisymmetric part of M^-1 then grows from step to step until the ellipsoid
    no longer contains the truth (the first root cause of the silent violations the stress harness found).

    Returns (rmax, shrink, wdw, definite): rmax = max_a P_aa / (alpha P'_aa) (how much of a
    diagonal entry the subtraction cancelled), shrink = max_a alpha P'_aa / P_aa (<= 1),
    wdw = sum_a w_a^2 P'_aa, and whether every diagonal entry stayed > 0 (one <= 0 proves P'
    indefinite).
    """
    n = c.shape[0]
    rmax = 0.0
    shrink = 0.0
    wdw = 0.0
    definite = True
    for a in range(n):
        c[a] += kc * g[a]
        ga = kp * g[a]
        old = P[a, a]
        for b in range(a, n):
            v = (P[a, b] - ga * g[b]) * inv_a
            P[a, b] = v
            P[b, a] = v
        new = P[a, a]
        if new > 0.0 and old > 0.0:
            r = old * inv_a / new
            rmax = max(rmax, r)
            shrink = max(shrink, 1.0 / r)
            wdw += w[a] * w[a] * new
        else:
            definite = False
    return rmax, shrink, wdw, definite


@njit(cache=True)
def scaled_inverse_norm(P, L, x):
    """An upper bound on ||C^-1||_2 for the correlation matrix C = D^-1/2 P D^-1/2, D = diag(P):
    ||L^-1||_F^2 with C = L L^T (Cholesky into the work array L; x is (n,) work). Returns inf if
    C is not numerically positive definite. O(n^3)."""
    n = P.shape[0]
    for j in range(n):
        if not (P[j, j] > 0.0 and P[j, j] < np.inf):
            return np.inf
    for j in range(n):
        d = 1.0
        for k in range(j):
            d -= L[j, k] * L[j, k]
        if not d > 0.0:
            return np.inf
        L[j, j] = math.sqrt(d)
        for i in range(j + 1, n):
            t = P[i, j] / math.sqrt(P[i, i] * P[j, j])
            for k in range(j):
                t -= L[i, k] * L[j, k]
            L[i, j] = t / L[j, j]
    total = 0.0
    for col in range(n):  # column col of L^-1 by forward substitution
        for a in range(n):
            t = 1.0 if a == col else 0.0
            for k in range(col, a):
                t -= L[a, k] * x[k]
            x[a] = t / L[a, a] if a >= col else 0.0
            total += x[a] * x[a]
    return total


@njit(cache=True)
def downdate_error(rmax, omega):
    """Bound on the relative error (Loewner order) that one rounded downdate puts into M^-1:
    STANDARD_STEP_ERROR u (rmax + 1) omega, with omega >= ||C'^-1||_2 for the correlation matrix
    C' of the result (M'^-1 scaled to a unit diagonal) and rmax the largest cancellation of a
    diagonal entry. Each entry carries rounding of at most 3 u (|P_ab| + kp |g_a g_b|) / alpha <=
    6 u rmax sqrt(P'_aa P'_bb) (as kp g_a^2 <= P_aa), plus u |P'_ab| for storing it, and
    v^T D' v <= omega v^T P' v: rmax is cancellation along an axis, omega a thin direction across
    the axes. (Cauchy-Schwarz on |v|^T (sqrt(P'_aa P'_bb)) |v| adds a factor n that rounding with
    independent signs does not reach: against the same step in exact rational arithmetic the
    error stayed below 0.74 u (1 + 2 rmax) ||C'^-1||_2 in 800 random steps, n = 2..7, condition
    numbers up to 1e8 and shrink factors up to 1e14; tests/test_obe_numerics.py checks it.)"""
    return STANDARD_STEP_ERROR * UNIT_ROUNDOFF * (rmax + 1.0) * omega


@njit(cache=True, fastmath=FASTMATH)
def run_standard(P, c, state, W, Y, E, crit, selective, alpha_max, stop_on_outlier, k0, record_every,
                 log_ball, hist_idx, hist_c, hist_lv, hist_S, out_idx, out_res, counts):
    """Standard (information-matrix) OBE over the rows of W, in place ([H4Paper] eqs. 28-30).

    P : (n, n)   M^-1, kept by Sherman-Morrison (O(n^2) per step), exactly symmetric
    c : (n,)     centre
    state : (N_STATE,) see the S_* indices; updated in place
    record_every : record every that many samples; 0: after every update step (the only rows
                   where the set changes); always after the last row
    counts (out) : [rows processed, updates, skipped, outliers, records, breakdowns, bad sigma]
    A breakdown is a row where M^-1 proved not positive definite: w^T P w <= 0 (the row is
    skipped) or a diagonal entry <= 0 after the downdate. Bad sigma: sigma' outside (0, 1].
    Both make the error bound infinite.
    """
    n = c.shape[0]
    N = W.shape[0]
    g = np.empty(n)
    sigma, logdet, T = state[S_SIGMA], state[S_LOGDET], state[S_TRACE]
    omega, bound = state[S_OMEGA], state[S_BOUND]
    omega_exact = omega
    since = 0
    Lw = np.zeros((n, n))
    xw = np.empty(n)
    n_upd = n_skip = n_out = n_rec = n_brk = n_bad = 0
    want_shapes = hist_S.shape[0] > 0
    on_update = record_every == 0
    processed = N
    countdown = record_every - k0 % record_every if not on_update else -1
    for i in range(N):
        yi = Y[i]
        ei = E[i] + ROUND_GUARD * (abs(yi) + E[i])
        G = 0.0
        m = 0.0
        for a in range(n):
            s = 0.0
            for b in range(n):
                s += P[a, b] * W[i, b]
            g[a] = s
            G += W[i, a] * s
            m += W[i, a] * c[a]
        eps = yi - m
        updated = False
        if not (G > 0.0 and G < np.inf):
            n_brk += 1
            bound = np.inf
        else:
            r = math.sqrt(sigma * G)
            if abs(eps) > ei + r:  # E ∩ strip is empty: outlier
                out_idx[n_out] = k0 + i
                out_res[n_out] = eps
                n_out += 1
                if stop_on_outlier:
                    processed = i
                    break
            elif selective and abs(eps) + r <= ei:  # strip contains E: no information
                n_skip += 1
            else:
                yc, gam, q = clip_strip(yi, ei, m, r)
                s = 1.0 / gam
                Gn = G * s * s
                en = (yc - m) * s
                Hn = 0.0
                if crit == 1:
                    for a in range(n):
                        Hn += g[a] * g[a]
                    Hn *= s * s
                lam, alpha = choose_weight(crit, n, sigma, Gn, en, T, Hn, alpha_max)
                if lam > 0.0 or not selective:
                    n_upd += 1
                    updated = True
                    if alpha == 0.0:  # n = 1, exact intersection: M' = (w/gamma')^2
                        c[0] += (yc - m) / W[i, 0]
                        P[0, 0] = 1.0 / Gn * P[0, 0]
                        logdet = -math.log(P[0, 0])
                        sigma = 1.0
                        T = P[0, 0]
                        bound = 4.0 * UNIT_ROUNDOFF  # a fresh interval: only this step's rounding
                        step_err, rho = bound, Gn
                    else:
                        den = alpha + lam * Gn
                        inv_a = 1.0 / alpha
                        rmax, shrink, wdw, definite = downdate(P, c, W[i], g, lam * en * s / den, lam * s * s / den,
                                                               inv_a)
                        sigma_new, sigma_ok = sigma_update(sigma, lam, alpha, Gn, en, q * s * s)
                        logdet += (n - 1) * math.log(alpha) + math.log(den)
                        if crit == 1:
                            T = (T - lam * Hn / den) * inv_a
                        rho = den * inv_a
                        step_err = np.inf
                        if definite:  # ||C'^-1|| <= shrink ||C^-1|| + lambda w^T D' w / gamma^2 (M' = alpha M + ...)
                            omega = omega * shrink + lam * s * s * wdw
                            since += 1
                            if omega > 2.0 * omega_exact or since >= 4 * n:  # refresh the bound exactly
                                omega = omega_exact = scaled_inverse_norm(P, Lw, xw)
                                since = 0
                        if not (definite and omega < np.inf):
                            n_brk += 1
                        elif not sigma_ok:
                            n_bad += 1
                        elif lam == 0.0:  # a zero-weight step (selective=False) leaves the state exactly
                            step_err = 0.0
                        else:
                            step_err = downdate_error(rmax, omega) + SIGMA_ERROR
                        bound = bound * (alpha * sigma / sigma_new) + step_err
                        if not bound < np.inf:
                            bound = np.inf
                        sigma = sigma_new
                    if step_err > state[S_WORST]:
                        state[S_WORST], state[S_WORST_ROW] = step_err, k0 + i
                        state[S_WORST_RHO], state[S_WORST_OMEGA] = rho, omega
                else:
                    n_skip += 1
        k = k0 + i
        countdown -= 1
        if countdown == 0 or i == N - 1 or (on_update and updated):
            if countdown == 0:
                countdown = record_every
            _record(n_rec, k, c, log_ball + 0.5 * n * math.log(sigma) - 0.5 * logdet, hist_idx, hist_c, hist_lv)
            if want_shapes:
                for a in range(n):
                    for b in range(n):
                        hist_S[n_rec, a, b] = sigma * P[a, b]
            n_rec += 1
    state[S_SIGMA], state[S_LOGDET], state[S_TRACE] = sigma, logdet, T
    state[S_OMEGA], state[S_BOUND] = omega, bound
    counts[0], counts[1], counts[2], counts[3] = processed, n_upd, n_skip, n_out
    counts[4], counts[5], counts[6] = n_rec, n_brk, n_bad


@njit(cache=True)
def back_substitute(X, z, out):
    """Solve X out = z for upper-triangular X."""
    n = z.shape[0]
    for a in range(n - 1, -1, -1):
        s = z[a]
        for b in range(a + 1, n):
            s -= X[a, b] * out[b]
        out[a] = s / X[a, a]


@njit(cache=True, fastmath=FASTMATH)
def run_factorized(X, z, c, state, W, Y, E, crit, selective, alpha_max, stop_on_outlier, k0, record_every,
                   log_ball, hist_idx, hist_c, hist_lv, hist_S, out_idx, out_res, counts):
    """Factorized (square-root information) OBE, in place ([refs §QR], [H4Paper] eqs. 33-35).

    X : (n, n) upper triangular with M = X^T X;  z = X c : (n,);  c : (n,) centre (kept current
    on return); state : (N_STATE,) see the S_* indices (S_OMEGA unused).
    Each update is the QR of [sqrt(alpha) X, sqrt(alpha) z; sqrt(lambda) w^T, sqrt(lambda) y]
    done as n Givens rotations of the appended row (O(n^2)); sigma' = alpha sigma + lambda - tau^2.
    M' = alpha M + lambda w w^T is a sum of positive semidefinite terms and the rotations are
    backward stable: each step adds only FACTORIZED_STEP_ERROR n u to the error bound (plus the
    cancellation in sigma'). record_every and counts as in :func:`run_standard`; a breakdown here
    is a zero or non-finite diagonal of X.
    """
    n = z.shape[0]
    N = W.shape[0]
    v = np.empty(n)
    h = np.empty(n)
    row = np.empty(n)
    Xinv = np.empty((n, n))
    unit = np.empty(n)
    dinv = np.empty(n)
    for a in range(n):
        dinv[a] = 1.0 / X[a, a]
    sigma, logdet, T, bound = state[S_SIGMA], state[S_LOGDET], state[S_TRACE], state[S_BOUND]
    step_base = FACTORIZED_STEP_ERROR * n * UNIT_ROUNDOFF
    n_upd = n_skip = n_out = n_rec = n_brk = n_bad = 0
    want_shapes = hist_S.shape[0] > 0
    on_update = record_every == 0
    dirty = False
    processed = N
    countdown = record_every - k0 % record_every if not on_update else -1
    for i in range(N):
        yi = Y[i]
        ei = E[i] + ROUND_GUARD * (abs(yi) + E[i])
        for a in range(n):  # v = X^-T w (forward substitution, row access)
            v[a] = W[i, a]
        for a in range(n):
            va = v[a] * dinv[a]
            v[a] = va
            for b in range(a + 1, n):
                v[b] -= X[a, b] * va
        G = 0.0
        m = 0.0
        for a in range(n):
            G += v[a] * v[a]
            m += v[a] * z[a]  # w^T c = v^T z
        eps = yi - m
        r = math.sqrt(sigma * G)
        updated = False
        if abs(eps) > ei + r:
            out_idx[n_out] = k0 + i
            out_res[n_out] = eps
            n_out += 1
            if stop_on_outlier:
                processed = i
                break
        elif selective and abs(eps) + r <= ei:
            n_skip += 1
        else:
            yc, gam, q = clip_strip(yi, ei, m, r)
            s = 1.0 / gam
            Gn = G * s * s
            en = (yc - m) * s
            Hn = 0.0
            if crit == 1:
                back_substitute(X, v, h)  # M^-1 w = X^-1 X^-T w
                for a in range(n):
                    Hn += h[a] * h[a]
                Hn *= s * s
            lam, alpha = choose_weight(crit, n, sigma, Gn, en, T, Hn, alpha_max)
            if lam > 0.0 or not selective:
                n_upd += 1
                updated = True
                dirty = True
                sa = math.sqrt(alpha)
                sl = math.sqrt(lam) * s
                for a in range(n):
                    row[a] = sl * W[i, a]
                ry = sl * yc
                # Givens rotations zeroing the appended row of [sqrt(alpha) X, sqrt(alpha) z; row, ry];
                # the sqrt(alpha) scaling is folded into the rotation (one pass over X).
                definite = True
                for a in range(n):
                    xa = sa * X[a, a]
                    ra = row[a]
                    if ra == 0.0:  # nothing to rotate: exact (a zero-weight step changes nothing)
                        rr, ct, st = xa, 1.0, 0.0
                    else:
                        rr = math.sqrt(xa * xa + ra * ra)
                        ct = xa / rr
                        st = ra / rr
                    if not (rr > 0.0 and rr < np.inf):
                        definite = False
                    inv = 1.0 / rr
                    cs = ct * sa
                    ss = st * sa
                    X[a, a] = rr
                    dinv[a] = inv
                    for b in range(a + 1, n):
                        xb = X[a, b]
                        rb = row[b]
                        X[a, b] = cs * xb + st * rb
                        row[b] = ct * rb - ss * xb
                    za = z[a]
                    z[a] = cs * za + st * ry
                    ry = ct * ry - ss * za
                sigma_new, sigma_ok = sigma_update(sigma, lam, alpha, Gn, en, q * s * s)
                den = alpha + lam * Gn
                if alpha > 0.0:
                    logdet += (n - 1) * math.log(alpha) + math.log(den)
                else:
                    logdet = 2.0 * math.log(X[0, 0])
                if crit == 1:
                    T = (T - lam * Hn / den) / alpha if alpha > 0.0 else 1.0 / (X[0, 0] * X[0, 0])
                step_err = np.inf
                if not definite:
                    n_brk += 1
                elif not sigma_ok:
                    n_bad += 1
                elif lam == 0.0:  # zero weight (selective=False): every rotation is skipped, exactly
                    step_err = 0.0
                else:
                    step_err = step_base + SIGMA_ERROR
                bound = bound * (alpha * sigma / sigma_new) + step_err
                if not bound < np.inf:
                    bound = np.inf
                sigma = sigma_new
                if step_err > state[S_WORST]:
                    state[S_WORST], state[S_WORST_ROW] = step_err, k0 + i
                    state[S_WORST_RHO], state[S_WORST_OMEGA] = den / alpha if alpha > 0.0 else np.inf, 1.0
            else:
                n_skip += 1
        k = k0 + i
        countdown -= 1
        if countdown == 0 or i == N - 1 or (on_update and updated):
            if countdown == 0:
                countdown = record_every
            if dirty:
                back_substitute(X, z, c)
                dirty = False
            _record(n_rec, k, c, log_ball + 0.5 * n * math.log(sigma) - 0.5 * logdet, hist_idx, hist_c, hist_lv)
            if want_shapes:
                for col in range(n):
                    for a in range(n):
                        unit[a] = 1.0 if a == col else 0.0
                    back_substitute(X, unit, h)
                    for a in range(n):
                        Xinv[a, col] = h[a]
                for a in range(n):
                    for b in range(n):
                        s = 0.0
                        for d in range(max(a, b), n):
                            s += Xinv[a, d] * Xinv[b, d]
                        hist_S[n_rec, a, b] = sigma * s
            n_rec += 1
    if dirty:
        back_substitute(X, z, c)
    state[S_SIGMA], state[S_LOGDET], state[S_TRACE], state[S_BOUND] = sigma, logdet, T, bound
    counts[0], counts[1], counts[2], counts[3] = processed, n_upd, n_skip, n_out
    counts[4], counts[5], counts[6] = n_rec, n_brk, n_bad
