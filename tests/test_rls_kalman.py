"""RLS and the Kalman estimator against OLS, the closed-form weighted LS, filterpy and Monte Carlo."""

import re

import numpy as np
import pytest
from scipy import stats

from boundid.errors import InputError, NumericalError
from boundid.estimators import RLS, KalmanEstimator, ols
from boundid.estimators.rls import PAPER_P0
from boundid.sets import Ellipsoid, log_unit_ball_volume


def _problem(seed, N=200, p=4, sigma=0.1):
    rng = np.random.default_rng(seed)
    W = rng.normal(size=(N, p)) * np.linspace(0.5, 2.0, p)
    theta = rng.normal(size=p)
    return rng, W, theta, W @ theta + sigma * rng.normal(size=N)


def test_rls_with_large_prior_equals_ols():
    """Reference: ols() (numpy SVD least squares): centre, covariance (relative to its norm), intervals to 1e-6."""
    _, W, _, y = _problem(0)
    est = RLS(4, shape0=1e8, names=list("abcd")).fit(W, y)
    ref = ols(W, y)
    np.testing.assert_allclose(est.center, ref.center, rtol=1e-6)
    np.testing.assert_allclose(est.statistics.cov, ref.statistics.cov, rtol=1e-6,
                               atol=1e-6 * np.abs(ref.statistics.cov).max())
    np.testing.assert_allclose(est.intervals, ref.intervals, rtol=1e-6)
    assert est.set.log_volume() == pytest.approx(ref.set.log_volume(), abs=1e-6)
    assert est.statistics.condition_number == pytest.approx(ref.statistics.condition_number, rel=1e-6)
    assert est.kind == "statistical" and est.statistics.dof == 196
    assert est.names == tuple("abcd") and est.n_samples == 200


def test_rls_forgetting_equals_weighted_ls_closed_form():
    """Reference: the minimiser of sum lam^(N-i) e_i^2 + lam^N (th - th0)^T P0^-1 (th - th0) (paper eqs. 18-19)."""
    _, W, _, y = _problem(1, N=60)
    lam, th0, P0 = 0.97, np.array([0.5, -0.2, 0.1, 1.0]), np.diag([10.0, 5.0, 2.0, 1.0])
    rls = RLS(4, center0=th0, shape0=P0, forgetting=lam)
    rls.fit(W, y)
    wgt = lam ** np.arange(59, -1, -1.0)
    A = lam**60 * np.linalg.inv(P0) + (W * wgt[:, None]).T @ W
    theta = np.linalg.solve(A, lam**60 * np.linalg.solve(P0, th0) + W.T @ (wgt * y))
    np.testing.assert_allclose(rls.theta, theta, rtol=1e-10)
    np.testing.assert_allclose(rls.P, np.linalg.inv(A), rtol=1e-9)
    J = wgt @ (y - W @ theta) ** 2 + lam**60 * (theta - th0) @ np.linalg.solve(P0, theta - th0)
    assert rls.J == pytest.approx(J, rel=1e-9)
    assert rls.n_eff == pytest.approx(wgt.sum(), rel=1e-12)
    assert rls.logdet == pytest.approx(-np.linalg.slogdet(A)[1], rel=1e-9)


def test_rls_numba_fit_equals_numpy_updates_and_resumes():
    """Reference: RLS.update (numpy, row by row; its first step against the closed form from
    theta(0) = 0, P(0) = 1000 I); and one fit then partial_fit against the updates; a second fit
    starts again from the prior."""
    _, W, _, y = _problem(2, N=120)
    a = RLS(4, record_every=7)
    first = a.update(W[0], y[0])
    np.testing.assert_allclose(first.center, PAPER_P0 * W[0] * y[0] / (1.0 + PAPER_P0 * W[0] @ W[0]), rtol=1e-12)
    for w, v in zip(W[1:], y[1:], strict=True):
        a.update(w, v)
    b = RLS(4, record_every=7)
    b.fit(W[:50], y[:50])
    est = b.partial_fit(W[50:], y[50:])
    np.testing.assert_allclose(b.theta, a.theta, rtol=1e-10)
    np.testing.assert_allclose(b.P, a.P, rtol=1e-8, atol=1e-14)
    assert b.J == pytest.approx(a.J, rel=1e-10) and b.n == a.n == 120
    # history: every 7th sample, plus the last row of each fit (49 and 119)
    expected = np.union1d(np.arange(6, 120, 7), [49, 119])
    np.testing.assert_array_equal(est.history.index, expected)
    ha = a.history
    common = np.isin(ha.index, est.history.index)
    np.testing.assert_allclose(est.history.centers[np.isin(est.history.index, ha.index)], ha.centers[common],
                               rtol=1e-8, atol=1e-10)
    assert est.history.log_volumes[-1] == pytest.approx(est.set.log_volume(), rel=1e-8)
    again = b.fit(W, y)
    np.testing.assert_allclose(again.center, est.center, rtol=1e-10)
    assert b.n == 120


