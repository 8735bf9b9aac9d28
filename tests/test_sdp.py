"""Tests of boundid.sets.sdp: inscribed, S-procedure, John, point-enclosing and one-step ellipsoids."""

from __future__ import annotations

import cvxpy as cp
import numpy as np
import pytest
from scipy.optimize import linprog

from boundid.errors import InfeasibleDataError, InputError, SolverError
from boundid.sets import Ellipsoid, Polytope, log_unit_ball_volume, sdp


def random_polytope(seed, p, N):
    rng = np.random.default_rng(seed)
    W = rng.normal(size=(N, p))
    e = 0.5 + rng.random(N)
    y = W @ rng.normal(size=p) + e * rng.uniform(-1, 1, N)
    return Polytope.from_strips(W, y, e)


def boundary(E: Ellipsoid, n=4000, seed=0):
    """Random points on the boundary of E."""
    U = np.random.default_rng(seed).normal(size=(n, E.dim))
    U /= np.linalg.norm(U, axis=1)[:, None]
    return E.center + U @ np.linalg.cholesky(E.shape).T


def test_inner_ellipsoid_of_box_is_half_sides():
    """Closed form: the maximum-volume ellipsoid in a box is axis-aligned with the half-sides as
    semi-axes, centred at the box centre."""
    P = Polytope.from_strips(np.eye(3), np.array([1.0, -2.0, 0.5]), np.array([1.0, 0.2, 3.0]))
    r = sdp.inner_ellipsoid(P)
    assert r.status == "optimal" and r.solver.startswith("interior point, Zhang-Gao")
    assert np.allclose(r.ellipsoid.center, [1.0, -2.0, 0.5], atol=1e-6)
    assert np.allclose(r.ellipsoid.shape, np.diag([1.0, 0.04, 9.0]), rtol=1e-5, atol=1e-7)


def test_enclosing_ellipsoid_of_square_is_circumcircle():
    """Closed form: the minimum-volume ellipse through a square's vertices is its circumcircle."""
    V = np.array([[1.0, 1.0], [1.0, -1.0], [-1.0, 1.0], [-1.0, -1.0]]) * 2.0 + [3.0, -1.0]
    r = sdp.enclosing_ellipsoid(V)
    assert np.allclose(r.ellipsoid.center, [3.0, -1.0], atol=1e-6)
    assert np.allclose(r.ellipsoid.shape, 8.0 * np.eye(2), rtol=1e-6)
    assert np.all(r.ellipsoid.contains(V))


@pytest.mark.parametrize("p,N,seed", [(2, 20, 0), (2, 60, 1), (3, 40, 2), (3, 80, 3)])
def test_volume_chain_and_containment(p, N, seed):
    """vol(inner) <= vol(P) <= vol(min-vol around vertices) <= vol(outer), vol(John); the outer
    and John ellipsoids contain every vertex of P (independent vertex enumeration by Qhull), and
    random boundary points of the inner ellipsoid satisfy every strip. (outer <= John is not a
    theorem: for a triangle John's ellipsoid is the minimum-volume one, so it is not asserted.)"""
    P = random_polytope(seed, p, N)
    V = P.vertices()
    inner, outer, john = sdp.inner_ellipsoid(P), sdp.outer_ellipsoid(P), sdp.john_outer(P)
    around = sdp.enclosing_ellipsoid(V)
    vol = P.volume()
    assert inner.ellipsoid.volume() <= vol <= around.ellipsoid.volume() * (1 + 1e-9)
    assert around.ellipsoid.volume() <= outer.ellipsoid.volume() * (1 + 1e-6)
    assert around.ellipsoid.volume() <= john.ellipsoid.volume() * (1 + 1e-6)
    for r in (outer, john, around):
        assert np.all(r.ellipsoid.contains(V))
    assert np.all(P.contains(boundary(inner.ellipsoid), rtol=1e-9))
    assert outer.info["max_reduced_cost"] <= outer.info["price_tol"]
    # John's ellipsoid is p x the inner one (solved once per P), vertex-checked
    np.testing.assert_allclose(john.ellipsoid.center, inner.ellipsoid.center)
    np.testing.assert_allclose(john.ellipsoid.shape, p**2 * inner.ellipsoid.shape * john.info["vertex_repair"])


