"""Compiled (numba) loops of the box, parallelotope and zonotope recursions.

Each loop runs the rows of W in place on the set's state and writes the same outputs:
``hist_idx, hist_c, hist_lv`` (records every ``record_every`` global samples and after the last
row), ``out_idx, out_res`` (outliers: sample index and innovation y - w^T c) and
``counts = [rows processed, updates, strips with no information, outliers, records]``.
The plain-numpy statement of each step (the reference the tests compare these loops with) is
in the family's module: ``box_step``, ``parallelotope_step``, ``zonotope_step``.

Every step first rounds the strip outward and clips it to the set's extent along w
(:func:`clip_strip`): notation y target, s bound, m = w^T c, r = half-extent of the set along w.
"""

from __future__ import annotations

import math

import numpy as np
from numba import njit

#: outward rounding guard: every bound is widened by ROUND_GUARD (|y| + s + sum_i |w_i c_i| + r),
#: far above the rounding of the dot products of one step and far below any measurement
#: accuracy, so that data consistent with the bounds only up to rounding (errors exactly at the
#: bounds) neither become outliers nor fall a rounding error outside the set
ROUND_GUARD = 1e-12
#: a clipped strip keeps a half-width of at least KAPPA max(r, s), and a parallelotope side at
#: least KAPPA of its previous length: a strip that only grazes the set, or a feasible set with
#: an empty interior, would otherwise make the set flat. The floor only widens (guarantee kept).
KAPPA = 1e-8

OUTLIER, NO_INFO, UPDATE = 0, 1, 2


@njit(cache=True)
def clip_strip(y, s, m, r, wc):
    """Guard and clip the strip |y - w^T x| <= s to the set's extent [m - r, m + r] along w
    (both widened by the rounding guard g, so that a point on the set's face stays inside).

    Returns (status, yc, sc): OUTLIER if the strip misses the set, NO_INFO if it contains it,
    else UPDATE with the clipped strip |yc - w^T x| <= sc."""
    g = ROUND_GUARD * (abs(y) + s + wc + r)
    s = s + g
    eps = y - m
    if abs(eps) > s + r:
        return OUTLIER, 0.0, 0.0
    if abs(eps) + r <= s:
        return NO_INFO, 0.0, 0.0
    lo = max(y - s, m - r - g)
    hi = min(y + s, m + r + g)
    return UPDATE, 0.5 * (lo + hi), max(0.5 * (hi - lo), KAPPA * max(r, s))


@njit(cache=True)
def _due(countdown, i, N, record_every):
    """(record now?, next countdown) for the global record schedule."""
    countdown -= 1
    if countdown == 0:
        return True, record_every
    return i == N - 1, countdown


