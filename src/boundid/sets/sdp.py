"""Exact and certified ellipsoids of polytopes and point sets by SDP (cvxpy + Clarabel).

[refs §SDP]: maximum-volume inscribed ellipsoid, S-procedure outer ellipsoid on tightened
strips (column generation), John's factor-n enlargement, minimum-volume ellipsoid around points,
the bracket [lower, upper] of the minimum-volume ellipsoid containing P, and the exact one-step
ellipsoid of E ∩ strip. Every SDP is solved in scaled coordinates (the box frame of P, where P
spans [-1, 1] along every axis, see :mod:`boundid.sets.polytope`, or the unit-ball coordinates
of E): unscaled, Clarabel failed on ~1000 strips.

Every function returns an :class:`SDPResult` (the ellipsoid plus solver status, wall time,
the strips of P used). The result is verified before it is returned: inner ellipsoids are shrunk
onto P exactly if the solver left them a rounding error outside; outer ones are enlarged by the
certified residual of their S-procedure certificate and checked against known vertices of P.
A failed or inaccurate solve raises :class:`boundid.errors.SolverError`, unless the caller
passes ``allow_fallback=True``: SCS is then tried and its (re-verified) answer returned.
"""

from __future__ import annotations

import threading
import time
from dataclasses import dataclass, field

import cvxpy as cp
import numpy as np
import scipy.sparse as sp
from scipy.spatial import ConvexHull, QhullError

from boundid._validation import as_float_array, as_matrix, as_vector
from boundid.errors import InfeasibleDataError, InputError, SolverError
from boundid.sets._inscribed import max_volume_inscribed
from boundid.sets._mvee import mvee_dual
from boundid.sets._s_lagrangian import s_procedure_multipliers
from boundid.sets.conic import CLARABEL_DENSE_LINALG, CLARABEL_LINALG
from boundid.sets.ellipsoid import Ellipsoid
from boundid.sets.polytope import LP_TOL, MAX_VERTEX_DIM, Polytope

#: an outer ellipsoid may be enlarged by at most this (relative, in squared radius) to repair
#: solver inaccuracy; a larger repair means the solve was inaccurate and raises SolverError
_MAX_REPAIR = 1e-4
#: Clarabel settings (see _solve)
_CLARABEL = {"tol_gap_abs": 1e-7, "tol_gap_rel": 1e-7, "tol_feas": 1e-7}
#: cvxpy numbers its variables and expressions with a global counter that is not thread-safe, so
#: models are built, compiled and unpacked under this lock; the solver itself (Clarabel releases
#: the GIL) runs outside it, so that threads of the caller may solve SDPs at once
_CVXPY = threading.RLock()


@dataclass(frozen=True)
class SDPResult:
    """An SDP ellipsoid with how it was obtained.

    ellipsoid : the Ellipsoid (parameter units).
    status : solver status ("optimal", or "no_cut" when step_ellipsoid had nothing to cut; the outer
        ellipsoid says when it stopped at max_rounds).
    time_s : wall time of the whole call (LPs, SDP solves, verification), s; a result cached on
        the polytope (inner, outer ellipsoids) keeps the time of the call that solved it.
    strips : indices of the strips of P the answer used (empty when not applicable).
    solver : "CLARABEL" or "SCS" (fallback); the outer ellipsoid's "interior point on the multipliers
        (k steps)" (:mod:`boundid.sets._s_lagrangian`) and the inner ellipsoid's "interior point,
        Zhang-Gao (k steps)" (:mod:`boundid.sets._inscribed`), or Clarabel's when those failed; "" when
        no SDP was solved.
    info : extra facts (constraint-generation rounds, certificate residual, repair factor ...).
    """

    ellipsoid: Ellipsoid
    status: str
    time_s: float
    strips: np.ndarray
    solver: str
    info: dict = field(default_factory=dict)


def _solve(problem: cp.Problem, allow_fallback: bool, what: str, study_scale: bool = False,
           linalg: dict = CLARABEL_LINALG) -> tuple[str, str]:
    """Solve with Clarabel (its linear algebra: ``linalg``); returns (solver, status). SCS only
    with ``allow_fallback``.

    ``study_scale``: the polytope SDPs (inner, outer) run with gap and feasibility tolerances 1e-7
    (``_CLARABEL``): at the default 1e-8 Clarabel sometimes stalls on the study-scale problems
    ("optimal_inaccurate" after ~50 iterations, the objective already right to 1e-8, at twice the
    cost). Their answers are verified by the caller (containment checked exactly, certificate
    residual bounded), whatever the tolerance. The small SDPs keep the defaults.
    """
    # faer (the S-procedure's) failing is retried once with QDLDL, the package's default
    for settings in (linalg, CLARABEL_LINALG) if linalg is not CLARABEL_LINALG else (linalg,):
        try:
            _run(problem, cp.CLARABEL, **settings, **(_CLARABEL if study_scale else {}))
            status = problem.status
        except cp.error.SolverError as exc:
            status = f"solver error ({exc})"
        if status == cp.OPTIMAL:
            return "CLARABEL", status
    if allow_fallback:
        try:
            _run(problem, cp.SCS, eps=1e-9, max_iters=200_000)
        except cp.error.SolverError as exc:
            raise SolverError(f"{what}: Clarabel returned '{status}' and the SCS fallback failed ({exc}).") from None
        if problem.status in (cp.OPTIMAL, cp.OPTIMAL_INACCURATE):
            return "SCS", problem.status
        status = f"{status}; SCS fallback: {problem.status}"
    raise SolverError(
        f"{what}: the SDP solver returned '{status}'. Check that the set is bounded with a non-empty "
        "interior; pass allow_fallback=True to try SCS (its answer is re-verified).")


def _run(problem: cp.Problem, solver: str, **opts) -> None:
    """``problem.solve(solver=solver, **opts)`` with cvxpy's part (compile, unpack) under the lock
    and the solver's outside it."""
    with _CVXPY:
        data, chain, inverse = problem.get_problem_data(solver, solver_opts=opts)
    solution = chain.solve_via_data(problem, data, False, False, opts)
    with _CVXPY:
        problem.unpack_results(solution, chain, inverse)


def _frame(P: Polytope):
    """The box frame of P (theta = origin + scale * z, P spans [-1, 1] along each z_j) and the
    LP bounding box in it (zlo, zhi), with the LP bounds."""
    b = P.bounds()
    if np.any(b.half_width <= 0):
        raise InputError(f"P is flat along parameters {np.flatnonzero(b.half_width <= 0)} (zero width): "
                         "its ellipsoids are degenerate. Drop or fix those parameters first.")
    origin, scale = P.box_frame()
    return origin, scale, (b.lo - origin) / scale, (b.hi - origin) / scale, b


def _halfspaces_z(P: Polytope, origin, scale):
    """Every side of every strip and halfspace of P as g^T z <= h in the frame theta = origin +
    scale z, unit-norm g; also the strip index owning each side (-1 for a halfspace)."""
    G, c, h = P._unit_strips(origin, scale)
    fin = np.isfinite(h)
    idx = np.flatnonzero(fin)
    Gs, hs, owner = [G[fin], -G[fin]], [c[fin] + h[fin], h[fin] - c[fin]], [idx, idx]
    if P.halfspaces is not None:
        H, hv = P.halfspaces
        Hs = H * scale
        nrm = np.linalg.norm(Hs, axis=1)
        Gs.append(Hs / nrm[:, None])
        hs.append((hv - H @ origin) / nrm)
        owner.append(np.full(len(hv), -1))
    return np.vstack(Gs), np.concatenate(hs), np.concatenate(owner)