@pytest.mark.parametrize("seed,p,N,min_rounds,drop", [(4, 3, 120, 1, False), (2, 2, 50, 2, False),
                                                      (2, 2, 50, 2, True)])
def test_inner_constraint_generation_equals_full_sdp(seed, p, N, min_rounds, drop, monkeypatch):
    """The constraint-generation inner ellipsoid (interior point, box frame) equals a direct
    cvxpy solve with every strip in the other formulation, log det of the symmetric square root
    (second algorithm, unscaled but well conditioned here); the second case needs a second
    round of constraint generation (the seed sides alone are not enough); the third is the
    second with every side the ellipsoid does not violate (by more than the 1e-7 the rounds
    accept; the sides it touches too) dropped from the working set after a round."""
    if drop:
        monkeypatch.setattr(sdp, "_INNER_DROP", -1e-7)
    P = random_polytope(seed, p, N)
    r = sdp.inner_ellipsoid(P)
    assert (r.info["sides_dropped"] > 0) == drop
    B, x0 = cp.Variable((p, p), PSD=True), cp.Variable(p)
    Wn, c = P.W / P.e_max[:, None], P.y / P.e_max
    cons = [cp.norm(Wn @ B, 2, axis=1) + cp.abs(Wn @ x0 - c) <= 1]
    cp.Problem(cp.Maximize(cp.log_det(B)), cons).solve(solver=cp.CLARABEL)
    ref = Ellipsoid(x0.value, B.value @ B.value)
    assert r.ellipsoid.log_volume() == pytest.approx(ref.log_volume(), abs=1e-5)
    assert np.allclose(r.ellipsoid.center, ref.center, atol=1e-5 * np.abs(ref.center).max())
    assert r.info["working_sides"] < 2 * N and r.info["rounds"] >= min_rounds


def test_inner_ellipsoid_when_the_triangular_form_fails(monkeypatch):
    """A polytope with halfspace priors on which Clarabel fails on the triangular-factor form (1 in
    about 120 such random polytopes): with the interior-point method made to fail, the same working
    set is solved in the symmetric root's log-det form, and the answer equals a direct cvxpy solve
    of that form with every side."""

    def fails(A, b, x0=None):
        raise SolverError("inner_ellipsoid: made to fail")

    monkeypatch.setattr(sdp, "max_volume_inscribed", fails)
    r = np.random.default_rng(1)
    W = r.normal(size=(60, 4))
    y = W @ r.normal(size=4) + r.uniform(-1, 1, 60)
    H, hv = r.normal(size=(3, 4)), np.abs(r.normal(size=3)) + 0.5
    P = Polytope.from_strips(W, y, 1.0, halfspaces=(H, hv))
    res = sdp.inner_ellipsoid(P)
    assert res.info["formulation"].startswith("symmetric root")
    B, x0 = cp.Variable((4, 4), PSD=True), cp.Variable(4)
    A, b = np.vstack([W, -W, H]), np.concatenate([y + 1.0, 1.0 - y, hv])
    cp.Problem(cp.Maximize(cp.log_det(B)), [cp.norm(A @ B, 2, axis=1) + A @ x0 <= b]).solve(solver=cp.CLARABEL)
    assert res.ellipsoid.log_volume() == pytest.approx(Ellipsoid(x0.value, B.value @ B.value).log_volume(), abs=1e-5)
    assert np.all(P.contains(boundary(res.ellipsoid), rtol=1e-9))


