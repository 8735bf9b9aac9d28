"""Batch OLS / IDIM-WLS against numpy's lstsq, closed-form covariances, scipy quantiles and Monte Carlo."""

import numpy as np
import pytest
from scipy import stats

from boundid.errors import InputError
from boundid.estimators import RankDeficientError, ols, wls


def _problem(rng, N=40, p=4, sigma=0.3):
    W = rng.normal(size=(N, p)) * np.array([1.0, 5.0, 0.2, 2.0])[:p]
    theta = rng.normal(size=p)
    return W, theta, W @ theta + sigma * rng.normal(size=N)


def test_ols_equals_lstsq_and_closed_forms():
    """Reference: numpy.linalg.lstsq; sigma^2 (W^T W)^-1; scipy.stats t and chi2 quantiles; np.linalg.cond."""
    rng = np.random.default_rng(0)
    W, _, y = _problem(rng)
    N, p = W.shape
    est = ols(W, y, level=0.9, names=list("abcd"))
    x, rss, _, _ = np.linalg.lstsq(W, y, rcond=None)
    np.testing.assert_allclose(est.center, x, rtol=1e-12, atol=1e-14)
    s2 = rss[0] / (N - p)
    cov = s2 * np.linalg.inv(W.T @ W)
    np.testing.assert_allclose(est.statistics.cov, cov, rtol=1e-10)
    se = np.sqrt(np.diag(cov))
    np.testing.assert_allclose(est.statistics.std_err, se, rtol=1e-10)
    np.testing.assert_allclose(est.statistics.rel_std_pct, 100 * se / np.abs(x), rtol=1e-10)
    t = stats.t.ppf(0.95, N - p)
    np.testing.assert_allclose(est.intervals[0], x - t * se, rtol=1e-10)
    np.testing.assert_allclose(est.intervals[1], x + t * se, rtol=1e-10)
    np.testing.assert_allclose(est.set.shape, stats.chi2.ppf(0.9, p) * cov, rtol=1e-10)
    assert est.statistics.condition_number == pytest.approx(np.linalg.cond(W), rel=1e-10)
    assert est.kind == "statistical" and est.level == 0.9
    assert est.statistics.dof == N - p and est.n_samples == N and est.time_s >= 0
    assert est.names == ("a", "b", "c", "d") and "std_err" in est.to_frame().columns


def test_wls_equals_ols_on_row_scaled_problem():
    """Reference: sigma_j^2 = |r_j|^2/(N_j - p) from each group's own lstsq fit, then lstsq on the scaled rows."""
    rng = np.random.default_rng(1)
    W, theta, _ = _problem(rng, N=90, p=3)
    groups = np.repeat([0, 1, 2], 30)
    y = W @ theta + np.array([0.05, 0.5, 2.0])[groups] * rng.normal(size=90)
    est = wls(W, y, groups, names=["m", "c", "k"])
    sig = np.array([np.sqrt(np.linalg.lstsq(W[groups == g], y[groups == g])[1][0] / (30 - 3)) for g in range(3)])
    np.testing.assert_allclose(est.info["sigma_group_values"], sig, rtol=1e-10)
    assert est.info["sigma_groups"] == pytest.approx({0: sig[0], 1: sig[1], 2: sig[2]}, rel=1e-10)
    assert est.statistics.noise_variance == pytest.approx({0: sig[0] ** 2, 1: sig[1] ** 2, 2: sig[2] ** 2}, rel=1e-10)
    Ws, ys = W / sig[groups][:, None], y / sig[groups]
    ref = ols(Ws, ys, names=["m", "c", "k"])
    np.testing.assert_allclose(est.center, np.linalg.lstsq(Ws, ys, rcond=None)[0], rtol=1e-11)
    np.testing.assert_allclose(est.statistics.cov, ref.statistics.cov, rtol=1e-10)
    np.testing.assert_allclose(est.intervals, ref.intervals, rtol=1e-10)
    assert est.statistics.condition_number == pytest.approx(np.linalg.cond(Ws), rel=1e-10)
    assert est.method == "WLS" and est.kind == "statistical"


def test_wls_finds_group_noise_levels():
    """Reference: the simulated per-group noise standard deviations (0.1 and 1.0), 1000 rows each."""
    rng = np.random.default_rng(2)
    W, theta, _ = _problem(rng, N=2000, p=4)
    groups = np.repeat([-1, 3], 1000)
    y = W @ theta + np.where(groups == 3, 1.0, 0.1) * rng.normal(size=2000)
    est = wls(W, y, groups)
    assert est.info["sigma_groups"][-1] == pytest.approx(0.1, rel=0.1)
    assert est.info["sigma_groups"][3] == pytest.approx(1.0, rel=0.1)
    # weighting helps: the WLS standard errors are smaller than the OLS ones
    assert np.all(est.statistics.std_err < ols(W, y).statistics.std_err)