def _known_vertices(P: Polytope) -> np.ndarray:
    """Points of P to verify outer ellipsoids on: every vertex for p <= 6; always the LP-bound
    vertices and every vertex any LP on P has produced (supports, tightening)."""
    V = np.vstack([P.bounds().vertices(), P.found_points()])
    if P.dim <= MAX_VERTEX_DIM:
        V = np.vstack([V, P.vertices()])
    return V


def _lower_triangle(n: int) -> sp.csr_matrix:
    """T (n^2, n(n+1)/2): T @ v is a lower-triangular n x n matrix, row-major, from its free entries v."""
    i, j = np.tril_indices(n)
    return sp.csr_matrix((np.ones(i.size), (i * n + j, np.arange(i.size))), shape=(n * n, i.size))


#: above this dimension the inscribed ellipsoid's KKT system is factorised by faer (one thread), below it by
#: QDLDL: every cone couples all n (n + 1) / 2 entries of the factor, a dense block that faer's supernodes
#: handle better once it is large (six-joint UR5, p = 52, 962 sides: 45 s against 99 s; three-joint
#: UR5, p = 22, 235 sides: 2.2 s against 1.0-1.5 s)
_INNER_DENSE_DIM = 36


def _inscribed(Gw: np.ndarray, hw: np.ndarray, triangular: bool, allow_fallback: bool, interior_point: bool = True):
    """max ln det M s.t. |M^T g_i| + g_i^T x0 <= h_i for the rows of (Gw, hw): ((solver, status), M, x0).
    With ``interior_point``, first by the primal-dual interior-point method of
    :mod:`boundid.sets._inscribed` ([ZhangGao2003]; M the Cholesky factor of its E^2); should it fail
    (or without it), by Clarabel. ``triangular``: M lower triangular, objective sum ln M_jj
    (second-order and exponential cones only); else M symmetric positive semidefinite with cvxpy's
    log_det (two semidefinite cones)."""
    if interior_point:
        try:
            x0, E2, steps = max_volume_inscribed(Gw, hw)
            return (f"interior point, Zhang-Gao ({steps} steps)", "optimal"), np.linalg.cholesky(E2), x0
        except (SolverError, np.linalg.LinAlgError, ValueError):
            pass
    n = Gw.shape[1]
    with _CVXPY:
        x0 = cp.Variable(n)
        if triangular:
            tril = _lower_triangle(n)
            M = cp.reshape(tril @ cp.Variable(tril.shape[1]), (n, n), order="C")
            objective = cp.sum(cp.log(cp.diag(M)))
        else:
            M = cp.Variable((n, n), PSD=True)
            objective = cp.log_det(M)
        prob = cp.Problem(cp.Maximize(objective), [cp.norm(Gw @ M, 2, axis=1) + Gw @ x0 <= hw])
    outcome = _solve(prob, allow_fallback, "inner_ellipsoid", study_scale=True,
                     linalg=CLARABEL_DENSE_LINALG if n > _INNER_DENSE_DIM else CLARABEL_LINALG)
    with _CVXPY:
        Mv = M.value if triangular else 0.5 * (M.value + M.value.T)
    return outcome, Mv, x0.value


#: the inscribed ellipsoid's working set drops a side whose slack at the last solution exceeds this
#: (relative to 1 + |h|, as its violations)
_INNER_DROP = 1e-2


def inner_ellipsoid(P: Polytope, allow_fallback: bool = False, batch: int = 64) -> SDPResult:
    """Maximum-volume ellipsoid inscribed in P (exact, convex; [refs §SDP]).

    E = {x0 + L u : |u| <= 1}: maximise log det L s.t. |L^T g_i| + g_i^T x0 <= h_i for every side
    of every strip and halfspace, and the LP bounding box (implied by P). Each working set is solved
    by a primal-dual interior-point method on the problem's optimality conditions
    (:mod:`boundid.sets._inscribed`, [ZhangGao2003]: O(m^2 n + m^3) a Newton step for m sides;
    six-joint UR5, p = 52, 1,393 sides: 2-3 s where Clarabel took 22-24 s), started at the
    working set's Chebyshev centre. Should it fail, Clarabel solves the working set with L lower
    triangular (every ellipsoid has one: the Cholesky factor of its shape), maximising
    sum ln L_jj with second-order and exponential cones only, the same optimum as the symmetric
    square root's log-det form without its two semidefinite cones (12x faster at p = 22,
    :mod:`boundid.bench.bench_sets`); should Clarabel fail on that (seen on about 1 in 120 small
    random polytopes with halfspace priors), the same working set is solved in that log-det form.
    ``solver`` of the result names the method of the last solve, ``info["formulation"]`` the form.
    Solved in the box frame of P by constraint generation over the sides (a working set seeded
    with the sides active at the LP-bound vertices; the most violated sides added after each
    solve, the sides with a slack above 1 % dropped, each at most once) so N = 1e5 rows work. The
    answer is shrunk about x0 so that it lies inside P exactly (the solver may leave it ~1e-9
    outside).
    ``strips`` of the result: the strips whose sides were in the final working set. The result
    is cached on P (john_outer reuses it).
    """
    key = ("inner", allow_fallback, batch)
    if key in P._sdp_cache:
        return P._sdp_cache[key]
    t0 = time.perf_counter()
    origin, scale, zlo, zhi, b = _frame(P)
    n = P.dim
    G, h, owner = _halfspaces_z(P, origin, scale)
    # seed: sides active at the 2p LP-bound vertices + the box itself (seeding also with the
    # hundreds of support points outer_ellipsoid leaves on P doubled the working set and the time:
    # UR5 study, 968 sides in one round 2.8 s, against 422 in two rounds 1.7 s; seeding with only the
    # 4 p of them nearest to the vertices' mean took 0.44 s instead of 1.55 s on the arms benchmark's
    # random states, but 29 rounds and 9 s instead of 2 and 4.3 s on the six-joint UR5 study's rows)
    Vz = (b.vertices() - origin) / scale
    act = np.flatnonzero(np.any(Vz @ G.T >= h - 1e-7 * (1 + np.abs(h)), axis=0))
    Gb, hbox = np.vstack([np.eye(n), -np.eye(n)]), np.concatenate([zhi, -zlo])
    ws = np.zeros(len(h), dtype=bool)
    ws[act] = True
    left = np.zeros(len(h), dtype=bool)  # sides dropped from the working set once
    rounds, solver, status = 0, "", ""
    triangular = interior_point = True
    while True:
        rounds += 1
        Gw, hw = np.vstack([G[ws], Gb]), np.concatenate([h[ws], hbox])
        try:
            (solver, status), Lv, xv = _inscribed(Gw, hw, triangular, allow_fallback, interior_point)
            interior_point = solver.startswith("interior point")     # once it fails, Clarabel's rounds
        except SolverError:
            if not triangular:
                raise
            triangular = False        # Clarabel failed on the triangular factor: the log-det form
            (solver, status), Lv, xv = _inscribed(Gw, hw, triangular, allow_fallback, interior_point=False)
        viol = (np.linalg.norm(G @ Lv, axis=1) + G @ xv - h) / (1 + np.abs(h))
        new = np.flatnonzero((viol > 1e-7) & ~ws)
        if new.size == 0:
            break
        if new.size > batch:
            new = new[np.argsort(viol[new])[-batch:]]
        # sides well clear of this ellipsoid (slack above _INNER_DROP) leave the working set, once
        # each (so the rounds end): the next ellipsoid differs little, and a side it violates comes
        # back (UR5 study: the second round on 210 sides instead of 466, a third of the time)
        drop = ws & (viol < -_INNER_DROP) & ~left
        ws &= ~drop
        left |= drop
        ws[new] = True
    # exact containment: shrink L about x0 until every side holds (x0 must be interior)
    Ga, ha = np.vstack([G, Gb]), np.concatenate([h, hbox])
    slack = ha - Ga @ xv
    if np.any(slack <= 0):
        raise SolverError(f"inner_ellipsoid: the computed centre lies outside P ({solver}, {status}).")
    reach = np.linalg.norm(Ga @ Lv, axis=1)
    s = min(1.0, float(np.min(slack[reach > 0] / reach[reach > 0])))
    if s < 1 - 1e-4:
        raise SolverError(f"inner_ellipsoid: inaccurate solve ({solver}, {status}); the ellipsoid left P "
                          f"by a factor {1 / s:.3g}.")
    Lv = s * Lv
    ell = Ellipsoid(origin + scale * xv, (scale[:, None] * (Lv @ Lv.T)) * scale[None, :])
    strips = np.unique(owner[ws][owner[ws] >= 0])
    res = SDPResult(ell, status, time.perf_counter() - t0, strips, solver,
                    {"rounds": rounds, "working_sides": int(ws.sum()), "sides_dropped": int(left.sum()), "shrink": s,
                     "formulation": "multipliers, E^2 = (A^T Y A)^-1" if solver.startswith("interior point") else
                     "triangular factor" if triangular else
                     "symmetric root (Clarabel failed on the triangular factor)"})
    P._sdp_cache[key] = res
    return res