def test_outer_ellipsoid_is_cached_per_arguments():
    """outer_ellipsoid is solved once per polytope and arguments (the volume bracket reuses it); other
    arguments solve again."""
    P = random_polytope(3, 3, 60)
    first = sdp.outer_ellipsoid(P)
    assert sdp.outer_ellipsoid(P) is first and sdp.min_volume_bracket(P).upper_result is first
    assert sdp.outer_ellipsoid(P, price_tol=1e-7) is not first


def test_outer_p14_contains_lp_vertices_and_samples():
    """p = 14: the S-procedure ellipsoid contains the 28 LP-bound vertices and random points of
    P (hit-and-run-free check: convex combinations of those vertices), and its projections
    contain the exact LP intervals; it is not smaller than the inner ellipsoid."""
    P = random_polytope(6, 14, 300)
    b = P.bounds()
    out = sdp.outer_ellipsoid(P)
    inner = sdp.inner_ellipsoid(P)
    V = b.vertices()
    lam = np.random.default_rng(0).dirichlet(np.ones(len(V)), size=500)
    assert np.all(out.ellipsoid.contains(np.vstack([V, lam @ V])))
    lo, hi = out.ellipsoid.intervals()
    assert np.all(lo <= b.lo + 1e-9) and np.all(hi >= b.hi - 1e-9)
    assert inner.ellipsoid.log_volume() < out.ellipsoid.log_volume()


def test_step_ellipsoid_centred_strip_brute_force():
    """Unit disc ∩ {|x2| <= h}: by symmetry the optimum is x^2/a^2 + y^2/b^2 <= 1 with a >= 1 and
    (1-h^2)/a^2 + h^2/b^2 <= 1; minimise a b over a fine grid of a (brute force)."""
    E = Ellipsoid.ball([0.0, 0.0], 1.0)
    for h in (0.3, 0.5, 0.8):
        a = np.linspace(1.0, 3.0, 200_001)
        bb = h / np.sqrt(1 - (1 - h**2) / a**2)
        i = np.argmin(a * bb)
        r = sdp.step_ellipsoid(E, [0.0, 1.0], 0.0, h)
        assert np.allclose(np.sort(r.ellipsoid.semi_axes()), np.sort([a[i], bb[i]]), rtol=1e-4)
        assert np.allclose(r.ellipsoid.center, 0.0, atol=1e-6)


def test_step_ellipsoid_off_centre_vs_enclosing_points():
    """An ellipse cut by an oblique off-centre strip: the S-procedure step equals the minimum-volume
    ellipse around dense samples of the boundary of E ∩ strip (second algorithm); containment of
    those samples is exact. The reference may fall back to SCS (its answer made to contain every
    point): on these ~10,000 dense, nearly collinear hull points Clarabel ends 'optimal_inaccurate' under
    the SSE OpenBLAS kernels (Prescott, Nehalem, Sandybridge) and 'optimal' under Haswell and SkylakeX."""
    E = Ellipsoid([1.0, -0.5], [[2.0, 0.6], [0.6, 0.5]])
    w, y, e = np.array([0.7, -1.2]), 1.9, 0.6
    r = sdp.step_ellipsoid(E, w, y, e)
    B = boundary(E, 20000, seed=1)
    B = B[np.abs(y - B @ w) <= e]
    # boundary of the strip inside E: points on the two lines, clipped to E
    t = np.linspace(-5, 5, 20001)
    d = np.array([1.2, 0.7]) / np.hypot(1.2, 0.7)
    lines = [(y + s * e) * w / (w @ w) + t[:, None] * d for s in (-1, 1)]
    L = np.vstack([ln[E.contains(ln)] for ln in lines])
    pts = np.vstack([B, L])
    ref = sdp.enclosing_ellipsoid(pts, allow_fallback=True)
    assert np.all(r.ellipsoid.contains(pts, rtol=1e-7))
    assert r.ellipsoid.log_volume() == pytest.approx(ref.ellipsoid.log_volume(), abs=2e-3)


