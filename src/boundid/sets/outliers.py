"""Outliers, exactly: the minimum number of outliers and the q-relaxed feasible set (MILPs).

Data y_k = w_k^T theta + e_k with |e_k| <= e_max_k (k < N) and theta in a prior box
B = {c + r * z : |z|_inf <= 1} (centre c, half-widths r, all finite). An *outlier* at theta is a
row with |y_k - w_k^T theta| > e_max_k.

* :func:`min_outliers`: the minimum number of outliers over B, min over theta in B of
  #{k : |y_k - w_k^T theta| > e_max_k}, and a theta attaining it: the estimator OMNE
  [Lahanier1987], solved here exactly as a mixed-integer LP.
* :func:`relaxed_bounds`: the bounds of each theta_j over the q-relaxed feasible set
  S_q = {theta in B : at most q outliers} [JaulinWalter2002] (2p MILPs). S_q is a union of
  polytopes, not convex: its interval hull is an *outer* description of it.

The MILP (big-M form). With a binary b_k per row (b_k = 1: row k may be violated),
``|y_k - w_k^T theta| <= e_max_k + M_k b_k`` with
M_k = |y_k - w_k^T c| + sum_i |w_ki| r_i - e_max_k, the largest violation of row k over B, so that
b_k = 1 relaxes row k exactly to B. It is solved in box coordinates theta = c + r * z, where row
k reads |d_k - a_k^T z| <= e_k with a_k = w_k * r and d_k = y_k - w_k^T c, and each of its two
sides gets its own big-M (the largest violation of that side over B; M_k is the larger one):

    lower side  a_k^T z >= d_k - e_k,   M_k^- = d_k - e_k + |a_k|_1
    upper side  a_k^T z <= d_k + e_k,   M_k^+ = |a_k|_1 - d_k - e_k

Before the MILP, rows are screened by what the box alone proves:

* a row whose strip contains B (M_k <= 0) is never violated: no binary, no constraint;
* a row whose strip misses B (|d_k| - |a_k|_1 > e_k) is violated everywhere: an outlier at every
  theta, counted without a binary;
* a side with M^- <= 0 (resp. M^+ <= 0) is never violated: that side is not written;
* the other rows (the *candidates*) get a binary, their sides divided by n_k = |a_k|_2 (unit
  rows: HiGHS's tolerances are distances in box units, 1e-9 of the half-widths, and every big-M
  is <= 2 |a_k|_1 / |a_k|_2 <= 2 sqrt(p)).

A starting incumbent is the Chebyshev (minimax) fit of :meth:`Polytope.consistency` on the
candidates, the worst row dropped until the rest are consistent; when it violates no candidate
it is optimal without a MILP. HiGHS ([HiGHS], branch and cut) runs with ``mip_rel_gap`` 0 and a
time limit per MILP; a MILP stopped by that limit still gives its dual bound, reported as a proven
bound (a lower bound on the number of outliers, an outer bound on each theta_j).
"""

from __future__ import annotations

import textwrap
import time
from dataclasses import dataclass, field

import highspy
import numpy as np

from boundid._validation import as_bounds, as_regression
from boundid.errors import InputError
from boundid.sets._working_set import _QuietHighs
from boundid.sets.box import Box
from boundid.sets.polytope import LP_TOL, Polytope, _box

#: HiGHS's feasibility tolerances on the unit rows (box units) and its absolute MIP gap
MIP_TOL = LP_TOL
_WIDTH = 78
_FEASIBLE = 2                                   # HiGHS primal_solution_status: a feasible point