def _combined_quadric(Gs, mid, half, tau, extra=(), sig=()) -> tuple[np.ndarray, np.ndarray, float]:
    """(SA, Sb, Sc) of sum_k tau_k q_k + sum_i sig_i q_i: the strips' quadrics (g g^T, -mid g,
    mid^2 - half^2) and the ``extra`` quadrics (A, b, c), weighted by their multipliers; n = Gs's
    columns, or the first extra quadric's size."""
    n = Gs.shape[1] if Gs.size else extra[0][0].shape[0]
    SA = (Gs.T * tau) @ Gs if Gs.size else np.zeros((n, n))
    Sb = -(Gs.T @ (mid * tau)) if Gs.size else np.zeros(n)
    Sc = float(np.sum((mid**2 - half**2) * tau)) if Gs.size else 0.0
    for s_, (Ai, bi, ci) in zip(sig, extra, strict=True):
        SA, Sb, Sc = SA + s_ * Ai, Sb + s_ * bi, Sc + s_ * ci
    return SA, Sb, Sc


def _s_procedure(Gs, mid, half, extra, allow_fallback: bool, what: str, study_scale: bool = False):
    """Minimum-volume ellipsoid containing ∩_i {|g_i^T z - mid_i| <= half_i} ∩ (extra quadrics)
    by the S-procedure ([Boyd1994] §3.7.2; [refs §SDP]).

    Quadrics q(z) = z^T A z + 2 b^T z + c <= 0: a strip is (g g^T, -mid g, mid^2 - half^2);
    ``extra`` is a list of (A, b, c). For multipliers tau, sig >= 0 the combination
    q = sum tau_k q_k + sum sig_i q_i = z^T SA z + 2 Sb^T z + Sc is <= 0 on the set, so the set
    lies in the ellipsoid {q <= 0} = {(z - c)^T SA (z - c) <= Sb^T SA^-1 Sb - Sc}, c = -SA^-1 Sb;
    the S-procedure's optimum is such an ellipsoid (any ellipsoid it certifies contains one).
    The multipliers scale freely, so: max ln det SA s.t. Sb^T SA^-1 Sb - Sc <= 1, i.e. the
    (n+1)-square LMI [[SA, Sb], [Sb^T, 1 + Sc]] >= 0 (half the size of the textbook form's
    (2n+1)-square LMI in (A0, b0, tau): the same optimum in 0.8 of the time at p = 22).

    Returns (A0, b0, tau, sig, solver, status, Zd) in z coordinates: A0 = SA and b0 = Sb of the
    multipliers, scaled so that the ellipsoid is {(z - c)^T A0 (z - c) <= 1} exactly, and Zd the
    dual's (n+1) x (n+1) pseudo-moment matrix: the LMI's dual with, in its leading block, the
    multiplier of SA (about SA^-1 plus that block). Adding a strip with quadric matrix
    Q = [[A, b], [b^T, c]] can enlarge ln det A0 only if tr(Zd Q) > 0 (its multiplier's reduced
    cost; Zd / Zd[n, n] holds pseudo-moments [[E zz^T, E z], [E z^T, 1]]).
    """
    n = Gs.shape[1] if Gs.size else extra[0][0].shape[0]
    m = Gs.shape[0]
    with _CVXPY:
        tau = cp.Variable(m, nonneg=True) if m else None
        sig = cp.Variable(len(extra), nonneg=True) if extra else None
        SA, Sb, Sc = 0, 0, 0
        if m:
            # sum_k tau_k Q_k as one matrix-vector product each (vec(g g^T) stacked in K): cvxpy
            # compiles this 3x faster than Gs^T diag(tau) Gs (0.13 s against 0.41 s at p = 22, m = 434);
            # K holds n^2 m floats (15 MB there; the working sets stay in the hundreds of strips)
            K = np.einsum("ki,kj->ijk", Gs, Gs).reshape(n * n, m)
            SA = cp.reshape(K @ tau, (n, n), order="C")
            Sb = cp.reshape(-((Gs.T * mid) @ tau), (n, 1), order="F")
            Sc = (mid**2 - half**2) @ tau
        for i, (Ai, bi, ci) in enumerate(extra):
            SA = SA + sig[i] * Ai
            Sb = Sb + sig[i] * bi[:, None]
            Sc = Sc + sig[i] * ci
        # ln det of a variable X tied to SA by equalities: 1.2x faster than ln det of the affine SA
        # itself, whose every multiplier would then enter ln det's semidefinite cone
        X = cp.Variable((n, n), symmetric=True)
        M = cp.bmat([[X, Sb], [Sb.T, cp.reshape(1 + Sc, (1, 1), order="F")]])
        lmi = 0.5 * (M + M.T) >> 0
        tie = X == SA
        prob = cp.Problem(cp.Maximize(cp.log_det(X)), [lmi, tie])
    solver, status = _solve(prob, allow_fallback, what, study_scale, CLARABEL_DENSE_LINALG)
    tau_v = np.clip(tau.value, 0, None) if m else np.zeros(0)
    sig_v = np.clip(sig.value, 0, None) if extra else np.zeros(0)
    A0, b0, c0 = _combined_quadric(Gs, mid, half, tau_v, extra, sig_v)
    A0 = 0.5 * (A0 + A0.T)
    try:
        r2 = float(b0 @ np.linalg.solve(A0, b0)) - c0
    except np.linalg.LinAlgError:
        raise SolverError(f"{what}: the SDP returned multipliers whose quadric is not an ellipsoid.") from None
    if not r2 > 0:
        raise SolverError(f"{what}: the SDP returned multipliers whose quadric is empty or a point (r^2 = {r2:.3g}).")
    Zd = None
    if lmi.dual_value is not None and tie.dual_value is not None:
        # the leading block is the multiplier of SA: the tie's (symmetrised: it binds all n^2 entries)
        Zd = np.array(lmi.dual_value, dtype=float)
        Zd[:n, :n] = 0.5 * (tie.dual_value + tie.dual_value.T)
    # multipliers / r2: the combined quadric is then (z - c)^T A0 (z - c) - 1
    return A0 / r2, b0 / r2, tau_v / r2, sig_v / r2, solver, status, Zd


