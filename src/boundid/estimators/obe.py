"""Recursive bounded-error estimators: the Optimal Bounding Ellipsoid (OBE) family.

Model: y_k = w_k^T theta + e_k with |e_k| <= e_max_k. Starting from an ellipsoid E0 that contains
the true theta, each observation's strip {theta : |y_k - w_k^T theta| <= e_max_k} is intersected
with the current ellipsoid and the intersection is enclosed in a new ellipsoid of the pencil of
[refs §OBE], whose weight minimises the volume [FogelHuang1982], the trace, or sigma
[DasguptaHuang1987]. Each strip is first clipped to the ellipsoid's extent along w_k, which
makes the volume step the exact one-step optimum. Two numerically different implementations of
the same recursion:

* ``form="standard"``: centre c, sigma and M^-1 kept by Sherman-Morrison ([H4Paper] eqs. 28-30);
  cheap, but M^-1 is a covariance-like matrix and each rank-one downdate *subtracts*: a step that
  shrinks the ellipsoid along w by a factor rho leaves M^-1's entries with absolute rounding
  u |M^-1| while the result along w is |M^-1| / rho, so about log10(rho) digits are lost
  (rho reaches 1e15 when a wide prior meets a narrow strip). Computing M^-1[a, b] and
  M^-1[b, a] separately also let the antisymmetric part of M^-1 grow until the truth fell out
  (a stress test found the truth at Mahalanobis^2 5.7 with kind "guaranteed"). The loop therefore keeps M^-1 exactly
  symmetric (upper triangle computed and mirrored), computes sigma' without cancellation,
  checks definiteness (w^T M^-1 w and the diagonal stay > 0) and sigma (in (0, 1]), and
  accumulates a first-order bound on the error of the Mahalanobis distance (the cancellation
  and conditioning of each downdate, :func:`_obe_kernels.downdate_error`), carried forward as
  later steps down-weight the old information. When it cannot vouch for its result the
  Estimate has kind "unverified" and says why.
* ``form="factorized"``: the square-root information form of [LesecqBarraud] ([H4Paper]
  eqs. 33-35, [refs §QR]): M = X^T X with X upper triangular, z = X c, each update a QR
  of the appended row by Givens rotations. M' = alpha M + lambda w w^T adds, never subtracts,
  so it stays positive definite and accurate; it keeps the same watch (sigma, definiteness), and
  its Estimate holds the set in that form (:class:`~boundid.sets.RootInformationEllipsoid`:
  membership, support and intervals by triangular solves with X), so no shape matrix sigma X^-1
  X^-T is formed and the set stays exact where that matrix cannot be held in double precision.

The guarantee: if theta is in E0 and every |e_k| <= e_max_k, theta is in every ellipsoid of the
recursion, up to CONTAINMENT_RTOL: (theta - c)^T S^-1 (theta - c) <= 1 + 1e-9, the rounding
allowance of every containment test in boundid (``Ellipsoid.contains``). The loop's first-order
bound b on the rounding error of that Mahalanobis^2 is absorbed into the reported set: its shape
is the computed one times 1 + INFLATION_FACTOR b, so it contains the exact recursion's set. The
estimator vouches for that ("guaranteed") while b <= VOUCH_MAX, where first order is accurate
and the inflation invisible (<= 1e-3 relative on the shape); above it the Estimate is
"unverified" and says why. Rounding of the centre and of y - w^T c (relative to |y|) is not
in the bound: ROUND_GUARD widens every strip by 1e-12 (|y| + e), 1e4 times that rounding.
Strips that miss the ellipsoid (the data contradict the bounds) are outliers: they are
recorded and skipped, or raise :class:`InfeasibleDataError`.
"""

from __future__ import annotations

import time
from dataclasses import dataclass
from typing import Literal

import numpy as np

from boundid._validation import as_bounds, as_float_array, as_regression
from boundid.errors import InfeasibleDataError, InputError, SolverError
from boundid.estimators import _obe_kernels as K
from boundid.estimators.estimate import Estimate, History
from boundid.estimators.method import Method, Problem, Style, option
from boundid.estimators.protocol import RecursiveEstimator, ellipsoid_prior
from boundid.sets.ellipsoid import Ellipsoid, RootInformationEllipsoid, log_unit_ball_volume

