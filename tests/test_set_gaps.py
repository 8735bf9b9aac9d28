"""Set-family cases no other test reached (gaps found by the mutation run)."""

from __future__ import annotations

import numpy as np
import pytest

from boundid.errors import InputError
from boundid.sets import Ellipsoid
from boundid.sets.zonotope import Zonotope


def test_semi_axes_are_the_square_roots_of_the_eigenvalues_largest_first():
    """Closed form: the shape R diag(9, 4, 1) R^T has semi-axes 3, 2, 1."""
    R, _ = np.linalg.qr(np.random.default_rng(0).normal(size=(3, 3)))
    E = Ellipsoid(np.zeros(3), R @ np.diag([1.0, 9.0, 4.0]) @ R.T)
    np.testing.assert_allclose(E.semi_axes(), [3.0, 2.0, 1.0], rtol=1e-12)


def test_flat_zonotope_membership_of_several_points():
    """Closed form: generators (1, 1) and (2, 2) span the segment c + t (1, 1), |t| <= 3 (the LP path,
    G rank deficient). Off the line and beyond the end are outside, on the segment inside, each
    point judged on its own whatever the points before it."""
    Z = Zonotope(np.array([1.0, -1.0]), np.array([[1.0, 2.0], [1.0, 2.0]]))
    pts = np.array([[1.0, 0.0],          # off the line
                    [5.0, 3.0],          # on the line, t = 4 > 3
                    [2.5, 0.5],          # t = 1.5
                    [0.0, 1.0],          # off the line
                    [-2.0, -4.0]])       # t = -3, the end
    np.testing.assert_array_equal(Z.contains(pts), [False, False, True, False, True])


def test_zonotope_refuses_a_transposed_generator_matrix():
    """G must be (p, m): for p = 1 a column (3, 1) is three rows, not three generators."""
    with pytest.raises(InputError):
        Zonotope(np.array([0.0]), np.ones((3, 1)))
