"""Tests of the recursive OBE estimators (boundid.estimators.obe and its numba kernels)."""

from __future__ import annotations

import numpy as np
import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st
from scipy.optimize import minimize_scalar

from boundid.errors import InfeasibleDataError, InputError, SolverError
from boundid.estimators import OBE
from boundid.estimators import _obe_kernels as K
from boundid.sets import Box, Ellipsoid, Polytope, RootInformationEllipsoid, step_ellipsoid
from test_obe_guarantee import is_outside

CRITERIA = ("volume", "trace", "dasgupta-huang")
FORMS = ("standard", "factorized")


def _problem(rng, p, N, e=0.5, scale=1.0):
    theta = rng.normal(size=p)
    W = scale * rng.normal(size=(N, p))
    e_max = e * rng.uniform(0.5, 1.5, N)
    y = W @ theta + rng.uniform(-1.0, 1.0, N) * e_max
    return theta, W, y, e_max


def _maha(theta, centers, shapes):
    d = theta - centers
    return np.einsum("ki,ki->k", d, np.linalg.solve(shapes, d[..., None])[..., 0])


# ---------------------------------------------------------------------------- the guarantee
@settings(max_examples=60, deadline=None, suppress_health_check=[HealthCheck.too_slow])
@given(seed=st.integers(0, 2**32 - 1), p=st.integers(1, 5), N=st.integers(1, 80),
       form=st.sampled_from(FORMS), criterion=st.sampled_from(CRITERIA), selective=st.booleans(),
       scale=st.sampled_from([1e-3, 1.0, 1e3]))
def test_truth_inside_every_ellipsoid_of_the_history(seed, p, N, form, criterion, selective, scale):
    """Guarantee (no reference needed): with theta in E0 and every error inside its bound, theta is
    inside every recorded ellipsoid, for both forms, all criteria, selective or not. Zero misses
    (the 1e-9 slack is rounding of the Mahalanobis distance only)."""
    rng = np.random.default_rng(seed)
    theta, W, y, e = _problem(rng, p, N, scale=scale)
    est = OBE(p, shape0=100.0 * p, criterion=criterion, form=form, selective=selective,
              record_every=1, record_shapes=True).fit(W, y, e)
    assert est.outliers.size == 0
    assert len(est.history) == N
    d2 = _maha(theta, est.history.centers, est.history.shapes)
    assert np.all(d2 <= 1.0 + 1e-9), (d2.max(), np.argmax(d2))
    assert est.contains(theta)
    assert np.all(np.isfinite(est.history.log_volumes))


@pytest.mark.parametrize("p", [1, 2, 3])
def test_guarantee_with_errors_exactly_at_the_bounds(p):
    """Guarantee in the degenerate case (no reference needed): a third of the errors exactly at
    +-e_max, so the feasible set often has an empty interior (a point for p = 1) and y holds the
    rounding of W theta + e. The factorized form keeps theta inside every ellipsoid and declares
    no outliers (the clipped-strip floor and the 1e-12 rounding guard of _obe_kernels)."""
    for seed in range(40):
        rng = np.random.default_rng(1000 * p + seed)
        N = int(rng.integers(5, 120))
        theta = rng.normal(size=p)
        W = rng.normal(size=(N, p)) * 10 ** rng.uniform(-3, 3)
        e = rng.uniform(0.1, 1.0, N)
        u = rng.uniform(-1, 1, N)
        u = np.where(rng.random(N) < 0.35, np.sign(u), u)
        y = W @ theta + u * e
        for crit in CRITERIA:
            est = OBE(p, shape0=100.0 * p, criterion=crit, record_shapes=True).fit(W, y, e)
            assert est.outliers.size == 0, (seed, crit)
            d2 = _maha(theta, est.history.centers, est.history.shapes)
            assert np.all(d2 <= 1.0 + 1e-9), (seed, crit, d2.max())


