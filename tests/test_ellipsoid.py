"""Ellipsoid geometry against closed forms (areas, support functions, projections)."""

import numpy as np
import pytest

from boundid.errors import InputError
from boundid.sets import Ellipsoid, log_unit_ball_volume


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
