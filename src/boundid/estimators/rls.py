"""Recursive least squares (RLS) with exponential forgetting, and its compiled loop.

The direct-drive paper ([DirectDrivePaper] eqs. 18-21) runs the standard RLS on each regression
model with theta(0) = 0 and P(0) = 1000 I; those are this class's defaults (the prior ellipsoid
center0 = theta(0), shape0 = P(0) of the estimator protocol, :mod:`boundid.estimators.protocol`).
One step, for a row w (p,) and a measurement y, with forgetting factor lambda in (0, 1]:

    e     = y - w^T theta                     (a-priori error)
    u     = P w,  d = lambda + w^T u
    theta = theta + u e / d
    P     = (P - v v^T) / lambda,     v = u / sqrt(d)

The same loop, with a per-row measurement variance r (d = lambda r + w^T u) and an optional
random-walk covariance Q added to P before each step, is the linear Kalman filter with the
parameters as state (:mod:`boundid.estimators.kalman` reuses :func:`filter_loop`).

Confidence set. RLS minimises J(theta) = sum_i lambda^(k-i) (y_i - w_i^T theta)^2 + lambda^k
(theta - theta(0))^T P(0)^-1 (theta - theta(0)); its minimum obeys J_k = lambda (J_{k-1} + e^2 / d), and
P is the inverse of its Hessian / 2. With n_eff = sum_i lambda^(k-i) (= k when lambda = 1) the
residual variance estimate is sigma^2 = J_k / (n_eff - p), the covariance sigma^2 P, the ellipsoid
{x : (x - theta)^T (sigma^2 P)^-1 (x - theta) <= chi2_{level, p}} and the intervals
theta_j -+ t_{(1+level)/2, n_eff - p} sigma sqrt(P_jj). With a negligible prior (P0 -> infinity)
and lambda = 1 these are exactly the OLS ones (:func:`boundid.estimators.least_squares.ols`).

Failing cleanly. P is a covariance updated by subtraction: rows far from unit scale (data x 1e7
with P0 = 1000 I) cancel all its digits and P turns indefinite, then NaN. Every call works on a
copy of the state and checks each row (d > 0 and finite, the a-priori error finite, diag P > 0)
and the result (theta finite, P positive definite by Cholesky); on failure it raises
:class:`boundid.errors.NumericalError` naming the row and the fix (scale the data) and commits
nothing, so the estimator is exactly as it was before the call.
"""

from __future__ import annotations

import time
from abc import ABC, abstractmethod
from dataclasses import dataclass

import numpy as np
from numba import njit
from scipy import stats

from boundid._validation import as_regression, as_vector
from boundid.errors import InputError, NumericalError
from boundid.estimators.estimate import Estimate, History, Statistics
from boundid.estimators.least_squares import check_level
from boundid.estimators.method import Method, Problem, Style, option
from boundid.estimators.protocol import SHAPE_LIMITS, RecursiveEstimator, ellipsoid_prior
from boundid.sets.ellipsoid import Ellipsoid, log_unit_ball_volume

PAPER_P0 = 1000.0  # direct-drive paper, section 6: P(0) = diag(1000, ..., 1000), theta(0) = 0


# Reassociation lets LLVM vectorise the dot products; no nnan/ninf, so NaN and inf still propagate.
FAST = {"reassoc", "contract", "nsz", "arcp"}