def _certified(A0, b0, Gs, mid, half, tau, extra, sig, r2_bound: float, what: str):
    """Centre and shape of the S-procedure ellipsoid, enlarged so that its certificate holds
    exactly for the numerical multipliers.

    With F = [[A0 - sum tau A_i, b0 - sum tau b_i], [., b0^T A0^-1 b0 - 1 - sum tau c_i]] the
    certificate gives (z - c)^T A0 (z - c) <= 1 + lambda_max(F) (|z|^2 + 1) on the set; with
    |z|^2 <= ``r2_bound`` there the ellipsoid scaled by sqrt(1 + mu (r2_bound + 1)) is certified.
    """
    try:
        L = np.linalg.cholesky(A0)
    except np.linalg.LinAlgError:
        raise SolverError(f"{what}: the SDP returned a shape matrix that is not positive definite.") from None
    center = -np.linalg.solve(A0, b0)
    SA, Sb, Sc = _combined_quadric(Gs, mid, half, tau, extra, sig)
    F = np.block([[A0 - SA, (b0 - Sb)[:, None]],
                  [(b0 - Sb)[None, :], np.array([[b0 @ np.linalg.solve(A0, b0) - 1 - Sc]])]])
    mu = max(0.0, float(np.linalg.eigvalsh(0.5 * (F + F.T))[-1]))
    k2 = 1.0 + mu * (r2_bound + 1.0)
    if k2 - 1 > _MAX_REPAIR:
        raise SolverError(f"{what}: inaccurate S-procedure certificate (residual {mu:.3g}); "
                          "try allow_fallback=True or fewer strips.")
    Linv = np.linalg.inv(L)
    return center, k2 * (Linv.T @ Linv), mu


def _outer_multipliers(Gs, mid, half, allow_fallback: bool):
    """The S-procedure of the strips |Gs z - mid| <= half as :func:`_s_procedure` returns it (no extra
    quadrics), solved in the multipliers alone (:mod:`boundid.sets._s_lagrangian`: the same optimum
    in O(m^3) a step where Clarabel's ln det cone costs O(n^6); six-joint UR5, n = 52 and 1,662
    strips: 3.3 s against 60 s); should that fail, by Clarabel."""
    try:
        tau, steps = s_procedure_multipliers(Gs, mid, half)
    except SolverError:
        return _s_procedure(Gs, mid, half, [], allow_fallback, "outer_ellipsoid", study_scale=True)
    n = Gs.shape[1]
    A0, b0, c0 = _combined_quadric(Gs, mid, half, tau)
    A0 = 0.5 * (A0 + A0.T)
    r2 = float(b0 @ np.linalg.solve(A0, b0)) - c0
    if not r2 > 0:
        return _s_procedure(Gs, mid, half, [], allow_fallback, "outer_ellipsoid", study_scale=True)
    A0, b0, tau = A0 / r2, b0 / r2, tau / r2
    # the dual's pseudo-moments: mean the centre, covariance A0^-1 / n
    centre = -np.linalg.solve(A0, b0)
    Zd = np.empty((n + 1, n + 1))
    Zd[:n, :n] = np.linalg.inv(A0) / n + np.outer(centre, centre)
    Zd[:n, n] = Zd[n, :n] = centre
    Zd[n, n] = 1.0
    return A0, b0, tau, np.zeros(0), f"interior point on the multipliers ({steps} steps)", "optimal", Zd


def _reduced_costs(Zd, G, lo, hi):
    """tr(Zd Q_k) / Zd[n, n] for the strips lo_k <= g_k^T z <= hi_k (Q_k of (g^T z - lo)(g^T z - hi)):
    Var_k + (mean_k - lo_k)(mean_k - hi_k) under the pseudo-moments of Zd (> 0: the strip helps)."""
    n = G.shape[1]
    zeta = Zd[n, n]
    mean = G @ Zd[:n, n] / zeta
    second = np.sum((G @ Zd[:n, :n]) * G, axis=1) / zeta     # a matrix product: 2 x the einsum's speed
    return second - mean**2 + (mean - lo) * (mean - hi), second - mean**2, mean


#: when a column-generation round adds strips, those with a reduced cost above -_NEAR * price_tol join too
_NEAR = 10.0
#: a working-set strip whose S-procedure multiplier is below this fraction of the largest one
#: counts as inactive (interior-point multipliers of inactive strips are ~1e-9 of the largest)
_DROP_TOL = 1e-6