def test_wls_joint_rows_missing_parameters():
    """Reference: lstsq on the joint's nonzero columns only, dof N_j - (p - 1), as in Gautier's per-joint fit."""
    rng = np.random.default_rng(8)
    W, theta, _ = _problem(rng, N=60, p=4)
    groups = np.repeat([0, 1], 30)
    W[groups == 1, 0] = 0.0  # joint 1's torque does not depend on parameter 0 (as in a serial arm)
    y = W @ theta + np.where(groups == 0, 0.1, 0.3) * rng.normal(size=60)
    est = wls(W, y, groups)
    rss1 = np.linalg.lstsq(W[groups == 1][:, 1:], y[groups == 1])[1][0]
    assert est.info["sigma_groups"][1] == pytest.approx(np.sqrt(rss1 / (30 - 3)), rel=1e-10)


def _coverage(rng, runs, noise, estimator):
    """Fraction of (run, parameter) pairs whose interval holds the truth, and of runs whose ellipsoid does."""
    hits, ell = 0, 0
    p = 3
    for _ in range(runs):
        W = rng.normal(size=(100, p))
        theta = np.array([1.0, -2.0, 0.5])
        e = estimator(W, W @ theta + noise(rng, 100))
        lo, hi = e.intervals
        hits += int(np.sum((lo <= theta) & (theta <= hi)))
        ell += int(e.contains(theta))
    return hits / (runs * p), ell / runs


def test_ols_coverage_gaussian(record_property):
    """Reference: the nominal 95 % level (Student t intervals, chi2 ellipsoid), 400 Gaussian runs."""
    cov_i, cov_e = _coverage(np.random.default_rng(3), 400, lambda r, n: 0.2 * r.normal(size=n), ols)
    record_property("interval_coverage", float(cov_i))
    record_property("ellipsoid_coverage", float(cov_e))
    assert abs(cov_i - 0.95) <= 0.03
    assert abs(cov_e - 0.95) <= 0.03


def test_wls_coverage_heteroscedastic_gaussian():
    """Reference: the nominal 95 % level with two joints of noise 0.05 and 0.5 (400 runs)."""
    groups = np.repeat([0, 1], 50)

    def noise(r, n):
        return np.where(groups == 0, 0.05, 0.5) * r.normal(size=n)

    cov_i, cov_e = _coverage(np.random.default_rng(4), 400, noise, lambda W, y: wls(W, y, groups))
    assert abs(cov_i - 0.95) <= 0.03
    assert abs(cov_e - 0.95) <= 0.03


def test_ols_coverage_uniform_bounded_noise(record_property):
    """Reference: the nominal 95 % level; bounded uniform noise is not Gaussian, the CLT keeps it close."""
    cov_i, cov_e = _coverage(np.random.default_rng(5), 400, lambda r, n: r.uniform(-0.3, 0.3, size=n), ols)
    record_property("interval_coverage_uniform", float(cov_i))
    record_property("ellipsoid_coverage_uniform", float(cov_e))
    print(f"uniform noise: interval coverage {cov_i:.3f}, ellipsoid coverage {cov_e:.3f}")
    assert abs(cov_i - 0.95) <= 0.03
    assert abs(cov_e - 0.95) <= 0.03


def test_rank_deficient_names_combination():
    """Reference: hand-derived null spaces: identical columns a, b -> a - b; column e = 2 c -> c - 0.5*e."""
    rng = np.random.default_rng(6)
    X = rng.normal(size=(30, 3))
    W = np.column_stack([X[:, 0], X[:, 0], X[:, 1], X[:, 2], 2 * X[:, 1]])
    y = rng.normal(size=30)
    with pytest.raises(RankDeficientError) as exc:
        ols(W, y, names=["a", "b", "c", "d", "e"])
    assert isinstance(exc.value, InputError)
    assert "a - b" in str(exc.value) and "c - 0.5*e" in str(exc.value)
    assert sorted(exc.value.combinations) == ["a - b", "c - 0.5*e"] and exc.value.rank == 3
    np.testing.assert_allclose(W @ exc.value.null_space.T, 0.0, atol=1e-12)
    with pytest.raises(RankDeficientError, match="theta1 - theta2"):
        wls(W, y, np.repeat([0, 1], 15))


@pytest.mark.parametrize(
    "call, match",
    [
        (lambda W, y: ols(np.where(np.eye(10, 3, dtype=bool), np.nan, W), y), "NaN"),
        (lambda W, y: ols(W, np.r_[y[:-1], np.inf]), "NaN or infinite"),
        (lambda W, y: ols(W, y[:-1]), "rows"),
        (lambda W, y: ols(W[:, 0], y), "2-D"),
        (lambda W, y: ols(W[:3], y[:3]), "N > p"),
        (lambda W, y: ols(W, y, level=95), "level"),
        (lambda W, y: ols(W, y, names=["a"]), "names"),
        (lambda W, y: wls(W, y, np.zeros(9)), "groups"),
        (lambda W, y: wls(W, y, np.r_[np.zeros(9), np.nan]), "NaN"),
        (lambda W, y: wls(W, y, np.r_[np.zeros(7), np.ones(3)]), "N_j > rank"),
        (lambda W, y: wls(W, W @ np.ones(3), np.r_[np.zeros(5), np.ones(5)]), "noise-free"),
    ],
)
def test_bad_input_raises_input_error(call, match):
    """Reference: the documented InputError for each malformed argument."""
    rng = np.random.default_rng(7)
    W, y = rng.normal(size=(10, 3)), rng.normal(size=10)
    with pytest.raises(InputError, match=match):
        call(W, y)
