"""Conic programs over many strips: cvxpy + Clarabel [Clarabel] with constraint generation, and
the Lagrangian (dual) bound that certifies each optimum.

A problem is  min c^T v  over v (n,) subject to

    fixed parts    A v <= b;   (f^T v + d, G v + g) in the second-order cone;   F0 + sum v_i F_i >= 0
    a pool         many rows a_k^T v <= b_k (the strips of a feasible set), generated: a working set
                   is solved, the most violated pool rows of each optimum are added, repeat
                   (as :mod:`boundid.sets._working_set` does for LPs), until no pool row is violated.

Several objectives share one compiled cvxpy problem (the cost is a cvxpy Parameter); only the
objectives whose optimum still violates a pool row are solved again after the working set grows.

**Dual bound.** For any multipliers lambda >= 0 (rows), (tau, sigma) in the cone (||sigma|| <= tau)
and Z >= 0 (LMIs), and every v satisfying the working set's constraints,

    L(v) = c^T v + lambda^T (A v - b) - tau (f^T v + d) - sigma^T (G v + g) - <Z, F0 + sum v_i F_i>
         <= c^T v,

and L is affine, L(v) = const + g^T v. If every feasible v lies in a box [lo, hi], then
const + sum_i min(g_i lo_i, g_i hi_i) is a lower bound on the optimum of the full problem (the
working set is a relaxation of it): a certificate that does not trust the solver, computed from
its multipliers (clipped, projected onto their cones). Without such a box (the standard parameters
of a lifted model are unbounded along what the data cannot see) no dual bound is given.
"""

from __future__ import annotations

import warnings
from dataclasses import dataclass, field

import cvxpy as cp
import numpy as np

from boundid.errors import SolverError

#: a pool row counts as violated above this (in the problem's scaled units)
GEN_TOL = 1e-9
_OK = (cp.OPTIMAL, cp.OPTIMAL_INACCURATE)
#: Clarabel's linear algebra for every solve of the package: QDLDL, its single-threaded sparse LDL.
#: Its default, faer on every core, was 5x slower on the study-scale problems on 2 cores (the UR5
#: study's inscribed ellipsoid, 427 second-order cones: 5.3 s against 1.0 s a solve; 2.0 s with
#: one faer thread), and one thread keeps a run's numbers the same from run to run.
CLARABEL_LINALG = {"direct_solve_method": "qdldl"}
#: ... except for the S-procedure SDPs (:func:`boundid.sets.sdp.outer_ellipsoid` and
#: ``step_ellipsoid``), whose KKT system is dense blocks (a (p+1)-square LMI and ln det's 2p-square
#: cone): there faer on one thread is faster (the UR5 study's SDP, p = 22 and 434 strips: 1.4 s
#: against 3.4 s a solve), and on one thread its numbers are the same from run to run. A solve that
#: fails with it is tried again with QDLDL.
CLARABEL_DENSE_LINALG = {"direct_solve_method": "faer", "max_threads": 1}
#: Clarabel settings of the second attempt after a numerical failure
RETRY = {"tol_gap_abs": 1e-7, "tol_gap_rel": 1e-7, "tol_feas": 1e-7, "static_regularization_constant": 1e-7}
#: every attempt at a solve, in turn until one does not stop on a numerical error: the defaults, RETRY,
#: then RETRY with ten times its static regularisation. The last one is for KKT systems that turn
#: singular at the optimum, where many strips are nearly active: a physically consistent bound of the
#: Panda arms benchmark (1,673 strips, p = 62) stopped on NumericalError at iteration 18 with the first
#: two and was Solved with it in 21 (the callers verify every answer, as always)
ATTEMPTS = ({}, RETRY, {**RETRY, "static_regularization_constant": 1e-6})


@dataclass
class ConicResult:
    """Optima of several objectives.

    points : (k, n) argmin of each objective; values : (k,) c^T v there;
    dual : (k,) the Lagrangian lower bound of each optimum (NaN when no box was given);
    status : (k,) the solver's last status per objective; info : rounds, working rows, solves.
    """

    points: np.ndarray
    values: np.ndarray
    dual: np.ndarray
    status: list[str]
    info: dict = field(default_factory=dict)


class Pool:
    """m elements (e.g. strips), each a few rows a^T v <= b, given implicitly.

    rows(idx) -> (A, b): the rows of elements ``idx`` stacked (e.g. both sides of each strip);
    violation(V) -> (m, k): the largest a^T v - b of each element at each column of V (n, k).
    """

    def __init__(self, rows, violation, m: int):
        self.rows, self.violation, self.m = rows, violation, m


