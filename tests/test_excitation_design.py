"""The guaranteed excitation criterion (boundid.experiments.excitation_design): the search's picks
against an independent brute force on a 2-parameter pendulum, the guarantee "exact set within
theta_true + 2 D(W)" on random data, and the refusals of bad input."""

from __future__ import annotations

import itertools

import numpy as np
import pytest

from boundid.errors import InputError
from boundid.experiments.excitation_design import (
    CRITERIA,
    classical_scores,
    design_set,
    design_widths,
    search_excitation,
)
from boundid.sets import Polytope

# ---------------------------------------------------------------------------------------------
# 1. brute force on the pendulum tau = J qdd + mgl sin q, rows w = (qdd, sin q)
# ---------------------------------------------------------------------------------------------

#: q(t) = A sin(w t) for A x w; sampled at 40 instants over 6 s (t = 0 gives an all-zero row)
AMPLITUDES, FREQUENCIES = (0.3, 1.0, 2.0), (0.7, 1.5, 3.0)
GRID = list(itertools.product(AMPLITUDES, FREQUENCIES))
T = np.linspace(0.0, 6.0, 40)
HALF = np.array([2.0, 10.0])  # prior half-widths of (J, mgl): kg m^2, N m
E_MAX = 0.2  # N m


def pendulum_rows(candidate):
    A, w = candidate
    q = A * np.sin(w * T)
    qdd = -A * w**2 * np.sin(w * T)
    return np.column_stack([qdd, np.sin(q)]), np.full(len(T), E_MAX)


def grid_draw():
    """A ``draw`` returning the grid's trajectories in turn (ignores the rng)."""
    it = iter(GRID)
    return lambda rng: next(it)


def brute_force_vertices_2d(W, e, half):
    """Vertices of {d : |W d| <= e, |d_j| <= half_j} in 2-D by intersecting every pair of the
    constraint lines and keeping the feasible points: no LP, no qhull."""
    nz = np.any(W != 0, axis=1)
    G = np.vstack([W[nz], -W[nz], np.eye(2), -np.eye(2)])
    g = np.concatenate([e[nz], e[nz], half, half])
    pts = []
    for i, j in itertools.combinations(range(len(g)), 2):
        M = G[[i, j]]
        if abs(np.linalg.det(M)) < 1e-12 * np.linalg.norm(M[0]) * np.linalg.norm(M[1]):
            continue
        x = np.linalg.solve(M, g[[i, j]])
        if np.all(G @ x <= g + 1e-9 * (1.0 + np.abs(g))):
            pts.append(x)
    return np.array(pts)


def vertex_widths(V, half):
    return (V.max(axis=0) - V.min(axis=0)) / (2.0 * half)


@pytest.fixture(scope="module")
def pendulum_search():
    return search_excitation(grid_draw(), pendulum_rows, len(GRID), np.random.default_rng(0), HALF)


@pytest.fixture(scope="module")
def pendulum_truth():
    """Per candidate: relative widths of the design set from Polytope.vertices() (scipy halfspace
    intersection) and from the pairwise brute force above."""
    qhull, brute = [], []
    for cand in GRID:
        W, e = pendulum_rows(cand)
        P = Polytope(W, np.zeros(len(e)), e, box=(-HALF, HALF))
        # the all-zero row at t = 0 makes inf - inf (a harmless RuntimeWarning) in vertices()' screening
        with np.errstate(invalid="ignore"):
            qhull.append(vertex_widths(P.vertices(), HALF))
        brute.append(vertex_widths(brute_force_vertices_2d(W, e, HALF), HALF))
    return np.array(qhull), np.array(brute)


def test_guaranteed_pick_is_the_smallest_exact_set_by_vertex_enumeration(pendulum_search, pendulum_truth):
    s = pendulum_search
    qhull, brute = pendulum_truth
    # the two enumerations agree with each other: the reference is sound
    np.testing.assert_allclose(qhull, brute, rtol=0, atol=1e-9)
    assert s.candidates == GRID and s.failed == []
    # per candidate and parameter, the LP widths equal the vertex widths (relative to the prior width)
    np.testing.assert_allclose(s.widths, qhull, rtol=0, atol=1e-7)
    np.testing.assert_allclose(s.scores["guaranteed"].to_numpy(), qhull.mean(axis=1), rtol=0, atol=1e-7)
    # the grid discriminates: candidates differ by far more than the tolerance, some parameters
    # are not narrowed at all (width 1: the prior box binds), and the best is well separated
    mean = qhull.mean(axis=1)
    assert np.any(qhull == 1.0) and np.any(qhull < 0.1)
    assert np.sort(mean)[1] - np.sort(mean)[0] > 1e-3
    assert s.best("guaranteed") == int(np.argmin(mean))
    # the whole ranking, not just the winner
    np.testing.assert_array_equal(np.argsort(s.scores["guaranteed"].to_numpy(), kind="stable"),
                                  np.argsort(mean, kind="stable"))