@njit(cache=True, fastmath=FAST)
def filter_loop(W, y, r, inv_lam, Q, theta, P, state, record_every, n0, status):
    """Run the RLS / Kalman recursion over the rows of W, in place on ``theta`` and ``P``.

    W : (N, p) C-contiguous, y : (N,)
    r : (N,) per-row measurement variance, or (1,) for one value for every row
    inv_lam : 1 / forgetting factor (1.0 for none)
    Q : (p, p) random-walk covariance added to P before each row, or (0, 0) for none
    theta : (p,), P : (p, p)   state, updated in place
    state : (3,) [ln det P, J, n_eff], updated in place (ln det P is recomputed when Q is used)
    record_every : record the state after every sample whose 1-based count is a multiple of it,
                   and after the last row (0: never); n0 = samples already processed before this call
    status : (2,) out: [-1, 0] on success; else [row (0-based in W) where the innovation variance
             d = lambda r + w^T P w or the a-priori error stopped being finite (d also > 0), or a
             diagonal entry of P fell to <= 0, d]; the loop stops there, leaving theta and P (the
             caller's copies) half-updated.

    Returns (index, centers, log_det_P, J, n_eff) at the recorded samples.
    """
    N, p = W.shape
    lam = 1.0 / inv_lam
    per_row_r = r.shape[0] > 1
    has_q = Q.shape[0] == p
    n_rec = 0
    if record_every > 0:
        n_rec = (n0 + N) // record_every - n0 // record_every
        if N > 0 and (n0 + N) % record_every != 0:
            n_rec += 1  # the last row
    rec_idx = np.empty(n_rec, dtype=np.int64)
    rec_c = np.empty((n_rec, p))
    rec_ld = np.empty(n_rec)
    rec_j = np.empty(n_rec)
    rec_n = np.empty(n_rec)
    u = np.empty(p)
    log_lam_p = p * np.log(lam)
    logdet, J, neff = state[0], state[1], state[2]
    ratio = 1.0  # product of the det factors lambda r / d in (0, 1], folded into logdet before it underflows
    m = 0
    for k in range(N):
        rk = r[k] if per_row_r else r[0]
        if has_q:
            for i in range(p):
                for j in range(p):
                    P[i, j] += Q[i, j]
        s = 0.0
        e = y[k]
        for i in range(p):
            acc = 0.0
            for j in range(p):
                acc += P[i, j] * W[k, j]
            u[i] = acc
            s += W[k, i] * acc
            e -= W[k, i] * theta[i]
        d = lam * rk + s
        if not (d > 0.0 and d < np.inf and abs(e) < np.inf):
            status[0], status[1] = k, d
            break
        c = 1.0 / d
        ec = e * c
        sc = np.sqrt(c)
        for i in range(p):
            theta[i] += u[i] * ec
            u[i] *= sc
        definite = True
        for i in range(p):  # P - v v^T with v = u / sqrt(d): P stays exactly symmetric under fastmath
            for j in range(p):
                P[i, j] = (P[i, j] - u[i] * u[j]) * inv_lam
            definite = definite and P[i, i] > 0.0  # a diagonal entry <= 0 proves P indefinite
        if not definite:
            status[0], status[1] = k, d
            break
        # det(P_new) = det(P) (lambda r / d) lambda^-p (matrix determinant lemma)
        ratio *= lam * rk * c
        logdet -= log_lam_p
        if ratio < 1e-250:
            logdet += np.log(ratio)
            ratio = 1.0
        J = lam * (J + e * ec)
        neff = lam * neff + 1.0
        if record_every > 0 and ((n0 + k + 1) % record_every == 0 or k == N - 1):
            logdet += np.log(ratio)
            ratio = 1.0
            if has_q:
                logdet = np.linalg.slogdet(P)[1]
            rec_idx[m] = n0 + k
            rec_c[m] = theta
            rec_ld[m] = logdet
            rec_j[m] = J
            rec_n[m] = neff
            m += 1
    logdet += np.log(ratio)
    if has_q and status[0] < 0:
        logdet = np.linalg.slogdet(P)[1]
    state[0], state[1], state[2] = logdet, J, neff
    return rec_idx, rec_c, rec_ld, rec_j, rec_n


