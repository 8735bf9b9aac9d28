"""The minimum number of outliers and the q-relaxed feasible set (boundid.sets.outliers, MILPs).

References, independent of the MILPs: brute force (every set of q dropped rows, the exact bounds
of the polytope left by scipy.optimize.linprog; S_q is the union of those polytopes, its interval
hull the hull of their bounds, the minimum number the smallest q that leaves one non-empty);
planted gross errors; boundid's Polytope LP bounds for q = 0 ([refs §LP]); a polytope known to be
inside S_q for a MILP cut short by its time limit.
"""

from __future__ import annotations

import itertools

import numpy as np
import pytest
import scipy.optimize

from boundid.errors import InputError
from boundid.sets import Box, OutlierCount, Polytope, RelaxedBounds, min_outliers, relaxed_bounds

#: agreement with the LP references, relative to the box's width (LP tolerances are ~1e-9)
RTOL = 1e-7


def _data(seed: int, N: int, p: int, n_out: int, gross: float = 3.0):
    """Rows y = W theta + e, |e| <= e_max, and ``n_out`` rows with an error of +-(1..gross) in
    units of W's scale; the box [-2, 2]^p holds the truth. Returns W, y, e_max, box, outlier rows."""
    rng = np.random.default_rng(seed)
    W = rng.normal(size=(N, p))
    e = rng.uniform(0.1, 0.3, N)
    y = W @ rng.uniform(-1, 1, p) + rng.uniform(-1, 1, N) * e
    out = np.sort(rng.choice(N, n_out, replace=False))
    y[out] += rng.choice([-1.0, 1.0], n_out) * rng.uniform(1.0, gross, n_out)
    return W, y, e, (-2.0 * np.ones(p), 2.0 * np.ones(p)), out


def _brute_hull(W, y, e, box, q):
    """Interval hull of S_q by brute force, (lo, hi), or None when S_q is empty."""
    N, p = W.shape
    lo, hi = np.full(p, np.inf), np.full(p, -np.inf)
    for drop in itertools.combinations(range(N), q):  # dropping more rows only enlarges the set
        keep = np.setdiff1d(np.arange(N), drop)
        A = np.vstack([W[keep], -W[keep]])
        b = np.r_[y[keep] + e[keep], e[keep] - y[keep]]
        for j, sign in itertools.product(range(p), (1.0, -1.0)):
            res = scipy.optimize.linprog(sign * np.eye(p)[j], A_ub=A, b_ub=b, bounds=list(zip(*box, strict=True)),
                                         method="highs")
            if res.status == 2:                        # this subset leaves an empty polytope
                break
            assert res.status == 0
            if sign > 0:
                lo[j] = min(lo[j], res.fun)
            else:
                hi[j] = max(hi[j], -res.fun)
    return (lo, hi) if np.all(np.isfinite(lo)) else None


def _close(a, b, box):
    return np.all(np.abs(a - b) <= RTOL * (box[1] - box[0]))


@pytest.mark.parametrize(("seed", "N", "p", "n_out"), [(0, 8, 1, 2), (1, 10, 2, 2), (2, 9, 3, 1), (3, 11, 3, 3)])
def test_against_brute_force(seed, N, p, n_out):
    """For q = 0..3: the MILP bounds equal the hull of the brute-force union, all proven; the
    minimum number of outliers is the smallest q with a non-empty S_q."""
    W, y, e, box, _ = _data(seed, N, p, n_out)
    smallest = None
    for q in range(4):
        ref = _brute_hull(W, y, e, box, q)
        got = relaxed_bounds(W, y, e, box, q)
        assert isinstance(got, RelaxedBounds) and got.proven and got.empty == (ref is None)
        if ref is None:
            continue
        smallest = q if smallest is None else smallest
        assert _close(got.lo, ref[0], box) and _close(got.hi, ref[1], box)
        assert np.array_equal(got.lo, got.lo_found) and np.array_equal(got.hi, got.hi_found)
        assert np.allclose(np.diag(got.argmin), got.lo) and np.allclose(np.diag(got.argmax), got.hi)
    count = min_outliers(W, y, e, box)
    assert isinstance(count, OutlierCount) and count.proven
    assert count.n_outliers == count.lower_bound == smallest == len(count.dropped)
    assert count.residual_ratio <= 1 + 1e-7
    assert np.all(np.abs(y[count.dropped] - W[count.dropped] @ count.theta) > e[count.dropped])


@pytest.mark.parametrize(("seed", "n_out"), [(10, 1), (11, 3), (12, 5)])
def test_planted_outliers_are_found(seed, n_out):
    """Gross errors (1 to 4, the bounds 0.1 to 0.3) on a few of 40 rows: the minimum number is the
    planted count and the rows dropped are the planted ones."""
    W, y, e, box, out = _data(seed, 40, 3, n_out, gross=4.0)
    count = min_outliers(W, y, e, box)
    assert count.proven and count.n_outliers == n_out
    assert np.array_equal(count.dropped, out)


def test_q0_equals_the_polytope_bounds():
    """Consistent data: S_0 is the polytope, its MILP bounds are Polytope's exact LP bounds."""
    W, y, e, box, _ = _data(20, 30, 4, 0)
    got = relaxed_bounds(W, y, e, box, 0)
    ref = Polytope(W, y, e, box=box).bounds()
    assert got.proven and _close(got.lo, ref.lo, box) and _close(got.hi, ref.hi, box)
    count = min_outliers(W, y, e, box)
    assert count.n_outliers == 0 and count.proven and count.status == "not run"   # the Chebyshev fit decides