def outer_ellipsoid(P: Polytope, strips=None, allow_fallback: bool = False, price_tol: float = 1e-6,
                    batch: int = 64, max_rounds: int = 30) -> SDPResult:
    """An ellipsoid guaranteed to contain P: the S-procedure on the strips of P each tightened to
    the exact extent of P along its normal, plus the LP bounding box and the halfspace priors
    tightened likewise ([refs §LP]); every such slab contains P, so any subset of them gives
    a valid outer ellipsoid, and more slabs give a smaller one.

    ``strips`` (default: every strip of P) is the pool. The S-procedure is solved in its
    multipliers (:mod:`boundid.sets._s_lagrangian`) by column generation on a working set. It starts
    with the strips active at the LP-bound vertices, each as its own interval clipped to the LP box's
    extent along it (a wider slab, still containing P, known without an LP); the strips that keep a
    multiplier are then tightened exactly by LP and the others leave. After each solve the dual's
    pseudo-moments price every pool strip (:func:`~boundid.sets.sdp._reduced_costs`). A side of a
    strip whose exact extent is unknown is priced with the extent of the points of P found so far,
    which can only overstate the reduced cost (the true extent is wider). The candidates, ``batch``
    at a time in order of that estimate, are settled with as little LP as it takes: first the side
    farther from the pseudo-mean, by an LP whose simplex stops at the first vertex of P beyond the
    level that would bring the reduced cost below -10 ``price_tol`` (a point of P there proves it;
    six-joint UR5: that level lies a median 27 % of the way from the found points' extent to the
    exact one, and the simplex gains that much in its first 20 of 175 steps), then likewise the other
    side, then, if the strip may still help, both sides exactly. Every LP adds a point of P. The
    LPs of a batch are shared by two threads, each on its own copy of the working-set LP
    (:data:`boundid.sets.polytope.LP_THREADS`). Pricing stops early while many strips help: once
    ``batch`` of them are known to (six-joint UR5: about 1,000 strips help the second solve, 180 are
    needed in the end; tightening them all cost 2,500 LPs). The strips known to help, and those
    within 10 ``price_tol`` of helping, join the working set. A strip whose multiplier is zero (below
    1e-6 of the largest) leaves it and is priced with the pool from then on (column dropping). It
    stops when no pool strip has a reduced cost above ``price_tol`` (in the box frame's squared
    units): the ellipsoid is then the S-procedure optimum over the whole tightened pool, found with a
    few hundred strips in the SDP instead of every non-redundant one. ``info["max_reduced_cost"]``
    records the largest remaining reduced cost (<= price_tol unless ``max_rounds`` was reached),
    ``info["sides_reached"]`` the sides settled by a point beyond their level (no exact extent).

    Verification: the S-procedure certificate is checked with the solver's multipliers and the
    ellipsoid enlarged by its residual (at most 1e-4 in squared radius, else SolverError); the
    tightened slabs are widened by the LP tolerance so they contain P exactly; then every known
    point of P (all vertices for p <= 6; the LP-bound vertices and every vertex the supports
    produced) is checked to lie inside.

    The result is cached on P (:func:`min_volume_bracket` reuses it).
    """
    pool = np.arange(P.n_strips) if strips is None else np.unique(np.asarray(strips, dtype=int))
    if pool.size and (pool.min() < 0 or pool.max() >= P.n_strips):
        raise InputError(f"strips must be indices in [0, {P.n_strips}).")
    key = ("outer", pool.tobytes(), allow_fallback, price_tol, batch, max_rounds)
    if key in P._sdp_cache:
        return P._sdp_cache[key]
    t0 = time.perf_counter()
    origin, scale, zlo, zhi, b = _frame(P)
    n = P.dim
    G, c, h = P._unit_strips(origin, scale)
    # the interval of g_k^T z spanned by the points of P found so far (inside the true extent)
    lin, uin = np.full(P.n_strips, np.inf), np.full(P.n_strips, -np.inf)
    exact_lo, exact_hi = np.full(P.n_strips, np.nan), np.full(P.n_strips, np.nan)
    n_lp = reached = 0

    def add_points(theta):
        if len(theta):
            proj = G @ ((np.asarray(theta).reshape(-1, n) - origin) / scale).T
            np.minimum(lin, proj.min(axis=1), out=lin)
            np.maximum(uin, proj.max(axis=1), out=uin)

    add_points(b.vertices())
    add_points(P.found_points())
    if n <= MAX_VERTEX_DIM:
        add_points(P.vertices())

    def new_points(before):
        nonlocal n_lp
        n_lp += len(P._found) - before
        add_points(P._found[before:])

    def solve_sides(rows, upper, targets):
        # one side of each strip: its exact extent, or a point of P at or beyond its target
        nonlocal reached
        if rows.size == 0:
            return
        before = len(P._found)
        v, ex = P._strip_reach(rows, upper, targets)
        new_points(before)
        exact_hi[rows[upper & ex]] = v[upper & ex] + LP_TOL
        exact_lo[rows[~upper & ex]] = v[~upper & ex] - LP_TOL
        # a side settled at its level: that point of P moves the estimate even if no LP found it
        np.maximum.at(uin, rows[upper & ~ex], v[upper & ~ex])
        np.minimum.at(lin, rows[~upper & ~ex], v[~upper & ~ex])
        reached += int(np.sum(~ex))

    def tighten(rows):
        # the exact extent of both sides of every strip of rows
        lo_, hi_ = rows[np.isnan(exact_lo[rows])], rows[np.isnan(exact_hi[rows])]
        both = np.concatenate([hi_, lo_])
        up = np.arange(both.size) < hi_.size
        solve_sides(both, up, np.where(up, np.inf, -np.inf))

    def estimates(rows):
        # each side's exact extent where known, else the extent of the points of P found so far
        return (np.where(np.isnan(exact_lo[rows]), lin[rows], exact_lo[rows]),
                np.where(np.isnan(exact_hi[rows]), uin[rows], exact_hi[rows]))

    def settle(rows, Zd, near):
        # price the candidate strips rows with as little LP as it takes: first each one's far side (the
        # end of its interval farther from the pseudo-mean) only up to the point that would bring its
        # reduced cost to -near, then likewise its near side, then, if it still may help, both sides exactly
        # (UR5, six joints: the far side's LP, stopped at its target, settles most of the candidates).
        # Its threshold is a hair below the caller's: the reduced costs of a few rows round differently
        # from those of the whole pool, and a candidate of the caller must stay one here (else no LP
        # would run and the caller would pick it again forever)
        near = near * (1 + 1e-6)
        far_up = None
        for phase in ("far", "near", "exact"):
            lo_e, hi_e = estimates(rows)
            rc, var, mean = _reduced_costs(Zd, G[rows], lo_e, hi_e)
            if far_up is None:
                far_up = (hi_e - mean) >= (mean - lo_e)
            live = rc > -near
            rows, lo_e, hi_e, var, mean, far_up = (a[live] for a in (rows, lo_e, hi_e, var, mean, far_up))
            if phase == "exact" or rows.size == 0:
                break
            upper = far_up if phase == "far" else ~far_up
            need = (var + near) * (1 + 1e-9)        # the product (mean - lo) (hi - mean) that settles it
            with np.errstate(divide="ignore", invalid="ignore"):
                t_hi = np.where(mean - lo_e > 0, mean + need / (mean - lo_e), np.inf)
                t_lo = np.where(hi_e - mean > 0, mean - need / (hi_e - mean), -np.inf)
            open_ = np.where(upper, np.isnan(exact_hi[rows]), np.isnan(exact_lo[rows]))
            solve_sides(rows[open_], upper[open_], np.where(upper, t_hi, t_lo)[open_])
        tighten(rows)

    # fixed rows: the LP box and the halfspace priors, tightened
    fixed_G, fixed_lo, fixed_hi = [np.eye(n)], [zlo - LP_TOL], [zhi + LP_TOL]
    if P.halfspaces is not None:
        H = P.halfspaces[0] * scale
        Hn = H / np.linalg.norm(H, axis=1)[:, None]
        for g in Hn:
            lo_, hi_ = P.extent(g / scale)
            fixed_G.append(g[None, :])
            fixed_lo.append([(lo_ - g @ (origin / scale)) - LP_TOL])
            fixed_hi.append([(hi_ - g @ (origin / scale)) + LP_TOL])
    fixed_G, fixed_lo, fixed_hi = np.vstack(fixed_G), np.concatenate(fixed_lo), np.concatenate(fixed_hi)
    # initial working set: pool strips active at the LP-bound vertices
    pool_fin = pool[np.isfinite(h[pool])]
    Vz = (b.vertices() - origin) / scale
    # (all of them: on the six-joint UR5 study's rows, the 4 p nearest to the vertices' mean, as the inscribed
    # ellipsoid's seed, left a first ellipsoid so loose that 30 rounds, adding a few strips each, did not
    # reach the optimum, where all 1,300 reach it in 10)
    act = pool_fin[np.any(np.abs(Vz @ G[pool_fin].T - c[pool_fin]) >= h[pool_fin] - 1e-7, axis=0)]
    # until tightened, a strip enters the S-procedure as its own interval clipped to the LP box's
    # extent along it: a wider slab that still contains P. Only the strips that keep a multiplier
    # are then tightened (UR5, all six joints: 1,610 strips active at the LP-bound vertices, of
    # which about 200 keep one; tightening them all cost 3,300 LPs, 110 s)
    slack = LP_TOL * np.abs(G).sum(axis=1)            # the LP box's own tolerance, along g
    loose_lo = np.maximum(c - h, np.minimum(G * zlo, G * zhi).sum(axis=1) - slack)
    loose_hi = np.minimum(c + h, np.maximum(G * zlo, G * zhi).sum(axis=1) + slack)
    ws = list(act)
    in_ws = np.zeros(P.n_strips, dtype=bool)
    in_ws[act] = True
    rounds, max_rc, solver, status, dropped = 0, np.inf, "", "", 0
    while True:
        rounds += 1
        k = np.array(ws, dtype=int)
        loose = np.isnan(exact_lo[k]) | np.isnan(exact_hi[k])
        Gs = np.vstack([fixed_G, G[k]])
        lo = np.concatenate([fixed_lo, np.where(np.isnan(exact_lo[k]), loose_lo[k], exact_lo[k])])
        hi = np.concatenate([fixed_hi, np.where(np.isnan(exact_hi[k]), loose_hi[k], exact_hi[k])])
        mid, half = 0.5 * (lo + hi), np.maximum(0.5 * (hi - lo), 0.0)
        A0, b0, tau, sig, solver, status, Zd = _outer_multipliers(Gs, mid, half, allow_fallback)
        if rounds >= max_rounds:
            status += f"; stopped after max_rounds = {max_rounds} (not the optimum over the pool)"
        if Zd is None or rounds >= max_rounds:
            break
        keep = tau[len(fixed_lo):] > _DROP_TOL * tau.max()
        if np.any(loose):
            # tighten the loose strips that keep a multiplier, drop those that do not, solve again
            tighten(k[loose & keep])
            in_ws[k[loose & ~keep]] = False
            dropped += int(np.sum(loose & ~keep))
            ws = list(k[~loose | keep])
            continue
        cand_pool = pool_fin[~in_ws[pool_fin]]
        Gp = G[cand_pool]
        # pricing: the strips that may come within `near` of helping are tightened, best estimate
        # first (the estimate from the found points overstates the reduced cost), until `batch` of
        # them are known to help or none is left; those known to come within `near` join: strips about
        # to turn helpful as the dual moves (UR5 study: one round fewer, of 3; H4 and arm likewise)
        near = _NEAR * price_tol
        while True:
            ex = ~np.isnan(exact_lo[cand_pool]) & ~np.isnan(exact_hi[cand_pool])
            rc = _reduced_costs(Zd, Gp, *estimates(cand_pool))[0]
            cand = np.flatnonzero((rc > -near) & ~ex)
            if cand.size == 0 or np.count_nonzero(ex & (rc > price_tol)) >= batch:
                break
            settle(cand_pool[cand[np.argsort(rc[cand])[::-1][:batch]]], Zd, near)
        max_rc = float(rc.max()) if rc.size else -np.inf
        if not max_rc > price_tol:
            break
        add = cand_pool[(rc > -near) & ex]
        ws.extend(add)
        in_ws[add] = True
        # column dropping before the next round: a strip whose multiplier is zero (to the solver's
        # accuracy) leaves the working set; it stays in the pool, priced exactly, and comes back if
        # it can help again (UR5 study: 434 strips, 130-170 with a multiplier; half the SDP's time)
        in_ws[k[~keep]] = False
        dropped += int(np.sum(~keep))
        ws = list(k[keep]) + ws[len(k):]
    # certificate with the final multipliers, then every known point of P
    cz, Sz, mu = _certified(A0, b0, Gs, mid, half, tau, [], sig, float(np.max(np.sum(
        np.maximum(np.abs(zlo), np.abs(zhi)) ** 2))), "outer_ellipsoid")
    ell = Ellipsoid(origin + scale * cz, (scale[:, None] * Sz) * scale[None, :])
    V = _known_vertices(P)
    inside = ell.contains(V)
    if not np.all(inside):
        raise SolverError(f"outer_ellipsoid: verification failed, {int(np.sum(~inside))} known points of P "
                          f"lie outside the certified ellipsoid ({solver}, {status}).")
    used = np.array(ws, dtype=int)
    res = SDPResult(ell, status, time.perf_counter() - t0, np.sort(used), solver,
                    {"certificate_residual": mu, "n_constraints": len(mid), "vertices_checked": len(V),
                     "rounds": rounds, "strips_dropped": dropped,
                     "strips_tightened": int(np.sum(~np.isnan(exact_lo) & ~np.isnan(exact_hi))),
                     "sides_reached": reached, "support_lps": n_lp, "max_reduced_cost": max_rc, "price_tol": price_tol,
                     "pool": int(pool.size)})
    P._sdp_cache[key] = res
    return res


