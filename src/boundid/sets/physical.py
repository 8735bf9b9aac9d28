"""The physically consistent feasible set: strips ∩ prior box ∩ physical constraints.

    P_phys = {theta : |y_k - w_k^T theta| <= e_k for every k} ∩ box ∩ {theta = K x, x satisfies
             the model's constraints}                        ([refs §LP], [WensingKimSlotine2018])

(K = identity unless the constraints are lifted: base parameters of standard ones,
[SousaCortesao2014]; the set is then the projection of a set of (x, theta), kept in that form.)

What it offers, for the comparison with the plain polytope P = strips ∩ box:

* :meth:`PhysicalSet.bounds`: min and max of each theta_j over P_phys;
* :meth:`PhysicalSet.consistency`: gamma*_phys = min over physically consistent theta in the
  box of max_k |y_k - w_k^T theta| / e_k (P_phys is empty iff gamma*_phys > 1: the data
  contradict physics within the bound), beside the plain gamma*;
* :meth:`PhysicalSet.chebyshev_center`: a ball inside P_phys.

How. With linear constraints and no lift, P_phys is a polytope: the LP layer solves it exactly
(:class:`~boundid.sets.polytope.Polytope` with the constraints as its ``halfspaces``, the
simplex of [refs §LP], constraint generation, vertex certificate). Otherwise (cones, LMIs, a lift) each
optimum is a conic program solved by Clarabel [Clarabel] through cvxpy
(:mod:`boundid.sets.conic`) by constraint generation over the strips, in the box frame of the
plain polytope (theta = origin + scale * z, P spanning [-1, 1] along every z_j; unscaled, the
solver fails). P's LP bounding box (widened by 1e-7 of its half-widths) is added to every conic
program: it contains P_phys, so it changes nothing but keeps every working set bounded. The 2p
programs of the bounds, most of a study's run time, call Clarabel directly (:class:`_StripProgram`:
one working set of strips shared by their first solves, grown as the objectives are solved in turn,
then a small one of its own for each objective still violating strips; each strip an equality row
and a bounded variable of its own, so that each interior-point step eliminates one dense row per
strip, not two; one solver set up per working set): measured on the six-joint UR5 (p = 52, 2,987
rows) and TX40 (p = 61, 690 rows) studies, about 2 x faster than the same programs through cvxpy,
the same bounds to the solver's accuracy (1e-5 of the widths).

Certificates. Every optimal point (and the centre, and the consistency minimiser) is checked
against every strip on the original data, the prior box and every constraint: the largest
violation, as a distance in the frame (units of P's half-widths), must be <= PRIMAL_TOL, else
SolverError. Without a lift the bounds are also *certified from outside*: the Lagrangian bound of
:mod:`boundid.sets.conic` over P's LP box, computed from the solver's multipliers, is a proven
lower bound of each minimum (upper bound of each maximum); ``lo``/``hi`` are those proven values
and the gap to the attained ones must stay below GAP_TOL of the half-width. With a lift the
standard parameters the data cannot see are unbounded (a heavy body on the first joint's axis
changes no torque), so no box holds them: the bounds are the attained values of verified points,
optimal to the solver's tolerance (1e-8 relative), not proven; the interior-point iterates drift
along those directions, so the point tolerance is PRIMAL_TOL x max(1, |v|_inf) there. A bound of
the projection may also be reached only in the limit of such a body growing without end (the
projection of a closed set need not be closed): the solver then returns a point close to it
(measured on the 2-link URDF: within 1e-5 of the half-width of the all-strips cvxpy optimum).
"""

from __future__ import annotations

import os
import time
from concurrent.futures import ThreadPoolExecutor
from dataclasses import dataclass, field

import clarabel
import cvxpy as cp
import numpy as np
import scipy.sparse as sp

from boundid._validation import as_float_array, as_matrix, as_regression, as_vector
from boundid.errors import InfeasibleDataError, InputError, SolverError
from boundid.sets.conic import (
    ATTEMPTS,
    CLARABEL_LINALG,
    GEN_TOL,
    ConicProblem,
    ConicResult,
    InfeasibleProblem,
    Pool,
    lmi_expressions,
)
from boundid.sets.conic import solve as solve_conic
from boundid.sets.constraints import PhysicalConstraints
from boundid.sets.ellipsoid import Ellipsoid
from boundid.sets.polytope import Bounds, Polytope

#: stated tolerance of the point certificates: a distance in units of the set's half-widths
PRIMAL_TOL = 1e-6
#: largest accepted gap between the proven (dual) and the attained bound, in half-widths
GAP_TOL = 1e-4
#: a constraint counts as active at a constrained least-squares solution when its violation (a
#: distance in the solver's column-scaled coordinates) exceeds -ACTIVE_TOL
ACTIVE_TOL = 1e-6
#: the plain LP box added to the conic programs is widened by this (in its half-widths)
_BOX_MARGIN = 1e-7
_EPS = np.finfo(float).eps


@dataclass(frozen=True)
class PhysicalBounds:
    """Per-parameter bounds of a physically consistent set.

    lo, hi : (p,) the bounds: proven outer bounds when ``certificate`` says "dual bound" or
        "simplex", else the attained values (see the module docstring).
    argmin, argmax : (p, p) row j is a point of the set where theta_j is lo_attained_j (hi_attained_j).
    lo_attained, hi_attained : (p,) theta_j at those points (verified points of the set).
    point : (p,) the mean of the 2p points: a point of the set (convexity).
    standard_argmin, standard_argmax : (p, n) the standard parameters x at those points (lifted
        constraints), else None.
    method : "LP (simplex)" or "SOCP/SDP (Clarabel)".
    certificate : "simplex" (LP vertices checked, as the plain LP bounds), "dual bound" (outer
        side proven), or "attained" (points verified, optimality to the solver's tolerance).
    info : time_s, solver statistics, worst violation of the points (``primal_excess``: largest
        violation / PRIMAL_TOL, <= 1), largest dual gap in half-widths (``dual_gap``).
    """

    lo: np.ndarray
    hi: np.ndarray
    argmin: np.ndarray
    argmax: np.ndarray
    lo_attained: np.ndarray
    hi_attained: np.ndarray
    point: np.ndarray
    method: str
    certificate: str
    standard_argmin: np.ndarray | None = None
    standard_argmax: np.ndarray | None = None
    info: dict = field(default_factory=dict)

    @property
    def center(self) -> np.ndarray:
        return 0.5 * (self.lo + self.hi)

    @property
    def half_width(self) -> np.ndarray:
        return 0.5 * (self.hi - self.lo)

    def vertices(self) -> np.ndarray:
        """The 2p optimal points stacked, (2p, p)."""
        return np.vstack([self.argmin, self.argmax])


@dataclass(frozen=True)
class PhysicalConsistency:
    """gamma*_phys = min over physically consistent theta in the box of max_k |y_k - w_k^T theta| / e_k.

    gamma : that maximum evaluated on the original data at ``theta`` (an upper bound on
        gamma*_phys); theta is physically consistent (verified, ``x`` its standard parameters).
    lower : a lower bound on gamma*_phys: the dual bound (no lift, finite box), else the solver's
        optimal value; when P itself is empty, at least P's gamma*.
    gamma_plain : gamma* of the strips and the box alone (physics ignored), <= gamma*_phys.
    tol : resolution of the verdict (PRIMAL_TOL plus the rounding of the residuals).
    """

    gamma: float
    lower: float
    gamma_plain: float
    theta: np.ndarray
    x: np.ndarray
    tol: float

    @property
    def empty(self) -> bool:
        """True iff the data contradict physics within the bound: gamma*_phys > 1 (both the lower
        bound and the value at theta above 1 + tol)."""
        return min(self.gamma, self.lower) > 1.0 + self.tol

    @property
    def physics_matters(self) -> bool:
        """True iff the data are consistent without physics but not with it."""
        return self.gamma_plain <= 1.0 + self.tol and self.empty