# ---------------------------------------------------------------------------------------- results
@dataclass(frozen=True)
class OutlierCount:
    """The minimum number of outliers over the prior box (OMNE [Lahanier1987]).

    n_outliers : the number of rows violated at ``theta`` (the best count found; the minimum
        when ``proven``).
    lower_bound : a proven lower bound on the minimum (the MILP's dual bound, rounded up);
        equals ``n_outliers`` when ``proven``.
    proven : ``lower_bound == n_outliers``: HiGHS's status optimal with gap 0 (the count is an
        integer, so a dual bound within 1e-6 of it proves it), or no MILP was needed (the
        Chebyshev incumbent violates only the rows that miss the box); False when the time limit
        stopped the MILP first.
    dropped : (n_outliers,) sorted indices of the rows violated at ``theta``.
    theta : (p,) a point of the box that satisfies every row not in ``dropped``.
    residual_ratio : max over the rows not dropped of |y_k - w_k^T theta| / e_max_k (the
        certificate: <= 1 up to the MILP's tolerance, 1e-9 of the box along each row).
    status : HiGHS's model status ("not run" when the screening or the incumbent decided).
    time_s : wall time of the whole call (screening, incumbent and MILP).
    info : sizes and solver statistics (rows contained, missed, candidates; the incumbent's count;
        MILP nodes and gap).
    """

    n_outliers: int
    lower_bound: int
    proven: bool
    dropped: np.ndarray
    theta: np.ndarray
    residual_ratio: float
    status: str
    time_s: float
    info: dict = field(default_factory=dict)

    def summary(self) -> str:
        """A plain-text report in the manner of statsmodels' ``summary()``."""
        verdict = "proven minimum" if self.proven else \
            f"best found; the minimum is >= {self.lower_bound} (not proven: time limit)"
        head = [("Outliers", f"{self.n_outliers} ({verdict})"),
                ("Dropped rows", str(self.dropped.tolist())),
                ("Max ratio", f"{self.residual_ratio:.6g} (|y - w^T theta| / e_max on the other rows)"),
                *_head_common(self.info, self.status, self.time_s)]
        rows = [(f"theta{j + 1}", [v]) for j, v in enumerate(self.theta)]
        return _report("boundid minimum number of outliers (OMNE)", head, ["theta"], rows)

    def __str__(self) -> str:
        return self.summary()


@dataclass(frozen=True)
class RelaxedBounds:
    """Bounds of each theta_j over S_q = {theta in box : at most q outliers} [JaulinWalter2002].

    S_q is a union of polytopes (one per set of q dropped rows), not convex: [lo, hi] is its
    interval hull, an **outer** description of S_q, never a set of which every point is in S_q.

    lo, hi : (p,) guaranteed outer bounds: lo_j <= min_{S_q} theta_j and max_{S_q} theta_j <= hi_j.
        A bound that is ``proven`` is the MILP's optimum (exact to its tolerance, 1e-9 of the
        box); one that is not is the MILP's dual bound at the time limit.
    lo_found, hi_found : (p,) the best values attained by points of S_q that the MILPs found
        (NaN when none was): lo <= lo_found and hi_found <= hi, equal when proven.
    lo_proven, hi_proven : (p,) whether each bound is proven optimal (HiGHS status optimal, gap 0).
    argmin, argmax : (p, p) row j: a point of S_q attaining lo_found_j (resp. hi_found_j), NaN if none.
    empty : S_q is empty (proven: every point of the box has more than q outliers); lo, hi are
        then NaN.
    q : the number of outliers allowed.
    time_s : wall time of the whole call; info : sizes and per-MILP statistics.
    """

    q: int
    lo: np.ndarray
    hi: np.ndarray
    lo_found: np.ndarray
    hi_found: np.ndarray
    lo_proven: np.ndarray
    hi_proven: np.ndarray
    argmin: np.ndarray
    argmax: np.ndarray
    empty: bool
    time_s: float
    info: dict = field(default_factory=dict)

    @property
    def proven(self) -> bool:
        """Every one of the 2p bounds is proven optimal."""
        return bool(np.all(self.lo_proven) and np.all(self.hi_proven))

    def summary(self) -> str:
        """A plain-text report in the manner of statsmodels' ``summary()``."""
        n, n_all = int(self.lo_proven.sum() + self.hi_proven.sum()), 2 * len(self.lo)
        bounds = "EMPTY: no point of the box has at most q outliers" if self.empty else \
            f"[lo, hi]: interval hull of S_q (an outer description); {n} of {n_all} bounds proven optimal" + \
            ("" if n == n_all else "; the others are MILP dual bounds at the time limit (still outer)")
        head = [("Set", f"S_q = box points with at most q = {self.q} outliers: a union of polytopes, not convex"),
                ("Bounds", bounds),
                *_head_common(self.info, self.info.get("status", ""), self.time_s)]
        cols = ["lo", "hi", "lo_found", "hi_found", "lo_proven", "hi_proven"]
        rows = [(f"theta{j + 1}", [self.lo[j], self.hi[j], self.lo_found[j], self.hi_found[j],
                                   bool(self.lo_proven[j]), bool(self.hi_proven[j])]) for j in range(len(self.lo))]
        return _report("boundid q-relaxed feasible set [JaulinWalter2002]", head, cols, rows)

    def __str__(self) -> str:
        return self.summary()


