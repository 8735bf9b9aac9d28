"""Tests of boundid.estimators.certify.validate (distance of a set estimate to the exact optimum)."""

from __future__ import annotations

import numpy as np
import pytest
from scipy.optimize import linprog
from scipy.spatial import HalfspaceIntersection

from boundid.errors import InputError
from boundid.estimators import OBE, BoxRecursion, Certificate, Estimate, PolytopeRecursion, validate
from boundid.sets import Box, Ellipsoid, Polytope, enclosing_ellipsoid


def _problem(seed, p, N, e=0.5):
    rng = np.random.default_rng(seed)
    theta = rng.normal(size=p)
    W = rng.normal(size=(N, p))
    y = W @ theta + rng.uniform(-e, e, N)
    return theta, W, y, e


def _linprog_bounds(W, y, e):
    """Independent LP bounds: scipy.optimize.linprog on the raw inequalities."""
    A = np.vstack([W, -W])
    b = np.concatenate([y + e, -(y - e)])
    p = W.shape[1]
    lo, hi = np.empty(p), np.empty(p)
    for j in range(p):
        c = np.zeros(p)
        c[j] = 1.0
        lo[j] = linprog(c, A_ub=A, b_ub=b, bounds=(None, None), method="highs").fun
        hi[j] = -linprog(-c, A_ub=A, b_ub=b, bounds=(None, None), method="highs").fun
    return lo, hi


def _qhull_vertices(W, y, e):
    """Independent vertex enumeration: scipy HalfspaceIntersection from the linprog Chebyshev centre."""
    A = np.vstack([W, -W])
    b = np.concatenate([y + e, -(y - e)])
    nrm = np.linalg.norm(A, axis=1)
    p = W.shape[1]
    res = linprog(np.r_[np.zeros(p), -1.0], A_ub=np.column_stack([A, nrm]), b_ub=b,
                  bounds=[(None, None)] * p + [(0, None)], method="highs")
    return HalfspaceIntersection(np.column_stack([A, -b]), res.x[:p]).intersections


@pytest.mark.parametrize("p", [2, 3])
def test_obe_estimate_certified_against_independent_references(p):
    """References: LP bounds by scipy linprog, vertices by scipy HalfspaceIntersection (both
    independent of boundid.sets). The OBE ellipsoid contains every vertex, its intervals are at
    least the LP bounds, and the volume excesses are ordered: over the inscribed ellipsoid >=
    over P >= over the minimum-volume outer ellipsoid >= 0."""
    theta, W, y, e = _problem(p, p, 12 * p)
    est = OBE(p, shape0=1e4).fit(W, y, e)
    cert = validate(est, Polytope.from_strips(W, y, e))
    assert isinstance(cert, Certificate)
    lo, hi = _linprog_bounds(W, y, e)
    np.testing.assert_allclose(cert.lp_lo, lo, atol=1e-7)
    np.testing.assert_allclose(cert.lp_hi, hi, atol=1e-7)
    V = _qhull_vertices(W, y, e)
    assert np.all(est.set.contains(V, rtol=1e-8))
    assert cert.contains_polytope and cert.vertex_kind == "all" and cert.n_outside == 0
    assert cert.n_vertices >= p + 1
    assert np.all(cert.width_ratio >= 1 - 1e-9)
    np.testing.assert_allclose(cert.width_ratio, (cert.hi - cert.lo) / (hi - lo), rtol=1e-6)
    assert cert.excess_inner >= cert.excess_polytope >= cert.excess_outer >= -1e-6
    assert cert.excess_inner - cert.excess_outer > 0.01