# ---------------------------------------------------------------------- coordinates
@dataclass(frozen=True)
class _Vars:
    """The solver's variables v (n,) and what they mean, in a frame theta = origin + scale * z:
    z = T v + t0 (p,), x = x0 + dx * v (standard parameters, or theta itself when not lifted);
    ``cons`` are the physical constraints on v; ``L`` (n_x, p) maps a move of theta to a move of x
    with the same theta-move (K L = I), for balls."""

    n: int
    T: np.ndarray
    t0: np.ndarray
    x0: np.ndarray
    dx: np.ndarray
    cons: PhysicalConstraints
    L: np.ndarray
    lifted: bool

    def z(self, V: np.ndarray) -> np.ndarray:
        return V @ self.T.T + self.t0

    def x(self, V: np.ndarray) -> np.ndarray:
        return self.x0 + self.dx * V


def _variables(cons: PhysicalConstraints, origin: np.ndarray, scale: np.ndarray) -> _Vars:
    """Variables for a frame theta = origin + scale * z. Not lifted: v = z. Lifted (theta = K x):
    v = x / dx with dx_j = scale_i when x_j is theta_i itself (column j of K a unit vector e_i and
    row i of K zero elsewhere), else the constraints' typical magnitude of x_j (1 if none)."""
    p = origin.shape[0]
    if not cons.is_lifted:
        dxs = scale.copy()
        vcons = cons.in_coordinates(origin, np.diag(dxs))
        return _Vars(p, np.eye(p), np.zeros(p), origin.copy(), dxs, vcons, np.eye(p), False)
    K = cons.lift
    n = cons.dim
    dx = cons.scale.copy() if cons.scale is not None else np.ones(n)
    x0 = np.zeros(n)
    nz = K != 0
    for j in range(n):
        rows = np.flatnonzero(nz[:, j])
        if rows.size == 1 and K[rows[0], j] == 1.0 and nz[rows[0]].sum() == 1:
            dx[j] = scale[rows[0]]
    T = (K * dx[None, :]) / scale[:, None]
    return _Vars(n, T, (K @ x0 - origin) / scale, x0, dx, cons.in_coordinates(x0, np.diag(dx)),
                 np.linalg.pinv(K), True)


def _margin_rows(vars_: _Vars, rho_scale: float):
    """Coefficients of a ball radius rho' (theta units rho = rho_scale * rho') in the constraints of
    a centre v: linear rows (m,), cones [(kappa)], LMIs [sigma] (sufficient conditions, module
    :meth:`PhysicalSet.chebyshev_center`)."""
    cons = vars_.cons
    L = vars_.L
    # the constraints on v act on x = x0 + dx v; a theta-move u moves x by L u
    Ax = cons.linear.A / vars_.dx[None, :]
    lin = np.linalg.norm(Ax @ L, axis=1) * rho_scale
    cones = []
    for c in cons.cones:
        Gx, fx = c.G / vars_.dx[None, :], c.f / vars_.dx
        cones.append(rho_scale * (np.linalg.norm(L.T @ fx) + np.linalg.norm(Gx @ L, 2)))
    lmis = []
    for Lm in cons.lmis:
        Fx = Lm.F / vars_.dx[:, None, None]
        H = np.tensordot(L.T, Fx, axes=1)                       # (p, k, k)
        lmis.append(rho_scale * float(np.sqrt(sum(np.linalg.norm(Hi, 2) ** 2 for Hi in H))))
    return lin, cones, lmis


# ---------------------------------------------------------------------- the bounds' conic programs
#: objectives solved on one working set before the strips their optima violate join it (so the
#: objectives after them see those strips); an objective whose optimum violates a strip is then
#: finished on a working set of its own (_StripProgram._finish)
_QUEUE_BATCH = 8
#: threads that solve a batch's objectives at once (the machines have 2 cores)
_THREADS = min(2, os.cpu_count() or 1)
#: at most this many of the strips one optimum violates join the working set (the most violated)
_ADD_STRIPS = 32
#: an objective whose first optimum violates strips is finished on a working set of its own: the
#: _OWN_PER_VAR x n strips of the shared set nearest that optimum and the _ADD_OWN it violates most,
#: then each solve's _ADD_OWN most violated (a few hundred strips instead of the shared ~2,000, and
#: better conditioned: six-joint UR5 study 33 -> 17-19 s, Panda study 68 -> 45 s for the bounds)
_OWN_PER_VAR = 2
_ADD_OWN = 64
#: an objective solved this many times without its optimum satisfying every strip: SolverError
_MAX_SOLVES = 50