FORMS = ("standard", "factorized")
# A guaranteed set promises (theta - c)^T S^-1 (theta - c) <= 1 + CONTAINMENT_RTOL for the truth
# (the default rtol of Ellipsoid.contains, "rounding only").
CONTAINMENT_RTOL = 1e-9
# The reported shape is inflated by 1 + INFLATION_FACTOR b for a first-order rounding bound b on
# the Mahalanobis^2 (the factor covers second-order terms and the bound's constants); the set is
# "guaranteed" only while b <= VOUCH_MAX (inflation <= 1e-3), else "unverified".
INFLATION_FACTOR = 10.0
VOUCH_MAX = 1e-4
# Rows per compiled call: bounds the history buffers of a long fit (records after every update).
CHUNK_ROWS = 1 << 16
#: shape0 when no prior is given: the ball of radius 1000 about center0
DEFAULT_SHAPE0 = 1e6


class OBE(RecursiveEstimator):
    """Recursive Optimal Bounding Ellipsoid estimator (guaranteed set); the estimator protocol of
    :mod:`boundid.estimators.protocol` (fit starts from E0; partial_fit and update continue).

    Parameters
    ----------
    p : int
        Number of parameters.
    prior : Box or Ellipsoid, optional
        The initial set: an Ellipsoid is E0 itself, a box center +- h the ellipsoid circumscribing
        it (semi-axes sqrt(p) h: the H4 paper starts from its design values and ranges).
    center0 : (p,) array or scalar, default 0;  shape0 : float, (p,) or (p, p) array, default 1e6
        E0 = {theta : (theta - c0)^T shape0^-1 (theta - c0) <= 1} when no ``prior`` is given
        (units: parameter units squared). A scalar s means s * I (a ball of radius sqrt(s)); a
        vector the diagonal. The guarantee needs the true parameters inside E0.
    criterion : "volume" | "trace" | "dasgupta-huang"
        What each step's weight minimises: the volume (Fogel-Huang), the trace of the shape
        matrix (sum of squared semi-axes), or sigma (Dasgupta-Huang, capped at ``alpha_max``).
        Every rule sees the strip clipped to the ellipsoid's extent and normalised to a unit
        half-width (sigma, and so the Dasgupta-Huang weight, depends on that normalisation).
    form : "standard" | "factorized"
        Information-matrix recursion, or square-root information (QR by Givens rotations).
    on_outlier : "skip" | "raise"
        What to do with a strip that misses the current ellipsoid.
    record_every : int or None
        None (default): record the centre and ln volume after every update step, the only
        samples where the set changes (so the history is complete at a fraction of the cost),
        and after the last row. An integer k: every k samples (and after the last one).
    record_shapes : bool
        Also record the shape matrices (for small-p teaching pictures; O(p^3) per record).
    selective : bool
        True (default): a strip that contains the whole ellipsoid, or whose optimal weight is 0,
        costs only the O(p^2) test. False: the full update runs on every sample (weight possibly
        0), the classic non-selective recursion, for benchmarks and comparisons.
    alpha_max : float
        Upper bound on the Dasgupta-Huang weight, in (0, 1).
    names : sequence of str, optional
        Parameter names for the Estimate.

    Notes
    -----
    The returned Estimate has n_samples, n_updates (update steps computed), n_skipped (strips
    with no information), time_s (compiled loops only), error_bound (first-order bound on the
    rounding error of the Mahalanobis^2 of a point of the set), inflation (the relative
    enlargement of the reported shape that absorbs it: 10 x error_bound for a guaranteed set, 0
    for an unverified one) and, when kind is "unverified", unverified_reason; its ``info`` holds
    criterion, form, selective, sigma and n_breakdowns (0: an estimate is only built from a sound
    state). Building the Estimate raises SolverError when the
    recursion proved its state corrupt: M^-1 indefinite on some row (w^T M^-1 w <= 0, the row then
    skipped, or a diagonal entry <= 0; counted in ``n_breakdowns``), sigma outside (0, 1], or (standard
    form) an M^-1 that is not positive definite.
    The factorized form keeps sigma separately instead of normalising it to 1 ([H4Paper] eq. 35
    divides [X, z] by sqrt(sigma)); the ellipsoid is the same. Its Estimate's set is a
    :class:`~boundid.sets.RootInformationEllipsoid` {|X theta - z|^2 <= sigma (1 + inflation)}.
    """

    def __init__(self, p: int, *, prior=None, center0=None, shape0=None, criterion: str = "volume",
                 form: str = "factorized", on_outlier: str = "skip", record_every: int | None = None,
                 record_shapes: bool = False, selective: bool = True, alpha_max: float = 0.9, names=None):
        super().__init__(p, names)
        if criterion not in K.CRITERIA:
            raise InputError(f"criterion must be one of {tuple(K.CRITERIA)}, got {criterion!r}.")
        if form not in FORMS:
            raise InputError(f"form must be one of {FORMS}, got {form!r}.")
        if on_outlier not in ("skip", "raise"):
            raise InputError(f"on_outlier must be 'skip' or 'raise', got {on_outlier!r}.")
        if record_every is not None and not (isinstance(record_every, int | np.integer) and record_every >= 1):
            raise InputError(f"record_every must be an integer >= 1, or None (after every update), "
                             f"got {record_every!r}.")
        if not (0.0 < alpha_max < 1.0):
            raise InputError(f"alpha_max must lie in (0, 1), got {alpha_max!r}.")
        self.criterion, self.form, self.on_outlier = criterion, form, on_outlier
        self.record_every = None if record_every is None else int(record_every)
        self.record_shapes = bool(record_shapes)
        self.selective, self.alpha_max = bool(selective), float(alpha_max)
        self._c0, self._S0 = ellipsoid_prior(self.p, prior, center0, shape0, DEFAULT_SHAPE0)
        self.reset()

    def reset(self) -> None:
        """Back to E0: forget every row."""
        c0, S0 = self._c0, self._S0
        self.center = c0.copy()
        M0 = np.linalg.inv(S0)
        M0 = 0.5 * (M0 + M0.T)
        self._state = np.zeros(K.N_STATE)  # layout: the S_* indices of _obe_kernels
        self._state[K.S_SIGMA] = 1.0
        self._state[K.S_LOGDET] = np.linalg.slogdet(M0)[1]
        self._state[K.S_TRACE] = np.trace(S0)
        self._state[K.S_OMEGA] = K.scaled_inverse_norm(S0, np.zeros((self.p, self.p)), np.empty(self.p))
        if self.form == "standard":
            self._P = S0.copy()
        else:
            self._X = np.ascontiguousarray(np.linalg.cholesky(M0).T)  # M = X^T X, X upper
            self._z = self._X @ c0
        self.n_samples = self.n_updates = self.n_skipped = self.n_breakdowns = self.n_bad_sigma = 0
        self.time_s = 0.0
        self._hist: list[tuple] = []
        self._outliers: list[np.ndarray] = []
        self._outlier_res: list[np.ndarray] = []

    # ------------------------------------------------------------------ recursion
    def partial_fit(self, W, y, e_max) -> Estimate:
        """Process the rows of W (N, p), y (N,) with bounds e_max (scalar or (N,)), continuing
        from the current state, in one compiled loop. Returns :meth:`estimate`."""
        W, y = as_regression(W, y)
        if W.shape[1] != self.p:
            raise InputError(f"W must have {self.p} columns (one per parameter), got {W.shape[1]}.")
        e = as_bounds(e_max, W.shape[0])
        W = np.ascontiguousarray(W)
        for start in range(0, W.shape[0], CHUNK_ROWS):  # bounded history buffers
            stop = start + CHUNK_ROWS
            self._run(W[start:stop], y[start:stop], e[start:stop])
        return self.estimate()

    def _run(self, W, y, e) -> None:
        """One compiled loop over checked rows; appends history and outliers."""
        N, p = W.shape
        every = 0 if self.record_every is None else self.record_every  # 0: after every update
        n_rec_max = N + 1 if every == 0 else N // every + 2
        hist_idx = np.empty(n_rec_max, np.int64)
        hist_c = np.empty((n_rec_max, p))
        hist_lv = np.empty(n_rec_max)
        hist_S = np.empty((n_rec_max if self.record_shapes else 0, p, p))
        out_idx = np.empty(N, np.int64)
        out_res = np.empty(N)
        counts = np.zeros(7, np.int64)
        crit = K.CRITERIA[self.criterion]
        stop = self.on_outlier == "raise"
        args = (self._state, W, y, e, crit, self.selective, self.alpha_max, stop, self.n_samples,
                every, log_unit_ball_volume(p), hist_idx, hist_c, hist_lv, hist_S, out_idx, out_res,
                counts)
        t0 = time.perf_counter()
        if self.form == "standard":
            K.run_standard(self._P, self.center, *args)
        else:
            K.run_factorized(self._X, self._z, self.center, *args)
        self.time_s += time.perf_counter() - t0
        processed, n_upd, n_skip, n_out, n_rec, n_brk, n_bad = (int(v) for v in counts)
        self.n_samples += processed + (1 if processed < N else 0)
        self.n_updates += n_upd
        self.n_skipped += n_skip
        self.n_breakdowns += n_brk
        self.n_bad_sigma += n_bad
        self._hist.append((hist_idx[:n_rec].copy(), hist_c[:n_rec].copy(), hist_lv[:n_rec].copy(),
                           hist_S[:n_rec].copy() if self.record_shapes else None))
        self._outliers.append(out_idx[:n_out].copy())
        self._outlier_res.append(out_res[:n_out].copy())
        if processed < N:
            k = int(out_idx[n_out - 1])
            raise InfeasibleDataError(
                f"observation {k} contradicts the bounds: its strip misses the current ellipsoid "
                f"(innovation {out_res[n_out - 1]:.6g}, bound {e[processed]:.6g}). The data are inconsistent "
                "with e_max (raise the bounds) or that sample is an outlier (use on_outlier='skip')."
            )

    # ------------------------------------------------------------------ results
    @property
    def sigma(self) -> float:
        return float(self._state[K.S_SIGMA])

    def _set(self, level: float = 1.0) -> Ellipsoid:
        """The current set with its level sigma multiplied by ``level`` (the inflation): the factorized
        form in its own square-root information form, {|X theta - z|^2 <= sigma level} (no inverse is
        formed, so it holds whatever the condition of M); the standard form from its M^-1."""
        if self.form == "factorized":
            return RootInformationEllipsoid(self._X, self._z, self.sigma * level)
        try:
            return Ellipsoid(self.center, (self.sigma * level) * self._P)
        except InputError as exc:
            raise SolverError(
                f"the standard-form OBE lost positive definiteness after {self.n_samples} samples: M^-1 is kept by "
                "subtraction and rounding made it indefinite (ill-conditioned regressors, or a prior far wider "
                f"than the bounds). Use form='factorized'. ({exc})") from None

    def shape(self) -> np.ndarray:
        """The current shape matrix sigma M^-1 (p, p) (formed from X for the factorized form: rounded
        where M is ill-conditioned; :meth:`ellipsoid` does not need it)."""
        return self._set().shape

    def information(self) -> np.ndarray:
        """The current information matrix M (p, p), E = {(theta - c)^T M (theta - c) <= sigma}."""
        if self.form == "standard":
            return np.linalg.inv(self._P)
        return self._X.T @ self._X

    def mahalanobis2(self, points) -> np.ndarray:
        """(theta - c)^T M (theta - c) / sigma for each row of ``points`` (m, p) (<= 1 inside), in the
        estimator's own representation: |X theta - z|^2 / sigma for the factorized form, the Cholesky
        factor of M^-1 for the standard form (LinAlgError once M^-1 is no longer positive definite)."""
        if self.form == "factorized":
            return self._set().mahalanobis2(points)
        T = np.atleast_2d(as_float_array(points, "points"))
        if T.ndim != 2 or T.shape[1] != self.p:
            raise InputError(f"points must have {self.p} columns, got shape {T.shape}.")
        R = np.linalg.solve(np.linalg.cholesky(self._P), (T - self.center).T)
        return np.sum(R * R, axis=0) / self.sigma

    def ellipsoid(self) -> Ellipsoid:
        """The current set, without the rounding inflation of :meth:`estimate`."""
        return self._set()

    def _check_state(self) -> None:
        """Raise SolverError if the recursion proved its own state corrupt: then there is no set to
        report, not even an unverified one."""
        if self.n_breakdowns and self.form == "standard":
            raise SolverError(
                f"the standard-form OBE lost positive definiteness after {self.n_samples} samples: on "
                f"{self.n_breakdowns} breakdown rows M^-1 proved indefinite (w^T M^-1 w <= 0 or a diagonal entry "
                "<= 0). M^-1 is kept by subtraction and rounding made it indefinite (ill-conditioned regressors, "
                "or a prior far wider than the bounds). Use form='factorized'."
            )
        if self.n_breakdowns:
            raise SolverError(
                f"the factorized OBE's factor X became singular or non-finite on {self.n_breakdowns} update steps "
                f"after {self.n_samples} samples: the rows overflow or underflow double precision. Scale the "
                "columns of W (and the prior) to order 1."
            )
        if self.n_bad_sigma:
            raise SolverError(
                f"the {self.form} OBE's sigma left (0, 1] on {self.n_bad_sigma} update steps after "
                f"{self.n_samples} samples (it cannot in exact arithmetic): the state is corrupt. "
                + ("Use form='factorized'." if self.form == "standard" else
                   "Scale the columns of W and y (and the prior) to order 1.")
            )

    def _unverified_reason(self, bound: float) -> str | None:
        """Why the estimator cannot vouch for its set (None: it can)."""
        if bound <= VOUCH_MAX:
            return None
        st = self._state
        head = (f"the rounding error of the set may reach {bound:.2g} in Mahalanobis^2, above the "
                f"{VOUCH_MAX:g} the estimator can absorb into its set")
        if self.form == "standard":
            rho, omega = st[K.S_WORST_RHO], st[K.S_WORST_OMEGA]
            return (f"{head}; the largest share comes from row {int(st[K.S_WORST_ROW])}, whose rank-one downdate "
                    f"shrank the ellipsoid by a factor {rho:.3g} along that row and left M^-1, scaled to a unit "
                    f"diagonal, with condition number up to {omega:.3g}: M^-1 is updated by subtraction, so its "
                    "relative accuracy is about such factors times the unit roundoff. Use form='factorized', or a "
                    "prior closer to the scale the data determine")
        return (f"{head}: the rounding of {self.n_updates} update steps (a few units of roundoff each, barely "
                "discounted when the weights are small) adds up; the bound is a worst case, not a measured error")

    def estimate(self) -> Estimate:
        """The current set as an :class:`Estimate`: kind "guaranteed" when the estimator can vouch for
        it, else "unverified" with ``unverified_reason``."""
        self._check_state()
        bound = float(self._state[K.S_BOUND])
        reason = self._unverified_reason(bound)
        inflation = INFLATION_FACTOR * bound if reason is None else 0.0
        E = self._set(1.0 + inflation)
        if len(self._hist) > 1:  # merge once; later estimates reuse the merged arrays
            idx, cs, lvs, Ss = zip(*self._hist, strict=True)
            self._hist = [(np.concatenate(idx), np.concatenate(cs), np.concatenate(lvs),
                           np.concatenate(Ss) if self.record_shapes else None)]
        for name in ("_outliers", "_outlier_res"):
            if len(getattr(self, name)) > 1:
                setattr(self, name, [np.concatenate(getattr(self, name))])
        idx, cs, lvs, Ss = self._hist[0] if self._hist else (np.zeros(0, np.int64), np.zeros((0, self.p)),
                                                               np.zeros(0), None)
        history = History(index=idx.copy(), centers=cs.copy(), log_volumes=lvs.copy(),
                          shapes=Ss.copy() if self.record_shapes and Ss is not None else None)
        outliers = self._outliers[0].copy() if self._outliers else np.zeros(0, np.int64)
        residuals = self._outlier_res[0].copy() if self._outlier_res else np.zeros(0)
        info = {"criterion": self.criterion, "form": self.form, "selective": self.selective, "sigma": self.sigma,
                "n_breakdowns": self.n_breakdowns}
        return Estimate(
            method=f"OBE-{self.form} ({self.criterion})", center=E.center.copy(), set=E,
            intervals=E.intervals(), kind="guaranteed" if reason is None else "unverified", names=self.names,
            history=history, outliers=outliers, outlier_residuals=residuals, n_samples=self.n_samples,
            n_updates=self.n_updates, n_skipped=self.n_skipped, time_s=self.time_s, error_bound=bound,
            inflation=inflation, unverified_reason=reason, info=info,
        )