class LinearFilter(RecursiveEstimator, ABC):
    """State, history and bookkeeping shared by :class:`RLS` and the Kalman estimator.

    Holds theta (p,), P (p, p), ln det P, the weighted cost J, the effective sample count n_eff,
    the number of samples n and the recorded history chunks. The prior, in the vocabulary of the
    estimator protocol: ``prior`` (an Ellipsoid; a Box is read as its circumscribing ellipsoid), or
    ``center0`` (theta(0), default 0) and ``shape0`` (P(0), default 1000 I, the direct-drive paper's).
    """

    def __init__(self, p, prior, center0, shape0, record_every, names, level):
        super().__init__(p, names)
        self._theta0, self._P0 = ellipsoid_prior(self.p, prior, center0, shape0, PAPER_P0)
        self._p0_max = float(np.max(np.diag(self._P0)))
        if not (isinstance(record_every, int | np.integer) and record_every >= 0):
            raise InputError(f"record_every must be an integer >= 0 (0: no history), got {record_every!r}.")
        self.record_every = int(record_every)
        self.level = check_level(level)
        self.reset()

    def reset(self) -> None:
        """Back to the prior (theta(0), P(0)): forget every row."""
        self.theta = self._theta0.copy()
        self.P = self._P0.copy()
        self.logdet = float(np.linalg.slogdet(self.P)[1])
        self.J = 0.0
        self.n_eff = 0.0
        self.n = 0
        self.time_s = 0.0
        self._chunks: list[tuple[np.ndarray, ...]] = []

    def fit(self, W, y, *args, **kwargs) -> Estimate:
        """Start from the prior and process the rows of W (N, p), y (N,); on NumericalError the
        estimator is left exactly as it was before the call (its previous rows included)."""
        snap = self._snapshot()
        try:
            return super().fit(W, y, *args, **kwargs)
        except NumericalError:
            self._restore(snap)
            raise

    def _check_row(self, w, y) -> tuple[np.ndarray, float]:
        w = as_vector(w, "w", self.p)
        y = as_vector(y, "y", 1)
        return w, float(y[0])

    def _check_batch(self, W, y) -> tuple[np.ndarray, np.ndarray]:
        W, y = as_regression(W, y)
        if W.shape[1] != self.p:
            raise InputError(f"W must have {self.p} columns (one per parameter), got {W.shape[1]}.")
        return np.ascontiguousarray(W), y

    def _numerical_error(self, row: int, d: float, what: str, W) -> NumericalError:
        """The error for a state that stopped being finite and positive definite at ``row``."""
        scale = float(np.max(np.abs(W))) if np.size(W) else float("nan")
        return NumericalError(
            f"{type(self).__name__}: at row {row} {what} (innovation variance {d:.3g}): the covariance P lost "
            f"positive definiteness or overflowed (largest |w| {scale:.3g}, prior shape0 = P(0) up to "
            f"{self._p0_max:.3g}). Scale the columns of W and y to order 1 (and shape0 to match) and refit; the "
            "estimator is left as it was before this call."
        )

    @staticmethod
    def _factor(P) -> np.ndarray:
        """The Cholesky factor of P symmetrised (LinAlgError when it is not positive definite): the
        validity check of a new state and the estimate's ellipsoid use this one factorisation, so an
        accepted state always gives an ellipsoid (a second factorisation of a scaled copy could fail
        at the margin where this one succeeded)."""
        return np.linalg.cholesky(0.5 * (P + P.T))

    @classmethod
    def _valid(cls, theta, P) -> bool:
        """theta finite and P positive definite (Cholesky; O(p^3), once per call)."""
        if not (np.all(np.isfinite(theta)) and np.all(np.isfinite(P))):
            return False
        try:
            cls._factor(P)
        except np.linalg.LinAlgError:
            return False
        return True

    def _run(self, W, y, r, inv_lam, Q):
        """The compiled loop on copies of the state, committed only if every row stayed finite;
        appends the recorded history."""
        theta, P = self.theta.copy(), np.ascontiguousarray(self.P).copy()
        state = np.array([self.logdet, self.J, self.n_eff])
        status = np.array([-1.0, 0.0])
        rec = filter_loop(W, y, r, inv_lam, Q, theta, P, state, self.record_every, self.n, status)
        if status[0] >= 0:
            raise self._numerical_error(self.n + int(status[0]), status[1], "the step broke down", W)
        if not self._valid(theta, P):
            raise self._numerical_error(self.n + W.shape[0] - 1, np.nan, "the state is no longer finite and "
                                        "positive definite", W)
        self.theta, self.P = theta, P
        self.logdet, self.J, self.n_eff = float(state[0]), float(state[1]), float(state[2])
        self.n += W.shape[0]
        if rec[0].size:
            self._chunks.append(rec)

    def _snapshot(self) -> tuple:
        """Everything a call may change, to put back if it fails."""
        return (self.theta.copy(), np.array(self.P, copy=True), self.logdet, self.J, self.n_eff, self.n,
                list(self._chunks))

    def _restore(self, snap: tuple) -> None:
        self.theta, self.P, self.logdet, self.J, self.n_eff, self.n, self._chunks = snap

    def _record_one(self, last: bool = False):
        """After a single-row step: record the state if this sample is due (or is the last of a batch)."""
        if self.record_every > 0 and (last or self.n % self.record_every == 0):
            self._chunks.append(
                (
                    np.array([self.n - 1]),
                    self.theta[None, :].copy(),
                    np.array([self.logdet]),
                    np.array([self.J]),
                    np.array([self.n_eff]),
                )
            )

    @abstractmethod
    def _log_volumes(self, logdet, J, neff) -> np.ndarray:
        """ln volume of the confidence ellipsoid at recorded samples, from ln det P, J and n_eff."""

    @property
    def history(self) -> History | None:
        """Recorded centres and ln volumes of the confidence ellipsoid (None if nothing recorded)."""
        if not self._chunks:
            return None
        if len(self._chunks) > 1:  # merge once; later reads reuse the merged arrays
            self._chunks = [tuple(np.concatenate([ch[i] for ch in self._chunks]) for i in range(5))]
        idx, c, ld, J, ne = self._chunks[0]
        return History(index=idx, centers=c, log_volumes=self._log_volumes(ld, J, ne))

    def _estimate(self, method, s2, scale2, quantile, dof, sigma, noise_variance, extra) -> Estimate:
        """Estimate with covariance cov = s2 P (P symmetrised), ellipsoid {(x - c)^T cov^-1 (x - c) <=
        scale2} (from P's own Cholesky factor, :meth:`_factor`) and intervals c -+ quantile std;
        ``sigma`` the residual standard deviation, ``noise_variance`` a row's noise variance.

        ``s2=None`` (noise variance not estimable yet): no ellipsoid, intervals (-inf, inf).
        """
        theta = self.theta.copy()
        if s2 is None:
            cov = np.full((self.p, self.p), np.nan)
            std = np.full(self.p, np.nan)
            ell, lo, hi = None, np.full(self.p, -np.inf), np.full(self.p, np.inf)
        else:
            cov = s2 * (0.5 * (self.P + self.P.T))
            std = np.sqrt(np.diag(cov))
            ell = Ellipsoid.from_factor(theta, np.sqrt(scale2 * s2) * self._factor(self.P))
            lo, hi = theta - quantile * std, theta + quantile * std
        with np.errstate(divide="ignore", invalid="ignore"):
            rel = 100.0 * std / np.abs(theta)
        statistics = Statistics(cov=cov, std_err=std, rel_std_pct=rel, dof=dof, sigma=sigma,
                                # sqrt(cond P) = cond(L) = cond(W) of the rows seen so far when the prior is negligible
                                condition_number=float(np.linalg.cond(self._factor(self.P))),
                                noise_variance=noise_variance)
        return Estimate(method=method, center=theta, set=ell, intervals=(lo, hi), kind="statistical",
                        level=self.level, names=self.names, history=self.history, n_samples=self.n,
                        time_s=self.time_s, statistics=statistics, info=extra)