def test_step_ellipsoid_no_cut_and_outlier():
    """A strip wider than E leaves E unchanged; a strip missing E raises InfeasibleDataError."""
    E = Ellipsoid.ball([0.0, 0.0, 0.0], 1.0)
    r = sdp.step_ellipsoid(E, [1.0, 0.0, 0.0], 0.0, 2.0)
    assert r.status == "no_cut" and r.ellipsoid is E
    with pytest.raises(InfeasibleDataError, match="outlier"):
        sdp.step_ellipsoid(E, [1.0, 0.0, 0.0], 5.0, 1.0)


def test_bad_inputs_raise():
    """Flat point sets, NaN points, wrong shapes, infeasible P: the named errors."""
    with pytest.raises(InputError, match="span"):
        sdp.enclosing_ellipsoid(np.array([[0.0, 0.0], [1.0, 1.0], [2.0, 2.0]]))
    with pytest.raises(InputError, match="NaN"):
        sdp.enclosing_ellipsoid(np.array([[0.0, np.nan], [1.0, 1.0], [2.0, 0.0]]))
    E = Ellipsoid.ball([0.0, 0.0], 1.0)
    with pytest.raises(InputError, match="length 2"):
        sdp.step_ellipsoid(E, [1.0, 0.0, 0.0], 0.0, 1.0)
    with pytest.raises(InputError, match="e_max"):
        sdp.step_ellipsoid(E, [1.0, 0.0], 0.0, -1.0)
    bad = Polytope.from_strips(np.vstack([np.eye(2), np.eye(2)]), [0.0, 0.0, 5.0, 5.0], 1.0)
    for f in (sdp.inner_ellipsoid, sdp.outer_ellipsoid, sdp.john_outer):
        with pytest.raises(InfeasibleDataError):
            f(bad)


@pytest.mark.parametrize("p,N,seed", [(2, 40, 0), (3, 60, 1), (3, 150, 5), (5, 400, 7)])
def test_outer_column_generation_equals_full_s_procedure(p, N, seed):
    """The column-generation outer ellipsoid equals the S-procedure solved in one piece on EVERY
    strip, each tightened to P's extent taken from the Qhull vertices (independent of the LPs),
    plus the LP box; it is never larger than the old reference (every non-redundant strip,
    tightened) and uses far fewer strips in its SDP. The reference is solved by Clarabel, ours in
    the multipliers (boundid.sets._s_lagrangian): two algorithms."""
    P = random_polytope(seed, p, N)
    out = sdp.outer_ellipsoid(P)
    origin, scale = P.box_frame()
    b = P.bounds()
    Vz = (P.vertices() - origin) / scale
    G = P.W * scale
    G /= np.linalg.norm(G, axis=1)[:, None]
    proj = Vz @ G.T
    lo = np.concatenate([(b.lo - origin) / scale, proj.min(axis=0)])
    hi = np.concatenate([(b.hi - origin) / scale, proj.max(axis=0)])
    Gs = np.vstack([np.eye(p), G])
    A0, *_ = sdp._s_procedure(Gs, 0.5 * (lo + hi), 0.5 * (hi - lo), [], False, "reference")
    logvol_ref = -0.5 * np.linalg.slogdet(A0)[1] + np.sum(np.log(scale))
    logvol_ours = out.ellipsoid.log_volume() - log_unit_ball_volume(p)
    assert logvol_ours == pytest.approx(logvol_ref, abs=1e-4)
    old = sdp.outer_ellipsoid(P, strips=P.nonredundant())
    assert out.ellipsoid.log_volume() <= old.ellipsoid.log_volume() + 1e-6
    assert len(out.strips) < N
    assert out.info["max_reduced_cost"] <= out.info["price_tol"]