def test_rls_paper_defaults_and_early_state():
    """Reference: the direct-drive paper's theta(0) = 0, P(0) = 1000 I; no variance estimate while n <= p."""
    rls = RLS(9)
    np.testing.assert_array_equal(rls.theta, np.zeros(9))
    np.testing.assert_array_equal(rls.P, PAPER_P0 * np.eye(9))
    assert PAPER_P0 == 1000.0
    rng = np.random.default_rng(3)
    est = rls.fit(rng.normal(size=(5, 9)), rng.normal(size=5))
    assert est.set is None and np.all(np.isinf(est.intervals[1]))
    assert np.all(np.isnan(est.history.log_volumes))


@pytest.mark.parametrize("engine", ["numba", "filterpy"])
def test_kalman_q0_r1_equals_rls(engine):
    """Reference: RLS (lambda = 1): with Q = 0 and R = 1 the Kalman filter is the same recursion, to 1e-9."""
    _, W, _, y = _problem(4, N=150)
    rls = RLS(4, center0=np.ones(4), shape0=50.0)
    rls.fit(W, y)
    kf = KalmanEstimator(4, center0=np.ones(4), shape0=50.0, R=1.0, Q=0.0)
    est = kf.fit(W, y, engine=engine)
    np.testing.assert_allclose(kf.theta, rls.theta, rtol=1e-9, atol=1e-12)
    np.testing.assert_allclose(kf.P, rls.P, rtol=1e-9, atol=1e-15)
    assert kf.J == pytest.approx(rls.J, rel=1e-9)
    assert est.kind == "statistical" and est.statistics.dof == np.inf


def test_kalman_numba_equals_filterpy():
    """Reference: filterpy.kalman.KalmanFilter (predict + update, Joseph form): per-row R, Q > 0, history, 1e-9."""
    rng, W, _, y = _problem(5, N=150)
    R = rng.uniform(0.005, 0.05, size=150)
    Q = 1e-5 * np.diag([1.0, 2.0, 0.0, 0.5])
    prior = {"center0": rng.normal(size=4), "shape0": np.diag([4.0, 3.0, 2.0, 1.0]), "R": 0.01}
    a = KalmanEstimator(4, **prior, Q=Q, record_every=10)
    b = KalmanEstimator(4, **prior, Q=Q, record_every=10)
    ea = a.fit(W, y, R=R, engine="filterpy")
    eb = b.fit(W, y, R=R, engine="numba")
    np.testing.assert_allclose(eb.center, ea.center, rtol=1e-9, atol=1e-12)
    np.testing.assert_allclose(b.P, a.P, rtol=1e-9, atol=1e-15)
    np.testing.assert_allclose(eb.intervals, ea.intervals, rtol=1e-9)
    np.testing.assert_array_equal(eb.history.index, ea.history.index)
    np.testing.assert_allclose(eb.history.centers, ea.history.centers, rtol=1e-9, atol=1e-12)
    np.testing.assert_allclose(eb.history.log_volumes, ea.history.log_volumes, rtol=1e-9)
    assert eb.info["nis"] == pytest.approx(ea.info["nis"], rel=1e-9)
    # single-row updates through filterpy continue the same state
    a.update(W[0], y[0], R=0.02)
    b.partial_fit(W[:1], y[:1], R=0.02)
    np.testing.assert_allclose(a.theta, b.theta, rtol=1e-9)