def test_one_dimensional_obe_is_the_exact_interval_intersection():
    """p = 1: the clipped volume/trace step is q* = inf, i.e. the exact intersection of the
    intervals; reference = running max/min of the interval ends (closed form)."""
    rng = np.random.default_rng(0)
    theta, W, y, e = _problem(rng, 1, 30)
    lo = np.maximum.accumulate(np.minimum((y - e) / W[:, 0], (y + e) / W[:, 0]))
    hi = np.minimum.accumulate(np.maximum((y - e) / W[:, 0], (y + e) / W[:, 0]))
    lo, hi = np.maximum(lo, -10.0), np.minimum(hi, 10.0)
    for form in FORMS:
        for crit in ("volume", "trace"):
            est = OBE(1, shape0=100.0, form=form, criterion=crit).fit(W, y, e)
            np.testing.assert_allclose(est.intervals[0], lo[-1:], rtol=1e-10, atol=1e-12)
            np.testing.assert_allclose(est.intervals[1], hi[-1:], rtol=1e-10, atol=1e-12)


# ---------------------------------------------------------------------------- the two forms
@pytest.mark.parametrize("criterion", CRITERIA)
def test_standard_and_factorized_forms_agree(criterion):
    """Second algorithm: the Sherman-Morrison recursion and the Givens QR recursion are the same
    mathematics; on well-conditioned data centre and shape agree to 1e-8 relative. (Over many
    thousands of updates the two drift apart slowly: the recursion amplifies rounding.)"""
    rng = np.random.default_rng(7)
    theta, W, y, e = _problem(rng, 5, 300)
    a = OBE(5, shape0=50.0, form="standard", criterion=criterion).fit(W, y, e)
    b = OBE(5, shape0=50.0, form="factorized", criterion=criterion).fit(W, y, e)
    assert a.n_updates == b.n_updates > 10
    scale = np.abs(a.set.shape).max()
    assert np.abs(a.set.shape - b.set.shape).max() <= 1e-8 * scale
    assert np.abs(a.center - b.center).max() <= 1e-8 * np.sqrt(scale)
    np.testing.assert_allclose(a.history.log_volumes, b.history.log_volumes, rtol=1e-9)
    assert a.info["sigma"] == pytest.approx(b.info["sigma"], rel=1e-8)


def _ill_conditioned(seed):
    rng = np.random.default_rng(seed)
    p = 6
    theta = rng.normal(size=p)
    U, _ = np.linalg.qr(rng.normal(size=(p, p)))
    W1 = (rng.normal(size=(2000, p)) * np.logspace(0, -8, p)) @ U.T  # cond(W1) ~ 1e8
    W2 = rng.normal(size=p) + 1e-8 * rng.normal(size=(5000, p))  # nearly collinear run
    W = np.vstack([W1, W2])
    e = 1e-6
    return theta, W, W @ theta + rng.uniform(-e, e, W.shape[0]), e


@pytest.mark.parametrize("seed", [0, 2])
def test_factorized_form_survives_ill_conditioning_standard_says_why(seed):
    """Numerical robustness ([H4Paper] §III.B): on cond(W) ~ 1e7-1e8 data followed by 5000 nearly
    collinear rows, the square-root form stays finite and positive definite (X has a positive
    diagonal) and reports its set in its own form, {|X theta - z|^2 <= sigma}, whose shape matrix
    sigma X^-1 X^-T would have condition number cond(X)^2 ~ 1e16 and could not be held in double
    precision: it vouches for it, and the truth is inside in exact arithmetic. The contract for
    the standard form (whose outcome here depends on rounding): a guaranteed set contains the
    truth; otherwise it says why ("unverified" with a reason, or SolverError)."""
    theta, W, y, e = _ill_conditioned(seed)
    assert np.linalg.cond(W) > 1e6
    fac = OBE(6, shape0=100.0, form="factorized", record_every=500)
    est = fac.fit(W, y, e)
    assert np.all(np.isfinite(fac._X)) and np.all(np.diag(fac._X) > 0)
    assert np.linalg.cond(fac._X) ** 2 > 1e14  # the case the form is for
    assert isinstance(est.set, RootInformationEllipsoid)
    assert est.kind == "guaranteed" and est.error_bound < 1e-8  # far from VOUCH_MAX on any CPU
    assert not is_outside(est.set, theta) and est.set.contains(theta)
    std = OBE(6, shape0=100.0, form="standard", record_every=500)
    try:
        s = std.fit(W, y, e)
    except SolverError as exc:
        assert "positive definiteness" in str(exc)
        return
    if s.kind == "guaranteed":
        assert not is_outside(s.set, theta)
    else:
        assert s.kind == "unverified" and s.unverified_reason