class RLS(LinearFilter):
    """Recursive least squares with forgetting factor (the estimator protocol of
    :mod:`boundid.estimators.protocol`).

    Parameters
    ----------
    p : int                    number of parameters
    prior : Ellipsoid or Box   the prior: centre theta(0), shape P(0); or, without it,
    center0 : (p,) or scalar   theta(0); default 0 (direct-drive paper)
    shape0 : (p, p), (p,) or scalar   P(0); a scalar s means s I; default 1000 I (paper)
    forgetting : float         lambda in (0, 1]; 1 = no forgetting (paper)
    record_every : int         keep the centre every that many samples, and after each batch, in
                               ``history`` (0: none)
    names : p parameter names
    level : confidence level of the reported ellipsoid and intervals

    ``update(w, y)`` processes one row in numpy (the readable reference); ``fit(W, y)`` (from the
    prior) and ``partial_fit(W, y)`` (continuing) run the compiled loop over a batch. Each returns
    the state as an :class:`Estimate`.
    """

    def __init__(self, p, *, prior=None, center0=None, shape0=None, forgetting=1.0, record_every=1, names=None,
                 level=0.95):
        lam = float(forgetting)
        if not 0.0 < lam <= 1.0:
            raise InputError(f"forgetting must lie in (0, 1] (1 = no forgetting), got {forgetting}.")
        self.forgetting = lam
        super().__init__(p, prior, center0, shape0, record_every, names, level)

    def update(self, w, y) -> Estimate:
        """Process one row w (p,) with measurement y, in numpy (the readable reference of the
        compiled loop); returns :meth:`estimate`. Raises NumericalError (state unchanged) if the
        step does not stay finite."""
        t0 = time.perf_counter()
        w, y = self._check_row(w, y)
        lam = self.forgetting
        e = y - w @ self.theta
        u = self.P @ w
        d = lam + w @ u
        if not (d > 0.0 and np.isfinite(d) and np.isfinite(e)):
            raise self._numerical_error(self.n, d, "the step broke down", w)
        theta, P = self.theta + u * (e / d), (self.P - np.outer(u, u) / d) / lam
        if not self._valid(theta, P):
            raise self._numerical_error(self.n, d, "the state is no longer finite and positive definite", w)
        self.theta, self.P = theta, P
        self.logdet += np.log(lam) - np.log(d) - self.p * np.log(lam)
        self.J = lam * (self.J + e * e / d)
        self.n_eff = lam * self.n_eff + 1.0
        self.n += 1
        self._record_one()
        self.time_s += time.perf_counter() - t0
        return self.estimate()

    def partial_fit(self, W, y) -> Estimate:
        """Process every row of W (N, p) against y (N,) in a compiled loop, continuing from the
        current state; returns :meth:`estimate`."""
        t0 = time.perf_counter()
        W, y = self._check_batch(W, y)
        self._run(W, y, np.ones(1), 1.0 / self.forgetting, np.zeros((0, 0)))
        self.time_s += time.perf_counter() - t0
        return self.estimate()

    @property
    def dof(self) -> float:
        """Residual degrees of freedom n_eff - p."""
        return self.n_eff - self.p

    @property
    def sigma2(self) -> float:
        """Residual variance estimate J / (n_eff - p) (NaN until n_eff > p)."""
        return self.J / self.dof if self.dof > 0 else np.nan

    def _log_volumes(self, logdet, J, neff):
        dof = neff - self.p
        with np.errstate(divide="ignore", invalid="ignore"):
            s2 = np.where(dof > 0, J / dof, np.nan)
        chi2 = stats.chi2.ppf(self.level, self.p)
        return log_unit_ball_volume(self.p) + 0.5 * self.p * np.log(chi2 * s2) + 0.5 * logdet

    def estimate(self) -> Estimate:
        """The current state as a statistical Estimate (no ellipsoid until n_eff > p and J > 0); its
        ``statistics.noise_variance`` is the residual variance sigma^2."""
        s2 = self.sigma2
        known = bool(np.isfinite(s2) and s2 > 0)
        method = "RLS" if self.forgetting == 1.0 else f"RLS (lambda={self.forgetting:g})"
        sigma = float(np.sqrt(s2))
        return self._estimate(
            method,
            s2 if known else None,
            stats.chi2.ppf(self.level, self.p),
            stats.t.ppf(0.5 * (1.0 + self.level), self.dof) if known else np.nan,
            self.dof,
            sigma,
            sigma**2,
            {"forgetting": self.forgetting},
        )


# ------------------------------------------------------------------------------ registry entry


@dataclass(frozen=True)
class RLSOptions:
    """What a study file may set for ``method = "rls"`` (the direct-drive paper's defaults)."""

    center0: float = option(0.0, "theta(0), every parameter (parameter units)", renamed_from=("theta0",))
    shape0: float = option(1000.0, "P(0) = shape0 I (parameter units squared)", lo=SHAPE_LIMITS[0],
                           hi=SHAPE_LIMITS[1], renamed_from=("P0",))
    forgetting: float = option(1.0, "forgetting factor lambda (1 = none)", lo=0.0, strict_lo=True, hi=1.0)


def _build(problem: Problem, o: RLSOptions) -> Estimate:
    return RLS(problem.p, center0=o.center0, shape0=o.shape0, forgetting=o.forgetting,
               record_every=problem.record_every, names=problem.names).fit(problem.W, problem.y)


METHOD = Method(name="rls", summary="recursive least squares with forgetting, confidence ellipsoid",
                options=RLSOptions, build=_build, set_family="ellipsoid", kind="statistical", needs_bound=False,
                style=Style("#CC79A7", "D", "-"))