def test_kalman_posterior_closed_form():
    """Reference: the Gaussian posterior P = (P0^-1 + W^T W / r)^-1, mean P (P0^-1 th0 + W^T y / r); z intervals."""
    _, W, _, y = _problem(6, N=40)
    th0, P0, r = np.zeros(4), np.diag([2.0, 1.0, 0.5, 3.0]), 0.04
    est = KalmanEstimator(4, center0=th0, shape0=P0, R=r, level=0.9).fit(W, y)
    P = np.linalg.inv(np.linalg.inv(P0) + W.T @ W / r)
    mean = P @ (W.T @ y / r)
    np.testing.assert_allclose(est.center, mean, rtol=1e-9)
    np.testing.assert_allclose(est.statistics.cov, P, rtol=1e-9)
    z = stats.norm.ppf(0.95)
    np.testing.assert_allclose(est.intervals[1], mean + z * np.sqrt(np.diag(P)), rtol=1e-9)
    np.testing.assert_allclose(est.set.shape, stats.chi2.ppf(0.9, 4) * P, rtol=1e-9)
    lv = log_unit_ball_volume(4) + 0.5 * np.linalg.slogdet(stats.chi2.ppf(0.9, 4) * P)[1]
    assert est.history.log_volumes[-1] == pytest.approx(lv, rel=1e-9)


def test_coverage_gaussian_and_uniform(record_property):
    """Reference: the nominal 95 % level over 300 runs (RLS: Student t / chi2; Kalman with the true R: normal)."""
    rng = np.random.default_rng(7)
    theta = np.array([1.0, -2.0, 0.5])
    hits = {"rls": 0, "rls_ell": 0, "kf": 0, "kf_ell": 0, "rls_unif": 0}
    runs = 300
    for _ in range(runs):
        W = rng.normal(size=(100, 3))
        y = W @ theta + 0.2 * rng.normal(size=100)
        e = RLS(3, shape0=1e8, record_every=0).fit(W, y)
        hits["rls"] += np.sum((e.intervals[0] <= theta) & (theta <= e.intervals[1]))
        hits["rls_ell"] += e.contains(theta)
        k = KalmanEstimator(3, shape0=1e8, R=0.04, record_every=0).fit(W, y)
        hits["kf"] += np.sum((k.intervals[0] <= theta) & (theta <= k.intervals[1]))
        hits["kf_ell"] += k.contains(theta)
        yu = W @ theta + rng.uniform(-0.3, 0.3, size=100)
        u = RLS(3, shape0=1e8, record_every=0).fit(W, yu)
        hits["rls_unif"] += np.sum((u.intervals[0] <= theta) & (theta <= u.intervals[1]))
    cov = {k: v / (runs * (1 if k.endswith("ell") else 3)) for k, v in hits.items()}
    for k, v in cov.items():
        record_property(f"coverage_{k}", float(v))
    print("coverage:", {k: round(v, 3) for k, v in cov.items()})
    for v in cov.values():
        assert abs(v - 0.95) <= 0.03


@pytest.mark.parametrize(
    "call, match",
    [
        (lambda: RLS(0), "positive integer"),
        (lambda: RLS(3, forgetting=0.0), "forgetting"),
        (lambda: RLS(3, forgetting=1.5), "forgetting"),
        (lambda: RLS(3, shape0=-1.0), "shape0"),
        (lambda: RLS(3, shape0=np.diag([1.0, -1.0, 1.0])), "positive definite"),
        (lambda: RLS(3, center0=np.zeros(2)), "center0"),
        (lambda: RLS(3, prior=Ellipsoid(np.zeros(3), np.eye(3)), shape0=1.0), "prior once"),
        (lambda: RLS(3, record_every=-1), "record_every"),
        (lambda: RLS(3, names=["a", "b"]), "names"),
        (lambda: RLS(3, level=1.0), "level"),
        (lambda: RLS(3).fit(np.full((5, 3), np.nan), np.zeros(5)), "NaN"),
        (lambda: RLS(3).fit(np.zeros((5, 4)), np.zeros(5)), "3 columns"),
        (lambda: RLS(3).fit(np.zeros((5, 3)), np.zeros(4)), "rows"),
        (lambda: RLS(3).update(np.zeros(2), 1.0), "length 3"),
        (lambda: RLS(3).update(np.zeros(3), np.nan), "NaN"),
        (lambda: KalmanEstimator(3, shape0=1.0, R=0.0), "R"),
        (lambda: KalmanEstimator(3, shape0=1.0, R=1.0, Q=-1.0), "Q"),
        (lambda: KalmanEstimator(3, shape0=1.0, R=1.0, Q=np.ones((2, 2))), "Q"),
        (lambda: KalmanEstimator(3, shape0=1.0, R=1.0).fit(np.zeros((5, 3)), np.zeros(5), R=np.ones(4)), "R"),
        (lambda: KalmanEstimator(3, shape0=1.0, R=1.0).fit(np.zeros((5, 3)), np.zeros(5), engine="x"), "engine"),
    ],
)
def test_bad_input_raises_input_error(call, match):
    """Reference: the documented InputError for each malformed argument."""
    with pytest.raises(InputError, match=match):
        call()


