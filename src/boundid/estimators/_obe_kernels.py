"""Compiled (numba) kernels of the recursive OBE estimators: weights and the two batch loops.

Notation (REFERENCES §1): ellipsoid E = {theta : (theta - c)^T M (theta - c) <= sigma}, n = dim,
row w, target y, bound e; innovation eps = y - w^T c, G = w^T M^-1 w, T = tr M^-1,
H = |M^-1 w|^2. The weight rules below take the strip *after clipping and normalising* to
gamma = 1 (the row divided by the clipped half-width), and return the convex-combination weight
lambda together with alpha = 1 - lambda (computed without cancellation), so that
M' = alpha M + lambda w w^T, sigma' = alpha sigma + lambda - lambda alpha eps^2 / (alpha + lambda G).
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

# Let LLVM reassociate the O(n^2) loops (SIMD reductions); NaN/inf semantics are kept.
FASTMATH = {"reassoc", "contract", "nsz"}


@njit(cache=True)
def weight_volume(n, sigma, G, eps):
    """Fogel-Huang volume-optimal weight (REFERENCES §1), gamma = 1. Returns (lambda, alpha).

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
    """Trace-optimal weight (REFERENCES §1), gamma = 1: q* = smallest positive root of
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
    """Dasgupta-Huang (1987) weight minimising sigma', capped at alpha_max < 1 (REFERENCES §1),
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
    """Clip the strip |y - w^T theta| <= e to E's extent [m - r, m + r] along w (REFERENCES §1).
    Returns (centre y', half-width gamma')."""
    lo = max(y - e, m - r)
    hi = min(y + e, m + r)
    return 0.5 * (lo + hi), max(0.5 * (hi - lo), KAPPA * max(r, e))


@njit(cache=True)
def _record(j, k, c, lv, hist_idx, hist_c, hist_lv):
    hist_idx[j] = k
    hist_c[j, :] = c
    hist_lv[j] = lv


@njit(cache=True, fastmath=FASTMATH)
def run_standard(P, c, state, W, Y, E, crit, selective, alpha_max, stop_on_outlier, k0, record_every,
                 log_ball, hist_idx, hist_c, hist_lv, hist_S, out_idx, out_res, counts):
    """Standard (information-matrix) OBE over the rows of W, in place (seed eq. (28)-(30)).

    P : (n, n)   M^-1, kept by Sherman-Morrison (O(n^2) per step)
    c : (n,)     centre
    state : [sigma, ln det M, tr M^-1]
    counts (out) : [rows processed, updates, skipped, outliers, records, breakdowns]
    A breakdown is a step where rounding made w^T P w <= 0 (P lost definiteness): it is skipped.
    """
    n = c.shape[0]
    N = W.shape[0]
    g = np.empty(n)
    sigma, logdet, T = state[0], state[1], state[2]
    n_upd = n_skip = n_out = n_rec = n_brk = 0
    want_shapes = hist_S.shape[0] > 0
    processed = N
    countdown = record_every - k0 % record_every  # record after global samples (k + 1) % record_every == 0
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
        if not (G > 0.0 and G < np.inf):
            n_brk += 1
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
                yc, gam = clip_strip(yi, ei, m, r)
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
                    if alpha == 0.0:  # n = 1, exact intersection: M' = (w/gamma')^2
                        c[0] += (yc - m) / W[i, 0]
                        P[0, 0] = 1.0 / Gn * P[0, 0]
                        logdet = -math.log(P[0, 0])
                        sigma = 1.0
                        T = P[0, 0]
                    else:
                        den = alpha + lam * Gn
                        kc = lam * en * s / den
                        kp = lam * s * s / den
                        inv_a = 1.0 / alpha
                        for a in range(n):
                            c[a] += kc * g[a]
                            ga = kp * g[a]
                            for b in range(n):
                                P[a, b] = (P[a, b] - ga * g[b]) * inv_a
                        sigma = alpha * sigma + lam - lam * alpha * en * en / den
                        logdet += (n - 1) * math.log(alpha) + math.log(den)
                        if crit == 1:
                            T = (T - lam * Hn / den) * inv_a
                else:
                    n_skip += 1
        k = k0 + i
        countdown -= 1
        if countdown == 0 or i == N - 1:
            if countdown == 0:
                countdown = record_every
            _record(n_rec, k, c, log_ball + 0.5 * n * math.log(sigma) - 0.5 * logdet, hist_idx, hist_c, hist_lv)
            if want_shapes:
                for a in range(n):
                    for b in range(n):
                        hist_S[n_rec, a, b] = sigma * P[a, b]
            n_rec += 1
    state[0], state[1], state[2] = sigma, logdet, T
    counts[0], counts[1], counts[2], counts[3], counts[4], counts[5] = processed, n_upd, n_skip, n_out, n_rec, n_brk