# ---------------------------------------------------------------------------- the weights
def _sigma_q(q, sigma, G, eps):  # [refs §OBE] pencil, gamma = 1
    return sigma + q - q * eps**2 / (1.0 + q * G)


def _weight_cases(rng, n_cases):
    for _ in range(n_cases):
        n = int(rng.integers(2, 9))
        A = rng.normal(size=(n, n))
        P = A @ A.T + 0.05 * np.eye(n)
        w = rng.normal(size=n)
        sigma = rng.uniform(0.1, 3.0)
        g = P @ w
        G = w @ g
        r = np.sqrt(sigma * G)
        gam = rng.uniform(0.02, 1.0) * r  # a clipped strip: |eps| + gam <= r
        eps = rng.uniform(-1.0, 1.0) * (r - gam)
        yield n, sigma, G / gam**2, eps / gam, np.trace(P), (g @ g) / gam**2


def test_volume_weight_minimises_the_volume():
    """Closed-form Fogel-Huang weight vs scipy.optimize.minimize_scalar of
    n ln sigma'(q) - ln(1 + q G) (ln volume up to a constant) over ln q."""
    rng = np.random.default_rng(1)
    for n, sigma, G, eps, _, _ in _weight_cases(rng, 300):
        def f(q, n=n, sigma=sigma, G=G, eps=eps):
            return n * np.log(_sigma_q(q, sigma, G, eps)) - np.log1p(q * G)
        lam, alpha = K.weight_volume(n, sigma, G, eps)
        assert lam + alpha == pytest.approx(1.0)
        num = minimize_scalar(lambda u, f=f: f(np.exp(u)), bounds=(-40, 40), method="bounded",
                              options={"xatol": 1e-12})
        q_num = np.exp(num.x)
        if lam == 0.0:
            assert f(q_num) >= f(0.0) - 1e-9  # no reduction possible: q = 0 is optimal
            continue
        q = lam / alpha
        assert f(q) <= f(q_num) + 1e-10
        assert q == pytest.approx(q_num, rel=1e-4)


def test_trace_weight_minimises_the_trace():
    """Closed-form (Cardano) trace weight vs minimize_scalar of tr(sigma' M'^-1) =
    sigma'(q) (T - q H / (1 + q G)) over ln q."""
    rng = np.random.default_rng(2)
    n_updates = 0
    for n, sigma, G, eps, T, H in _weight_cases(rng, 300):
        def f(q, sigma=sigma, G=G, eps=eps, T=T, H=H):
            return _sigma_q(q, sigma, G, eps) * (T - q * H / (1.0 + q * G))
        lam, alpha = K.weight_trace(n, sigma, G, eps, T, H)
        num = minimize_scalar(lambda u, f=f: f(np.exp(u)), bounds=(-40, 40), method="bounded",
                              options={"xatol": 1e-12})
        q_num = np.exp(num.x)
        if lam == 0.0:
            assert f(q_num) >= f(0.0) * (1 - 1e-9)
            continue
        n_updates += 1
        q = lam / alpha
        assert f(q) <= f(q_num) * (1 + 1e-10)
        assert q == pytest.approx(q_num, rel=1e-4)
    assert n_updates > 100


def test_dasgupta_huang_weight_minimises_sigma():
    """Closed-form Dasgupta-Huang weight vs minimize_scalar of sigma'(lambda) (convex form,
    [refs §OBE]) on [0, alpha_max], including G = 1 exactly and G < 1, G > 1."""
    rng = np.random.default_rng(3)
    alpha_max = 0.9
    n_updates = 0
    for k in range(400):
        sigma = rng.uniform(0.05, 3.0)
        G = 1.0 if k % 10 == 0 else np.exp(rng.uniform(-3, 3))
        eps = rng.uniform(-3.0, 3.0)

        def s(lam, sigma=sigma, G=G, eps=eps):
            return (1 - lam) * sigma + lam - lam * (1 - lam) * eps**2 / (1 - lam + lam * G)
        lam, alpha = K.weight_dh(sigma, G, eps, alpha_max)
        num = minimize_scalar(s, bounds=(0.0, alpha_max), method="bounded", options={"xatol": 1e-12})
        best = min(num.fun, s(0.0), s(alpha_max))
        assert s(lam) <= best + 1e-10
        if lam > 0:
            n_updates += 1
            if 1e-6 < num.x < alpha_max - 1e-6:
                assert lam == pytest.approx(num.x, abs=1e-5)
    assert n_updates > 100