def test_rls_update_equals_fit_with_forgetting():
    """Second route: RLS.update (numpy, row by row) against RLS.fit (compiled) at forgetting 0.97,
    and both against the closed-form weighted LS minimiser (paper eqs. 18-19)."""
    _, W, _, y = _problem(8, N=90)
    lam = 0.97
    a = RLS(4, forgetting=lam, record_every=5)
    for w, v in zip(W, y, strict=True):
        a.update(w, v)
    b = RLS(4, forgetting=lam, record_every=5)
    b.fit(W[:40], y[:40])
    b.partial_fit(W[40:], y[40:])
    np.testing.assert_allclose(b.theta, a.theta, rtol=1e-10)
    np.testing.assert_allclose(b.P, a.P, rtol=1e-8, atol=1e-12 * np.abs(a.P).max())
    assert b.J == pytest.approx(a.J, rel=1e-10) and b.n_eff == pytest.approx(a.n_eff, rel=1e-12)
    assert b.logdet == pytest.approx(a.logdet, rel=1e-10)
    wgt = lam ** np.arange(89, -1, -1.0)
    A = lam**90 * np.eye(4) / PAPER_P0 + (W * wgt[:, None]).T @ W
    np.testing.assert_allclose(a.theta, np.linalg.solve(A, W.T @ (wgt * y)), rtol=1e-9)
    common = np.intersect1d(a.history.index, b.history.index)
    assert common.size >= 17
    np.testing.assert_allclose(b.history.centers[np.isin(b.history.index, common)],
                               a.history.centers[np.isin(a.history.index, common)], rtol=1e-8, atol=1e-10)


def test_kalman_dense_q_agrees_with_filterpy():
    """Reference: filterpy.kalman.KalmanFilter (predict with the full Q, Joseph-form update) against
    the compiled loop, with a dense symmetric positive definite random-walk covariance Q (all
    off-diagonal entries non-zero), per-row R; and against a plain numpy predict/update."""
    rng, W, _, y = _problem(9, N=120)
    A = rng.normal(size=(4, 4))
    Q = 1e-4 * (A @ A.T + 0.1 * np.eye(4))
    assert np.all(Q[~np.eye(4, dtype=bool)] != 0) and np.linalg.eigvalsh(Q)[0] > 0
    R = rng.uniform(0.005, 0.05, size=120)
    prior = {"center0": rng.normal(size=4), "shape0": np.diag([4.0, 3.0, 2.0, 1.0]), "R": 0.01}
    a = KalmanEstimator(4, **prior, Q=Q, record_every=10)
    b = KalmanEstimator(4, **prior, Q=Q, record_every=10)
    ea = a.fit(W, y, R=R, engine="filterpy")
    eb = b.fit(W, y, R=R, engine="numba")
    np.testing.assert_allclose(eb.center, ea.center, rtol=1e-9, atol=1e-12)
    np.testing.assert_allclose(b.P, a.P, rtol=1e-9, atol=1e-15)
    np.testing.assert_allclose(eb.history.log_volumes, ea.history.log_volumes, rtol=1e-9)
    x, P = prior["center0"].copy(), prior["shape0"].copy()
    for w, v, r in zip(W, y, R, strict=True):
        P = P + Q
        S = w @ P @ w + r
        K = P @ w / S
        x = x + K * (v - w @ x)
        P = P - np.outer(K, w @ P)
    np.testing.assert_allclose(b.theta, x, rtol=1e-9)
    np.testing.assert_allclose(b.P, P, rtol=1e-8, atol=1e-14)