def test_cond_and_logdet_picks_match_numpy(pendulum_search):
    s = pendulum_search
    conds, logdets = [], []
    for cand in GRID:
        W, _ = pendulum_rows(cand)
        conds.append(np.linalg.cond(W / np.linalg.norm(W, axis=0)))
        sign, ld = np.linalg.slogdet((W * HALF).T @ (W * HALF))
        assert sign > 0
        logdets.append(ld)
    conds, logdets = np.array(conds), np.array(logdets)
    np.testing.assert_allclose(s.scores["cond"].to_numpy(), conds, rtol=1e-9)
    np.testing.assert_allclose(s.scores["logdet"].to_numpy(), logdets, rtol=1e-9, atol=1e-9)
    assert s.best("cond") == int(np.argmin(conds))
    assert s.best("logdet") == int(np.argmax(logdets))  # larger det W^T W is better
    # the criteria disagree on this grid, so each pick tests its own column and direction
    assert s.best("cond") != s.best("guaranteed")
    assert set(s.scores.columns) >= {*CRITERIA, "rows", "time_s"}
    assert (s.scores["rows"] == len(T)).all() and (s.scores["time_s"] >= 0).all()


def test_classical_scores_of_degenerate_rows():
    W = np.array([[1.0, 2.0], [2.0, 4.0], [3.0, 6.0]])  # rank 1
    cond, logdet = classical_scores(W, np.ones(2))
    assert cond == np.inf or cond > 1e15
    assert logdet == -np.inf or logdet < -30
    cond, logdet = classical_scores(np.column_stack([np.ones(3), np.zeros(3)]), np.ones(2))  # a zero column
    assert cond == np.inf and logdet == -np.inf


# ---------------------------------------------------------------------------------------------
# 2. the guarantee: exact set within theta_true + 2 D(W)
# ---------------------------------------------------------------------------------------------

def _problem(rng, N, p):
    W = rng.normal(size=(N, p))
    center = rng.normal(scale=3.0, size=p)
    half = rng.uniform(0.5, 3.0, size=p)
    e = rng.uniform(0.05, 0.3, size=N)  # small against |W| half: most parameters narrowed
    return W, center, half, e


def _errors(rng, e, kind, p):
    """Errors within the bound e: "uniform" with p rows exactly at +-e; "plus", "minus", "signs":
    every row at 0.999 of the bound (all rows exactly at it leave the truth alone, a one-point set
    at the edge of consistency in floating point, which Polytope.bounds() may refuse)."""
    N = len(e)
    if kind == "uniform":
        err = rng.uniform(-1.0, 1.0, N) * e
        at = rng.choice(N, size=min(p, N), replace=False)
        err[at] = np.sign(rng.uniform(-1, 1, len(at))) * e[at]
        return err
    sign = {"plus": np.ones(N), "minus": -np.ones(N)}.get(kind)
    return 0.999 * (np.sign(rng.uniform(-1, 1, N)) if sign is None else sign) * e


@pytest.mark.parametrize("N, p", [(6, 2), (15, 3), (40, 4), (80, 6)])
def test_exact_set_lies_within_twice_the_design_set(N, p):
    rng = np.random.default_rng(1000 * N + p)
    reach = []  # how far the exact bounds go, as a fraction of 2 x the design half-width
    for trial in range(20):
        W, center, half, e = _problem(rng, N, p)
        rel = design_widths(W, e, half)
        dhalf = rel * half  # D is symmetric: its half-width along j
        assert np.all((rel >= 0) & (rel <= 1))
        if trial % 5 == 4:
            # truth on a corner of the prior box, errors strictly inside the bound (see _errors)
            theta = center + half * np.sign(rng.uniform(-1, 1, p))
            err = 0.999 * rng.uniform(-1.0, 1.0, N) * e
        else:  # truth inside the box, errors at (or next to) the bound
            theta = center + half * rng.uniform(-1.0, 1.0, p)
            err = _errors(rng, e, ("uniform", "plus", "minus", "signs")[trial % 5], p)
        b = Polytope(W, W @ theta + err, e, box=(center - half, center + half)).bounds()
        tol = 1e-7 * 2.0 * half
        assert np.all(b.lo <= theta + tol) and np.all(theta <= b.hi + tol)  # the truth is feasible
        assert np.all(b.lo >= theta - 2.0 * dhalf - tol), (trial, b.lo - theta, dhalf)
        assert np.all(b.hi <= theta + 2.0 * dhalf + tol), (trial, b.hi - theta, dhalf)
        assert np.all(b.hi - b.lo <= 2.0 * (2.0 * dhalf) + tol)  # width <= 2 x design width
        reach.append(np.max(np.maximum(b.hi - theta, theta - b.lo) / (2.0 * dhalf)))
    assert max(reach) <= 1.0 + 1e-6