@pytest.mark.parametrize("alpha_max", [0.2, 0.5, 0.9, 0.999])
def test_dasgupta_huang_weight_respects_alpha_max(alpha_max):
    """Reference: minimize_scalar of sigma'(lambda) on [0, 1) without the cap (convex form,
    [refs §OBE]). Always 0 <= lambda <= alpha_max; lambda == alpha_max exactly when the
    unconstrained optimum lies above the cap (or sigma' keeps falling to lambda -> 1, the branch
    1 + beta (G - 1) <= 0), and lambda equals the unconstrained optimum below it."""
    rng = np.random.default_rng(13)
    capped = inside = 0
    for k in range(400):
        sigma = rng.uniform(0.05, 3.0)
        G = 1.0 if k % 10 == 0 else np.exp(rng.uniform(-4, 4))
        eps = rng.uniform(-3.0, 3.0)

        def s(lam, sigma=sigma, G=G, eps=eps):
            return (1 - lam) * sigma + lam - lam * (1 - lam) * eps**2 / (1 - lam + lam * G)
        lam, alpha = K.weight_dh(sigma, G, eps, alpha_max)
        assert 0.0 <= lam <= alpha_max and alpha == 1.0 - lam
        free = minimize_scalar(s, bounds=(0.0, 1.0 - 1e-12), method="bounded", options={"xatol": 1e-12}).x
        if lam == 0.0:
            continue
        if free > alpha_max + 1e-6:
            assert lam == alpha_max
            capped += 1
        elif free < alpha_max - 1e-6:
            assert lam == pytest.approx(free, abs=1e-5)
            inside += 1
    assert capped > 20 and inside > 20


def test_cardano_root_matches_numpy_roots():
    """The cubic solver vs numpy.roots (companion-matrix eigenvalues)."""
    rng = np.random.default_rng(4)
    for _ in range(500):
        b3 = np.exp(rng.uniform(-5, 5))
        b2, b1 = rng.normal(size=2) * np.exp(rng.uniform(-3, 3, 2))
        b0 = -np.exp(rng.uniform(-5, 5))
        r = np.roots([b3, b2, b1, b0])
        ref = r.real[(np.abs(r.imag) <= 1e-9 * np.abs(r)) & (r.real > 0)].min()
        assert K.smallest_positive_cubic_root(b3, b2, b1, b0) == pytest.approx(ref, rel=1e-7)


@pytest.mark.parametrize("form", FORMS)
def test_clipped_volume_step_is_the_exact_one_step_optimum(form):
    """Exact reference: the minimum-volume ellipsoid of E ∩ strip by SDP (sets.step_ellipsoid,
    S-procedure, exact for one ellipsoid and one strip). The clipped Fogel-Huang step has the
    same volume (1e-6 relative) and centre, with both hyperplanes cutting E, or one missing it."""
    rng = np.random.default_rng(21)
    n_cut = 0
    for k in range(24):
        n = int(rng.integers(2, 6))
        A = rng.normal(size=(n, n))
        S = A @ A.T + 0.1 * np.eye(n)
        c = rng.normal(size=n)
        w = rng.normal(size=n)
        m, r = w @ c, np.sqrt(w @ S @ w)
        case = k % 3
        if case == 0:  # both sides cut E
            e = r * rng.uniform(0.1, 0.7)
            y = m + rng.uniform(-1, 1) * (r - e)
        else:  # one side inside E, the other beyond E's extent
            u = rng.uniform(-0.9, 0.9)
            e = r * (1 - u) * rng.uniform(0.6, 1.5)
            y = m + r * u + e if case == 1 else m - r * u - e
        ref = step_ellipsoid(Ellipsoid(c, S), w, y, e).ellipsoid
        est = OBE(n, center0=c, shape0=S, form=form).update(w, y, e)
        assert abs(est.set.log_volume() - ref.log_volume()) <= 1e-6, (k, case)
        scale = np.sqrt(np.max(np.diag(ref.shape)))
        np.testing.assert_allclose(est.center, ref.center, atol=1e-4 * scale)
        n_cut += est.n_updates
    assert n_cut >= 16


