"""The numerical watch of the OBE loops (boundid.estimators._obe_kernels): each error bound against
the same computation in exact rational arithmetic (fractions.Fraction on the very same floats)."""

from __future__ import annotations

from fractions import Fraction

import numpy as np
import pytest

from boundid.estimators import OBE
from boundid.estimators import _obe_kernels as K

U = 2.0**-53


def _spd(rng, n, cond, diagonal=False):
    Q, _ = np.linalg.qr(rng.normal(size=(n, n)))
    P = (Q * np.logspace(0, -np.log10(cond), n)) @ Q.T
    if diagonal:
        P = np.diag(np.diag(P))
    D = 10 ** rng.uniform(-4, 4, n)
    P = P * np.outer(D, D)
    return 0.5 * (P + P.T)


def _inv_corr_norm(P):
    """||C^-1||_2 of C = P scaled to a unit diagonal (numpy eigvalsh)."""
    d = np.sqrt(np.diag(P))
    return 1.0 / np.linalg.eigvalsh(P / np.outer(d, d))[0]


def _loewner_error(P_float, P_exact):
    """max |eig(L^-1 (P_float - P_exact) L^-T)|, P_exact = L L^T: the relative error in the order
    that decides containment (difference taken exactly, then rounded once)."""
    n = P_float.shape[0]
    E = np.array([[float(Fraction(P_float[a, b]) - P_exact[a][b]) for b in range(n)] for a in range(n)])
    Pe = np.array([[float(P_exact[a][b]) for b in range(n)] for a in range(n)])
    Li = np.linalg.inv(np.linalg.cholesky(Pe))
    return float(np.abs(np.linalg.eigvalsh(Li @ E @ Li.T)).max()), Pe


def test_downdate_error_bound_holds_against_exact_arithmetic():
    """Reference: the standard form's step P' = (P - kp g g^T) / alpha, g = P w, done in exact
    rational arithmetic on the same inputs (so the rounding of g counts too). Over 400 random
    steps (n = 2..7, condition numbers up to 1e8, diagonal and full matrices, axis-aligned and
    generic rows, shrink factors up to 1e14) the rounding error of the compiled step, in the
    Loewner order relative to the result, stays below downdate_error(rmax, ||C'^-1||) (the worst
    case reaches about half of it); the result is exactly symmetric; and the recursive bound
    ||C'^-1|| <= shrink ||C^-1|| + lambda s^2 w^T D' w of the loop holds."""
    rng = np.random.default_rng(0)
    checked = 0
    worst = 0.0
    for t in range(400):
        n = int(rng.integers(2, 8))
        P = _spd(rng, n, 10 ** rng.uniform(0, 8), diagonal=t % 3 == 0)
        w = rng.normal(size=n) * 10 ** rng.uniform(-3, 3, n)
        if t % 5 == 0:
            w = np.eye(n)[0] + 1e-3 * rng.normal(size=n)
        g = P @ w
        G = float(w @ g)
        lam = rng.uniform(0.01, 0.99)
        alpha = 1.0 - lam
        s2 = 10 ** rng.uniform(-2, 14) / G  # normalised G = s^2 G in [1e-2, 1e14]
        kp = lam * s2 / (alpha + lam * s2 * G)
        Pf, c = P.copy(), np.zeros(n)
        rmax, shrink, wdw, definite = K.downdate(Pf, c, w, g, 0.0, kp, 1.0 / alpha)
        assert np.array_equal(Pf, Pf.T)
        ge = [sum(Fraction(P[a, b]) * Fraction(w[b]) for b in range(n)) for a in range(n)]  # g = P w exactly
        exact = [[(Fraction(P[a, b]) - Fraction(kp) * ge[a] * ge[b]) / Fraction(alpha) for b in range(n)]
                 for a in range(n)]
        try:
            err, Pe = _loewner_error(Pf, exact)
        except np.linalg.LinAlgError:  # the exact result is not numerically definite: nothing to bound
            continue
        assert definite
        omega = _inv_corr_norm(Pe)
        worst = max(worst, err / K.downdate_error(rmax, omega))
        if err < 1e-9:  # shrink and wdw come from the rounded P': compare where it is accurate
            assert omega <= (_inv_corr_norm(P) * shrink + lam * s2 * wdw) * (1 + 1e-6)
        checked += 1
    assert checked > 300
    assert worst <= 1.0, worst


def test_scaled_inverse_norm_bounds_the_correlation_condition():
    """Reference: numpy.linalg.eigvalsh. ||L^-1||_F^2 lies in [||C^-1||_2, n ||C^-1||_2]; an
    indefinite matrix gives inf."""
    rng = np.random.default_rng(1)
    for _ in range(100):
        n = int(rng.integers(1, 9))
        P = _spd(rng, n, 10 ** rng.uniform(0, 10))
        ref = _inv_corr_norm(P)
        got = K.scaled_inverse_norm(P, np.zeros((n, n)), np.empty(n))
        assert ref * (1 - 1e-6) <= got <= n * ref * (1 + 1e-6)
    assert K.scaled_inverse_norm(np.diag([1.0, -1.0]), np.zeros((2, 2)), np.empty(2)) == np.inf
    assert K.scaled_inverse_norm(np.array([[1.0, 2.0], [2.0, 1.0]]), np.zeros((2, 2)), np.empty(2)) == np.inf