@pytest.mark.parametrize("N, p", [(6, 2), (15, 3), (40, 4), (80, 6)])
def test_twice_the_design_set_is_reached_by_adversarial_errors(N, p):
    """The factor 2 is tight: with errors e = -W d*, d* the vertex of D(W) furthest along j (|e| <=
    e_max), the data are those of theta_true - d*, the exact set is theta_true - d* + D(W) and its
    lower bound on theta_j is theta_true_j - 2 d*_j. A design width computed too small (or too
    large) fails here."""
    rng = np.random.default_rng(7000 + N)
    W, center, half, e = _problem(rng, N, p)
    rel = design_widths(W, e, half)
    assert np.all(rel < 0.5)  # theta_true +- 2 D inside the prior box: the box does not bind
    D = design_set(W, e, half).bounds()
    theta = center
    for j in range(p):
        d = D.argmax[j]
        assert np.all(np.abs(W @ d) <= e * (1 + 1e-9))
        err = -(W @ d)
        b = Polytope(W, W @ theta + err, e, box=(center - half, center + half)).bounds()
        np.testing.assert_allclose(b.lo[j], theta[j] - 2.0 * rel[j] * half[j], rtol=0, atol=1e-7 * 2 * half[j])
        np.testing.assert_allclose(b.hi - b.lo, 2.0 * rel * half, rtol=0, atol=1e-7 * 2 * half.max())


def test_zero_errors_and_truth_at_the_centre_give_the_design_set_itself():
    rng = np.random.default_rng(7)
    for N, p in [(5, 2), (20, 3), (50, 5), (120, 8)]:
        W, center, half, e = _problem(rng, N, p)
        rel = design_widths(W, e, half)
        b = Polytope(W, W @ center, e, box=(center - half, center + half)).bounds()
        np.testing.assert_allclose((b.hi - b.lo) / (2 * half), rel, rtol=0, atol=1e-7)
        np.testing.assert_allclose((b.hi - center) / half, rel, rtol=0, atol=1e-7)
        np.testing.assert_allclose((center - b.lo) / half, rel, rtol=0, atol=1e-7)
        assert np.any(rel < 0.5)  # narrowed: not just the prior box
        # design_set is the zero-centred polytope of the same rows
        D = design_set(W, e, half).bounds()
        np.testing.assert_allclose(D.hi, -D.lo, rtol=0, atol=1e-9 * half.max())
        np.testing.assert_allclose(D.hi / half, rel, rtol=0, atol=1e-9)


def test_design_widths_scale_with_the_bound_and_saturate_at_the_prior():
    rng = np.random.default_rng(3)
    W, _, half, e = _problem(rng, 30, 3)
    rel = design_widths(W, e, half)
    assert np.all(rel < 0.5)
    # D(W) at e/2 is D(W) at e scaled by 1/2 when the box does not bind
    np.testing.assert_allclose(design_widths(W, e / 2, half), rel / 2, rtol=1e-7)
    # a huge bound leaves the prior box: width 1
    np.testing.assert_allclose(design_widths(W, 1e6 * e, half), np.ones(3), atol=1e-9)
    # a scalar bound is one number for every row
    np.testing.assert_allclose(design_widths(W, 0.1, half), design_widths(W, np.full(30, 0.1), half), atol=1e-12)


# ---------------------------------------------------------------------------------------------
# 3. bad input
# ---------------------------------------------------------------------------------------------

W2 = np.array([[1.0, 0.0], [0.0, 1.0], [1.0, 1.0]])


@pytest.mark.parametrize("half", [[np.nan, 1.0], [np.inf, 1.0], [0.0, 1.0], [-1.0, 1.0], [1.0, -np.inf]])
def test_design_set_refuses_bad_half_widths(half):
    with pytest.raises(InputError, match=r"half"):
        design_set(W2, 0.1, half)
    with pytest.raises(InputError):
        design_widths(W2, 0.1, half)


@pytest.mark.parametrize("e_max", [np.nan, np.inf, 0.0, -0.1, [0.1, 0.0, 0.1], [0.1, np.nan, 0.1],
                                   [0.1, 0.1, np.inf]])