# ---------------------------------------------------------------------------- against the polytope
@pytest.mark.parametrize("p", [2, 3, 4])
@pytest.mark.parametrize("form", FORMS)
def test_final_ellipsoid_contains_every_vertex_of_the_exact_polytope(p, form):
    """Exact reference: the vertices of the feasible polytope (boundid.sets.Polytope, Qhull
    halfspace intersection) all lie in the final ellipsoid, for every criterion."""
    rng = np.random.default_rng(10 + p)
    for trial in range(3):
        theta, W, y, e = _problem(rng, p, 15 * p)
        V = Polytope.from_strips(W, y, e).vertices()
        shape0 = 1e4
        assert np.all(np.sum(V**2, axis=1) < shape0)  # P inside E0, so E_N must contain P
        for crit in CRITERIA:
            est = OBE(p, shape0=shape0, form=form, criterion=crit).fit(W, y, e)
            assert np.all(est.set.contains(V, rtol=1e-8)), (trial, crit)


def test_p14_final_ellipsoid_contains_the_lp_bound_vertices():
    """Exact reference at p = 14 (the H4 size): the 2p vertices where the LP bounds of P are
    attained lie in the final ellipsoid, for both forms; its intervals contain the LP bounds."""
    rng = np.random.default_rng(14)
    theta, W, y, e = _problem(rng, 14, 300)
    b = Polytope.from_strips(W, y, e).bounds()
    for form in FORMS:
        est = OBE(14, shape0=1e4, form=form).fit(W, y, e)
        assert np.all(est.set.contains(b.vertices(), rtol=1e-8))
        lo, hi = est.intervals
        assert np.all(lo <= b.lo + 1e-9) and np.all(hi >= b.hi - 1e-9)


# ---------------------------------------------------------------------------- behaviour
def test_selective_skip_of_a_strip_containing_the_ellipsoid():
    """A strip wider than the ellipsoid's extent carries no information (closed-form extent
    w^T c +- sqrt(w^T S w)): skipped, state unchanged, counted in n_skipped."""
    for form in FORMS:
        obe = OBE(3, center0=[1.0, 2.0, 3.0], shape0=[1.0, 4.0, 9.0], form=form)
        w = np.array([1.0, 1.0, 1.0])
        half = np.sqrt(w @ np.diag([1.0, 4.0, 9.0]) @ w)
        est = obe.update(w, 6.0 + 0.1, half + 0.2)
        assert est.n_updates == 0 and est.n_skipped == 1
        np.testing.assert_allclose(est.set.shape, np.diag([1.0, 4.0, 9.0]), rtol=1e-12)
        est = obe.update(w, 6.0 + 0.1, 0.5 * half)
        assert est.n_updates == 1 and est.n_samples == 2
        assert est.set.log_volume() < np.log(4 / 3 * np.pi * 6.0)


def test_outliers_are_recorded_and_skipped_or_raise():
    """A strip beyond the ellipsoid's extent (closed form) is an outlier: its index and innovation
    are recorded and the ellipsoid stays unchanged and positive definite; or it raises."""
    rng = np.random.default_rng(5)
    theta, W, y, e = _problem(rng, 3, 60)
    y = y.copy()
    y[[20, 45]] += 1e3
    for form in FORMS:
        est = OBE(3, shape0=100.0, form=form).fit(W, y, e)
        np.testing.assert_array_equal(est.outliers, [20, 45])
        assert np.all(np.abs(est.outlier_residuals) > 900)
        assert est.contains(theta)
        np.linalg.cholesky(est.set.shape)
        obe = OBE(3, shape0=100.0, form=form, on_outlier="raise")
        with pytest.raises(InfeasibleDataError, match="observation 20"):
            obe.fit(W, y, e)
        assert obe.n_samples == 21
        assert obe.estimate().contains(theta)