@dataclass(frozen=True)
class VolumeBracket:
    """ln vol of the minimum-volume ellipsoid containing P, bracketed ([FreundOrlin1985]: it is hard to compute).

    lower : a lower bound on ln vol of every ellipsoid containing P: the dual bound of the
        minimum-volume ellipsoid around points of P (:func:`boundid.sets._mvee.mvee_dual`); any ellipsoid
        containing P contains those points, so none is smaller.
    upper : ln vol of the S-procedure outer ellipsoid (it contains P).
    points_ellipsoid : an ellipsoid around the points, within ``points_gap`` (ln vol) of their
        minimum-volume one (it need not contain P).
    upper_result : the SDPResult of the S-procedure ellipsoid.
    n_points : points of P used (LP-bound vertices, support points, vertices for p <= 6).
    info : rounds, iterations, time_s.
    """

    lower: float
    upper: float
    points_ellipsoid: Ellipsoid
    points_gap: float
    upper_result: SDPResult
    n_points: int
    info: dict = field(default_factory=dict)

    @property
    def gap_per_axis(self) -> float:
        """(upper - lower) / p: how far the S-procedure may be above the optimum, per axis."""
        return (self.upper - self.lower) / self.points_ellipsoid.dim


def min_volume_bracket(P: Polytope, n_directions: int | None = None, rounds: int = 10, seed: int = 0,
                       vertices: bool = True, allow_fallback: bool = False) -> VolumeBracket:
    """Bracket ln vol of the minimum-volume ellipsoid containing P: [lower, upper].

    upper: :func:`outer_ellipsoid` (cached on P: solved here only if no call has solved it, and then
    timed here). lower: the dual bound of the minimum-volume ellipsoid around
    points of P found by LP (:func:`boundid.sets._mvee.mvee_dual`): the LP-bound vertices, every point the LPs on
    P have produced, and the supports of P along ``n_directions`` (default 20 p) random
    directions of the box frame (seeded: same seed, same numbers) and the principal axes of the
    upper ellipsoid. Then up to ``rounds`` refinements: along the outward normal of the points'
    ellipsoid at each point on (or near) its boundary, the farthest point of P is added if it
    lies outside (an active-set search for the points that matter), until none does. The rounds
    solve the points' ellipsoid to 1e-4 per axis, the final bound to 1e-7. The lower bound is
    valid after any number of rounds; ``info["rounds"]``: the rounds that added points.
    ``vertices``: for p <= 6 also every vertex of P
    (Qhull), which makes the lower end the exact optimum (to the stopping tolerance 1e-7 per axis).
    """
    t0 = time.perf_counter()
    upper = outer_ellipsoid(P, allow_fallback=allow_fallback)
    origin, scale, _, _, b = _frame(P)
    n = P.dim
    n_directions = 20 * n if n_directions is None else int(n_directions)
    rng = np.random.default_rng(seed)
    axes = np.linalg.eigh((upper.ellipsoid.shape / scale[:, None]) / scale[None, :])[1].T
    _, X = P.support_points(np.vstack([rng.normal(size=(n_directions, n)), axes, -axes]) / scale)
    pts = np.vstack([b.vertices(), P.found_points(), X])
    if vertices and n <= MAX_VERTEX_DIM:
        pts = np.vstack([pts, P.vertices()])
    Z = np.unique((pts - origin) / scale, axis=0)
    iters = added = 0
    u = None
    for _ in range(rounds):
        # a round only looks for points of P outside the points' ellipsoid, for which 1e-4 per axis
        # will do; the bound below is taken at 1e-7, from the last round's weights (few more steps)
        _, _, c, S, it, u = mvee_dual(Z, tol=1e-4, u0=u)
        iters += it
        # outward normals of the points' ellipsoid at the points near its boundary
        Si = np.linalg.inv(S)
        Zc = Z - c
        near = np.einsum("ij,jk,ik->i", Zc, Si, Zc) >= 1 - 1e-3
        _, Xn = P.support_points((Zc[near] @ Si) / scale)
        Zn = (Xn - origin) / scale
        Znc = Zn - c
        out = Zn[np.einsum("ij,jk,ik->i", Znc, Si, Znc) > 1 + 1e-9]
        if out.size == 0:
            break
        # warm start: the new points join with a small weight (all weights stay positive)
        Z = np.vstack([Z, np.unique(out, axis=0)])
        u = np.concatenate([u, np.full(len(Z) - len(u), 1e-3 / len(Z))])
        added += 1
    lower, up_pts, c, S, it, u = mvee_dual(Z, u0=u)
    iters += it
    shift = float(np.sum(np.log(scale)))
    ell = Ellipsoid(origin + scale * c, (scale[:, None] * S) * scale[None, :])
    return VolumeBracket(lower + shift, float(upper.ellipsoid.log_volume()), ell, up_pts - lower, upper, len(Z),
                         {"rounds": added, "iterations": iters, "time_s": time.perf_counter() - t0})