def test_exact_optimum_has_zero_excess_and_a_shrunk_ellipsoid_fails():
    """Reference: the minimum-volume ellipsoid of the vertices (sets.enclosing_ellipsoid) is the
    exact optimum: its outer excess is 0 and it contains P. Shrunk by 0.9 it must miss vertices."""
    theta, W, y, e = _problem(3, 2, 25)
    P = Polytope.from_strips(W, y, e)
    opt = enclosing_ellipsoid(P.vertices()).ellipsoid
    cert = validate(opt, P)
    assert cert.method == "Ellipsoid" and cert.contains_polytope
    assert abs(cert.excess_outer) <= 1e-6
    assert cert.excess_polytope > 0 and cert.excess_inner > cert.excess_polytope
    bad = validate(opt.scaled(0.9), P, outer=opt, volumes=True)
    assert not bad.contains_polytope and bad.n_outside >= 1 and bad.max_gauge > 1.1
    assert bad.excess_outer == pytest.approx(np.log(0.9), rel=1e-9)
    assert "NO" in bad.summary()


def test_p14_certificate_uses_lp_bound_vertices():
    """p = 14 (the H4 size): vertices cannot be enumerated, the 2p LP-bound vertices are checked;
    the S-procedure outer ellipsoid is the outer reference (it contains them too). The OBE
    intervals are several times wider than the exact bounds (~6x here)."""
    theta, W, y, e = _problem(14, 14, 200)
    est = OBE(14, shape0=1e4).fit(W, y, e)
    cert = validate(est, (W, y, e))
    assert cert.vertex_kind == "lp-bound" and cert.n_vertices == 28
    assert cert.contains_polytope
    assert np.isnan(cert.log_volume_polytope)
    assert np.all(cert.width_ratio >= 1.0) and np.mean(cert.width_ratio) > 2.0
    assert cert.excess_inner > cert.excess_outer > 0
    df = cert.to_frame()
    assert list(df.index) == [f"theta{j + 1}" for j in range(14)]
    assert "width_ratio" in df and "LP-bound" in cert.summary()


def test_volumes_can_be_skipped_and_references_reused():
    """volumes=False gives NaN excesses (no SDP); supplied references are used as given."""
    theta, W, y, e = _problem(5, 2, 20)
    P = Polytope.from_strips(W, y, e)
    est = OBE(2, shape0=1e4, names=["a", "b"]).fit(W, y, e)
    cert = validate(est, P, volumes=False)
    assert np.isnan(cert.excess_outer) and cert.contains_polytope
    assert cert.names == ("a", "b")
    ball = Ellipsoid.ball(np.zeros(2), 100.0)
    cert2 = validate(est, P, outer=ball, inner=ball)
    assert cert2.log_volume_outer == pytest.approx(ball.log_volume())
    assert cert2.outer_kind == "supplied"


def test_bad_input_raises_input_error():
    """Dimension mismatch, a point estimate, a wrong type -> InputError."""
    theta, W, y, e = _problem(6, 2, 20)
    P = Polytope.from_strips(W, y, e)
    with pytest.raises(InputError, match="dimension"):
        validate(Ellipsoid.ball(np.zeros(3), 1.0), P, volumes=False)
    point = Estimate("OLS", np.zeros(2), None, (np.zeros(2), np.zeros(2)), "point")
    with pytest.raises(InputError, match="no set"):
        validate(point, P)
    with pytest.raises(InputError):
        validate(np.eye(2), P)
    with pytest.raises(InputError):
        validate(Ellipsoid.ball(np.zeros(2), 1.0), "polytope")


def test_containment_verdict_near_the_boundary():
    """Closed form: the ball around the vertices' centroid through the farthest vertex has that
    vertex exactly on its boundary (Mahalanobis^2 = 1 to rounding). Shrunk by 1 - 1e-4 it must not
    contain the polytope (that vertex at 1/(1 - 1e-4)^2 ~ 1 + 2e-4); grown by 1 + 1e-6 it must (every
    vertex at <= 1/(1 + 1e-6)^2); the certifier's rounding slack (1e-8) lies between the two."""
    for seed, p in ((5, 2), (6, 3), (7, 4)):
        theta, W, y, e = _problem(seed, p, 10 * p)
        P = Polytope.from_strips(W, y, e)
        V = P.vertices()
        c = V.mean(axis=0)
        r = np.sqrt(np.max(np.sum((V - c) ** 2, axis=1)))
        ball = Ellipsoid.ball(c, r)
        exact = validate(ball, P, volumes=False)
        assert exact.contains_polytope and abs(exact.max_gauge - 1.0) < 1e-12
        shrunk = validate(ball.scaled(1 - 1e-4), P, volumes=False)
        assert not shrunk.contains_polytope and shrunk.n_outside >= 1
        assert shrunk.max_gauge == pytest.approx(1 / (1 - 1e-4) ** 2, rel=1e-9)
        grown = validate(ball.scaled(1 + 1e-6), P, volumes=False)
        assert grown.contains_polytope and grown.n_outside == 0
        assert grown.max_gauge <= 1 / (1 + 1e-6) ** 2 + 1e-12