def _svec_index(k: int) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Clarabel's PSDTriangleConeT order of a symmetric (k, k) matrix: the upper triangle by
    columns, (0,0), (0,1), (1,1), (0,2), ..., off-diagonal entries times sqrt 2 (so that the inner
    product of two such vectors is that of the matrices). Returns the C-order flat indices of
    (i, j) and of (j, i), and the weights."""
    j, i = np.tril_indices(k)
    return i * k + j, j * k + i, np.where(i == j, 1.0, np.sqrt(2.0))


def _svec(M: np.ndarray) -> np.ndarray:
    """svec of the symmetric part of a (k, k) matrix (:func:`_svec_index`)."""
    up, lo, w = _svec_index(M.shape[0])
    return 0.5 * (M.ravel()[up] + M.ravel()[lo]) * w


def _smat(s: np.ndarray, k: int) -> np.ndarray:
    """The symmetric (k, k) matrix of an svec (inverse of :func:`_svec`)."""
    j, i = np.tril_indices(k)
    M = np.zeros((k, k))
    vals = np.where(i == j, s, s / np.sqrt(2.0))
    M[i, j] = vals
    M[j, i] = vals
    return M


class _StripProgram:
    """min c^T v over the fixed parts of a :class:`ConicProblem` (its rows, cones, LMIs and box)
    and the strips |G_k^T v - c_k| <= h_k, for many objectives c: Clarabel [Clarabel] called
    directly (as cvxpy calls it: its default settings, CLARABEL_LINALG, ATTEMPTS after a numerical
    failure), with constraint generation over working sets of strips (below).

    Each strip of the working set is one equality row G_k^T v - r_k = c_k and the bound |r_k| <= h_k
    on a variable r_k of its own, not the two rows +-(G_k^T v) <= h_k +- c_k: the same feasible set
    of v, but the sparse LDL factorisation of each interior-point step eliminates one dense row per
    strip instead of two (1.45 x less time per step on the TX40 study's programs, 1.55 x on the
    UR5's).

    Working sets: the objectives are first solved in batches of _QUEUE_BATCH on one shared working
    set; the strips each optimum violates (by more than GEN_TOL, at most _ADD_STRIPS of them, the
    most violated) then join it, so the objectives solved later start with those strips. An
    objective whose optimum violated strips is then finished alone (:meth:`_finish`, on _THREADS
    threads, one objective whole on one): on the shared strips nearest its optimum and those it
    violated, grown by the strips each of its optima violates. An optimum that violates no strip is
    optimal over every strip (every working set is a relaxation). info: rounds (shared working sets
    solved on), solves, working_rows (strips in the last shared set), finished_alone, solves_alone.

    Dual bound (module docstring of :mod:`boundid.sets.conic`): with Clarabel's multipliers z
    (projected onto the dual cones) of  min q^T u s.t. A u + s = b, s in K,  every feasible u has
    q^T u >= (q + A^T z)^T u - b^T z, minimised over the box of u: ConicProblem's box for v and
    [-h_k, h_k] for r_k. NaN when the ConicProblem has no box.
    """

    def __init__(self, prob: ConicProblem, G: np.ndarray, c: np.ndarray, h: np.ndarray):
        n = prob.n
        self.prob, self.n = prob, n
        fin = np.isfinite(h)
        self.G, self.c, self.h, self.fin = G, c, h, fin
        self.le_A = np.vstack([A for A, _ in prob.le]) if prob.le else np.zeros((0, n))
        self.le_b = np.concatenate([b for _, b in prob.le]) if prob.le else np.zeros(0)
        rows, rhs, self.cones = [], [], []
        for Gs, g, f, d in prob.socs:                  # (f^T v + d, G v + g) in the cone: s = b - A v
            rows.append(-np.vstack([f[None, :], Gs]))
            rhs.append(np.concatenate([[d], g]))
            self.cones.append(("soc", 1 + len(g)))
        for F0, F in prob.psds:
            k = F0.shape[0]
            up, lo, w = _svec_index(k)
            Fm = F.reshape(n, k * k).T                 # svec(F(v)) = svec(F0) + Sm v
            rows.append(-0.5 * (Fm[up] + Fm[lo]) * w[:, None])
            rhs.append(_svec(F0))
            self.cones.append(("psd", k))
        self.cone_A = np.vstack(rows) if rows else np.zeros((0, n))
        self.cone_b = np.concatenate(rhs) if rhs else np.zeros(0)

    # ------------------------------------------------------------------ one working set
    def _model(self, ws: np.ndarray):
        """(A, b, Clarabel cones) on u = (v, r) for the strips ``ws``: rows [equalities; rows of the
        problem; r <= h; -r <= h; cones; LMIs]."""
        n, m = self.n, len(ws)
        I = sp.identity(m, format="csr")
        Z = sp.csr_matrix
        A = sp.vstack([sp.hstack([Z(self.G[ws]), -I]),
                       sp.hstack([Z(self.le_A), Z((self.le_A.shape[0], m))]),
                       sp.hstack([Z((m, n)), I]),
                       sp.hstack([Z((m, n)), -I]),
                       sp.hstack([Z(self.cone_A), Z((self.cone_A.shape[0], m))])], format="csc")
        A.eliminate_zeros()
        b = np.concatenate([self.c[ws], self.le_b, self.h[ws], self.h[ws], self.cone_b])
        cones = [clarabel.ZeroConeT(m)] if m else []
        if self.le_A.shape[0] + 2 * m:
            cones.append(clarabel.NonnegativeConeT(self.le_A.shape[0] + 2 * m))
        for kind, k in self.cones:
            cones.append(clarabel.SecondOrderConeT(k) if kind == "soc" else clarabel.PSDTriangleConeT(k))
        return A, b, cones

    def _solve(self, model, q: np.ndarray):
        """One Clarabel solve of ``model`` (A, b, cones, [solver]) for the cost q: (status, u, z) with
        the status in cvxpy's words ("optimal" or "optimal_inaccurate"). The model's solver is set up
        once and then only given the new cost (Clarabel's data update: the same iterates as a new
        solver, bit for bit, without its setup); after a numerical failure new solvers with the other
        settings of ATTEMPTS try again."""
        A, b, cones, cache = model
        N = A.shape[1]
        for extra in ATTEMPTS:
            try:
                if extra or not cache:
                    settings = clarabel.DefaultSettings()
                    settings.verbose = False
                    for key, val in {**CLARABEL_LINALG, **extra}.items():
                        setattr(settings, key, val)
                    solver = clarabel.DefaultSolver(sp.csc_matrix((N, N)), q, A, b, cones, settings)
                    if not extra:
                        cache.append(solver)
                else:
                    solver = cache[0]
                    solver.update(q=q)
                sol = solver.solve()
                status = str(sol.status)
            except Exception as exc:                    # noqa: BLE001 (reported below like cvxpy's errors)
                sol, status = None, f"solver error ({exc})"
            if status in ("Solved", "AlmostSolved", "PrimalInfeasible", "AlmostPrimalInfeasible"):
                break
        if status in ("PrimalInfeasible", "AlmostPrimalInfeasible"):
            raise InfeasibleProblem(self.prob.what)
        if status not in ("Solved", "AlmostSolved"):
            raise SolverError(
                f"{self.prob.what}: Clarabel returned '{status}'. The problem is solved in scaled coordinates "
                "already; check that the data and the prior box bound every parameter (or give CAD bounds for "
                "the standard parameters of a base model), and report the case if it persists.")
        return ("optimal" if status == "Solved" else "optimal_inaccurate"), np.asarray(sol.x), np.asarray(sol.z)

    def _dual_bound(self, q: np.ndarray, A, b, z: np.ndarray, ws: np.ndarray) -> float:
        """The Lagrangian lower bound of the class docstring (NaN without a box)."""
        if self.prob.box is None or not np.all(np.isfinite(z)):
            return float("nan")
        z = z.copy()
        m = len(ws)
        start = m                                      # the equality rows' multipliers are free
        n_nonneg = self.le_A.shape[0] + 2 * m
        z[start:start + n_nonneg] = np.clip(z[start:start + n_nonneg], 0.0, None)
        at = start + n_nonneg
        for kind, k in self.cones:
            if kind == "soc":
                z[at] = max(z[at], float(np.linalg.norm(z[at + 1:at + k])))
                at += k
            else:
                size = k * (k + 1) // 2
                w, U = np.linalg.eigh(_smat(z[at:at + size], k))
                z[at:at + size] = _svec((U * np.clip(w, 0.0, None)) @ U.T)
                at += size
        g = q + A.T @ z
        const = -float(b @ z)
        lo = np.concatenate([self.prob.box[0], -self.h[ws]])
        hi = np.concatenate([self.prob.box[1], self.h[ws]])
        with np.errstate(invalid="ignore"):
            terms = np.minimum(g * lo, g * hi)
        terms = np.where(g == 0, 0.0, terms)
        return const + float(terms.sum()) - 1e-12 * (abs(const) + float(np.abs(terms).sum()))

    # ------------------------------------------------------------------ all objectives
    def _solve_into(self, part, costs: np.ndarray, model, ws: np.ndarray, out) -> None:
        """Solve the objectives ``part`` (indices into ``costs``) in turn on ``model``, writing each
        argmin, value, dual bound and status into ``out`` = (X, values, dual, status)."""
        A, b = model[0], model[1]
        X, values, dual, status = out
        for i in part:
            q = np.concatenate([costs[i], np.zeros(len(ws))])
            status[i], u, z = self._solve(model, q)
            X[i] = u[:self.n]
            values[i] = float(costs[i] @ X[i])
            dual[i] = self._dual_bound(q, A, b, z, ws)

    def minimize_many(self, costs: np.ndarray, seed=()) -> ConicResult:
        """argmin of each row of ``costs`` (k, n) over the fixed parts and every strip."""
        costs = np.atleast_2d(np.asarray(costs, float))
        k, n = costs.shape[0], self.n
        X = np.full((k, n), np.nan)
        values, dual = np.full(k, np.nan), np.full(k, np.nan)
        status = [""] * k
        in_ws = np.zeros(len(self.h), dtype=bool)
        in_ws[np.asarray(seed, dtype=int)] = True
        in_ws &= self.fin
        queue, own = list(range(k)), {}
        rounds = solves = 0
        out = (X, values, dual, status)
        while queue:
            batch, queue = queue[:_QUEUE_BATCH], queue[_QUEUE_BATCH:]
            ws = np.flatnonzero(in_ws)
            A, b, cones = self._model(ws)
            rounds += 1
            # the batch's solves are independent: one solver per thread (Clarabel releases the GIL), each
            # answer the same as in turn (a solver given a new cost iterates as a new one, bit for bit)
            parts = [batch[j::_THREADS] for j in range(min(_THREADS, len(batch)))]
            with ThreadPoolExecutor(len(parts)) as pool:
                list(pool.map(self._solve_into, parts, [costs] * len(parts),
                              [(A, b, cones, []) for _ in parts], [ws] * len(parts), [out] * len(parts)))
            solves += len(batch)
            viol = self._violations(X[batch])
            solved_on = in_ws.copy()                   # the working set these optima saw
            for col, i in enumerate(batch):
                new = np.flatnonzero((viol[:, col] > GEN_TOL) & ~solved_on)
                if new.size:
                    worst = new[np.argsort(viol[new, col])[::-1]]
                    # its own set: the shared strips nearest its optimum, and the ones it violates
                    slack = -viol[ws, col]
                    keep = ws if ws.size <= _OWN_PER_VAR * n else \
                        ws[np.argpartition(slack, _OWN_PER_VAR * n)[:_OWN_PER_VAR * n]]
                    own[i] = np.union1d(keep, worst[:_ADD_OWN])
                    in_ws[worst[:_ADD_STRIPS]] = True       # the objectives after it see these
                    X[i] = np.nan
        # the objectives whose optimum violated strips, each finished on its own working set, one thread each
        with ThreadPoolExecutor(_THREADS) as pool:
            own_solves = list(pool.map(lambda i: self._finish(i, costs, own[i], out), sorted(own)))
        info = {"rounds": rounds, "solves": solves + sum(own_solves), "working_rows": int(in_ws.sum()),
                "finished_alone": len(own), "solves_alone": sum(own_solves)}
        return ConicResult(X, values, dual, status, info)

    def _violations(self, V: np.ndarray) -> np.ndarray:
        """|G v - c| - h for every strip and each row v of V (m, len(V)); -inf for the strips with no bound."""
        viol = np.abs(self.G @ V.T - self.c[:, None]) - self.h[:, None]
        viol[~self.fin] = -np.inf
        return viol

    def _finish(self, i: int, costs: np.ndarray, ws: np.ndarray, out) -> int:
        """Solve objective i on the working set ``ws`` of its own, grown by the strips each optimum violates
        (the _ADD_OWN most violated) until none is; its answer goes into ``out``. Returns the solves."""
        for solves in range(1, _MAX_SOLVES + 1):
            model = self._model(ws)
            self._solve_into([i], costs, (*model, []), ws, out)
            viol = self._violations(out[0][i][None, :])[:, 0]
            viol[ws] = -np.inf
            new = np.flatnonzero(viol > GEN_TOL)
            if new.size == 0:
                return solves
            ws = np.union1d(ws, new[np.argsort(viol[new])[::-1][:_ADD_OWN]])
        raise SolverError(f"{self.prob.what}: constraint generation did not converge in {_MAX_SOLVES} solves of one "
                          f"objective ({ws.size} working strips).")


def _same_polytope(P: Polytope, Q: Polytope) -> bool:
    """Whether two plain polytopes have the same strips and prior box."""
    if P.W.shape != Q.W.shape or (P.box is None) != (Q.box is None):
        return False
    same = np.array_equal(P.W, Q.W) and np.array_equal(P.y, Q.y) and np.array_equal(P.e_max, Q.e_max)
    return bool(same and (P.box is None or all(np.array_equal(a, b) for a, b in zip(P.box, Q.box, strict=True))))


class PhysicalSet:
    """P_phys = strips ∩ prior box ∩ physical constraints (module docstring).

    Parameters
    ----------
    W : (N, p) regression rows; y : (N,) targets; e_max : scalar or (N,) error bounds (> 0).
    constraints : :class:`~boundid.sets.constraints.PhysicalConstraints` with p parameters
        (e.g. ``model.physical_constraints()``).
    box : optional (lo, hi), each (p,), the prior box (+-inf for an open side).
    plain : optional, the plain polytope P of the same W, y, e_max and box (e.g. a study's exact
        polytope, whose LP bounds are solved already): used as :attr:`plain`, so that its LP bounds
        and frame are not solved a second time (the answers are the same: they are deterministic).
    """

    def __init__(self, W, y, e_max, constraints: PhysicalConstraints, box=None, plain: Polytope | None = None):
        if not isinstance(constraints, PhysicalConstraints):
            raise InputError(f"constraints must be a PhysicalConstraints (e.g. model.physical_constraints()), "
                             f"got {type(constraints).__name__}.")
        self.plain = Polytope(W, y, e_max, box=box)
        if plain is not None:
            if not isinstance(plain, Polytope) or plain.halfspaces is not None or not _same_polytope(plain, self.plain):
                raise InputError("plain must be the Polytope of the same W, y, e_max and box (no halfspaces), "
                                 "e.g. Polytope(W, y, e_max, box=box).")
            self.plain = plain
        if constraints.n_params != self.plain.dim:
            raise InputError(f"the constraints are on {constraints.n_params} parameters but W has {self.plain.dim} "
                             "columns; take them from the same model.")
        self.constraints = constraints
        self._lp: Polytope | None = None
        if constraints.is_linear and not constraints.is_lifted:
            A, b = constraints.linear.A, constraints.linear.b
            self._lp = Polytope(W, y, e_max, box=box, halfspaces=(A, b) if len(b) else None)
        self._bounds: PhysicalBounds | None = None
        self._consistency: PhysicalConsistency | None = None

    @property
    def dim(self) -> int:
        return self.plain.dim

    @property
    def method(self) -> str:
        return "LP (simplex)" if self._lp is not None else "SOCP/SDP (Clarabel)"

    def __repr__(self) -> str:
        return f"PhysicalSet(dim={self.dim}, strips={self.plain.n_strips}, {self.constraints!r}, {self.method})"

    # ------------------------------------------------------------------ frames and pools
    def _frame(self):
        """(origin, scale, LP box (zlo, zhi) widened or None): P's box frame when P is not empty,
        else the LP layer's first frame."""
        P = self.plain
        if P.consistency().empty:
            F = P._get_frame()
            return F.origin.copy(), F.scale.copy(), None
        b = P.bounds()
        origin, scale = P.box_frame()
        zlo, zhi = (b.lo - origin) / scale, (b.hi - origin) / scale
        m = _BOX_MARGIN * np.maximum(0.5 * (zhi - zlo), 1e-12)
        return origin, scale, (zlo - m, zhi + m)

    def _prior_z(self, origin, scale):
        P = self.plain
        if P.box is None:
            return np.full(self.dim, -np.inf), np.full(self.dim, np.inf)
        return (P.box[0] - origin) / scale, (P.box[1] - origin) / scale

    def _z_box(self, origin, scale, lp_box):
        """The prior box ∩ LP box in z."""
        plo, phi = self._prior_z(origin, scale)
        if lp_box is None:
            return plo, phi
        return np.maximum(plo, lp_box[0]), np.minimum(phi, lp_box[1])

    def _add_z_box(self, prob: ConicProblem, V: _Vars, zlo, zhi, extra: int = 0, pad=None) -> None:
        """lo <= z <= hi as rows on (v, extras) (only needed when lifted: otherwise a variable box).
        ``pad`` (p,): coefficient of the first extra variable added to both sides (ball radius)."""
        T = np.hstack([V.T, np.zeros((self.dim, extra))])
        if pad is not None:
            T[:, V.n] = 0.0
        for sgn, bound in ((1.0, zhi), (-1.0, -zlo)):
            fin = np.isfinite(bound)
            A = sgn * T[fin]
            if pad is not None:
                A[:, V.n] = pad[fin]
            prob.add_le(A, bound[fin] - sgn * V.t0[fin])

    def _constraint_parts(self, prob: ConicProblem, V: _Vars, extra: int = 0) -> None:
        cons = V.cons
        if extra:
            cons = cons.in_coordinates(np.zeros(V.n), np.hstack([np.eye(V.n), np.zeros((V.n, extra))]))
        prob.add_constraints(cons)

    def _strips(self, origin, scale):
        """Unit strip rows in z: |G z - c| <= h (zero rows: h = inf)."""
        G, c, h = self.plain._unit_strips(origin, scale)
        return G, c, h

    def _seed(self, G, c, h, Z: np.ndarray) -> np.ndarray:
        """Strips active (within 1e-7) at the points Z (m, p) of the frame."""
        if Z.size == 0:
            return np.zeros(0, dtype=int)
        R = np.abs(Z @ G.T - c) - h
        return np.flatnonzero(np.any(R >= -1e-7 * (1.0 + h), axis=0))

    # ------------------------------------------------------------------ verification
    def _excess(self, theta: np.ndarray, V: _Vars, Vpts: np.ndarray, scale: np.ndarray, gamma: float = 1.0,
                where: str = "") -> float:
        """Largest violation / tolerance of the points over every strip (original data, residual
        bound gamma e), the prior box and every constraint (frame units); SolverError above 1.
        The tolerance is PRIMAL_TOL, times max(1, |v|_inf) for lifted variables: interior-point
        residuals are relative to the iterate, which grows along the unbounded directions of the
        standard parameters the data cannot see."""
        P = self.plain
        X = np.atleast_2d(theta)
        Vp = np.atleast_2d(Vpts)
        size = np.maximum(1.0, np.abs(Vp[:, :V.n]).max(axis=1)) if V.lifted else np.ones(len(Vp))
        worst, what = 0.0, ""
        Ws = P.W * scale
        nrm = np.linalg.norm(Ws, axis=1)
        nrm[nrm == 0] = 1.0
        R = np.abs(P.y[:, None] - P.W @ X.T) - gamma * P.e_max[:, None]
        rnd = 16 * _EPS * (np.abs(P.y)[:, None] + np.abs(P.W) @ np.abs(X).T)
        q = (R - rnd) / nrm[:, None] / (PRIMAL_TOL * size[None, :])
        if q.size and q.max() > worst:
            worst, what = float(q.max()), f"strip {int(np.unravel_index(np.argmax(q), q.shape)[0])}"
        if P.box is not None:
            qb = np.maximum(P.box[0] - X, X - P.box[1]) / scale / (PRIMAL_TOL * size[:, None])
            if qb.max() > worst:
                worst, what = float(qb.max()), "prior box"
        vi = V.cons.violations(Vp[:, :V.n]) / (PRIMAL_TOL * size[:, None])
        if vi.size and vi.max() > worst:
            k = int(np.unravel_index(np.argmax(vi), vi.shape)[1])
            worst, what = float(vi.max()), f"constraint {V.cons.labels[k]!r}"
        if worst > 1.0:
            raise SolverError(
                f"{where}: a solution violates the {what} by {worst:.3g} times the stated tolerance "
                f"({PRIMAL_TOL:g} of the set's half-widths). The conic solve was inaccurate; check for rows or "
                "constraints of very different magnitude, or report the case.")
        return worst

    # ------------------------------------------------------------------ consistency
    def consistency(self) -> PhysicalConsistency:
        """gamma*_phys and a physically consistent minimiser (never raises for bad data)."""
        if self._consistency is not None:
            return self._consistency
        cons_plain = self.plain.consistency()
        if self._lp is not None:
            c = self._lp.consistency()
            lower = c.lp_gamma if np.isfinite(c.lp_gamma) else c.gamma
            x = c.theta
            res = PhysicalConsistency(c.gamma, max(lower, cons_plain.lp_gamma), cons_plain.gamma, c.theta, x, c.tol)
        else:
            res = self._conic_consistency(cons_plain)
        self._consistency = res
        return res

    def _conic_consistency(self, cons_plain) -> PhysicalConsistency:
        origin, scale, lp_box = self._frame()
        V = _variables(self.constraints, origin, scale)
        G, c, h = self._strips(origin, scale)
        n = V.n
        zlo, zhi = self._prior_z(origin, scale)
        finite_box = np.all(np.isfinite(zlo)) and np.all(np.isfinite(zhi)) and not V.lifted
        box = (np.append(zlo, 0.0), np.append(zhi, np.inf)) if finite_box else None
        prob = ConicProblem(n + 1, box=box, what="physically consistent gamma*", cap=n)
        if not finite_box:
            prob.add_le(-np.eye(n + 1)[n:], [0.0])                      # t >= 0
            self._add_z_box(prob, V, zlo, zhi, extra=1)
        self._constraint_parts(prob, V, extra=1)
        GT = G @ V.T
        fin = np.isfinite(h)

        def rows(idx):
            idx = idx[fin[idx]]
            A = np.vstack([np.hstack([GT[idx], -h[idx, None]]), np.hstack([-GT[idx], -h[idx, None]])])
            off = G[idx] @ V.t0
            return A, np.concatenate([c[idx] - off, off - c[idx]])

        def violation(Vt):
            Z = V.T @ Vt[:n] + V.t0[:, None]
            out = np.abs(G @ Z - c[:, None]) - h[:, None] * Vt[n][None, :]
            return np.where(fin[:, None], out, -np.inf)

        Z0 = np.atleast_2d((cons_plain.theta - origin) / scale) if np.all(np.isfinite(cons_plain.theta)) else \
            np.zeros((0, self.dim))
        seed = np.union1d(cons_plain.active, self._seed(G, c, h, Z0)).astype(int)
        cost = np.zeros(n + 1)
        cost[n] = 1.0
        try:
            r = prob.minimize_many(cost[None, :], Pool(rows, violation, len(h)), seed=seed)
        except InfeasibleProblem:
            return PhysicalConsistency(np.inf, np.inf, cons_plain.gamma, np.full(self.dim, np.nan),
                                       np.full(self.constraints.dim, np.nan), 0.0)
        v = r.points[0]
        theta = origin + scale * V.z(v[None, :n])[0]
        P = self.plain
        rho = np.abs(P.y - P.W @ theta) / P.e_max
        gamma = float(rho.max())
        tol = PRIMAL_TOL + 16 * _EPS * float(((np.abs(P.y) + np.abs(P.W) @ np.abs(theta)) / P.e_max).max())
        self._excess(theta, V, v[None, :n], scale, gamma=max(gamma, 1.0), where="physically consistent gamma*")
        lower = r.dual[0] if np.isfinite(r.dual[0]) else r.values[0]
        lower = max(lower, cons_plain.lp_gamma if np.isfinite(cons_plain.lp_gamma) else -np.inf)
        return PhysicalConsistency(gamma, float(lower), cons_plain.gamma, theta, V.x(v[None, :n])[0], tol)

    def is_empty(self) -> bool:
        return self.consistency().empty

    def _empty_error(self, cons: PhysicalConsistency) -> InfeasibleDataError:
        if not cons.empty:
            return InfeasibleDataError(
                f"the physically consistent set is empty to solver accuracy: gamma*_phys = {cons.gamma:.10g} is 1 "
                f"within the tolerance {cons.tol:.2g} (plain gamma* = {cons.gamma_plain:.6g}): the data sit at the "
                "edge of consistency with physics. Enlarge e_max slightly or remove outliers.")
        if cons.gamma_plain > 1.0 + cons.tol:
            return InfeasibleDataError(
                f"the data contradict the error bounds even without physics: gamma* = {cons.gamma_plain:.6g} > 1 "
                f"(with physics: {cons.gamma:.6g}). Enlarge e_max by at least that factor or remove outliers.")
        return InfeasibleDataError(
            f"the data contradict physics within the bound: the strips and the prior box alone are consistent "
            f"(gamma* = {cons.gamma_plain:.6g} <= 1), but no physically consistent parameter vector fits every "
            f"row: gamma*_phys = {cons.gamma:.6g} > 1 (the smallest uniform inflation of the bounds that admits "
            "a physical one). The model or the bound is wrong (structural error larger than e_max, a wrong "
            f"sign convention, friction the model lacks); the nearest physical fit leaves {cons.gamma:.4g} e_max.")

    # ------------------------------------------------------------------ bounds
    def bounds(self) -> PhysicalBounds:
        """min and max of every parameter over P_phys (module docstring for how and what is proven).

        Raises InfeasibleDataError if P_phys is empty (saying whether physics or the data alone
        make it so, with both gamma*), InputError if it is unbounded, SolverError if a solve fails
        or its answer fails its certificate.
        """
        if self._bounds is not None:
            return self._bounds
        t0 = time.perf_counter()
        if self.plain.consistency().empty:
            raise self._empty_error(self.consistency())
        if self._lp is not None:
            try:
                b = self._lp.bounds()
            except InfeasibleDataError:
                raise self._empty_error(self.consistency()) from None
            self._bounds = self._from_lp(b, t0)
        else:
            self._bounds = self._conic_bounds(t0)
        return self._bounds

    def _from_lp(self, b: Bounds, t0: float) -> PhysicalBounds:
        chk = self.constraints.violations(b.vertices())
        clo, chi = column_bounds(self.constraints)          # single-parameter rows hold at every point
        lo, hi = np.maximum(b.lo, clo), np.minimum(b.hi, chi)
        return PhysicalBounds(lo, hi, b.argmin, b.argmax, b.lo, b.hi, b.point, self.method, "simplex",
                              info={**b.info, "time_s": time.perf_counter() - t0, "vertex_excess": b.vertex_excess,
                                    "worst_constraint_violation": float(chk.max()) if chk.size else 0.0})

    def _conic_bounds(self, t0: float) -> PhysicalBounds:
        origin, scale, lp_box = self._frame()
        V = _variables(self.constraints, origin, scale)
        p, n = self.dim, V.n
        zlo, zhi = self._z_box(origin, scale, lp_box)
        G, c, h = self._strips(origin, scale)
        plain_b = self.plain.bounds()
        seed = self._seed(G, c, h, (plain_b.vertices() - origin) / scale)
        costs = np.vstack([V.T, -V.T])

        prob = ConicProblem(n, box=None if V.lifted else (zlo, zhi), what="physically consistent bounds")
        if V.lifted:
            self._add_z_box(prob, V, zlo, zhi)
        self._constraint_parts(prob, V)
        # the strips on v: |G (T v + t0) - c| <= h
        program = _StripProgram(prob, G @ V.T, c - G @ V.t0, h)
        try:
            r = program.minimize_many(costs, seed=seed)
        except InfeasibleProblem:
            raise self._empty_error(self.consistency()) from None
        Z = V.z(r.points)
        Theta = origin + scale * Z
        excess = self._excess(Theta, V, r.points, scale, where="physically consistent bounds")
        amin, amax = Theta[:p], Theta[p:]
        lo_att, hi_att = np.diag(amin).copy(), np.diag(amax).copy()
        if V.lifted:
            lo, hi, cert, gap = lo_att, hi_att, "attained", np.nan
        else:
            lo_d = origin + scale * (r.dual[:p] + V.t0)
            hi_d = origin + scale * (-r.dual[p:] + V.t0)
            gap = float(max(np.max((lo_att - lo_d) / scale), np.max((hi_d - hi_att) / scale)))
            if not np.isfinite(gap) or gap > GAP_TOL:
                raise SolverError(
                    f"physically consistent bounds: the proven (dual) bounds are {gap:.3g} half-widths from the "
                    f"attained ones (tolerance {GAP_TOL:g}): the conic solves were inaccurate (statuses "
                    f"{sorted(set(r.status))}). Report the case (W, y, e_max, constraints).")
            # P_phys is inside P: P's LP bounds hold too (and keep the interval inside P's)
            lo = np.maximum(np.minimum(lo_d, lo_att), plain_b.lo)
            hi = np.minimum(np.maximum(hi_d, hi_att), plain_b.hi)
            cert = "dual bound"
        clo, chi = column_bounds(self.constraints)          # single-parameter rows hold at every point
        lo, hi = np.maximum(lo, clo), np.minimum(hi, chi)
        X = V.x(r.points)
        info = {**r.info, "time_s": time.perf_counter() - t0, "primal_excess": excess, "dual_gap": gap,
                "statuses": sorted(set(r.status))}
        return PhysicalBounds(lo, hi, amin, amax, lo_att, hi_att, Theta.mean(axis=0), self.method, cert,
                              X[:p] if V.lifted else None, X[p:] if V.lifted else None, info)

    # ------------------------------------------------------------------ centre
    def chebyshev_center(self) -> tuple[np.ndarray, float]:
        """(centre, radius) of a Euclidean ball (parameter units, as the plain polytope's) inside
        P_phys. Linear constraints without a lift: the largest such ball (the LP layer's).
        Otherwise the largest ball satisfying sufficient conditions, exact for the strips, box and
        linear rows: for a cone ||G x + g|| + r (||G L|| + ||L^T f||) <= f^T x + d, for an LMI
        F(x) >= r sqrt(sum_i ||sum_j L_ji F_j||^2) I, with L = pinv(K) (the identity without a lift)
        moving x along with theta. The centre is verified like the bounds' points."""
        cons = self.consistency()
        if cons.empty:
            raise self._empty_error(cons)
        if self._lp is not None:
            return self._lp.chebyshev_center()
        origin, scale, lp_box = self._frame()
        V = _variables(self.constraints, origin, scale)
        n = V.n
        rs = float(scale.min())
        prob = ConicProblem(n + 1, what="physically consistent Chebyshev centre")
        zlo, zhi = self._z_box(origin, scale, lp_box)
        self._add_z_box(prob, V, zlo, zhi, extra=1, pad=rs / scale)
        prob.add_le(-np.eye(n + 1)[n:], [0.0])
        lin, kap, sig = _margin_rows(V, rs)
        vc = V.cons
        if vc.linear.m:
            nrm = np.linalg.norm(vc.linear.A, axis=1)
            prob.add_le(np.hstack([vc.linear.A, lin[:, None]]) / nrm[:, None], vc.linear.b / nrm)
        for cone, k in zip(vc.cones, kap, strict=True):
            s = cone.lipschitz
            prob.add_soc(np.hstack([cone.G, np.zeros((cone.G.shape[0], 1))]) / s, cone.g / s,
                         np.append(cone.f, -k) / s, cone.d / s)
        for L, sg in zip(vc.lmis, sig, strict=True):
            k = L.F0.shape[0]
            prob.add_lmi(L.F0, np.concatenate([L.F, -sg * np.eye(k)[None]], axis=0))
        G, c, h = self._strips(origin, scale)
        P = self.plain
        a = rs * np.linalg.norm(P.W, axis=1) / np.where(np.isfinite(h), P.e_max / h, 1.0)
        GT = G @ V.T
        fin = np.isfinite(h)

        def rows(idx):
            idx = idx[fin[idx]]
            off = G[idx] @ V.t0
            return (np.vstack([np.hstack([GT[idx], a[idx, None]]), np.hstack([-GT[idx], a[idx, None]])]),
                    np.concatenate([c[idx] + h[idx] - off, h[idx] - c[idx] + off]))

        def violation(Vt):
            out = np.abs(G @ (V.T @ Vt[:n] + V.t0[:, None]) - c[:, None]) + a[:, None] * Vt[n][None, :] - h[:, None]
            return np.where(fin[:, None], out, -np.inf)

        Z0 = (self.bounds().vertices() - origin) / scale
        cost = np.zeros(n + 1)
        cost[n] = -1.0
        r = prob.minimize_many(cost[None, :], Pool(rows, violation, len(h)), seed=self._seed(G, c, h, Z0))
        v = r.points[0]
        centre = origin + scale * V.z(v[None, :n])[0]
        self._excess(centre, V, v[None, :n], scale, where="physically consistent Chebyshev centre")
        return centre, max(0.0, float(v[n]) * rs)

    # ------------------------------------------------------------------ membership
    def contains(self, theta, tol: float = 1e-9) -> bool:
        """Whether theta (p,) satisfies every strip and the box (relative ``tol``, as
        :meth:`Polytope.contains`) and is physically consistent (:func:`physical_margin` >= -tol)."""
        theta = as_vector(theta, "theta", self.dim)
        return bool(self.plain.contains(theta, rtol=tol)) and physical_margin(self.constraints, theta)[0] >= -tol


def column_bounds(cons: PhysicalConstraints) -> tuple[np.ndarray, np.ndarray]:
    """(lo, hi) (p,) on theta implied by the linear rows on a single variable x_j that is itself a
    parameter theta_i (no lift; or column j of K the unit vector e_i and row i of K zero elsewhere,
    e.g. a friction coefficient among base parameters); -inf, inf elsewhere. They hold at every
    physically consistent point."""
    p = cons.n_params
    lo, hi = np.full(p, -np.inf), np.full(p, np.inf)
    K = np.eye(cons.dim) if cons.lift is None else cons.lift
    own = {}
    for j in range(cons.dim):
        rows = np.flatnonzero(K[:, j])
        if rows.size == 1 and np.count_nonzero(K[rows[0]]) == 1:
            own[j] = (int(rows[0]), float(K[rows[0], j]))
    for a, bi in zip(cons.linear.A, cons.linear.b, strict=True):
        nz = np.flatnonzero(a)
        if nz.size != 1 or int(nz[0]) not in own:
            continue
        i, k = own[int(nz[0])]
        coef = a[nz[0]] / k                              # a_j x_j <= b with theta_i = k x_j
        if coef > 0:
            hi[i] = min(hi[i], bi / coef)
        else:
            lo[i] = max(lo[i], bi / coef) + 0.0          # + 0.0: no -0.0
    return lo, hi


# ---------------------------------------------------------------------- single points
def physical_margin(constraints: PhysicalConstraints, theta) -> tuple[float, np.ndarray]:
    """(margin, x): how physically consistent theta (p,) is; >= 0 iff it is.

    Not lifted: margin = -(worst violation) of :meth:`PhysicalConstraints.check` at x = theta (a
    distance in theta's units for linear rows). Lifted (theta = K x): the largest s <= 1 such that
    some x with K x = theta satisfies every constraint with margin s in the scaled coordinates
    x = scale * w (rows and cones divided by their norms, LMIs F(x) >= s I after the congruence of
    :meth:`ConicProblem.add_lmi`), found by one conic program; x is the maximiser."""
    p = constraints.n_params
    theta = as_vector(theta, "theta", p)
    if not constraints.is_lifted:
        x = theta if constraints.lift is None else np.linalg.solve(constraints.lift, theta)
        chk = constraints.check(x)
        return -chk.worst if np.isfinite(chk.worst) else np.inf, x
    n = constraints.dim
    dx = constraints.scale if constraints.scale is not None else np.ones(n)
    cons = constraints.in_coordinates(np.zeros(n), np.diag(dx))
    w, s = cp.Variable(n), cp.Variable()
    K = constraints.lift * dx[None, :]
    rs = np.maximum(np.abs(K).max(axis=1), 1e-300)
    parts = [(K / rs[:, None]) @ w == theta / rs, s <= 1.0]
    if cons.linear.m:
        nrm = np.linalg.norm(cons.linear.A, axis=1)
        parts.append((cons.linear.A / nrm[:, None]) @ w + s <= cons.linear.b / nrm)
    for c in cons.cones:
        lip = c.lipschitz
        parts.append(cp.SOC((c.f @ w + c.d) / lip - s, (c.G @ w + c.g) / lip))
    parts += [M - s * np.eye(M.shape[0]) >> 0 for M in lmi_expressions(cons.lmis, w)]
    prob = cp.Problem(cp.Maximize(s), parts)
    try:
        solve_conic(prob, "physical margin")
    except InfeasibleProblem:
        raise SolverError("physical margin: no standard parameters x give K x = theta; theta is not in the "
                          "range of the lift (a wrong base-parameter vector?).") from None
    return float(s.value), dx * w.value


def constrained_fit(W, y, constraints: PhysicalConstraints) -> tuple[np.ndarray, np.ndarray, tuple[str, ...]]:
    """argmin |y - W theta| over physically consistent theta: (theta, x, active constraint labels).

    Solved as min t s.t. |R D u - Q^T y| <= t (W = Q R, theta = D u with D the inverse column norms
    of W: a p-row problem whatever N), plus the constraints in u (lifted: theta = K x, x = scale w).
    """
    W, y = as_regression(W, y)
    p = W.shape[1]
    if not isinstance(constraints, PhysicalConstraints) or constraints.n_params != p:
        raise InputError(f"constraints must be a PhysicalConstraints on the {p} parameters of W (e.g. "
                         "model.physical_constraints()).")
    Q, R = np.linalg.qr(W)
    b = Q.T @ y
    cn = np.linalg.norm(W, axis=0)
    D = 1.0 / np.where(cn > 0, cn, 1.0)
    V = _variables(constraints, np.zeros(p), D)                 # theta = D (T v + t0)
    n = V.n
    A = R @ (D[:, None] * V.T)
    a = R @ (D * V.t0) - b
    size = max(float(np.linalg.norm(b)), 1e-300)
    prob = ConicProblem(n + 1, what="physically consistent least squares")
    prob.add_soc(np.hstack([A, np.zeros((p, 1))]) / size, a / size, np.eye(n + 1)[n], 0.0)
    cons_v = V.cons.in_coordinates(np.zeros(n), np.hstack([np.eye(n), np.zeros((n, 1))]))
    prob.add_constraints(cons_v)
    cost = np.zeros(n + 1)
    cost[n] = 1.0
    try:
        r = prob.minimize_many(cost[None, :])
    except InfeasibleProblem:
        raise InfeasibleDataError("the physical constraints admit no parameter vector at all; check them "
                                  "(e.g. contradictory CAD bounds).") from None
    v = r.points[0, :n]
    theta = D * (V.T @ v + V.t0)
    viol = V.cons.violations(v)[0]
    active = tuple(lab for lab, s in zip(V.cons.labels, viol, strict=True) if s > -ACTIVE_TOL)
    return theta, V.x(v[None, :])[0], active


# ---------------------------------------------------------------------- ellipsoid ∩ physics
class ConstrainedEllipsoid:
    """{S theta : theta in E, theta physically consistent}: an ellipsoid E (p) intersected with a
    model's physical set, seen through a selector S (q, p) (default identity; rows of the identity
    for a projection). A ConvexSet: intervals and support by one SOCP/SDP per direction (Clarabel,
    in E's unit-ball coordinates theta = c + L u, |u| <= 1, where every variable is in [-1, 1]: the
    dual bound of :mod:`boundid.sets.conic` then proves each support value when not lifted);
    contains by one feasibility program; log_volume is NaN (not computed).
    """

    def __init__(self, ellipsoid: Ellipsoid, constraints: PhysicalConstraints, selector=None):
        if not isinstance(ellipsoid, Ellipsoid):
            raise InputError(f"ellipsoid must be an Ellipsoid, got {type(ellipsoid).__name__}.")
        if constraints.n_params != ellipsoid.dim:
            raise InputError(f"the constraints are on {constraints.n_params} parameters, the ellipsoid has "
                             f"{ellipsoid.dim}; take them from the same model.")
        self.ellipsoid, self.constraints = ellipsoid, constraints
        p = ellipsoid.dim
        self.selector = np.eye(p) if selector is None else np.atleast_2d(as_float_array(selector, "selector"))
        if self.selector.shape[1] != p:
            raise InputError(f"selector must have {p} columns, got shape {self.selector.shape}.")
        self._intervals: tuple[np.ndarray, np.ndarray] | None = None
        #: after intervals(): (2q, p) the maximisers of S theta then of -S theta, points of the set
        self.extreme_points: np.ndarray | None = None
        self.info: dict = {}

    @property
    def dim(self) -> int:
        return int(self.selector.shape[0])

    def __repr__(self) -> str:
        return f"ConstrainedEllipsoid(dim={self.dim}, {self.constraints!r})"

    def _problem(self):
        """(ConicProblem, map v -> theta (A, a): theta = a + A v, map v -> x, variables)."""
        E, cons = self.ellipsoid, self.constraints
        Lc = E.factor
        p = E.dim
        if not cons.is_lifted:
            Kinv = np.eye(p) if cons.lift is None else np.linalg.inv(cons.lift)
            vcons = cons.in_coordinates(Kinv @ E.center, Kinv @ Lc)
            prob = ConicProblem(p, box=(-np.ones(p), np.ones(p)), what="ellipsoid ∩ physical set")
            prob.add_soc(np.eye(p), np.zeros(p), np.zeros(p), 1.0)
            prob.add_constraints(vcons)
            return prob, Lc, E.center, (Kinv @ E.center, Kinv @ Lc), vcons
        n = cons.dim
        half = np.linalg.norm(Lc, axis=1)
        V = _variables(cons, E.center, half)
        Linv = np.linalg.inv(Lc)
        A = half[:, None] * V.T                                         # theta = c + half * (T v + t0)
        a = E.center + half * V.t0
        prob = ConicProblem(n, what="ellipsoid ∩ physical set")
        prob.add_soc(Linv @ A, Linv @ (a - E.center), np.zeros(n), 1.0)
        prob.add_constraints(V.cons)
        return prob, A, a, (V.x0, np.diag(V.dx)), V.cons

    def _supports(self, D: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray, dict]:
        """(proven or attained max of d^T theta, the maximisers theta, the attained values) for rows d of D (k, p)."""
        prob, A, a, (x0, M), vcons = self._problem()
        try:
            r = prob.minimize_many(-(D @ A))
        except InfeasibleProblem:
            raise InfeasibleDataError("the ellipsoid and the physical set do not intersect: no physically consistent "
                                      "parameter vector lies in the ellipsoid (the estimator's set excludes physics; "
                                      "check the bound and the model).") from None
        Theta = a + r.points @ A.T
        att = np.einsum("ij,ij->i", D, Theta)
        viol = vcons.violations(r.points)
        E = self.ellipsoid
        inside = E.mahalanobis2(Theta)
        worst = max(float(viol.max()) if viol.size else 0.0, float(np.sqrt(inside.max())) - 1.0)
        if worst > PRIMAL_TOL:
            raise SolverError(f"ellipsoid ∩ physical set: a maximiser violates the set by {worst:.3g} (unit-ball "
                              f"units, tolerance {PRIMAL_TOL:g}); the conic solve was inaccurate.")
        if np.all(np.isfinite(r.dual)):
            proven = np.maximum(-(r.dual) + D @ a, att)
            scale = np.linalg.norm(D @ E.factor, axis=1)
            gap = float(np.max((proven - att) / scale))
            if gap > GAP_TOL:
                raise SolverError(f"ellipsoid ∩ physical set: proven and attained supports differ by {gap:.3g} of "
                                  f"the ellipsoid's extent (tolerance {GAP_TOL:g}); the conic solve was inaccurate.")
            cert = "dual bound"
        else:
            proven, gap, cert = att, float("nan"), "attained"
        return proven, Theta, att, {**r.info, "certificate": cert, "dual_gap": gap, "primal_worst": worst}

    def intervals(self) -> tuple[np.ndarray, np.ndarray]:
        """(lo, hi) of S theta over the set (2q programs; proven outer bounds when not lifted)."""
        if self._intervals is None:
            S = self.selector
            t0 = time.perf_counter()
            vals, Theta, _, info = self._supports(np.vstack([S, -S]))
            q = self.dim
            lo, hi = -vals[q:], vals[:q]
            if np.array_equal(S, np.eye(self.ellipsoid.dim)):
                # bounds that hold at every point: E's own, and single-parameter constraint rows
                clo, chi = column_bounds(self.constraints)
                elo, ehi = self.ellipsoid.intervals()
                lo, hi = np.maximum(lo, np.maximum(clo, elo)), np.minimum(hi, np.minimum(chi, ehi))
            self._intervals = (lo, hi)
            self.extreme_points = Theta
            self.info = {**info, "time_s": time.perf_counter() - t0}
        return self._intervals

    def support(self, direction) -> float:
        d = as_vector(direction, "direction", self.dim)
        return float(self._supports((d @ self.selector)[None, :])[0][0])

    def supports(self, directions) -> np.ndarray:
        """max of d^T S theta for each row d of ``directions`` (m, q) (one batch of conic solves)."""
        return self._supports(as_matrix(directions, "directions", self.dim) @ self.selector)[0]

    def support_point(self, direction) -> tuple[float, np.ndarray]:
        """(max of d^T S theta, S theta at a maximiser)."""
        d = as_vector(direction, "direction", self.dim)
        val, Theta, _, _ = self._supports((d @ self.selector)[None, :])
        return float(val[0]), self.selector @ Theta[0]

    def contains(self, points):
        """Whether each point (q,) is S theta for some theta in E ∩ physics (to 1e-9 of E's scale)."""
        X = np.atleast_2d(as_float_array(points, "points"))
        if X.shape[1] != self.dim:
            raise InputError(f"points must have {self.dim} columns, got shape {X.shape}.")
        out = np.array([self._contains_one(x) for x in X])
        return bool(out[0]) if np.ndim(points) == 1 else out

    def _contains_one(self, x: np.ndarray) -> bool:
        E, cons = self.ellipsoid, self.constraints
        p = E.dim
        if not cons.is_lifted and np.array_equal(self.selector, np.eye(p)):
            return bool(E.contains(x)) and physical_margin(cons, x)[0] >= -1e-9
        prob, A, a, _, vcons = self._problem()
        n = A.shape[1]
        v, t = cp.Variable(n), cp.Variable()
        Lc = E.factor
        Linv = np.linalg.inv(Lc)
        S = self.selector
        half = np.linalg.norm(S @ Lc, axis=1)
        parts = [cp.SOC(t, Linv @ (A @ v + a - E.center)), ((S @ A) @ v + S @ a - x) / half == 0]
        if vcons.linear.m:
            nrm = np.linalg.norm(vcons.linear.A, axis=1)
            parts.append((vcons.linear.A / nrm[:, None]) @ v <= vcons.linear.b / nrm)
        for c in vcons.cones:
            parts.append(cp.SOC(c.f @ v + c.d, c.G @ v + c.g))
        for F0, F in prob.psds:
            k = F0.shape[0]
            M = F0 + cp.reshape(F.reshape(n, k * k).T @ v, (k, k), order="C")
            parts.append(0.5 * (M + M.T) >> 0)
        pr = cp.Problem(cp.Minimize(t), parts)
        try:
            solve_conic(pr, "ellipsoid ∩ physical set membership")
        except InfeasibleProblem:
            return False
        return float(t.value) <= 1.0 + 1e-9

    def log_volume(self) -> float:
        """NaN: the volume of an ellipsoid cut by LMIs is not computed."""
        return float("nan")

    def project(self, i: int, j: int) -> ConstrainedEllipsoid:
        """The exact shadow on parameters (i, j): the same set seen through two rows of the selector."""
        q = self.dim
        if not (0 <= i < q and 0 <= j < q and i != j):
            raise InputError(f"project needs two distinct indices in [0, {q}), got ({i}, {j}).")
        return ConstrainedEllipsoid(self.ellipsoid, self.constraints, self.selector[[i, j]])

    def boundary(self, n_points: int = 64) -> np.ndarray:
        """2-D only: the support points along ``n_points`` directions, counter-clockwise (a polygon
        inscribed in the set whose vertices lie on its boundary; one program per direction)."""
        if self.dim != 2:
            raise InputError(f"boundary() is for 2-D sets; project(i, j) first (dimension {self.dim}).")
        ang = np.linspace(0.0, 2 * np.pi, int(n_points), endpoint=False)
        D = np.column_stack([np.cos(ang), np.sin(ang)])
        _, Theta, _, _ = self._supports(D @ self.selector)
        pts = Theta @ self.selector.T
        return np.vstack([pts, pts[:1]])
