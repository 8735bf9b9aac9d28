"""ConvexSet contract of the set families (boundid.sets: Box, Zonotope, Parallelotope,
VertexPolytope, shadow, Polytope, Ellipsoid). Every expected value comes from an independent computation: the vertex
set (corners, all sign combinations of the generators) and Qhull (scipy.spatial.ConvexHull) for
support, intervals, membership, volume and shadows; HiGHS LPs (Polytope) for the shadow of an
H-polytope."""

from __future__ import annotations

import itertools

import numpy as np
import pytest
from scipy.spatial import ConvexHull

from boundid.errors import InputError
from boundid.sets import (
    Box,
    ConvexSet,
    Ellipsoid,
    Parallelotope,
    Polytope,
    VertexPolytope,
    Zonotope,
    shadow,
    support_values,
)


def _zonotope_points(c, G):
    """Every point c + G s, s in {-1, 1}^m: their hull is the zonotope."""
    signs = np.array(list(itertools.product([-1.0, 1.0], repeat=G.shape[1])))
    return c + signs @ G.T


def _instances(rng, p):
    """(set, its vertices) for each family in dimension p, random."""
    lo = rng.normal(size=p)
    box = Box(lo, lo + rng.uniform(0.2, 3.0, p))
    corners = _zonotope_points(box.center, np.diag(box.half_widths))
    c = rng.normal(size=p)
    G = rng.normal(size=(p, p + 2))
    Gp = rng.normal(size=(p, p))
    Z, P = Zonotope(c, G), Parallelotope(c, Gp)
    Vz = _zonotope_points(c, G)
    Vz = Vz[ConvexHull(Vz).vertices]
    Vp = _zonotope_points(c, Gp)
    pts = rng.normal(size=(12, p))
    V = VertexPolytope(pts)
    return [(box, corners), (Z, Vz), (P, Vp), (V, pts[ConvexHull(pts).vertices])]


@pytest.mark.parametrize("p", [2, 3])
def test_support_and_intervals_agree_with_the_vertices(p):
    """support(d) = max over the vertices of d^T v (vertices: corners / sign combinations /
    the given points), one direction at a time and batched (supports); intervals() =
    (-support(-e_j), support(e_j))."""
    rng = np.random.default_rng(10 + p)
    for S, V in _instances(rng, p):
        assert isinstance(S, ConvexSet)
        assert S.dim == p
        D = rng.normal(size=(20, p))
        for d in D:
            assert S.support(d) == pytest.approx(np.max(V @ d), rel=1e-12, abs=1e-12)
        np.testing.assert_allclose(S.supports(D), np.max(D @ V.T, axis=1), rtol=1e-12, atol=1e-12)
        lo, hi = S.intervals()
        np.testing.assert_allclose(lo, V.min(axis=0), rtol=1e-12, atol=1e-12)
        np.testing.assert_allclose(hi, V.max(axis=0), rtol=1e-12, atol=1e-12)
        E = np.eye(p)
        np.testing.assert_allclose(hi, [S.support(E[j]) for j in range(p)], rtol=1e-12, atol=1e-12)
        np.testing.assert_allclose(lo, [-S.support(-E[j]) for j in range(p)], rtol=1e-12, atol=1e-12)


def test_support_values_asks_a_set_without_supports_once_per_row():
    """support_values uses a family's batched supports, and a set of one's own that has only
    support (the ConvexSet protocol asks no more) once per direction: the same values."""
    box = Box([-1.0, 0.0], [1.0, 2.0])

    class OnlySupport:
        def support(self, d):
            return box.support(d)

    D = np.random.default_rng(5).normal(size=(6, 2))
    np.testing.assert_allclose(support_values(OnlySupport(), D), support_values(box, D), rtol=1e-15)


@pytest.mark.parametrize("p", [2, 3])
def test_contains_the_vertices_and_nothing_just_outside(p):
    """Every vertex is inside; every hull vertex pushed out by 1e-6 of its distance from the
    centroid is outside (contains allows rounding only); the centroid is inside."""
    rng = np.random.default_rng(20 + p)
    for S, V in _instances(rng, p):
        H = V[ConvexHull(V).vertices]
        g = V.mean(axis=0)
        assert np.all(S.contains(V)), type(S).__name__
        assert not np.any(S.contains(g + (1 + 1e-6) * (H - g))), type(S).__name__
        assert S.contains(g) is True
        assert S.contains(V).shape == (len(V),)