@pytest.mark.parametrize("family", ["box", "polytope"])
def test_sets_of_other_families_are_certified_through_the_protocol(family):
    """Reference: scipy HalfspaceIntersection vertices and linprog bounds. A box recursion's box
    and the exact polytope recursion's polytope (p = 3) contain every vertex of P, their support
    is at least P's along every axis; their gauge: |T(x - c)|_inf <= 1 (box), NaN (polytope); the
    exact recursion's widths are the LP widths and its ln volume P's. The LP box itself passes,
    shrunk by 1e-3 it fails."""
    theta, W, y, e = _problem(9, 3, 30)
    prior = Box.from_center(np.zeros(3), 10.0)
    make = BoxRecursion if family == "box" else PolytopeRecursion
    est = make(3, prior=prior).fit(W, y, e)
    cert = validate(est, Polytope.from_strips(W, y, e))
    V = _qhull_vertices(W, y, e)
    assert np.all(est.set.contains(V, rtol=1e-8))
    assert cert.contains_polytope and cert.support_ok and cert.n_outside == 0
    assert np.all(cert.width_ratio >= 1 - 1e-7)
    if family == "box":
        assert cert.max_gauge <= 1 + 1e-9
        c, h = 0.5 * (cert.lp_lo + cert.lp_hi), 0.5 * (cert.lp_hi - cert.lp_lo)
        exact = validate(Box(c - h, c + h), Polytope.from_strips(W, y, e), volumes=False)
        bad = validate(Box(c - (1 - 1e-3) * h, c + (1 - 1e-3) * h), Polytope.from_strips(W, y, e), volumes=False)
        assert exact.contains_polytope and not bad.contains_polytope and not bad.support_ok
    else:
        assert np.isnan(cert.max_gauge)
        np.testing.assert_allclose(cert.width_ratio, 1.0, atol=1e-6)
        assert cert.excess_polytope == pytest.approx(0.0, abs=1e-6)


def test_certificate_brackets_the_excess_over_the_minimum_volume_outer_ellipsoid():
    """For p = 3 the minimum-volume ellipsoid containing P is computable exactly (the enclosing
    ellipsoid of every vertex, Qhull + Clarabel, an independent route): the certificate's bracket
    of the set's ln-volume excess per axis must contain the true excess, and the bracket's ends
    must straddle that optimum's ln vol."""
    from boundid.sets import sdp

    rng = np.random.default_rng(5)
    theta = rng.normal(size=3)
    W = rng.normal(size=(60, 3))
    y = W @ theta + rng.uniform(-0.2, 0.2, 60)
    P = Polytope(W, y, 0.2)
    est = OBE(3, shape0=100.0).fit(W, y, 0.2)
    bracket = sdp.min_volume_bracket(P)
    cert = validate(est, P, bracket=bracket)
    exact = sdp.enclosing_ellipsoid(P.vertices()).ellipsoid.log_volume()
    assert bracket.lower <= exact + 1e-6 and exact <= bracket.upper + 1e-9
    low, high = cert.excess_min_outer
    true_excess = (est.set.log_volume() - exact) / 3
    assert low - 1e-9 <= true_excess <= high + 1e-6
    assert "(bracketed)" in cert.summary()