class ConicProblem:
    """min c^T v over the fixed parts and the pool (module docstring).

    n : number of variables; box : optional (lo, hi) known to contain every feasible v (for the
    dual bound; also added as constraints); what : name for error messages; cap : index of a
    variable every objective minimises (a level such as gamma) whose box side may be +inf: the dual
    bound then uses 2 |v*_cap| + 1 there (the minimum cannot exceed the level of the solver's
    feasible point, so adding that side changes nothing).
    """

    def __init__(self, n: int, box: tuple[np.ndarray, np.ndarray] | None = None, what: str = "conic problem",
                 cap: int | None = None):
        self.n = n
        self.box = box
        self.what = what
        self.cap = cap
        self.le: list[tuple[np.ndarray, np.ndarray]] = []
        self.socs: list[tuple[np.ndarray, np.ndarray, np.ndarray, float]] = []
        self.psds: list[tuple[np.ndarray, np.ndarray]] = []
        if box is not None:
            lo, hi = box
            I = np.eye(n)
            fin_hi, fin_lo = np.isfinite(hi), np.isfinite(lo)
            self.add_le(np.vstack([I[fin_hi], -I[fin_lo]]), np.concatenate([hi[fin_hi], -lo[fin_lo]]))

    # ------------------------------------------------------------------ parts
    def add_le(self, A, b) -> None:
        A, b = np.asarray(A, float), np.asarray(b, float)
        if A.shape[0]:
            self.le.append((A, b))

    def add_soc(self, G, g, f, d) -> None:
        """(f^T v + d, G v + g) in the second-order cone: ||G v + g|| <= f^T v + d."""
        self.socs.append((np.asarray(G, float), np.asarray(g, float), np.asarray(f, float), float(d)))

    def add_lmi(self, F0, F) -> None:
        """F0 + sum_i v_i F[i] >= 0, F (n, k, k); rescaled by a congruence D F D (D diagonal, from
        the sizes of the diagonal entries) so that its entries are of order one."""
        F0, F = np.asarray(F0, float), np.asarray(F, float)
        size = np.abs(np.diagonal(F0)) + np.abs(np.diagonal(F, axis1=1, axis2=2)).sum(axis=0)
        D = 1.0 / np.sqrt(np.where(size > 0, size, 1.0))
        self.psds.append((F0 * np.outer(D, D), F * np.outer(D, D)[None]))

    def add_constraints(self, cons) -> None:
        """Every row, cone and LMI of a non-lifted PhysicalConstraints on v (each row and cone
        divided by its norm)."""
        lin = cons.linear
        if lin.m:
            nrm = np.linalg.norm(lin.A, axis=1)
            self.add_le(lin.A / nrm[:, None], lin.b / nrm)
        for c in cons.cones:
            s = max(c.lipschitz, 1e-300)
            self.add_soc(c.G / s, c.g / s, c.f / s, c.d / s)
        for L in cons.lmis:
            self.add_lmi(L.F0, L.F)

    # ------------------------------------------------------------------ model
    def _build(self, ws_rows: tuple[np.ndarray, np.ndarray] | None):
        v, c = cp.Variable(self.n), cp.Parameter(self.n)
        parts, cons = [], []
        les = list(self.le) + ([ws_rows] if ws_rows is not None and ws_rows[0].shape[0] else [])
        for A, b in les:
            con = A @ v <= b
            parts.append(("le", (A, b), con))
            cons.append(con)
        for G, g, f, d in self.socs:
            con = cp.SOC(f @ v + d, G @ v + g)
            parts.append(("soc", (G, g, f, d), con))
            cons.append(con)
        for F0, F in self.psds:
            k = F0.shape[0]
            Fm = F.reshape(self.n, k * k).T                      # vec(F(v)) = vec(F0) + Fm v
            M = F0 + cp.reshape(Fm @ v, (k, k), order="C")
            con = 0.5 * (M + M.T) >> 0
            parts.append(("psd", (F0, Fm), con))
            cons.append(con)
        return cp.Problem(cp.Minimize(c @ v), cons), v, c, parts

    def _dual_bound(self, cost: np.ndarray, parts, v: np.ndarray) -> float:
        """The Lagrangian bound of the module docstring (NaN without a box or without duals)."""
        if self.box is None:
            return float("nan")
        g, const = cost.astype(float).copy(), 0.0
        for kind, data, con in parts:
            dv = con.dual_value
            if dv is None:
                return float("nan")
            if kind == "le":
                A, b = data
                lam = np.clip(np.asarray(dv, float).ravel(), 0.0, None)
                g += A.T @ lam
                const -= lam @ b
            elif kind == "soc":
                G, gg, f, d = data
                tau, sig = float(np.ravel(dv[0])[0]), np.asarray(dv[1], float).ravel()
                tau = max(tau, float(np.linalg.norm(sig)))
                g -= tau * f + G.T @ sig
                const -= tau * d + sig @ gg
            else:
                F0, Fm = data
                Z = np.asarray(dv, float)
                w, U = np.linalg.eigh(0.5 * (Z + Z.T))
                Z = (U * np.clip(w, 0.0, None)) @ U.T
                g -= Fm.T @ Z.ravel()
                const -= float(np.sum(Z * F0))
        lo, hi = self.box
        if self.cap is not None and not np.isfinite(hi[self.cap]):
            hi = hi.copy()
            hi[self.cap] = 2.0 * abs(float(v[self.cap])) + 1.0
        with np.errstate(invalid="ignore"):
            terms = np.minimum(g * lo, g * hi)
        terms = np.where(g == 0, 0.0, terms)
        bound = const + float(terms.sum())
        return bound - 1e-12 * (abs(const) + float(np.abs(terms).sum()))   # rounding of the sum

    # ------------------------------------------------------------------ solve
    def minimize_many(self, costs: np.ndarray, pool: Pool | None = None, seed=(), batch: int = 16,
                      max_rounds: int = 200) -> ConicResult:
        """argmin of each row of ``costs`` (k, n) over the fixed parts and the whole pool."""
        costs = np.atleast_2d(np.asarray(costs, float))
        k = costs.shape[0]
        X = np.full((k, self.n), np.nan)
        values, dual = np.full(k, np.nan), np.full(k, np.nan)
        status = [""] * k
        in_ws = np.zeros(pool.m if pool is not None else 0, dtype=bool)
        if pool is not None and len(seed):
            in_ws[np.asarray(seed, dtype=int)] = True
        pending = np.arange(k)
        rounds = solves = 0
        while pending.size:
            rounds += 1
            if rounds > max_rounds:
                raise SolverError(f"{self.what}: constraint generation did not converge in {max_rounds} rounds "
                                  f"({int(in_ws.sum())} working rows).")
            ws = pool.rows(np.flatnonzero(in_ws)) if pool is not None else None
            prob, v, c, parts = self._build(ws)
            for i in pending:
                c.value = costs[i]
                st = solve(prob, self.what)
                solves += 1
                X[i], status[i] = v.value, st
                values[i] = float(costs[i] @ v.value)
                dual[i] = self._dual_bound(costs[i], parts, X[i])
            if pool is None:
                break
            V = pool.violation(X[pending].T)                    # (m, len(pending))
            solved_on = in_ws.copy()                           # the working set these optima saw
            still = []
            for col, i in enumerate(pending):
                viol = V[:, col]
                new = np.flatnonzero((viol > GEN_TOL) & ~solved_on)
                if new.size:
                    if new.size > batch:
                        new = new[np.argpartition(viol[new], -batch)[-batch:]]
                    in_ws[new] = True
                    still.append(i)
            pending = np.array(still, dtype=int)
        info = {"rounds": rounds, "solves": solves, "working_rows": int(in_ws.sum())}
        return ConicResult(X, values, dual, status, info)