def john_outer(P: Polytope, allow_fallback: bool = False) -> SDPResult:
    """The maximum-volume inscribed ellipsoid scaled by p about its centre (John 1948: it
    contains P; factor p, not sqrt(p), since P is not centrally symmetric; [refs §SDP]).

    The guarantee holds for the exact inscribed ellipsoid; the numerical one is near-optimal in
    log det, which can leave its shape off by about the square root of the solver's tolerance (a
    simplex, where p x the inner ellipsoid passes through every vertex, shows it). So the scaled
    ellipsoid is checked on the known vertices of P and enlarged to cover them: for p <= 6 these
    are all the vertices, so the enlarged ellipsoid contains P = conv(vertices) whatever the
    enlargement; above, only the LP-bound and LP-found vertices are known and an enlargement
    beyond 1e-4 in squared radius raises SolverError (another vertex could be further out).
    ``info["vertex_repair"]``: the squared-radius factor applied (1 when none).
    The inner ellipsoid is solved once per P (:func:`inner_ellipsoid` caches it on P).
    """
    t0 = time.perf_counter()
    inner = inner_ellipsoid(P, allow_fallback=allow_fallback)
    ell = inner.ellipsoid.scaled(P.dim)
    V = _known_vertices(P)
    d2 = float(np.max(ell.mahalanobis2(V)))
    all_vertices = P.dim <= MAX_VERTEX_DIM
    if d2 > 1 + _MAX_REPAIR and not all_vertices:
        raise SolverError(f"john_outer: a vertex of P lies outside p x the inner ellipsoid (squared "
                          f"distance {d2:.6g}) and P has too many dimensions ({P.dim} > {MAX_VERTEX_DIM}) to "
                          "enumerate its vertices and cover them all; the inner ellipsoid solve was inaccurate. "
                          "Use outer_ellipsoid (verified by LPs) instead.")
    if d2 > 1:
        ell = Ellipsoid(ell.center, d2 * ell.shape)
    return SDPResult(ell, inner.status, time.perf_counter() - t0, inner.strips, inner.solver,
                     {**inner.info, "vertex_repair": max(d2, 1.0), "vertices_checked": len(V),
                      "all_vertices_checked": all_vertices})


def polytope_ellipsoids(P: Polytope, names=("outer", "inner", "john"),
                        allow_fallback: bool = False) -> dict[str, tuple[SDPResult | Exception, float]]:
    """The SDP ellipsoids ``names`` of P (of "outer": :func:`outer_ellipsoid`, "inner":
    :func:`inner_ellipsoid`, "john": :func:`john_outer`), each as (result, wall time in s), or
    (the exception it raised, time) so that one failure leaves the others their answers.

    They are solved one after the other, after the LP bounds they all start from: the inscribed
    ellipsoid (it adds nothing to P), the outer one, then John's, which checks the vertices the
    outer one's LPs find. The outer ellipsoid's LPs run on two threads of their own
    (:data:`boundid.sets.polytope.LP_THREADS`), so the inscribed ellipsoid in a third one would
    only take their cores (arms benchmark, Panda: the inscribed ellipsoid took 10 s beside the
    outer one, 1 s alone).
    """
    unknown = set(names) - {"outer", "inner", "john"}
    if unknown:
        raise InputError(f"unknown ellipsoids {sorted(unknown)}: choose among 'outer', 'inner', 'john'.")
    solvers = {"outer": outer_ellipsoid, "inner": inner_ellipsoid, "john": john_outer}

    def timed(name):
        t0 = time.perf_counter()
        try:
            out = solvers[name](P, allow_fallback=allow_fallback)
        except Exception as exc:                  # noqa: BLE001 - returned to the caller, who decides
            out = exc
        return out, time.perf_counter() - t0

    t0 = time.perf_counter()
    try:
        P.bounds()
    except Exception as exc:                      # noqa: BLE001 - every ellipsoid needs them
        return {name: (exc, time.perf_counter() - t0) for name in names}
    out = {name: timed(name) for name in ("inner", "outer", "john") if name in names}
    return {name: out[name] for name in names}