def test_partial_fit_continues_and_update_equals_fit():
    """Second route: fit then partial_fit, or row by row with update(), gives the batch result
    (same arithmetic, so equal to rounding); history indices are global; a second fit starts
    again from E0 (equal to a fresh estimator's)."""
    rng = np.random.default_rng(6)
    theta, W, y, e = _problem(rng, 4, 50)
    for form in FORMS:
        whole = OBE(4, shape0=100.0, form=form, record_every=7).fit(W, y, e)
        parts = OBE(4, shape0=100.0, form=form, record_every=7)
        parts.fit(W[:23], y[:23], e[:23])
        two = parts.partial_fit(W[23:], y[23:], e[23:])
        one = OBE(4, shape0=100.0, form=form, record_every=7)
        for k in range(50):
            last = one.update(W[k], y[k], e[k])
        for other in (two, last):
            np.testing.assert_allclose(other.center, whole.center, rtol=1e-12, atol=1e-14)
            # the computed sets agree to rounding; the reported ones are inflated by each run's own
            # rounding bound (inflation ~1e-13 here), which may differ in its last digits
            np.testing.assert_allclose(other.set.shape / (1 + other.inflation),
                                       whole.set.shape / (1 + whole.inflation), rtol=1e-12, atol=1e-16)
            assert abs(other.inflation - whole.inflation) < 1e-10
            assert other.n_updates == whole.n_updates
        assert list(whole.history.index) == [6, 13, 20, 27, 34, 41, 48, 49]
        assert set(whole.history.index) <= set(two.history.index)
        again = parts.fit(W, y, e)
        np.testing.assert_array_equal(again.center, whole.center)
        np.testing.assert_array_equal(again.set.shape, whole.set.shape)
        assert list(again.history.index) == list(whole.history.index)


def test_box_prior_is_circumscribed():
    """E0 of a box prior passes through the box corners (closed form: corner Mahalanobis = 1)."""
    obe = OBE(3, prior=Box.from_center([1.0, -2.0, 0.5], [0.1, 2.0, 5.0]), names=["a", "b", "c"])
    E = obe.estimate().set
    corners = np.array([[1.0 + s1 * 0.1, -2.0 + s2 * 2.0, 0.5 + s3 * 5.0]
                        for s1 in (-1, 1) for s2 in (-1, 1) for s3 in (-1, 1)])
    np.testing.assert_allclose(E.mahalanobis2(corners), 1.0, rtol=1e-12)
    assert obe.estimate().names == ("a", "b", "c")
    assert obe.estimate().kind == "guaranteed"


def test_estimate_reports_counts_and_sigma():
    """The typed fields and info hold the documented values; counts add up; the ellipsoid is
    c, sigma M^-1."""
    rng = np.random.default_rng(8)
    theta, W, y, e = _problem(rng, 3, 100)
    obe = OBE(3, shape0=100.0, criterion="trace")
    est = obe.fit(W, y, e)
    info = est.info
    for key in ("criterion", "form", "sigma"):
        assert key in info
    assert est.time_s > 0
    assert est.n_samples == 100 == est.n_updates + est.n_skipped + est.n_outliers
    np.testing.assert_allclose(est.set.shape, info["sigma"] * np.linalg.inv(obe.information()), rtol=1e-9)
    assert est.method == "OBE-factorized (trace)"
    assert "OBE" in est.summary()


@pytest.mark.parametrize(
    "call",
    [
        lambda o: o.fit(np.ones((5, 2)), np.ones(5), 1.0),  # wrong column count
        lambda o: o.fit(np.ones((5, 3)), np.ones(4), 1.0),  # y length
        lambda o: o.fit(np.full((5, 3), np.nan), np.ones(5), 1.0),  # NaN
        lambda o: o.fit(np.ones((5, 3)), np.ones(5), 0.0),  # zero bound
        lambda o: o.fit(np.ones((5, 3)), np.ones(5), -np.ones(5)),  # negative bounds
        lambda o: o.fit(np.ones((5, 3)), np.ones(5), np.ones(4)),  # bound length
        lambda o: o.update(np.ones(2), 1.0, 1.0),  # wrong row length
    ],
)
def test_bad_input_raises_input_error(call):
    """Bad input -> InputError (not a numba crash or a silent NaN)."""
    with pytest.raises(InputError):
        call(OBE(3))


@pytest.mark.parametrize(
    "kwargs",
    [{"criterion": "det"}, {"form": "qr"}, {"on_outlier": "ignore"}, {"record_every": 0},
     {"alpha_max": 1.0}, {"shape0": -1.0}, {"center0": [1.0, 2.0]}, {"names": ["a"]},
     {"prior": Box(np.zeros(2), np.ones(2))}, {"prior": Box(np.zeros(3), np.ones(3)), "shape0": 1.0}],
)
def test_bad_options_raise_input_error(kwargs):
    """Unknown options and bad priors -> InputError naming the argument."""
    with pytest.raises(InputError):
        OBE(3, **kwargs)