@pytest.mark.parametrize("p", [2, 3])
def test_log_volume_matches_qhull(p):
    """ln vol from each family's formula (sum of ln widths, McMullen's sum of |det| over
    generator subsets, 2^p |det G|, Qhull) against ConvexHull of the vertices."""
    rng = np.random.default_rng(30 + p)
    for S, V in _instances(rng, p):
        assert S.log_volume() == pytest.approx(np.log(ConvexHull(V).volume), rel=1e-10), type(S).__name__


def test_zonotope_membership_by_lp_agrees_with_the_facet_test(monkeypatch):
    """The LP fallback of Zonotope.contains (used when the facet normals are too many) against the
    facet-normal test on the same points: every vertex inside, every vertex pushed out by 1e-6
    outside, for a well-shaped and a nearly flat (1e-7 thin) zonotope."""
    import boundid.sets.zonotope as zmod

    rng = np.random.default_rng(9)
    G = rng.normal(size=(3, 5))
    thin = G.copy()
    thin[2] = thin[0] + 1e-7 * rng.normal(size=5)
    for Gk in (G, thin):
        V = _zonotope_points(np.ones(3), Gk)
        V = V[ConvexHull(V).vertices]
        pts = np.vstack([V, 1 + (1 + 1e-6) * (V - 1)])
        by_facets = Zonotope(np.ones(3), Gk).contains(pts)
        monkeypatch.setattr(zmod, "MAX_FACET_SUBSETS", 0)
        by_lp = Zonotope(np.ones(3), Gk).contains(pts)
        monkeypatch.undo()
        assert by_facets[: len(V)].all() and not by_facets[len(V):].any()
        np.testing.assert_array_equal(by_lp, by_facets)


def test_zonotope_membership_of_few_points_by_lp_without_the_facet_normals():
    """A zonotope with many generator subsets (p = 6, m = 12: C(12, 5) = 792 normals) tested at a
    few points uses the membership LP and never computes the normals; checked against the facet-
    normal test of the same zonotope at the same points (vertices c + G sign(G^T n) for random n:
    inside; the same pushed out to c + (1 + 1e-6)(x - c): outside)."""
    rng = np.random.default_rng(12)
    G = rng.normal(size=(6, 12))
    c = rng.normal(size=6)
    xi = np.sign(rng.normal(size=(2, 6)) @ G)
    pts = np.vstack([c + xi @ G.T, c + (1 + 1e-6) * (xi @ G.T)])
    Z = Zonotope(c, G)
    by_lp = np.array([Z.contains(x) for x in pts])
    assert Z._normals is None
    by_facets = Zonotope(c, G).contains(np.repeat(pts, 10, axis=0))[::10]   # enough points to pay for them
    np.testing.assert_array_equal(by_lp, [True, True, False, False])
    np.testing.assert_array_equal(by_facets, by_lp)


def test_log_volume_edge_cases():
    """A flat box or rank-deficient zonotope has ln vol = -inf; a zonotope with too many generator
    subsets reports NaN (the protocol's 'cannot say') rather than a guess."""
    assert Box([0.0, 0.0], [1.0, 0.0]).log_volume() == -np.inf
    assert Zonotope([0.0, 0.0], [[1.0, 2.0], [1.0, 2.0]]).log_volume() == -np.inf
    assert np.isnan(Zonotope(np.zeros(14), np.random.default_rng(0).normal(size=(14, 28))).log_volume())
    assert Zonotope([1.0], [[2.0, -1.0]]).log_volume() == pytest.approx(np.log(6.0))


@pytest.mark.parametrize("p", [3, 4])
def test_project_is_the_exact_shadow(p):
    """project(i, j) against Qhull of the projected vertices: same area, same vertex set, a 2-D
    set whose boundary is closed and counter-clockwise (positive signed area)."""
    rng = np.random.default_rng(40 + p)
    for S, V in _instances(rng, p):
        for i, j in [(0, 1), (p - 1, 0)]:
            sh = S.project(i, j)
            assert isinstance(sh, ConvexSet) and sh.dim == 2
            ref = ConvexHull(V[:, [i, j]])
            assert sh.log_volume() == pytest.approx(np.log(ref.volume), rel=1e-10)
            B = sh.boundary()
            np.testing.assert_array_equal(B[0], B[-1])
            x, y = B[:, 0], B[:, 1]
            assert 0.5 * np.sum(x[:-1] * y[1:] - x[1:] * y[:-1]) == pytest.approx(ref.volume, rel=1e-10)
            R = ref.points[ref.vertices]
            d = np.linalg.norm(B[:-1, None, :] - R[None], axis=2)
            assert d.shape[0] == d.shape[1] and d.min(axis=1).max() < 1e-10 and d.min(axis=0).max() < 1e-10