def _head_common(info: dict, status: str, time_s: float) -> list[tuple[str, str]]:
    return [("Rows", f"N = {info['n_rows']}: {info['n_contained']} contain the box, {info['n_missed']} miss it "
                     f"(outliers everywhere), {info['n_candidates']} candidates (one binary each)"),
            ("Solver", f"HiGHS MILP, status {status}; {info.get('nodes', 0)} nodes"),
            ("Time [s]", f"{time_s:.4g}")]


def _report(title: str, head: list[tuple[str, str]], cols: list[str], rows: list[tuple[str, list]]) -> str:
    lines = ["=" * _WIDTH, f"{title:^{_WIDTH}}", "-" * _WIDTH]
    for k, v in head:
        lines += textwrap.wrap(f"{k + ':':<14}{v}", _WIDTH, subsequent_indent=" " * 14) or [""]
    lines += ["-" * _WIDTH, f"{'parameter':<10}" + "".join(f"{c:>11}" for c in cols)]
    lines += [f"{name:<10}" + "".join(f"{v!s:>11}" if isinstance(v, bool) else f"{v:>11.6g}" for v in vals)
              for name, vals in rows]
    return "\n".join([*lines, "=" * _WIDTH])


# ---------------------------------------------------------------------------------------- screening
@dataclass(frozen=True)
class _Strips:
    """The data in box coordinates theta = center + half * z, screened (module docstring).

    G : (m, p) unit rows a_k / n_k of the candidates; lo_rhs, up_rhs : (m,) (d_k -+ e_k) / n_k;
    lo_M, up_M : (m,) the sides' big-M / n_k (<= 0: the side is never violated, not written).
    candidates, missed : row indices; n_contained : how many rows contain the box.
    """

    W: np.ndarray
    y: np.ndarray
    e: np.ndarray
    center: np.ndarray
    half: np.ndarray
    G: np.ndarray
    lo_rhs: np.ndarray
    up_rhs: np.ndarray
    lo_M: np.ndarray
    up_M: np.ndarray
    candidates: np.ndarray
    missed: np.ndarray
    n_contained: int

    @property
    def info(self) -> dict:
        return {"n_rows": len(self.y), "n_contained": self.n_contained, "n_missed": len(self.missed),
                "n_candidates": len(self.candidates)}

    def to_theta(self, z: np.ndarray) -> np.ndarray:
        return self.center + self.half * z

    def violated(self, theta: np.ndarray) -> np.ndarray:
        """Indices of the rows with |y_k - w_k^T theta| > e_max_k."""
        return np.flatnonzero(np.abs(self.y - self.W @ theta) > self.e)


def _strips(W, y, e_max, box) -> _Strips:
    W, y = as_regression(W, y)
    e = as_bounds(e_max, W.shape[0])
    lo, hi = _prior_box(box, W.shape[1])
    c, r = 0.5 * (lo + hi), 0.5 * (hi - lo)
    a, d = W * r, y - W @ c
    reach = np.abs(a).sum(axis=1)                               # |a_k|_1: the range of a_k^T z over the box
    lo_M, up_M = d - e + reach, reach - d - e                   # largest violation of each side
    contained = np.maximum(lo_M, up_M) <= 0                     # M_k <= 0
    missed = np.abs(d) - reach > e
    cand = np.flatnonzero(~contained & ~missed)
    n = np.linalg.norm(a[cand], axis=1)
    return _Strips(W, y, e, c, r, a[cand] / n[:, None], (d - e)[cand] / n, (d + e)[cand] / n,
                   lo_M[cand] / n, up_M[cand] / n, cand, np.flatnonzero(missed), int(contained.sum()))