def test_time_limit_gives_outer_bounds_marked_not_proven():
    """A time limit too short for any MILP: nothing is proven, the bounds are the dual bounds (outer,
    here the box), and they contain the brute-force hull; the count brackets the true minimum."""
    W, y, e, box, _ = _data(3, 11, 3, 3)
    ref = _brute_hull(W, y, e, box, 3)
    got = relaxed_bounds(W, y, e, box, 3, time_limit=1e-9)
    assert not got.proven and not got.lo_proven.any() and not got.hi_proven.any()
    assert np.all(got.lo <= ref[0]) and np.all(ref[1] <= got.hi)
    found = np.isfinite(got.lo_found)
    assert np.all(got.lo_found[found] >= ref[0][found] - 1e-9) and np.all(got.lo[found] <= got.lo_found[found])
    text = " ".join(got.summary().split())
    assert "0 of 6 bounds proven" in text and "dual bounds at the time limit" in text
    count = min_outliers(W, y, e, box, time_limit=1e-9)
    exact = min_outliers(W, y, e, box)
    assert not count.proven and count.lower_bound <= exact.n_outliers <= count.n_outliers
    assert "not proven" in " ".join(count.summary().split())


def test_time_limit_mid_search_still_contains_a_subset_polytope():
    """300 rows, 60 gross errors, q = 60 and 0.05 s per MILP: the search is cut short; the outer
    bounds contain the polytope of the rows without the planted errors (a part of S_60)."""
    W, y, e, box, out = _data(30, 300, 4, 60, gross=5.0)
    got = relaxed_bounds(W, y, e, box, 60, time_limit=0.05)
    assert not got.proven
    keep = np.setdiff1d(np.arange(300), out)
    inner = Polytope(W[keep], y[keep], e[keep], box=box).bounds()
    tol = RTOL * (box[1] - box[0])
    assert np.all(got.lo <= inner.lo + tol) and np.all(inner.hi - tol <= got.hi)
    ok, ok_hi = np.isfinite(got.lo_found), np.isfinite(got.hi_found)
    assert np.all(got.lo[ok] <= got.lo_found[ok]) and np.all(got.hi_found[ok_hi] <= got.hi[ok_hi])
    assert all(t < 1.0 for t in got.info["milp_times_s"])


def test_screening_by_the_box():
    """Rows whose strip contains the box need no binary; rows that miss it are outliers everywhere;
    q below their number leaves S_q empty, q covering every candidate leaves the whole box."""
    W = np.array([[1.0, 0.0], [0.0, 1.0], [1.0, 1.0], [1.0, -1.0]])
    y = np.array([0.0, 0.0, 50.0, 0.2])
    e = np.array([10.0, 10.0, 1.0, 0.1])              # rows 0, 1 contain [-1, 1]^2; row 2 misses it
    box = Box(-np.ones(2), np.ones(2))
    count = min_outliers(W, y, e, box)
    assert count.n_outliers == 1 and count.dropped.tolist() == [2] and count.proven
    assert count.info["n_contained"] == 2 and count.info["n_missed"] == 1 and count.info["n_candidates"] == 1
    assert relaxed_bounds(W, y, e, box, 0).empty
    whole = relaxed_bounds(W, y, e, box, 2)
    assert not whole.empty and whole.proven and np.array_equal(whole.lo, -np.ones(2))
    assert np.array_equal(whole.hi, np.ones(2))
    strip = relaxed_bounds(W, y, e, box, 1)                 # 0.1 <= x1 - x2 <= 0.3 in the box
    assert np.allclose(strip.lo, [-0.9, -1.0]) and np.allclose(strip.hi, [1.0, 0.9])
    text = " ".join(strip.summary().split())
    assert "outer" in text and "not convex" in text and "6 of" not in text and "4 of 4" in text


@pytest.mark.parametrize(("kwargs", "match"), [
    ({"box": None}, "box is required"),
    ({"box": (np.zeros(2), np.array([1.0, np.inf]))}, "box must be finite"),
    ({"box": (np.ones(2), np.zeros(2))}, "box needs lo < hi"),
    ({"box": (np.zeros(3), np.ones(3))}, "box lo and hi must each be a scalar or have length 2"),
    ({"e_max": 0.0}, "e_max must be strictly positive"),
    ({"y": np.array([0.0, np.nan, 0.0])}, "y contains 1 NaN"),
    ({"y": np.zeros(2)}, "W has 3 rows but y has 2"),
    ({"q": -1}, r"q \(the number of outliers allowed\)"),
    ({"q": 4}, r"q \(the number of outliers allowed\)"),
    ({"q": 1.5}, r"q \(the number of outliers allowed\)"),
    ({"q": True}, r"q \(the number of outliers allowed\)"),
    ({"time_limit": 0.0}, "time_limit must be"),
    ({"time_limit": float("nan")}, "time_limit must be"),
])
def test_bad_input_is_named(kwargs, match):
    args = {"W": np.eye(3)[:, :2], "y": np.zeros(3), "e_max": 1.0, "box": (-np.ones(2), np.ones(2)), "q": 1,
            "time_limit": 1.0, **kwargs}
    with pytest.raises(InputError, match=match):
        relaxed_bounds(**args)
    if "q" not in kwargs:
        args.pop("q")
        with pytest.raises(InputError, match=match):
            min_outliers(**args)