def test_shadow_of_an_lp_polytope_matches_its_vertices():
    """shadow(P, i, j) by support-point LPs (HiGHS) against Qhull of P's vertex enumeration
    (HalfspaceIntersection) projected on the plane."""
    rng = np.random.default_rng(7)
    p, N = 4, 40
    W = rng.normal(size=(N, p))
    y = W @ rng.normal(size=p) + rng.uniform(-1, 1, N)
    P = Polytope(W, y, 1.0)
    V = P.vertices()

    class LPOnly:
        """P with its support_point oracle only: one LP per query, no basis cones."""
        dim, n_lps = P.dim, 0

        def support_point(self, d):
            LPOnly.n_lps += 1
            return P.support_point(d)

    calls = {"cone": 0}
    real_cone = P.support_cone

    def counted(d):
        calls["cone"] += 1
        return real_cone(d)

    P.support_cone = counted
    with_cones = 0
    for i, j in [(0, 1), (2, 3), (3, 1)]:
        before = calls["cone"]
        sh = shadow(P, i, j)
        with_cones += calls["cone"] - before
        ref = VertexPolytope(V).project(i, j)
        assert sh.log_volume() == pytest.approx(ref.log_volume(), rel=1e-8)
        assert len(sh.vertices) == len(ref.vertices)
        assert np.all(ref.contains(sh.vertices)) and np.all(sh.contains(ref.vertices))
        # the same polygon from the LP-only oracle, with more LPs: the basis cones certify edges
        plain = shadow(LPOnly(), i, j)
        np.testing.assert_allclose(plain.vertices, sh.vertices, atol=1e-9)
    assert with_cones < 0.75 * LPOnly.n_lps


def test_parallelotope_strip_form_and_box():
    """from_strips gives {x : |n_k^T x - mid_k| <= half_k}: each strip's extent over the set
    (support in +-n_k) is [mid_k - half_k, mid_k + half_k]; from_box is the box itself."""
    rng = np.random.default_rng(3)
    N = rng.normal(size=(3, 3))
    mid, half = rng.normal(size=3), rng.uniform(0.5, 2, 3)
    P = Parallelotope.from_strips(N, mid, half)
    for k in range(3):
        assert P.support(N[k]) == pytest.approx(mid[k] + half[k])
        assert -P.support(-N[k]) == pytest.approx(mid[k] - half[k])
    B = Box([0.0, 1.0], [2.0, 4.0])
    PB = Parallelotope.from_box(B)
    np.testing.assert_allclose(PB.intervals(), B.intervals())
    assert PB.log_volume() == pytest.approx(B.log_volume())


def test_zonotope_reduction_contains_the_original():
    """reduced(k) has k generators and contains every vertex of the original zonotope
    (Combastel: the boxed generators' sum lies in their box)."""
    rng = np.random.default_rng(5)
    Z = Zonotope(rng.normal(size=3), rng.normal(size=(3, 9)))
    R = Z.reduced(6)
    assert R.n_generators == 6
    V = _zonotope_points(Z.center, Z.generators)
    assert np.all(R.contains(V[ConvexHull(V).vertices]))
    assert Z.reduced(9).n_generators == 9


def test_bad_input_is_refused_with_a_clear_error():
    with pytest.raises(InputError, match="lo <= hi"):
        Box([1.0, 0.0], [0.0, 1.0])
    with pytest.raises(InputError, match="singular"):
        Parallelotope([0.0, 0.0], [[1.0, 2.0], [2.0, 4.0]])
    with pytest.raises(InputError, match="square"):
        Parallelotope([0.0, 0.0], np.ones((2, 3)))
    with pytest.raises(InputError, match="different"):
        Box([0.0, 0.0], [1.0, 1.0]).project(1, 1)
    with pytest.raises(InputError, match="2-D"):
        Zonotope(np.zeros(3), np.eye(3)).boundary()
    with pytest.raises(InputError, match="flat"):
        VertexPolytope([[0.0, 0.0], [1.0, 1.0], [2.0, 2.0]])
    with pytest.raises(InputError, match="generators"):
        Zonotope([0.0, 0.0], np.ones((3, 2)))
    with pytest.raises(InputError, match="max_generators"):
        Zonotope(np.zeros(3), np.eye(3)).reduced(2)


