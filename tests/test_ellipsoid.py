"""Ellipsoid geometry against closed forms (areas, support functions, projections)."""

import pickle

import numpy as np
import pytest

from boundid.errors import InputError
from boundid.sets import Ellipsoid, RootInformationEllipsoid, log_unit_ball_volume


def test_volume_closed_form():
    # area of an ellipse with semi-axes 2 and 3 is 6 pi; ball volume in 3-D is 4/3 pi r^3
    assert Ellipsoid([0, 0], np.diag([4.0, 9.0])).volume() == pytest.approx(6 * np.pi)
    assert Ellipsoid.ball(np.zeros(3), 2.0).volume() == pytest.approx(4 / 3 * np.pi * 8)
    assert np.exp(log_unit_ball_volume(4)) == pytest.approx(np.pi**2 / 2)


def test_support_and_intervals_match_sampled_boundary():
    rng = np.random.default_rng(0)
    A = rng.normal(size=(2, 2))
    E = Ellipsoid([1.0, -2.0], A @ A.T + 0.1 * np.eye(2))
    pts = E.boundary(20001)
    d = np.array([0.3, -1.2])
    assert E.support(d) == pytest.approx((pts @ d).max(), rel=1e-6)
    D = rng.normal(size=(7, 2))
    np.testing.assert_allclose(E.supports(D), (D @ pts.T).max(axis=1), rtol=1e-6)
    lo, hi = E.intervals()
    np.testing.assert_allclose(lo, pts.min(axis=0), rtol=1e-6, atol=1e-9)
    np.testing.assert_allclose(hi, pts.max(axis=0), rtol=1e-6, atol=1e-9)
    assert np.all(E.contains(pts * (1 - 1e-9) + E.center * 1e-9))
    assert not np.any(E.contains(E.center + 1.001 * (pts - E.center)))


def test_information_and_projection():
    S = np.array([[2.0, 0.5, 0.1], [0.5, 1.0, 0.2], [0.1, 0.2, 3.0]])
    E = Ellipsoid(np.zeros(3), S)
    np.testing.assert_allclose(E.information @ S, np.eye(3), atol=1e-12)
    F = Ellipsoid.from_information(np.zeros(3), np.linalg.inv(S), sigma=4.0)
    np.testing.assert_allclose(F.shape, 4 * S)
    assert E.scaled(2.0).log_volume() == pytest.approx(E.log_volume() + 3 * np.log(2))
    P = E.project(2, 0)
    np.testing.assert_allclose(P.shape, [[3.0, 0.1], [0.1, 2.0]])


@pytest.mark.parametrize(
    "center, shape, match",
    [
        ([0, 0], [[1, 0], [0, -1]], "positive definite"),
        ([0, 0], [[1, 0.5], [0, 1]], "symmetric"),
        ([0, np.nan], np.eye(2), "NaN"),
        ([0, 0, 0], np.eye(2), "3 x 3"),
    ],
)
def test_bad_input_is_named(center, shape, match):
    with pytest.raises(InputError, match=match):
        Ellipsoid(center, shape)


def test_ellipsoid_owns_its_centre():
    """An Ellipsoid must not change when the caller's array does (estimators keep updating theirs)."""
    c = np.array([1.0, 2.0])
    E = Ellipsoid(c, np.eye(2))
    c += 10.0
    np.testing.assert_array_equal(E.center, [1.0, 2.0])


def _root_form(rng, n):
    """A well-conditioned ellipsoid in both forms: X from the QR of a random matrix, S = sigma (X^T X)^-1."""
    X = np.linalg.qr(rng.normal(size=(n + 3, n)))[1]
    X *= np.sign(np.diag(X))[:, None]  # positive diagonal
    z, sigma = rng.normal(size=n), rng.uniform(0.2, 3.0)
    E = RootInformationEllipsoid(X, z, sigma)
    return E, Ellipsoid(np.linalg.solve(X, z), sigma * np.linalg.inv(X.T @ X))