def enclosing_ellipsoid(points, allow_fallback: bool = False) -> SDPResult:
    """Minimum-volume ellipsoid containing ``points`` (m, n) (exact; [refs §SDP]):
    maximise log det A s.t. |A p_i + b| <= 1; E = {x : |A x + b| <= 1}.

    The points must span R^n affinely (m >= n + 1). Solved in coordinates centred and scaled by
    the points' bounding box, by constraint generation over the points (for n <= 6 over the
    convex-hull vertices only). The answer
    is enlarged to contain every point exactly if the solver left one a rounding error outside.
    """
    t0 = time.perf_counter()
    X = as_matrix(points, "points")
    m, n = X.shape
    lo, hi = X.min(axis=0), X.max(axis=0)
    c, hw = 0.5 * (lo + hi), 0.5 * (hi - lo)
    if np.any(hw <= 0) or m < n + 1 or np.linalg.matrix_rank(X - X.mean(axis=0)) < n:
        raise InputError(f"points must span R^{n} affinely (at least {n + 1} points, not all on a hyperplane); "
                         "a flat point set has no finite minimum-volume ellipsoid.")
    Z = (X - c) / hw
    Zs = Z
    if 2 <= n <= MAX_VERTEX_DIM and m > 4 * n:
        try:
            Zs = Z[ConvexHull(Z).vertices]
        except QhullError:
            Zs = Z
    # constraint generation over the points: start from the extreme points along each axis and
    # a strided sample, add the points left outside (dense, near-duplicate points stall Clarabel)
    ws = np.zeros(len(Zs), dtype=bool)
    ws[np.argmin(Zs, axis=0)] = ws[np.argmax(Zs, axis=0)] = True
    ws[np.linspace(0, len(Zs) - 1, min(len(Zs), 20 * n)).astype(int)] = True
    rounds = 0
    while True:
        rounds += 1
        with _CVXPY:
            A = cp.Variable((n, n), PSD=True)
            bv = cp.Variable(n)
            prob = cp.Problem(cp.Maximize(cp.log_det(A)), [cp.norm(Zs[ws] @ A + bv[None, :], 2, axis=1) <= 1])
        solver, status = _solve(prob, allow_fallback, "enclosing_ellipsoid")
        out = np.sum((Zs @ A.value + bv.value) ** 2, axis=1) - 1
        new = np.flatnonzero((out > 1e-7) & ~ws)
        if new.size == 0:
            break
        ws[new[np.argsort(out[new])[-64:]]] = True
    Av = 0.5 * (A.value + A.value.T)
    try:
        Ainv = np.linalg.inv(Av)
    except np.linalg.LinAlgError:
        raise SolverError("enclosing_ellipsoid: singular shape from the solver.") from None
    cz = -Ainv @ bv.value
    d2 = float(np.max(np.sum((Z @ Av + bv.value) ** 2, axis=1)))
    if d2 > 1 + _MAX_REPAIR:
        raise SolverError(f"enclosing_ellipsoid: inaccurate solve ({solver}, {status}), a point at squared "
                          f"distance {d2:.6g}.")
    Sz = max(d2, 1.0) * (Ainv @ Ainv)
    ell = Ellipsoid(c + hw * cz, (hw[:, None] * Sz) * hw[None, :])
    return SDPResult(ell, status, time.perf_counter() - t0, np.zeros(0, dtype=int), solver,
                     {"points_in_sdp": int(ws.sum()), "rounds": rounds, "repair": max(d2, 1.0)})


def step_ellipsoid(E: Ellipsoid, w, y: float, e_max: float, allow_fallback: bool = False) -> SDPResult:
    """Minimum-volume ellipsoid containing E ∩ {x : |y - w^T x| <= e_max} (exact; [refs §OBE], [refs §SDP]).

    Solved in the unit-ball coordinates of E (x = c + L z, shape = L L^T); the strip is first
    clipped to E's extent along w, which makes the one-ellipsoid-one-strip S-procedure exact.
    Returns E itself (status "no_cut") when the strip does not cut E; raises
    InfeasibleDataError when E ∩ strip is empty (an outlier for the recursive update). The
    answer is enlarged by the rounding of its map back from E's coordinates (``info
    ["rounding_margin"]``, in squared radius: 8 n eps cond(E)).
    """
    t0 = time.perf_counter()
    if not isinstance(E, Ellipsoid):
        raise InputError(f"E must be an Ellipsoid, got {type(E).__name__}.")
    n = E.dim
    w = as_vector(w, "w", n)
    y = float(as_vector(y, "y", 1)[0])
    e = float(as_float_array(e_max, "e_max"))
    if not (np.isfinite(e) and e > 0):
        raise InputError(f"e_max must be finite and > 0, got {e}.")
    L = E.factor
    g = L.T @ w
    s = float(np.linalg.norm(g))
    eps = y - float(w @ E.center)
    if s == 0:
        if abs(eps) <= e:
            return SDPResult(E, "no_cut", time.perf_counter() - t0, np.zeros(0, dtype=int), "", {})
        raise InfeasibleDataError(f"w = 0 and |y| = {abs(y):.6g} > e_max = {e:.6g}: the strip is empty.")
    u, m_, h_ = g / s, eps / s, e / s
    lo, hi = max(m_ - h_, -1.0), min(m_ + h_, 1.0)
    if lo > hi:
        raise InfeasibleDataError(
            f"E ∩ strip is empty: |y - w^T c| = {abs(eps):.6g} > e_max + sqrt(w^T S w) = {e + s:.6g}. "
            "This observation contradicts the current ellipsoid (an outlier): skip it or enlarge e_max.")
    if lo <= -1.0 and hi >= 1.0:
        return SDPResult(E, "no_cut", time.perf_counter() - t0, np.zeros(0, dtype=int), "", {})
    mid, half = np.array([0.5 * (lo + hi)]), np.array([0.5 * (hi - lo)])
    ball = (np.eye(n), np.zeros(n), -1.0)
    A0, b0, tau, sig, solver, status, _ = _s_procedure(u[None, :], mid, half, [ball], allow_fallback,
                                                    "step_ellipsoid")
    cz, Sz, mu = _certified(A0, b0, u[None, :], mid, half, tau, [ball], sig, 1.0, "step_ellipsoid")
    # the certificate holds in E's unit-ball coordinates; the map back (x = c + L z) and a distance
    # taken in x round with a relative error of about n eps cond(E), which an ellipsoid through
    # the cut's rim (an exact certificate) would not absorb at cond(E) = 1e8: the squared radius
    # is enlarged by 8 n eps cond(E) (1e-14 for a round E, 2e-6 at n = 14 and cond 1e8)
    grow = 1.0 + 8 * n * np.finfo(float).eps * np.linalg.cond(L) ** 2
    ell = Ellipsoid(E.center + L @ cz, grow * (L @ Sz @ L.T))
    return SDPResult(ell, status, time.perf_counter() - t0, np.zeros(0, dtype=int), solver,
                     {"certificate_residual": mu, "rounding_margin": grow - 1.0,
                      "clipped": (lo > m_ - h_) or (hi < m_ + h_)})