@njit(cache=True)
def run_box(lo, hi, W, Y, E, stop_on_outlier, k0, record_every, hist_idx, hist_c, hist_lv, out_idx, out_res,
            counts):
    """Box recursion: box <- interval hull of box ∩ clipped strip (exact, O(p) per row).

    For coordinate j with w_j != 0 the rest of w^T x, R_j = sum_{i != j} w_i x_i, ranges over
    [m - w_j c_j -+ (r - |w_j| h_j)] on the box (c centre, h half-widths), so the strip
    a <= w^T x <= b gives w_j x_j in [a - R_j,max, b - R_j,min]."""
    p = lo.shape[0]
    N = W.shape[0]
    n_upd = n_skip = n_out = n_rec = 0
    processed = N
    countdown = record_every - k0 % record_every
    for i in range(N):
        m = 0.0
        r = 0.0
        wc = 0.0
        for a in range(p):
            ca = 0.5 * (lo[a] + hi[a])
            m += W[i, a] * ca
            r += abs(W[i, a]) * 0.5 * (hi[a] - lo[a])
            wc += abs(W[i, a] * ca)
        st, yc, sc = clip_strip(Y[i], E[i], m, r, wc)
        if st == OUTLIER:
            out_idx[n_out] = k0 + i
            out_res[n_out] = Y[i] - m
            n_out += 1
            if stop_on_outlier:
                processed = i
                break
        elif st == NO_INFO:
            n_skip += 1
        else:
            n_upd += 1
            g = ROUND_GUARD * (abs(yc) + sc + wc + r)
            for a in range(p):
                wa = W[i, a]
                if wa == 0.0:
                    continue
                ca = 0.5 * (lo[a] + hi[a])
                Rc = m - wa * ca
                Rr = max(r - abs(wa) * 0.5 * (hi[a] - lo[a]), 0.0)
                t_lo = yc - sc - Rc - Rr - g
                t_hi = yc + sc - Rc + Rr + g
                if wa > 0.0:
                    lo[a] = max(lo[a], t_lo / wa)
                    hi[a] = min(hi[a], t_hi / wa)
                else:
                    lo[a] = max(lo[a], t_hi / wa)
                    hi[a] = min(hi[a], t_lo / wa)
        rec, countdown = _due(countdown, i, N, record_every)
        if rec:
            lv = 0.0
            for a in range(p):
                hist_c[n_rec, a] = 0.5 * (lo[a] + hi[a])
                wd = hi[a] - lo[a]
                lv += math.log(wd) if wd > 0.0 else -np.inf
            hist_idx[n_rec] = k0 + i
            hist_lv[n_rec] = lv
            n_rec += 1
    counts[0], counts[1], counts[2], counts[3], counts[4] = processed, n_upd, n_skip, n_out, n_rec


@njit(cache=True)
def run_parallelotope(c, Gt, state, W, Y, E, stop_on_outlier, k0, record_every, hist_idx, hist_c, hist_lv,
                      out_idx, out_res, counts):
    """Parallelotope recursion ([VicinoZappa1996], [ChisciGarulliZappa1996]), O(p^2) per row.

    P = c + G B^p with Gt = G^T (row k = generator g_k); state = [ln |det G|]. In the unit-box
    coordinates z of P (x = c + G z) the clipped strip reads alpha <= v^T z <= beta with
    v = G^T w. The p + 1 strips bounding P ∩ S are tightened exactly: the p sides of the box by
    the box step in z coordinates, the new strip by the clipping. Dropping strip k of the box
    gives a candidate of volume prod_{i != k} h_i * eta / |v_k| (h_i tightened half-widths, eta
    the clipped strip's half-width), dropping the new strip one of volume prod_i h_i: the least
    volume replaces the side k maximising |v_k| h_k when eta < |v_k| h_k.
    """
    p = c.shape[0]
    N = W.shape[0]
    v = np.empty(p)
    z0 = np.empty(p)
    hz = np.empty(p)
    logdet = state[0]
    n_upd = n_skip = n_out = n_rec = 0
    processed = N
    countdown = record_every - k0 % record_every
    for i in range(N):
        m = 0.0
        wc = 0.0
        for a in range(p):
            m += W[i, a] * c[a]
            wc += abs(W[i, a] * c[a])
        r = 0.0
        for k in range(p):
            s = 0.0
            for a in range(p):
                s += Gt[k, a] * W[i, a]
            v[k] = s
            r += abs(s)
        st, yc, sc = clip_strip(Y[i], E[i], m, r, wc)
        if st == OUTLIER:
            out_idx[n_out] = k0 + i
            out_res[n_out] = Y[i] - m
            n_out += 1
            if stop_on_outlier:
                processed = i
                break
        elif st == NO_INFO:
            n_skip += 1
        else:
            n_upd += 1
            alpha = yc - sc - m
            beta = yc + sc - m
            g = ROUND_GUARD * (abs(alpha) + abs(beta) + r)
            best = -1.0
            j = 0
            for k in range(p):  # box step on the unit box, z coordinates
                vk = v[k]
                zl = -1.0
                zu = 1.0
                if vk != 0.0:
                    Rr = max(r - abs(vk), 0.0)
                    if vk > 0.0:
                        zl = max(zl, (alpha - Rr - g) / vk)
                        zu = min(zu, (beta + Rr + g) / vk)
                    else:
                        zl = max(zl, (beta + Rr + g) / vk)
                        zu = min(zu, (alpha - Rr - g) / vk)
                hz[k] = max(0.5 * (zu - zl), KAPPA)
                z0[k] = 0.5 * (zl + zu)
                if abs(vk) * hz[k] > best:
                    best = abs(vk) * hz[k]
                    j = k
            if sc < best:  # replace side j by the new strip
                vj = v[j]
                zj = yc - m
                for k in range(p):
                    if k != j:
                        zj -= v[k] * z0[k]
                z0[j] = zj / vj
                for a in range(p):
                    s = 0.0
                    for k in range(p):
                        s += z0[k] * Gt[k, a]
                    c[a] += s
                for k in range(p):
                    if k != j:
                        f = v[k] / vj
                        for a in range(p):
                            Gt[k, a] = hz[k] * (Gt[k, a] - f * Gt[j, a])
                        logdet += math.log(hz[k])
                f = sc / vj
                for a in range(p):
                    Gt[j, a] *= f
                logdet += math.log(abs(f))
            else:  # keep the p sides, tightened
                for a in range(p):
                    s = 0.0
                    for k in range(p):
                        s += z0[k] * Gt[k, a]
                    c[a] += s
                for k in range(p):
                    for a in range(p):
                        Gt[k, a] *= hz[k]
                    logdet += math.log(hz[k])
        rec, countdown = _due(countdown, i, N, record_every)
        if rec:
            hist_c[n_rec, :] = c
            hist_idx[n_rec] = k0 + i
            hist_lv[n_rec] = p * math.log(2.0) + logdet
            n_rec += 1
    state[0] = logdet
    counts[0], counts[1], counts[2], counts[3], counts[4] = processed, n_upd, n_skip, n_out, n_rec