def _prior_box(box, p: int) -> tuple[np.ndarray, np.ndarray]:
    """(lo, hi) of a finite box given as a :class:`Box` or a pair (Polytope's checks, and finiteness)."""
    if box is None:
        raise InputError("box is required: a finite prior box (lo, hi) gives each row's big-M.")
    try:
        lo, hi = _box(box.intervals() if isinstance(box, Box) else box, p)
    except InputError:
        raise
    except ValueError:                                          # numpy cannot broadcast a side to (p,)
        raise InputError(f"box lo and hi must each be a scalar or have length {p} (one per parameter).") from None
    if not (np.all(np.isfinite(lo)) and np.all(np.isfinite(hi))):
        raise InputError("box must be finite on every side: each row's big-M is its largest violation over the box.")
    return lo, hi


def _incumbent(S: _Strips) -> np.ndarray:
    """Chebyshev fit of the candidates, the worst row dropped until the rest are consistent."""
    keep, box = S.candidates, (S.center - S.half, S.center + S.half)
    while True:
        cons = Polytope(S.W[keep], S.y[keep], S.e[keep], box=box).consistency()
        theta = np.clip(cons.theta, *box)
        if not cons.empty or len(keep) == 1:
            return theta
        keep = np.delete(keep, np.argmax(np.abs(S.y[keep] - S.W[keep] @ theta) / S.e[keep]))


# ---------------------------------------------------------------------------------------- the MILP
@dataclass(frozen=True)
class _Solved:
    status: str
    optimal: bool
    infeasible: bool
    gap: float
    x: np.ndarray | None          # the incumbent (z, b), None if HiGHS has none
    value: float                  # its objective (inf if none)
    bound: float                  # the dual bound (-inf if none)
    nodes: int
    time_s: float


def _milp(S: _Strips, time_limit: float) -> highspy.Highs:
    """Columns z (p, in [-1, 1]) and b (m, binary); rows: the candidates' sides that can be violated,
    g_k^T z + M_k^- b_k >= lo_rhs_k and g_k^T z - M_k^+ b_k <= up_rhs_k (unit g_k, module docstring)."""
    h = _QuietHighs()
    h.setOptionValue("output_flag", False)
    for name, val in (("time_limit", float(time_limit)), ("mip_rel_gap", 0.0), ("mip_abs_gap", MIP_TOL),
                      ("mip_feasibility_tolerance", MIP_TOL), ("primal_feasibility_tolerance", MIP_TOL),
                      ("threads", 1)):
        h.setOptionValue(name, val)
    m, p = S.G.shape
    h.addVars(p + m, np.r_[-np.ones(p), np.zeros(m)], np.ones(p + m))
    h.changeColsIntegrality(m, np.arange(p, p + m, dtype=np.int32), np.full(m, highspy.HighsVarType.kInteger))
    lo_side, up_side = np.flatnonzero(S.lo_M > 0), np.flatnonzero(S.up_M > 0)
    _sparse_rows(h, S.G[lo_side], p + lo_side, S.lo_M[lo_side], S.lo_rhs[lo_side], np.inf)
    _sparse_rows(h, S.G[up_side], p + up_side, -S.up_M[up_side], -np.inf, S.up_rhs[up_side])
    return h


def _sparse_rows(h: highspy.Highs, G: np.ndarray, col: np.ndarray, coef: np.ndarray, lo, up) -> None:
    """Append rows lo <= G_i z + coef_i x[col_i] <= up_i (p + 1 entries each)."""
    k, p = G.shape
    idx = np.hstack([np.broadcast_to(np.arange(p), (k, p)), col[:, None]]).astype(np.int32).ravel()
    val = np.hstack([G, coef[:, None]]).ravel()
    h.addRows(k, np.broadcast_to(lo, (k,)).astype(float), np.broadcast_to(up, (k,)).astype(float), idx.size,
              np.arange(k, dtype=np.int32) * (p + 1), idx, val)