def test_ellipsoid_implements_the_protocol():
    """Ellipsoid against closed forms: support(d) bounds d^T x over 20 000 boundary points and is
    attained at the maximiser c + S d / sqrt(d^T S d), which lies on the boundary; project(i, j)
    is the (i, j) block of S; gauge the Mahalanobis^2 (1 on the boundary, 4 at twice the distance)."""
    rng = np.random.default_rng(11)
    A = rng.normal(size=(3, 3))
    E = Ellipsoid(rng.normal(size=3), A @ A.T + 0.1 * np.eye(3))
    assert isinstance(E, ConvexSet) and E.dim == 3
    u = rng.normal(size=(20_000, 3))
    X = E.center + (u / np.linalg.norm(u, axis=1)[:, None]) @ np.linalg.cholesky(E.shape).T
    for d in rng.normal(size=(5, 3)):
        assert np.max(X @ d) <= E.support(d) + 1e-12
        x_star = E.center + E.shape @ d / np.sqrt(d @ E.shape @ d)
        assert d @ x_star == pytest.approx(E.support(d), rel=1e-12)
        assert E.gauge(x_star) == pytest.approx(1.0, rel=1e-12)
    sh = E.project(2, 0)
    np.testing.assert_array_equal(sh.shape, E.shape[np.ix_([2, 0], [2, 0])])
    np.testing.assert_allclose(E.gauge(X[:10]), 1.0, rtol=1e-12)
    assert E.gauge(E.center + 2 * (X[0] - E.center)) == pytest.approx(4.0)
    B = sh.boundary(50)
    x, y = B[:, 0], B[:, 1]
    np.testing.assert_array_equal(B[0], B[-1])
    assert 0.5 * np.sum(x[:-1] * y[1:] - x[1:] * y[:-1]) > 0


def test_polytope_implements_the_protocol():
    """Polytope (an H-polytope solved by HiGHS LPs) against Qhull of its vertices
    (HalfspaceIntersection): support and intervals (to LP accuracy), contains, ln volume, the
    shadow of project(i, j), and boundary() in 2-D; ln volume NaN above MAX_VERTEX_DIM."""
    rng = np.random.default_rng(12)
    W = rng.normal(size=(30, 3))
    P = Polytope(W, W @ rng.normal(size=3) + rng.uniform(-1, 1, 30), 1.0)
    V = P.vertices()
    assert isinstance(P, ConvexSet) and P.dim == 3
    for d in rng.normal(size=(10, 3)):
        assert P.support(d) == pytest.approx(np.max(V @ d), rel=1e-8, abs=1e-9)
    lo, hi = P.intervals()
    np.testing.assert_allclose(lo, V.min(axis=0), rtol=1e-8, atol=1e-9)
    np.testing.assert_allclose(hi, V.max(axis=0), rtol=1e-8, atol=1e-9)
    g = V.mean(axis=0)
    assert np.all(P.contains(V)) and not np.any(P.contains(g + (1 + 1e-6) * (V - g)))
    assert P.log_volume() == pytest.approx(np.log(ConvexHull(V).volume), rel=1e-10)
    sh = P.project(2, 1)
    assert sh.log_volume() == pytest.approx(np.log(ConvexHull(V[:, [2, 1]]).volume), rel=1e-8)
    assert np.isnan(P.gauge(g))
    W2 = rng.normal(size=(10, 2))
    P2 = Polytope(W2, W2 @ rng.normal(size=2), 1.0)
    B = P2.boundary()
    x, y = B[:, 0], B[:, 1]
    assert 0.5 * np.sum(x[:-1] * y[1:] - x[1:] * y[:-1]) == pytest.approx(ConvexHull(P2.vertices()).volume, rel=1e-10)
    W7 = rng.normal(size=(20, 7))
    assert np.isnan(Polytope(W7, W7 @ np.ones(7), 1.0).log_volume())


def test_gauge_is_one_on_the_boundary():
    """Box and parallelotope gauges are |T (x - c)|_inf: 0 at the centre, 1 at every vertex, 2 at
    a vertex pushed to twice its distance; the families without a cheap gauge give NaN."""
    rng = np.random.default_rng(13)
    for S, V in _instances(rng, 3):
        if isinstance(S, Box | Parallelotope):
            c = S.center
            assert S.gauge(c) == 0.0
            np.testing.assert_allclose(S.gauge(V), 1.0, rtol=1e-12)
            np.testing.assert_allclose(S.gauge(c + 2 * (V - c)), 2.0, rtol=1e-12)
        else:
            assert np.all(np.isnan(S.gauge(V)))