def _textbook_s_procedure(Gs, mid, half, extra):
    """ln det A0 of the S-procedure in its textbook form ([Boyd1994] §3.7.2): variables (A0, b0,
    multipliers), the (2n+1)-square LMI [[A0 - SA, b0 - Sb, 0], [., -1 - Sc, b0^T], [0, b0, -A0]] <= 0."""
    m, n = Gs.shape
    A0, b0 = cp.Variable((n, n), symmetric=True), cp.Variable((n, 1))
    tau, sig = cp.Variable(m, nonneg=True), cp.Variable(len(extra), nonneg=True)
    SA = Gs.T @ cp.diag(tau) @ Gs + sum(sig[i] * A for i, (A, _, _) in enumerate(extra))
    Sb = cp.reshape(-(Gs.T * mid) @ tau + sum(sig[i] * b for i, (_, b, _) in enumerate(extra)), (n, 1), order="F")
    Sc = (mid**2 - half**2) @ tau + sum(sig[i] * c for i, (_, _, c) in enumerate(extra))
    M = cp.bmat([[A0 - SA, b0 - Sb, np.zeros((n, n))],
                 [(b0 - Sb).T, cp.reshape(-1 - Sc, (1, 1), order="F"), b0.T],
                 [np.zeros((n, n)), b0, -A0]])
    cp.Problem(cp.Maximize(cp.log_det(A0)), [0.5 * (M + M.T) << 0]).solve(solver=cp.CLARABEL)
    return np.linalg.slogdet(A0.value)[1]


@pytest.mark.parametrize("seed,n,m,ball", [(0, 2, 5, False), (1, 3, 12, False), (2, 4, 9, True), (3, 6, 30, False)])
def test_s_procedure_equals_textbook_form(seed, n, m, ball):
    """The S-procedure as solved (max ln det SA over the multipliers, an (n+1)-square LMI) has the
    optimum of the textbook (2n+1)-square form in (A0, b0, multipliers), a second formulation;
    and its multipliers certify its ellipsoid exactly: sum tau_k q_k + sum sig_i q_i equals
    (z - c)^T A0 (z - c) - 1, so every point of the strips (and quadrics) lies inside."""
    rng = np.random.default_rng(seed)
    Gs = rng.normal(size=(m, n))
    Gs /= np.linalg.norm(Gs, axis=1)[:, None]
    z0 = rng.normal(size=n) * 0.3
    half = 0.5 + rng.random(m)
    mid = Gs @ z0 + 0.3 * half * rng.uniform(-1, 1, m)
    if not ball:                                       # make the strips bound the set
        Gs, mid, half = np.vstack([np.eye(n), Gs]), np.concatenate([z0, mid]), np.concatenate([np.ones(n), half])
    extra = [(np.eye(n), np.zeros(n), -1.0)] if ball else []
    A0, b0, tau, sig, *_ = sdp._s_procedure(Gs, mid, half, extra, False, "test")
    assert np.linalg.slogdet(A0)[1] == pytest.approx(_textbook_s_procedure(Gs, mid, half, extra), abs=1e-5)
    c = -np.linalg.solve(A0, b0)
    Z = rng.normal(size=(7, n))
    for z in Z:
        q = np.sum(tau * ((Gs @ z - mid) ** 2 - half**2)) + sum(s * (z @ A @ z + 2 * b @ z + cc)
                                                             for s, (A, b, cc) in zip(sig, extra, strict=True))
        assert q == pytest.approx((z - c) @ A0 @ (z - c) - 1, rel=1e-9, abs=1e-9)


@pytest.mark.parametrize("p,N,seed", [(2, 30, 0), (3, 60, 2), (4, 80, 3)])
def test_min_volume_bracket_against_vertex_enumeration(p, N, seed):
    """lower <= ln vol(minimum-volume ellipsoid of ALL vertices of P: Qhull, then the SDP of
    enclosing_ellipsoid, a second algorithm) <= upper, with the lower end from LP support points
    only (vertices=False); it is close to the exact optimum (within 0.05 per axis), and with
    vertices=True it equals it (to 1e-6)."""
    P = random_polytope(seed, p, N)
    exact = sdp.enclosing_ellipsoid(P.vertices()).ellipsoid.log_volume()
    br = sdp.min_volume_bracket(P, vertices=False)
    assert br.lower <= exact + 1e-6 and exact <= br.upper + 1e-6
    assert (exact - br.lower) / p < 0.05
    assert br.gap_per_axis >= -1e-9
    full = sdp.min_volume_bracket(P)
    assert full.lower == pytest.approx(exact, abs=1e-6)