def _solve(h: highspy.Highs, cost: np.ndarray, start: np.ndarray | None) -> _Solved:
    """min cost^T x from the feasible ``start`` (None: HiGHS finds its own)."""
    n = cost.size
    h.changeColsCost(n, np.arange(n, dtype=np.int32), cost)
    if start is not None:
        h.setSolution(n, np.arange(n, dtype=np.int32), start)
    t0 = time.perf_counter()
    h.run()
    t = time.perf_counter() - t0
    st, info = h.getModelStatus(), h.getInfo()
    found = info.primal_solution_status == _FEASIBLE
    optimal = st == highspy.HighsModelStatus.kOptimal
    x = np.array(h.getSolution().col_value) if found else None
    value = info.objective_function_value if found else np.inf
    infeasible = st == highspy.HighsModelStatus.kInfeasible
    return _Solved(h.modelStatusToString(st), optimal, infeasible, info.mip_gap, x, value,
                   value if optimal else info.mip_dual_bound, int(info.mip_node_count), t)


def _start(S: _Strips, theta: np.ndarray) -> np.ndarray:
    """(z, b) of a point theta of the box: b_k = 1 for the candidates theta violates."""
    b = np.isin(S.candidates, S.violated(theta))
    return np.r_[np.clip((theta - S.center) / S.half, -1.0, 1.0), b.astype(float)]


def _check_time_limit(time_limit) -> float:
    t = float(time_limit) if np.isscalar(time_limit) and not isinstance(time_limit, bool | str) else np.nan
    if not (np.isfinite(t) and t > 0):
        raise InputError(f"time_limit must be a finite number of seconds > 0, got {time_limit!r}.")
    return t


def _check_q(q, n_rows: int) -> int:
    if isinstance(q, bool) or not isinstance(q, int | np.integer) or not 0 <= q <= n_rows:
        raise InputError(f"q (the number of outliers allowed) must be an integer in [0, {n_rows}], got {q!r}.")
    return int(q)


# ---------------------------------------------------------------------------------------- the API
def min_outliers(W, y, e_max, box, *, time_limit: float = 10.0) -> OutlierCount:
    """The minimum number of outliers over the prior box, exactly (OMNE [Lahanier1987]).

    min over theta in box, b in {0, 1}^N of sum_k b_k  s.t.  |y_k - w_k^T theta| <= e_max_k + M_k b_k,
    M_k = |y_k - w_k^T c| + sum_i |w_ki| r_i - e_max_k (screening and big-M: module docstring).

    Parameters
    ----------
    W : (N, p) regression rows w_k.
    y : (N,) targets y_k.
    e_max : scalar or (N,) strictly positive error bounds (same unit as y).
    box : (lo, hi), each (p,), finite with lo < hi, or a :class:`Box`: the prior on theta.
    time_limit : seconds for the MILP; when it stops HiGHS first the result is not ``proven``
        and gives the best count found and the proven lower bound.

    Returns
    -------
    OutlierCount
    """
    t0 = time.perf_counter()
    S = _strips(W, y, e_max, box)
    limit = _check_time_limit(time_limit)
    m, p = S.G.shape
    x = _start(S, _incumbent(S) if m else S.center)
    info = {**S.info, "incumbent": len(S.missed) + int(x[p:].sum())}
    status, bound = "not run", info["incumbent"]
    if info["incumbent"] > len(S.missed):                       # the incumbent may not be optimal: MILP
        sol = _solve(_milp(S, limit), np.r_[np.zeros(p), np.ones(m)], x)
        x = x if sol.x is None else sol.x                       # HiGHS keeps the start unless it improves it
        status, info["nodes"], info["mip_gap"] = sol.status, sol.nodes, sol.gap
        bound = len(S.missed) + int(np.ceil(max(sol.bound, 0.0) - 1e-6))   # -inf before the root LP
    theta = S.to_theta(x[:p])
    dropped = np.union1d(S.missed, np.intersect1d(S.candidates[x[p:] > 0.5], S.violated(theta)))
    ok = np.setdiff1d(np.arange(len(S.y)), dropped)
    ratio = float(np.max(np.abs(S.y[ok] - S.W[ok] @ theta) / S.e[ok], initial=0.0))
    n = len(dropped)
    return OutlierCount(n, min(bound, n), bound >= n, dropped, theta, ratio, status, time.perf_counter() - t0, info)