def _state(f):
    h = f.history
    return (f.theta.copy(), np.array(f.P, copy=True), f.J, f.n_eff, f.n, f.logdet,
            None if h is None else (h.index.copy(), h.centers.copy()))


def _assert_same_state(a, b):
    for u, v in zip(a, b, strict=True):
        if isinstance(u, tuple):
            for s, t in zip(u, v, strict=True):
                np.testing.assert_array_equal(s, t)
        else:
            np.testing.assert_array_equal(u, v)


def _assert_sound(f):
    """A state the estimator kept: finite, P positive definite, its Estimate built."""
    assert np.all(np.isfinite(f.theta)) and np.all(np.isfinite(f.P))
    np.linalg.cholesky(0.5 * (f.P + f.P.T))
    assert np.all(np.isfinite(f.estimate().center))


@pytest.mark.parametrize("how", ["rls fit", "rls update", "kalman numba", "kalman filterpy", "kalman update"])
def test_filters_fail_cleanly_on_badly_scaled_data(how):
    """Reference: the state before the failing call. After five rows of ordinary data, rows x 1e8
    push the covariance form to the edge of positive definiteness (data x 1e7 from the start, P0 =
    1000, at the first row; it used to go on to NaN and end in 'LinAlgError: Eigenvalues did not
    converge' with a corrupted object). The contract, whichever way the rounding of a given CPU
    goes: either NumericalError names the row and the fix and the estimator is exactly as it was
    before the failing call (history included), or every row is taken and the state is sound."""
    rng, W, theta, y = _problem(10, N=60)
    f = RLS(4, record_every=1) if how.startswith("rls") else KalmanEstimator(4, shape0=1000.0, R=1.0)
    f.fit(W[:5], y[:5]) if how != "kalman filterpy" else f.fit(W[:5], y[:5], engine="filterpy")
    before = _state(f)
    assert before[4] == 5 and len(before[6][0]) == 5
    Wb, yb = W[5:] * 1e8, y[5:] * 1e8
    try:
        if how == "rls fit":
            f.partial_fit(Wb, yb)
        elif how == "kalman numba":
            f.partial_fit(Wb, yb, engine="numba")
        elif how == "kalman filterpy":
            f.partial_fit(Wb, yb, engine="filterpy")
        else:
            for w, v in zip(Wb, yb, strict=True):
                before = _state(f)  # row by row: the failing row leaves the previous rows' state
                f.update(w, v)
    except NumericalError as exc:
        assert re.search(r"at row \d+ .*Scale the columns of W and y", str(exc))
        _assert_same_state(_state(f), before)
        est = f.estimate()
        assert np.all(np.isfinite(est.center)) and est.n_samples == before[4]
    else:
        assert f.n == 60
    _assert_sound(f)
    if how.endswith("fit") or how.endswith("numba"):  # a fit from the prior: it fails cleanly or is sound
        before = _state(f)
        try:
            f.fit(Wb, yb)
        except NumericalError:
            _assert_same_state(_state(f), before)
        _assert_sound(f)
        _assert_same_state(_state(f), before)


@pytest.mark.parametrize("make", [lambda: RLS(4), lambda: KalmanEstimator(4, shape0=1000.0, R=1.0)])
def test_issue_scaled_data_from_the_start_raises_numerical_error(make):
    """The case of data x 1e7 with the paper's P0 = 1000 I. The first rows already cancel
    all 16 digits of P; NumericalError says so and the filter keeps its prior (n = 0)."""
    _, W, _, y = _problem(11, N=200)
    f = make()
    with pytest.raises(NumericalError, match="Scale the columns"):
        f.fit(W * 1e7, y * 1e7)
    assert f.n == 0 and np.array_equal(f.P, 1000.0 * np.eye(4)) and np.all(f.theta == 0)