@njit(cache=True)
def reduce_rows(Gt, n, max_generators, out):
    """[Combastel2003] order reduction of the first n rows of Gt (one generator per row) into
    ``out``: the max_generators - p largest (Euclidean norm) first, in decreasing order, then p
    axis generators, the box of the sum of the others. Returns the row count of ``out``."""
    p = Gt.shape[1]
    if n <= max_generators:
        out[:n, :] = Gt[:n, :]
        return n
    norms = np.empty(n)
    for k in range(n):
        s = 0.0
        for a in range(p):
            s += Gt[k, a] * Gt[k, a]
        norms[k] = s
    order = np.argsort(-norms, kind="mergesort")
    n_keep = max_generators - p
    for q in range(n_keep):
        out[q, :] = Gt[order[q], :]
    for a in range(p):
        s = 0.0
        for q in range(n_keep, n):
            s += abs(Gt[order[q], a])
        for b in range(p):
            out[n_keep + a, b] = 0.0
        out[n_keep + a, a] = s
    return max_generators


@njit(cache=True)
def _segments(Gt, n):
    s = 0.0
    for k in range(n):
        q = 0.0
        for a in range(Gt.shape[1]):
            q += Gt[k, a] * Gt[k, a]
        s += math.sqrt(q)
    return s


@njit(cache=True)
def run_zonotope(c, Gt, state, W, Y, E, max_generators, stop_on_outlier, k0, record_every, hist_idx, hist_c,
                 hist_lv, out_idx, out_res, counts):
    """Zonotope recursion ([AlamoBravoCamacho2005], [Combastel2003]): O(p m^2) per update (the
    Gram matrix), O(p m + m^2) per strip that leaves Z unchanged.

    Z = c + G B^n with Gt (max_generators + 1, p) holding the n generators as rows,
    state = [n]. With v = G^T w and the clipped strip (yc, sc), every member
    Z(lambda) = (c + lambda (yc - w^T c)) + [G - lambda v^T, sc lambda] B^(n+1) contains Z ∩ S.
    Candidates: lambda* = G v / (|v|^2 + sc^2) (the F-radius minimiser; one more generator, then
    the order reduction), lambda_j = g_j / v_j for every v_j != 0 (eliminates segment j: the count
    stays), and Z itself. The step keeps the candidate with the least total segment length
    sum_k |g_k| (Euclidean), computed for the lambda_j from the Gram matrix Q = G G^T:
    |g_k - (v_k / v_j) g_j|^2 = Q_kk - 2 (v_k / v_j) Q_kj + (v_k / v_j)^2 Q_jj.
    The history's ln volumes are NaN (the exact volume sums C(n, p) determinants).
    """
    p = c.shape[0]
    N = W.shape[0]
    n = int(state[0])
    rows = Gt.shape[0]
    v = np.empty(rows)
    lam = np.empty(p)
    Q = np.empty((rows, rows))
    cand = np.empty_like(Gt)
    red = np.empty_like(Gt)
    gram_ok = False  # Q is recomputed only after the generators change
    n_upd = n_skip = n_out = n_rec = 0
    processed = N
    countdown = record_every - k0 % record_every
    for i in range(N):
        m = 0.0
        wc = 0.0
        for a in range(p):
            m += W[i, a] * c[a]
            wc += abs(W[i, a] * c[a])
        r = 0.0
        vv = 0.0
        for k in range(n):
            s = 0.0
            for a in range(p):
                s += Gt[k, a] * W[i, a]
            v[k] = s
            r += abs(s)
            vv += s * s
        st, yc, sc = clip_strip(Y[i], E[i], m, r, wc)
        if st == OUTLIER:
            out_idx[n_out] = k0 + i
            out_res[n_out] = Y[i] - m
            n_out += 1
            if stop_on_outlier:
                processed = i
                break
        elif st == NO_INFO:
            n_skip += 1
        else:
            innov = yc - m
            if not gram_ok:
                for k in range(n):
                    for l in range(k, n):
                        s = 0.0
                        for a in range(p):
                            s += Gt[k, a] * Gt[l, a]
                        Q[k, l] = s
                        Q[l, k] = s
                gram_ok = True
            best = 0.0
            for k in range(n):
                best += math.sqrt(Q[k, k])
            choice = -2  # -2: keep Z, -1: lambda*, j >= 0: eliminate segment j
            # lambda*: the F-radius minimiser, reduced to the order limit
            den = vv + sc * sc
            for a in range(p):
                s = 0.0
                for k in range(n):
                    s += v[k] * Gt[k, a]
                lam[a] = s / den
            for k in range(n):
                for a in range(p):
                    cand[k, a] = Gt[k, a] - v[k] * lam[a]
            for a in range(p):
                cand[n, a] = sc * lam[a]
            n_red = reduce_rows(cand, n + 1, max_generators, red)
            seg = _segments(red, n_red)
            if seg < best:
                best = seg
                choice = -1
            for j in range(n):
                vj = v[j]
                if vj == 0.0:
                    continue
                seg = sc / abs(vj) * math.sqrt(Q[j, j])
                for k in range(n):
                    if k != j:
                        u = v[k] / vj
                        seg += math.sqrt(max(Q[k, k] - 2.0 * u * Q[k, j] + u * u * Q[j, j], 0.0))
                if seg < best:
                    best = seg
                    choice = j
            if choice == -2:
                n_skip += 1
            elif choice == -1:
                n_upd += 1
                gram_ok = False
                for a in range(p):
                    c[a] += lam[a] * innov
                Gt[:n_red, :] = red[:n_red, :]
                n = n_red
            else:
                n_upd += 1
                gram_ok = False
                vj = v[choice]
                f = innov / vj
                for a in range(p):
                    c[a] += f * Gt[choice, a]
                for k in range(n):
                    if k != choice:
                        u = v[k] / vj
                        for a in range(p):
                            Gt[k, a] -= u * Gt[choice, a]
                f = sc / vj
                for a in range(p):
                    Gt[choice, a] *= f
        rec, countdown = _due(countdown, i, N, record_every)
        if rec:
            hist_c[n_rec, :] = c
            hist_idx[n_rec] = k0 + i
            hist_lv[n_rec] = np.nan
            n_rec += 1
    state[0] = n
    counts[0], counts[1], counts[2], counts[3], counts[4] = processed, n_upd, n_skip, n_out, n_rec