@pytest.mark.slow
def test_min_volume_bracket_p14():
    """p = 14: the bracket is ordered and its lower ellipsoid contains the LP-bound vertices."""
    P = random_polytope(6, 14, 300)
    br = sdp.min_volume_bracket(P)
    assert br.lower <= br.upper
    assert np.all(br.points_ellipsoid.contains(P.bounds().vertices(), rtol=1e-6))
    assert br.points_gap <= 1e-6 * 14


@pytest.mark.parametrize("seed", range(6))
def test_john_outer_contains_a_simplex(seed):
    """On a triangle p x the exact inner ellipsoid passes through every vertex (John's bound is
    tight for a simplex), so the solver's near-optimal inner ellipsoid leaves vertices just
    outside: john_outer must still contain every vertex (enumerated by halfspace intersection,
    scipy/Qhull) and never raise for p <= 6. The lesson-1 triangle of the teaching suite is the
    case that raised before."""
    rng = np.random.default_rng(seed)
    V = rng.normal(size=(3, 2))
    c = V.mean(axis=0)
    W, y, e = [], [], []
    for i in range(3):                       # one strip per side, the opposite vertex on its far edge
        a, b = V[i], V[(i + 1) % 3]
        n = np.array([b[1] - a[1], a[0] - b[0]])
        n /= np.linalg.norm(n)
        near, far = n @ a, n @ V[(i + 2) % 3]
        W.append(n), y.append(0.5 * (near + far)), e.append(0.5 * abs(near - far))
    P = Polytope(np.array(W), np.array(y), np.array(e))
    assert P.contains(c)
    john = sdp.john_outer(P)
    assert np.all(john.ellipsoid.mahalanobis2(P.vertices()) <= 1 + 1e-12)
    assert np.all(john.ellipsoid.mahalanobis2(V) <= 1 + 1e-9)


def test_polytope_ellipsoids_equal_the_calls_on_a_fresh_polytope():
    """The stage's ellipsoids (the inscribed, the outer, John's, on one polytope that caches its LP
    work) are those of the three calls on a fresh copy of the polytope, in the caller's order of
    names; and the outer one, certified, still contains every vertex (Qhull, independent of the LPs)."""
    P, Q = random_polytope(3, 5, 300), random_polytope(3, 5, 300)
    got = sdp.polytope_ellipsoids(P)
    ref = {"outer": sdp.outer_ellipsoid(Q), "inner": sdp.inner_ellipsoid(Q), "john": sdp.john_outer(Q)}
    assert list(got) == ["outer", "inner", "john"]
    for name, (res, seconds) in got.items():
        assert isinstance(res, sdp.SDPResult) and seconds > 0
        np.testing.assert_allclose(res.ellipsoid.center, ref[name].ellipsoid.center, rtol=1e-12, atol=1e-12)
        np.testing.assert_allclose(res.ellipsoid.shape, ref[name].ellipsoid.shape, rtol=1e-12, atol=1e-12)
    assert np.all(got["outer"][0].ellipsoid.contains(P.vertices()))


def test_polytope_ellipsoids_report_a_failure_and_keep_the_others(monkeypatch):
    """A failing inscribed ellipsoid comes back as its exception (John's, which needs it, too);
    the outer one is still solved; an unknown name is refused."""
    P = random_polytope(4, 3, 60)

    def fails(*args, **kwargs):
        raise SolverError("inner_ellipsoid: made to fail")

    monkeypatch.setattr(sdp, "inner_ellipsoid", fails)
    got = sdp.polytope_ellipsoids(P)
    assert isinstance(got["inner"][0], SolverError) and isinstance(got["john"][0], SolverError)
    assert np.all(got["outer"][0].ellipsoid.contains(P.vertices()))
    with pytest.raises(InputError, match="unknown ellipsoids"):
        sdp.polytope_ellipsoids(P, ("outer", "lowner"))