def relaxed_bounds(W, y, e_max, box, q, *, time_limit: float = 10.0) -> RelaxedBounds:
    """Outer interval hull of S_q = {theta in box : at most q outliers} [JaulinWalter2002] (2p MILPs).

    For each j: min and max of theta_j over theta in box, b in {0, 1}^N with
    |y_k - w_k^T theta| <= e_max_k + M_k b_k and sum_k b_k <= q (big-M and screening: module
    docstring; rows that miss the box use up q without a binary). Each MILP starts from the best
    point of S_q known so far (the Chebyshev incumbent, the optima of the previous MILPs).

    Parameters
    ----------
    W, y, e_max, box : as :func:`min_outliers`.
    q : int in [0, N], the number of outliers allowed.
    time_limit : seconds per MILP; a bound that it cuts short is the MILP's dual bound, still a
        guaranteed outer bound, marked not proven.

    Returns
    -------
    RelaxedBounds
    """
    t0 = time.perf_counter()
    S = _strips(W, y, e_max, box)
    q = _check_q(q, len(S.y))
    limit = _check_time_limit(time_limit)
    budget = q - len(S.missed)
    m, p = S.G.shape
    if budget < 0 or budget >= m:                  # the box alone decides: S_q is empty, or the whole box
        return _box_answer(S, q, budget < 0, time.perf_counter() - t0)
    h = _milp(S, limit)
    h.addRow(-np.inf, float(budget), m, np.arange(p, p + m, dtype=np.int32), np.ones(m))
    theta = _incumbent(S)
    known = [_start(S, theta)] if len(S.violated(theta)) <= q else []
    solved = []
    for sign in (1.0, -1.0):
        for j in range(p):
            cost = np.zeros(p + m)
            cost[j] = sign
            start = min(known, key=lambda x: cost @ x) if known else None
            sol = _solve(h, cost, start)
            solved.append(sol)
            if sol.x is not None:
                known.append(sol.x)
            if sol.infeasible:
                return _box_answer(S, q, True, time.perf_counter() - t0, solved)
    return _hull(S, q, solved, time.perf_counter() - t0)


def _hull(S: _Strips, q: int, solved: list[_Solved], time_s: float) -> RelaxedBounds:
    """RelaxedBounds from the 2p MILPs (min z_j for j < p, then min -z_j): outer bounds from the
    optima or dual bounds, clipped to the box; found values from the incumbents."""
    p = len(S.center)
    bound = np.clip([s.bound for s in solved], -1.0, 1.0)
    X = np.array([S.to_theta(s.x[:p]) if s.x is not None else np.full(p, np.nan) for s in solved])
    proven = np.array([s.optimal for s in solved])
    return RelaxedBounds(q, S.to_theta(bound[:p]), S.to_theta(-bound[p:]), np.diag(X[:p]).copy(),
                         np.diag(X[p:]).copy(), proven[:p], proven[p:], X[:p], X[p:], False, time_s,
                         {**S.info, **_stats(solved)})


def _box_answer(S: _Strips, q: int, empty: bool, time_s: float, solved: list[_Solved] = ()) -> RelaxedBounds:
    """S_q decided without bounds: empty, or the whole box (q covers every row that can be violated)."""
    p = len(S.center)
    mark = np.nan if empty else 1.0                         # NaN everywhere for an empty S_q
    lo, hi = mark * (S.center - S.half), mark * (S.center + S.half)
    amin, amax = mark * (S.center - S.half * np.eye(p)), mark * (S.center + S.half * np.eye(p))
    ones = np.ones(p, dtype=bool)
    return RelaxedBounds(q, lo, hi, lo.copy(), hi.copy(), ones, ones.copy(), amin, amax, empty, time_s,
                         {**S.info, **_stats(solved)})


def _stats(solved) -> dict:
    return {"status": ", ".join(sorted({s.status for s in solved})) or "not run",
            "nodes": sum(s.nodes for s in solved), "milp_times_s": [s.time_s for s in solved]}