# ------------------------------------------------------------------------------ registry entry


@dataclass(frozen=True)
class OBEOptions:
    """What a study file may set for ``method = "obe"`` (e_max is the study's bound, Problem.e_max)."""

    form: Literal["standard", "factorized"] = option("factorized", "standard (Sherman-Morrison, [H4Paper] eqs. "
                                                     "28-30) or factorized (QR, eqs. 33-35)")
    criterion: Literal["volume", "trace", "dasgupta-huang"] = option(
        "volume", "the weight's criterion: volume [FogelHuang1982], trace, or sigma [DasguptaHuang1987]")
    stop_at_outlier: bool = option(
        False, "a strip that misses the ellipsoid (the data contradict the bound there): false skips it and lists "
               "it among the outliers; true stops the estimator with an error naming the row")


def _build(problem: Problem, o: OBEOptions) -> Estimate:
    on_outlier = "raise" if o.stop_at_outlier else "skip"
    return OBE(problem.p, prior=problem.prior, criterion=o.criterion, form=o.form, on_outlier=on_outlier,
               record_every=problem.record_every, names=problem.names).fit(problem.W, problem.y, problem.e_max)


# colour by form (Okabe-Ito blue, sky blue), marker and dash by criterion: six distinct variants
_OBE_COLOR = {"factorized": "#0072B2", "standard": "#56B4E9"}
_OBE_MARK = {"volume": ("o", "-"), "trace": ("s", "--"), "dasgupta-huang": ("^", "-.")}

METHOD = Method(
    name="obe", summary="Optimal Bounding Ellipsoid: guaranteed ellipsoid, one strip at a time",
    options=OBEOptions, build=_build, set_family="ellipsoid", kind="guaranteed", needs_bound=True,
    style=lambda o: Style(_OBE_COLOR[o.form], *_OBE_MARK[o.criterion]))