def test_step_ellipsoid_of_an_ill_conditioned_ellipsoid_contains_the_cut():
    """E with condition 1e8 cut on one side: every point of E ∩ strip (the rim of the cut and E's
    boundary inside the strip, sampled from E's own Cholesky factor, independent of the SDP) lies
    in the step ellipsoid as judged in parameter space. The certificate is exact in E's unit-ball
    coordinates; without the rounding margin of the map back, 4 in 10 such points came out
    ~5e-9 outside (a case found in review)."""
    rng = np.random.default_rng([0, 94])
    n = int(rng.integers(1, 15))
    Q, _ = np.linalg.qr(rng.normal(size=(n, n)))
    ev = 10.0 ** rng.uniform(-4, 4, n)
    ev[0], ev[-1] = 1e-4, 1e4
    S = (Q * ev) @ Q.T
    S = 0.5 * (S + S.T)
    c = rng.normal(size=n) * 10.0 ** rng.uniform(-2, 3)
    w = rng.normal(size=n)
    r = np.sqrt(w @ S @ w)
    e = r * rng.uniform(0.05, 0.9)
    y = w @ c + rng.uniform(-1, 1) * (r - e) * 1.2
    E = Ellipsoid(c, S)
    res = sdp.step_ellipsoid(E, w, y, e)
    L = np.linalg.cholesky(S)
    u = L.T @ w / r
    lo, hi = (y - e - w @ c) / r, (y + e - w @ c) / r
    assert res.status == "optimal" and n == 4 and -1 < lo < 1 <= hi     # cut on one side only
    Z = rng.normal(size=(20000, n))
    rim = Z - np.outer(Z @ u, u)
    rim = lo * u + rim / np.linalg.norm(rim, axis=1)[:, None] * np.sqrt(1 - lo**2)
    sphere = Z / np.linalg.norm(Z, axis=1)[:, None]
    sphere = sphere[sphere @ u >= lo]
    assert np.all(res.ellipsoid.contains(c + np.vstack([rim, sphere]) @ L.T))


@pytest.mark.parametrize("p,N,seed", [(8, 300, 0), (12, 600, 2)])
def test_outer_priced_by_targets_equals_full_s_procedure(p, N, seed):
    """Above p = 6 (no vertex enumeration) the pricing settles most candidate strips with LPs stopped
    at a target (``sides_reached``); the ellipsoid still equals the S-procedure solved in one piece on
    EVERY strip tightened to P's extent, each extent from scipy's linprog (a separate solver), plus
    the LP box: the strips left loose could not have helped."""
    P = random_polytope(seed, p, N)
    out = sdp.outer_ellipsoid(P)
    assert out.info["sides_reached"] > 0
    origin, scale = P.box_frame()
    G = P.W * scale
    nrm = np.linalg.norm(G, axis=1)
    G /= nrm[:, None]
    A_ub = np.vstack([P.W, -P.W])
    b_ub = np.concatenate([P.y + P.e_max, P.e_max - P.y])

    def extent(g):                                  # max of g^T z over P, z = (theta - origin) / scale
        res = linprog(-(g / scale), A_ub=A_ub, b_ub=b_ub, bounds=(None, None), method="highs")
        assert res.status == 0
        return -res.fun - g @ (origin / scale)

    D = np.vstack([np.eye(p), G])
    hi = np.array([extent(g) for g in D])
    lo = -np.array([extent(-g) for g in D])
    A0, *_ = sdp._s_procedure(D, 0.5 * (lo + hi), 0.5 * (hi - lo), [], False, "reference")
    logvol_ref = -0.5 * np.linalg.slogdet(A0)[1] + np.sum(np.log(scale))
    assert out.ellipsoid.log_volume() - log_unit_ball_volume(p) == pytest.approx(logvol_ref, abs=1e-4)