@njit(cache=True)
def back_substitute(X, z, out):
    """Solve X out = z for upper-triangular X."""
    n = z.shape[0]
    for a in range(n - 1, -1, -1):
        s = z[a]
        for b in range(a + 1, n):
            s -= X[a, b] * out[b]
        out[a] = s / X[a, a]


@njit(cache=True)
def upper_inverse(X):
    """X^-1 for upper-triangular X, by back substitution on the unit vectors (upper triangular).
    (scipy.linalg.solve_triangular with a matrix right-hand side took ~15 ms for 9 x 9 on the
    shared project machine, OpenBLAS threads contending; this takes microseconds.)"""
    n = X.shape[0]
    Xi = np.zeros((n, n))
    for col in range(n):
        Xi[col, col] = 1.0 / X[col, col]
        for a in range(col - 1, -1, -1):
            s = 0.0
            for b in range(a + 1, col + 1):
                s -= X[a, b] * Xi[b, col]
            Xi[a, col] = s / X[a, a]
    return Xi


@njit(cache=True, fastmath=FASTMATH)
def run_factorized(X, z, c, state, W, Y, E, crit, selective, alpha_max, stop_on_outlier, k0, record_every,
                   log_ball, hist_idx, hist_c, hist_lv, hist_S, out_idx, out_res, counts):
    """Factorized (square-root information) OBE, in place (REFERENCES §2, seed eq. (33)-(35)).

    X : (n, n) upper triangular with M = X^T X;  z = X c : (n,);  c : (n,) centre (kept current
    on return); state : [sigma, unused, tr M^-1 (trace criterion only)].
    Each update is the QR of [sqrt(alpha) X, sqrt(alpha) z; sqrt(lambda) w^T, sqrt(lambda) y]
    done as n Givens rotations of the appended row (O(n^2)); sigma' = alpha sigma + lambda - tau^2.
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
    sigma, T = state[0], state[2]
    n_upd = n_skip = n_out = n_rec = 0
    want_shapes = hist_S.shape[0] > 0
    dirty = False
    processed = N
    countdown = record_every - k0 % record_every  # record after global samples (k + 1) % record_every == 0
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
            yc, gam = clip_strip(yi, ei, m, r)
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
                dirty = True
                sa = math.sqrt(alpha)
                sl = math.sqrt(lam) * s
                for a in range(n):
                    row[a] = sl * W[i, a]
                ry = sl * yc
                # Givens rotations zeroing the appended row of [sqrt(alpha) X, sqrt(alpha) z; row, ry];
                # the sqrt(alpha) scaling is folded into the rotation (one pass over X).
                for a in range(n):
                    xa = sa * X[a, a]
                    ra = row[a]
                    rr = math.sqrt(xa * xa + ra * ra)
                    inv = 1.0 / rr
                    ct = xa * inv
                    st = ra * inv
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
                sigma = alpha * sigma + lam - ry * ry
                if crit == 1:
                    T = (T - lam * Hn / (alpha + lam * Gn)) / alpha if alpha > 0.0 else 1.0 / (X[0, 0] * X[0, 0])
            else:
                n_skip += 1
        k = k0 + i
        countdown -= 1
        if countdown == 0 or i == N - 1:
            if countdown == 0:
                countdown = record_every
            if dirty:
                back_substitute(X, z, c)
                dirty = False
            lv = log_ball + 0.5 * n * math.log(sigma)
            for a in range(n):
                lv -= math.log(X[a, a])
            _record(n_rec, k, c, lv, hist_idx, hist_c, hist_lv)
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
    state[0], state[2] = sigma, T
    counts[0], counts[1], counts[2], counts[3], counts[4], counts[5] = processed, n_upd, n_skip, n_out, n_rec, 0