def test_design_set_refuses_bad_bounds(e_max):
    with pytest.raises(InputError, match="e_max"):
        design_set(W2, e_max, [1.0, 1.0])


def test_design_set_refuses_a_half_width_of_the_wrong_length():
    with pytest.raises(InputError):
        design_set(W2, 0.1, [1.0, 1.0, 1.0])


def _random_pendulum_draw(rng):
    return float(rng.uniform(0.2, 2.0)), float(rng.uniform(0.5, 3.0))


def test_search_refuses_no_candidates():
    for n in (0, -1):
        with pytest.raises(InputError, match="at least 1 candidate"):
            search_excitation(_random_pendulum_draw, pendulum_rows, n, np.random.default_rng(0), HALF)


def test_unknown_criterion_is_refused(pendulum_search):
    with pytest.raises(InputError, match="unknown excitation criterion 'aopt'"):
        pendulum_search.best("aopt")


def test_a_draw_that_always_refuses_names_the_first_refusal():
    calls = []

    def draw(rng):
        calls.append(len(calls))
        raise InputError(f"refusal number {len(calls) - 1}")

    with pytest.raises(InputError, match=r"no candidate trajectory could be drawn in 6 tries.*refusal number 0$"):
        search_excitation(draw, pendulum_rows, 3, np.random.default_rng(0), HALF)
    assert len(calls) == 6  # up to 2 n draws


def test_refused_draws_and_rows_are_recorded_and_replaced():
    count = {"draw": 0}

    def draw(rng):
        i = count["draw"]
        count["draw"] += 1
        if i in (1, 4):
            raise InputError(f"draw {i} out of the workspace")
        return _random_pendulum_draw(rng)

    def rows(cand):
        if cand[0] > 1.8:  # rows may refuse too
            raise InputError(f"amplitude {cand[0]:.3f} too large")
        return pendulum_rows(cand)

    s = search_excitation(draw, rows, 4, np.random.default_rng(5), HALF)
    assert len(s.candidates) == 4 and len(s.scores) == 4 and s.widths.shape == (4, 2)
    assert list(s.scores.index) == [0, 1, 2, 3]
    failed_idx = [i for i, _ in s.failed]
    assert {1, 4} <= set(failed_idx)
    assert dict(s.failed)[1] == "InputError: draw 1 out of the workspace"
    assert all(reason.startswith("InputError: ") for _, reason in s.failed)
    assert count["draw"] == 4 + len(s.failed)  # every failure replaced by the next draw
    assert all(c[0] <= 1.8 for c in s.candidates)
    # the widths belong to the candidates they are listed with
    for cand, w in zip(s.candidates, s.widths, strict=True):
        W, e = pendulum_rows(cand)
        np.testing.assert_allclose(w, design_widths(W, e, HALF), atol=1e-12)


def test_too_many_refusals_leave_fewer_candidates_and_other_errors_propagate():
    def draw(rng):
        x = rng.uniform()
        if x < 0.8:
            raise InputError("unlucky")
        return (1.0, 1.0 + x)

    # with rng 11, five of the 2 n = 6 draws are refused: the search stops there with what it has
    s = search_excitation(draw, pendulum_rows, 3, np.random.default_rng(11), HALF)
    assert len(s.candidates) == 1 and [i for i, _ in s.failed] == [0, 1, 2, 3, 4]
    assert len(s.candidates) == len(s.scores) == len(s.widths)

    def broken(rng):
        raise ValueError("a bug, not a refusal")

    with pytest.raises(ValueError, match="a bug"):
        search_excitation(broken, pendulum_rows, 2, np.random.default_rng(0), HALF)
    # ... unless the caller lists it among the refusals
    s = search_excitation(lambda rng: (_ for _ in ()).throw(ValueError("x")) if rng.uniform() < 0.5
                          else _random_pendulum_draw(rng), pendulum_rows, 2, np.random.default_rng(0), HALF,
                          errors=(ValueError,))
    assert all(r.startswith("ValueError") for _, r in s.failed)


def test_search_is_deterministic_for_a_seed():
    def run(seed):
        return search_excitation(_random_pendulum_draw, pendulum_rows, 5, np.random.default_rng(seed), HALF)

    a, b, c = run(42), run(42), run(43)
    assert a.candidates == b.candidates
    cols = ["guaranteed", "cond", "logdet", "rows"]
    assert a.scores[cols].equals(b.scores[cols])
    np.testing.assert_array_equal(a.widths, b.widths)
    assert all(a.best(k) == b.best(k) for k in CRITERIA)
    assert a.candidates != c.candidates