def solve(prob: cp.Problem, what: str) -> str:
    """Solve with Clarabel; raise SolverError unless the answer is optimal (or 'optimal_inaccurate',
    whose answer the callers verify like any other). A solve that stops on a numerical error is
    tried again with the tolerances 1e-7 and stronger static regularisations (ATTEMPTS)."""
    for settings in ATTEMPTS:
        try:
            with warnings.catch_warnings():     # "may be inaccurate": the callers verify every answer
                warnings.simplefilter("ignore", UserWarning)
                prob.solve(solver=cp.CLARABEL, **CLARABEL_LINALG, **settings)
            status = prob.status
        except cp.error.SolverError as exc:
            status = f"solver error ({exc})"
        if status in _OK or status in (cp.INFEASIBLE, cp.INFEASIBLE_INACCURATE):
            break
    if status in (cp.INFEASIBLE, cp.INFEASIBLE_INACCURATE):
        raise InfeasibleProblem(what)
    if status not in _OK:
        raise SolverError(
            f"{what}: Clarabel returned '{status}'. The problem is solved in scaled coordinates already; "
            "check that the data and the prior box bound every parameter (or give CAD bounds for the standard "
            "parameters of a base model), and report the case if it persists.")
    return status


def lmi_expressions(lmis, v: cp.Variable) -> list:
    """The matrices F0 + sum_i v_i F_i of ``lmis`` (each with F0 (k, k), F (n, k, k)), rescaled as
    :meth:`ConicProblem.add_lmi` does, as symmetric cvxpy expressions of v (n,): ``M >> 0`` is the
    constraint, for a hand-written cvxpy problem."""
    scaled = ConicProblem(v.size)
    for L in lmis:
        scaled.add_lmi(L.F0, L.F)
    out = []
    for F0, F in scaled.psds:
        k = F0.shape[0]
        M = F0 + cp.reshape(F.reshape(v.size, k * k).T @ v, (k, k), order="C")
        out.append(0.5 * (M + M.T))
    return out


class InfeasibleProblem(Exception):
    """Clarabel proved the working-set problem infeasible (the caller says what that means)."""