def test_root_information_form_answers_as_the_shape_form():
    """Second representation of the same set: every ConvexSet answer of {|X x - z|^2 <= sigma}
    (triangular solves with X) equals that of the Ellipsoid built from S = sigma (X^T X)^-1."""
    rng = np.random.default_rng(5)
    for n in (1, 2, 4, 7):
        R, E = _root_form(rng, n)
        np.testing.assert_allclose(R.center, E.center, rtol=1e-12, atol=1e-12)
        np.testing.assert_allclose(R.shape, E.shape, rtol=1e-10, atol=1e-12)
        np.testing.assert_allclose(R.information, E.information, rtol=1e-10, atol=1e-12)
        assert R.log_volume() == pytest.approx(E.log_volume(), rel=1e-12)
        np.testing.assert_allclose(R.semi_axes(), E.semi_axes(), rtol=1e-10)
        np.testing.assert_allclose(R.intervals(), E.intervals(), rtol=1e-10, atol=1e-12)
        D = rng.normal(size=(5, n))
        np.testing.assert_allclose(R.supports(D), E.supports(D), rtol=1e-10, atol=1e-12)
        assert R.support(D[0]) == pytest.approx(E.support(D[0]), rel=1e-10)
        np.testing.assert_allclose(R.extent(D[1]), E.extent(D[1]), rtol=1e-10, atol=1e-12)
        P = E.center + rng.normal(size=(50, n)) * np.sqrt(np.diag(E.shape))
        np.testing.assert_allclose(R.mahalanobis2(P), E.mahalanobis2(P), rtol=1e-10)
        np.testing.assert_array_equal(R.contains(P), E.contains(P))
        assert R.scaled(1.5).log_volume() == pytest.approx(E.scaled(1.5).log_volume(), rel=1e-12)
        if n >= 2:
            Rp, Ep = R.project(0, n - 1), E.project(0, n - 1)
            np.testing.assert_allclose(Rp.shape, Ep.shape, rtol=1e-10, atol=1e-12)
        if n == 2:
            B = R.boundary(64)
            np.testing.assert_allclose(E.mahalanobis2(B), 1.0, rtol=1e-10)
        again = pickle.loads(pickle.dumps(R))  # estimates travel to Dask workers
        np.testing.assert_array_equal(again.X, R.X) and np.testing.assert_array_equal(again.center, R.center)


def test_root_information_form_holds_what_no_shape_matrix_can():
    """Closed form: X = diag(1, 1e9) has S = diag(1, 1e-18), condition 1e18, beyond what a
    Cholesky factorisation in double precision can vouch for once rotated. Rotated by an
    orthogonal Q (X Q^T, re-triangularised by QR), the set is the same: the point at distance
    1 - 1e-9 along the thin axis is inside and 1 + 1e-6 is outside, as in exact arithmetic."""
    theta = 0.3
    Q = np.array([[np.cos(theta), -np.sin(theta)], [np.sin(theta), np.cos(theta)]])
    _, X = np.linalg.qr(np.diag([1.0, 1e9]) @ Q.T)
    X *= np.sign(np.diag(X))[:, None]
    c = np.array([2.0, -1.0])
    R = RootInformationEllipsoid(X, X @ c, 1.0)
    thin = Q[:, 1]  # the axis of semi-axis 1e-9
    assert R.contains(c + (1 - 1e-9) * 1e-9 * thin)
    assert not R.contains(c + (1 + 1e-6) * 1e-9 * thin)
    assert R.semi_axes() == pytest.approx([1.0, 1e-9], rel=1e-7)
    assert R.support(thin) - thin @ R.center == pytest.approx(1e-9, rel=1e-7)


@pytest.mark.parametrize("X, z, sigma, match", [
    (np.array([[1.0, 0.0], [1.0, 1.0]]), [0.0, 0.0], 1.0, "upper triangular"),
    (np.array([[1.0, 0.0], [0.0, -1.0]]), [0.0, 0.0], 1.0, "positive diagonal"),
    (np.eye(2), [0.0, np.nan], 1.0, "z"),
    (np.eye(2), [0.0, 0.0], 0.0, "sigma"),
    (np.eye(2), [0.0, 0.0], np.inf, "sigma"),
    (np.eye(3), [0.0, 0.0], 1.0, "X must have 2 columns"),
])
def test_root_information_bad_input_is_named(X, z, sigma, match):
    with pytest.raises(InputError, match=match):
        RootInformationEllipsoid(X, z, sigma)


def test_from_factor_is_the_shape_form_of_its_factor():
    """Reference: Ellipsoid(c, L L^T). The factor is used as given (no second factorisation), and a
    factor that is not lower triangular with a positive diagonal is refused."""
    rng = np.random.default_rng(8)
    L = np.tril(rng.normal(size=(4, 4)))
    L[np.diag_indices(4)] = np.abs(np.diag(L)) + 0.1
    c = rng.normal(size=4)
    E, ref = Ellipsoid.from_factor(c, L), Ellipsoid(c, L @ L.T)
    np.testing.assert_array_equal(E.factor, L)
    assert E.log_volume() == pytest.approx(ref.log_volume(), rel=1e-12)
    D = rng.normal(size=(6, 4))
    np.testing.assert_allclose(E.supports(D), ref.supports(D), rtol=1e-12)
    with pytest.raises(InputError, match="lower-triangular"):
        Ellipsoid.from_factor(c, L.T)
    with pytest.raises(InputError, match="positive"):
        Ellipsoid.from_factor(c, -L)