def test_sigma_update_is_accurate_where_the_textbook_form_cancels():
    """Reference: sigma' = alpha sigma + lambda - lambda alpha t^2 / (alpha gamma^2 + lambda G) in
    exact rational arithmetic (t the strip centre's offset from E's centre, r^2 = sigma G, the
    clipped strip inside E's extent: |t| + gamma <= r). From the rounded normalised inputs
    sigma_update is within a few units of roundoff of it, down to grazing strips (gamma = 1e-12 r)
    and tiny weights, where the textbook formula in floating point loses up to all its digits."""
    rng = np.random.default_rng(2)
    F = Fraction
    worst_new = worst_textbook = 0.0
    for t in range(400):
        sigma, G = rng.uniform(0.01, 1.0), 10 ** rng.uniform(-3, 3)
        r = np.sqrt(sigma * G)
        gam = r * 10 ** rng.uniform(-12, 0)
        off = (r - gam) * (1.0 if t % 3 else rng.uniform(0.0, 1.0)) * (1.0 if t % 2 else -1.0)
        lam = 10 ** rng.uniform(-12, -0.01)
        alpha = 1.0 - lam
        r2 = F(sigma) * F(G)
        den = F(alpha) * F(gam) ** 2 + F(lam) * F(G)
        exact = F(alpha) * F(sigma) + F(lam) - F(lam) * F(alpha) * F(off) ** 2 / den
        qn = float((r2 - F(off) ** 2) / F(gam) ** 2)
        Gn, en = G / gam**2, off / gam
        got, ok = K.sigma_update(sigma, lam, alpha, Gn, en, qn)
        assert ok
        worst_new = max(worst_new, abs(float((F(got) - exact) / exact)))
        textbook = alpha * sigma + lam - lam * alpha * en * en / (alpha + lam * Gn)
        worst_textbook = max(worst_textbook, abs(float((F(textbook) - exact) / exact)))
    assert worst_new <= K.SIGMA_ERROR + 8 * U  # its own rounding plus that of the three inputs
    assert worst_textbook > 1e-6  # the cancellation the new form avoids is real


def test_factorized_set_answers_from_its_factor_against_exact_arithmetic():
    """Reference: exact rational arithmetic on the stored X, z, sigma. From well-conditioned to
    nearly collinear regressors (cond(X)^2 up to ~1e14), the factorized Estimate's set
    {|X theta - z|^2 <= sigma (1 + inflation)} classifies points at Mahalanobis^2 1 -+ 1e-6 as
    exact arithmetic does, and its centre is the exact X^-1 z to a few units of roundoff in X's
    coordinates (|X c - z|^2 / sigma <= 1e-20: the centre is a point of the set, a rounding away
    from its middle)."""
    rng = np.random.default_rng(3)
    for trial in range(12):
        p = int(rng.integers(2, 6))
        Q, _ = np.linalg.qr(rng.normal(size=(p, p)))
        W = (rng.normal(size=(60, p)) * np.logspace(0, -rng.uniform(0, 7), p)) @ Q.T
        theta = rng.normal(size=p)
        y = W @ theta + rng.uniform(-0.01, 0.01, 60)
        E = OBE(p, shape0=100.0 * p).fit(W, y, 0.01).set
        X = [[Fraction(v) for v in row] for row in E.X]
        z = [Fraction(v) for v in E.z]

        def exact(x, X=X, z=z, p=p, sigma=Fraction(E.sigma)):
            t = [Fraction(v) for v in x]
            return sum((sum(X[i][j] * t[j] for j in range(p)) - z[i]) ** 2 for i in range(p)) / sigma

        assert float(exact(E.center)) <= 1e-20, trial
        u = rng.normal(size=p)
        L = E.factor
        for level in (1.0 - 1e-6, 1.0 + 1e-6):  # points just inside and just outside, along L u
            x = E.center + np.sqrt(level) * (L @ u) / np.linalg.norm(u)
            assert E.contains(x, rtol=0.0) == (exact(x) <= 1), (trial, level, float(exact(x)))


@pytest.mark.parametrize("form", ["standard", "factorized"])
def test_history_on_update_steps_is_complete(form):
    """Second route: the set only changes at update steps, so the default history (after every
    update and the last row) reproduces the every-sample history at its recorded rows, and between
    them the every-sample history is constant."""
    rng = np.random.default_rng(4)
    theta = rng.normal(size=4)
    W = rng.normal(size=(400, 4))
    y = W @ theta + rng.uniform(-0.3, 0.3, 400)
    sparse = OBE(4, shape0=100.0, form=form).fit(W, y, 0.3)
    full = OBE(4, shape0=100.0, form=form, record_every=1).fit(W, y, 0.3)
    hs, hf = sparse.history, full.history
    assert len(hs) == sparse.n_updates + (0 if hs.index[-1] == 399 and 399 in hs.index[:-1] else 1)
    assert len(hs) < len(hf) == 400
    np.testing.assert_array_equal(hs.centers, hf.centers[hs.index])
    np.testing.assert_array_equal(hs.log_volumes, hf.log_volumes[hs.index])
    pos = np.searchsorted(hs.index, np.arange(400), side="right") - 1  # last recorded row at or before each row
    ok = pos >= 0
    np.testing.assert_array_equal(hf.centers[ok], hs.centers[pos[ok]])
